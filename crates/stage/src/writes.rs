//! Board writes ([`BoardWrite`]) as people and scripts read them: a line of text (the time,
//! the byte or timer that caused it, the board, its 16 outputs or a PWM board's duties), or a
//! JSON object; the boards' state at the end ([`BoardState`]) as the last JSON line.
//! `orch interpret` and `orch run --json` show them so.

use orch_core::Duty;
use serde_json::{json, Value};

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
