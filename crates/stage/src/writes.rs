//! Board writes ([`BoardWrite`]) as people and scripts read them: a line of text (the time,
//! the byte or timer that caused it, the board, its 16 outputs or a PWM board's duties), or a
//! JSON object; the boards' state at the end ([`BoardState`]) as the last JSON line.
//! `orch interpret` and `orch run --json` show them so; [`JsonLog`] writes them as the live
//! robot makes them.

use std::io::Write;
use std::sync::{Arc, Mutex};

use orch_core::Duty;
use serde_json::{json, Value};

use crate::live::WriteLog;
use crate::BoardWrite;

/// A board's state at the end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardState {
    /// The board's 7-bit address.
    pub address: u8,
    /// The 16 outputs on.
    pub outputs: u16,
    /// A PWM board's 16 duties (0..=4095); `None` for an on/off board.
    pub duty: Option<[u16; 16]>,
}

/// The boards' state at the end as the last JSON line: `{"type":"final","boards":[...]}`,
/// each board's `address`, `outputs` and (a PWM board's) `duty`.
pub fn final_json(boards: &[BoardState]) -> Value {
    let list: Vec<Value> = boards
        .iter()
        .map(|b| match b.duty {
            Some(duty) => json!({"address": b.address, "outputs": b.outputs, "duty": duty}),
            None => json!({"address": b.address, "outputs": b.outputs}),
        })
        .collect();
    json!({"type": "final", "boards": list})
}

/// A write as a JSON object: `t_us`, `byte` (null for a timer's), `address`, and `duty` (a
/// PWM board's 16 duties) or `outputs`.
pub fn json(w: &BoardWrite) -> Value {
    match w.duty {
        Some(duty) => json!({"t_us": w.t_us, "byte": w.byte, "address": w.address, "duty": duty}),
        None => json!({"t_us": w.t_us, "byte": w.byte, "address": w.address, "outputs": w.outputs}),
    }
}

/// A write as a line of text (no newline): `      0.320 ms  byte 1      0x20 <- 0x0100
/// |........#.......|`, or for a PWM board `… 0x40 <- duty 8:100% 12:35%`.
pub fn text(w: &BoardWrite) -> String {
    let cause = match w.byte {
        Some(i) => format!("byte {i}"),
        None => "timer".to_string(),
    };
    let ms = w.t_us as f64 / 1000.0;
    match &w.duty {
        Some(d) => format!(
            "{ms:>11.3} ms  {cause:<11} {:#04x} <- duty {}",
            w.address,
            duty_text(&duties(d))
        ),
        None => {
            let fingers: String = (0..16)
                .map(|b| if w.outputs & (1 << b) != 0 { '#' } else { '.' })
                .collect();
            format!(
                "{ms:>11.3} ms  {cause:<11} {:#04x} <- {:#06x}  |{fingers}|",
                w.address, w.outputs
            )
        }
    }
}

/// A PWM board's duties as written (0..=4095 each).
pub fn duties(values: &[u16; 16]) -> [Duty; 16] {
    values.map(|v| Duty::new(v).unwrap_or(Duty::FULL))
}

/// A PWM board's duties as people read them: each output that is on, with its duty in per
/// cent ("8:100% 12:35%"), or "all off".
pub fn duty_text(duties: &[Duty; 16]) -> String {
    let on: Vec<String> = duties
        .iter()
        .enumerate()
        .filter(|(_, d)| d.get() > 0)
        .map(|(n, d)| format!("{n}:{:.0}%", d.percent()))
        .collect();
    if on.is_empty() {
        "all off".to_string()
    } else {
        on.join(" ")
    }
}

/// The live robot's board writes as JSON lines ([`json()`]) on a writer it shares with the
/// robot's loop (`orch run --json`): each write as it is made ([`sink`](Self::sink)), the
/// boards' state at the end ([`finish`](Self::finish)). A writer that fails to flush
/// (standard output gone: a closed pipe) is let go: the robot plays on without its log.
pub struct JsonLog<W> {
    w: Option<Arc<Mutex<W>>>,
}

impl<W: Write + Send + 'static> JsonLog<W> {
    /// A log on `w`; none (every call does nothing) without one.
    pub fn to(w: Option<W>) -> Self {
        Self {
            w: w.map(|w| Arc::new(Mutex::new(w))),
        }
    }

    /// What the live robot calls with each write ([`LiveRobot::new`](crate::LiveRobot::new)'s
    /// log), if there is a log.
    pub fn sink(&self) -> Option<WriteLog> {
        let w = Arc::clone(self.w.as_ref()?);
        Some(Box::new(move |write: &BoardWrite| {
            let mut w = w.lock().unwrap_or_else(|e| e.into_inner());
            // A writer gone: the robot plays on without the log.
            let _ = writeln!(w, "{}", json(write));
        }))
    }

    /// Flushes what was written; a writer that fails is let go.
    pub fn flush(&mut self) {
        if let Some(w) = &self.w {
            if w.lock().unwrap_or_else(|e| e.into_inner()).flush().is_err() {
                self.w = None;
            }
        }
    }

    /// The last line, the boards' state at the end ([`final_json`]), and a flush.
    pub fn finish(&mut self, boards: &[BoardState]) {
        if let Some(w) = &self.w {
            let mut w = w.lock().unwrap_or_else(|e| e.into_inner());
            let _ = writeln!(w, "{}", final_json(boards));
        }
        self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer whose bytes can be read back, and whose flush fails once `broken` is set.
    #[derive(Clone, Default)]
    struct Shared {
        bytes: Arc<Mutex<Vec<u8>>>,
        broken: Arc<Mutex<bool>>,
    }

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.bytes.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            if *self.broken.lock().unwrap() {
                return Err(std::io::ErrorKind::BrokenPipe.into());
            }
            Ok(())
        }
    }

    fn write(t_us: u64) -> BoardWrite {
        BoardWrite {
            t_us,
            byte: Some(0x90),
            address: 0x20,
            outputs: 1,
            duty: None,
        }
    }

    fn lines(w: &Shared) -> Vec<String> {
        let bytes = w.bytes.lock().unwrap();
        String::from_utf8_lossy(&bytes)
            .lines()
            .map(str::to_string)
            .collect()
    }

    #[test]
    fn a_log_writes_each_write_then_the_end_and_lets_a_broken_writer_go() {
        let end = [BoardState {
            address: 0x20,
            outputs: 0,
            duty: None,
        }];
        assert!(JsonLog::<Shared>::to(None).sink().is_none());
        JsonLog::<Shared>::to(None).finish(&end);

        let w = Shared::default();
        let mut log = JsonLog::to(Some(w.clone()));
        let mut sink = log.sink().unwrap();
        sink(&write(5));
        log.flush();
        log.finish(&end);
        assert_eq!(
            lines(&w),
            [json(&write(5)).to_string(), final_json(&end).to_string()]
        );

        let w = Shared::default();
        let mut log = JsonLog::to(Some(w.clone()));
        *w.broken.lock().unwrap() = true;
        log.flush();
        log.finish(&end);
        assert!(
            lines(&w).is_empty(),
            "no end line once the writer has failed"
        );
    }
}
