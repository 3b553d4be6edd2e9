//! A `--thru` output: the live input passed on to a MIDI output, on a thread of its own (a DIN
//! line is written at the wire's pace, which must not hold up the robot), re-framed with
//! running status and filtered to the output's channels.

use std::sync::mpsc::{self, Sender};
use std::time::Instant as Wall;

use orch_io::midi::all_notes_off;
use orch_io::{OutSpec, Output, Target};
use orch_perform::MidiOut as _;
use orch_robot::Robot;

use crate::framer::Framer;
use crate::LiveError;

/// The `--thru` outputs, parsed from `texts` as `--out` takes them (its errors said of
/// `--thru`): MIDI outputs only (`serial:`, `rawmidi:`, `udp:`); the virtual robot and I2C
/// boards are the robot itself (`--out`), refused. Every one is parsed before any is looked
/// at. Bad input ([`LiveError::BadInput`]) otherwise.
pub fn specs(texts: &[String]) -> Result<Vec<OutSpec>, LiveError> {
    let specs: Vec<OutSpec> = texts
        .iter()
        .map(|t| {
            OutSpec::parse(t)
                .map_err(|e| LiveError::BadInput(e.to_string().replacen("--out", "--thru", 1)))
        })
        .collect::<Result<_, _>>()?;
    if let Some(t) = specs
        .iter()
        .find(|t| matches!(t.target, Target::Sim | Target::I2c(_)))
    {
        return Err(LiveError::BadInput(format!(
            "--thru {}: --thru takes MIDI outputs (serial:, rawmidi:, udp:); the robot is --out",
            t.text
        )));
    }
    Ok(specs)
}

/// A `--thru` output on a thread of its own (a DIN line is written at the wire's pace, which
/// must not hold up the robot).
pub struct Thru {
    spec: OutSpec,
    framer: Framer,
    tx: Sender<Option<Vec<u8>>>,
    thread: std::thread::JoinHandle<Result<(), String>>,
}

impl Thru {
    /// Opens `spec` for `robot` and starts its thread.
    pub fn start(spec: OutSpec, robot: &Robot) -> Result<Thru, LiveError> {
        let mut out = Output::open(&spec.target, &robot.config, &robot.kinds, robot.pwm_hz)
            .map_err(|e| LiveError::BadInput(format!("--thru {}: {e}", spec.text)))?
            .ok_or_else(|| {
                LiveError::BadInput("--thru sim: the virtual robot is --out sim".into())
            })?;
        let (tx, rx) = mpsc::channel::<Option<Vec<u8>>>();
        let thread = std::thread::Builder::new()
            .name(format!("orch-thru {}", spec.text))
            .spawn(move || -> Result<(), String> {
                let origin = Wall::now();
                let t = || origin.elapsed().as_micros() as u64;
                while let Ok(Some(bytes)) = rx.recv() {
                    out.send(t(), &bytes).map_err(|e| e.to_string())?;
                }
                for m in all_notes_off().chunks(3) {
                    out.send(t(), m).map_err(|e| e.to_string())?;
                }
                out.finish(t()).map_err(|e| e.to_string())
            })
            .map_err(|e| LiveError::Failed(format!("--thru {}: its thread: {e}", spec.text)))?;
        Ok(Thru {
            spec,
            framer: Framer::default(),
            tx,
            thread,
        })
    }

    /// Takes one input byte.
    pub fn push(&mut self, byte: u8) {
        let (tx, channels) = (&self.tx, self.spec.channels);
        self.framer.push(byte, channels, &mut |m| {
            let _ = tx.send(Some(m.to_vec()));
        });
    }

    /// The input went away: a message half received is forgotten, and All Notes Off goes out
    /// on this output's channels.
    pub fn line_lost(&mut self) {
        self.framer.forget();
        for m in all_notes_off().chunks(3) {
            if self.spec.channels.passes(m) {
                let _ = self.tx.send(Some(m.to_vec()));
            }
        }
    }

    /// All Notes Off on every channel, then the output is closed.
    pub fn stop(self) -> Result<(), LiveError> {
        let _ = self.tx.send(None);
        match self.thread.join() {
            Ok(r) => r.map_err(|e| LiveError::Failed(format!("--thru {}: {e}", self.spec.text))),
            Err(_) => Err(LiveError::Failed(format!(
                "--thru {}: its thread panicked",
                self.spec.text
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texts(t: &[&str]) -> Vec<String> {
        t.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn thru_takes_midi_outputs_and_refuses_the_robot_after_parsing_all() {
        let ok = specs(&texts(&["udp:127.0.0.1:5004", "rawmidi:/dev/snd/midiC1D0"])).unwrap();
        assert_eq!(ok.len(), 2);
        assert!(specs(&[]).unwrap().is_empty());
        for robot in ["sim", "i2c:/dev/i2c-1"] {
            let e = specs(&texts(&[robot])).unwrap_err();
            assert!(matches!(e, LiveError::BadInput(_)), "{e}");
            assert!(
                e.to_string()
                    .starts_with(&format!("--thru {robot}: --thru takes")),
                "{e}"
            );
        }
        let e = specs(&texts(&["sim", "nonsense:x"]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--thru") && !e.contains("--out nonsense"),
            "parsed first: {e}"
        );
        assert!(!e.contains("the robot is --out"), "parsed first: {e}");
    }
}
