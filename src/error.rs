//! Which failures are the user's input (exit 2) and which happened while running (exit 1).

use std::fmt;

/// Marks an error as bad input: a file, a configuration or bytes that cannot be used.
#[derive(Debug)]
pub struct BadInput(pub String);

impl fmt::Display for BadInput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// An `anyhow` error marked as bad input.
pub fn bad_input(message: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(BadInput(message.into()))
}

/// A library's error as the binary says it: bad input (exit 2, in its own words) when
/// `is_bad_input` says the user's input is at fault, else as it is (exit 1, with what is
/// behind it).
pub fn lift<E>(e: E, is_bad_input: impl FnOnce(&E) -> bool) -> anyhow::Error
where
    E: std::error::Error + Send + Sync + 'static,
{
    if is_bad_input(&e) {
        bad_input(e.to_string())
    } else {
        anyhow::Error::new(e)
    }
}

/// A live robot's or output's error ([`lift`]).
pub fn live(e: orch_stage::LiveError) -> anyhow::Error {
    lift(e, orch_stage::LiveError::is_bad_input)
}

/// 2 for bad input anywhere in the chain (a [`BadInput`], a robot configuration that was
/// refused: [`orch_robot::RobotError`], or a song, bar or tempo refused:
/// [`orch_stage::StageError`], hex text that is not: [`orch_stage::bytes::ReadError`]), 1
/// otherwise.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    if e.chain().any(|c| {
        c.is::<BadInput>()
            || c.is::<orch_robot::RobotError>()
            || c.downcast_ref::<orch_stage::StageError>()
                .is_some_and(orch_stage::StageError::is_bad_input)
            || c.downcast_ref::<orch_stage::bytes::ReadError>()
                .is_some_and(orch_stage::bytes::ReadError::is_bad_input)
    }) {
        2
    } else {
        1
    }
}

/// Whether the error is only our reader going away (`orch decode | head`).
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
