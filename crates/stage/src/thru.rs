//! A `--thru` output: the live input passed on to a MIDI output, on a thread of its own (a DIN
//! line is written at the wire's pace, which must not hold up the robot), re-framed with
//! running status and filtered to the output's channels.

use std::sync::mpsc::{self, Sender};
use std::time::Instant as Wall;

use orch_io::midi::all_notes_off;
use orch_io::{OutSpec, Output};
use orch_perform::MidiOut as _;
use orch_robot::Robot;

use crate::framer::Framer;
use crate::LiveError;

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
