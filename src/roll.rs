//! `orch analyze --svg FILE`: the piano roll of the performance, drawn by `orch-roll`.

use std::io::Write;
use std::path::Path;

use orch_perform::{Played, Tempo};
use orch_seq::Song;

use crate::robot::Robot;

/// Writes the roll of `played` (a performance of `song`, read from `file`, on `robot` at
/// `tempo`) to `out` as SVG.
pub fn write(
    out: &mut impl Write,
    file: &Path,
    song: &Song,
    robot: &Robot,
    played: &Played,
    tempo: Tempo,
) -> anyhow::Result<()> {
    let range = robot.config.range;
    let keys = (range.low().get(), range.high().get());
    let title = file.file_name().map_or_else(
        || file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let roll = orch_roll::build::roll(song, played, keys, tempo.get(), &title)?;
    out.write_all(orch_roll::render(&roll, &orch_roll::Options::default()).as_bytes())?;
    out.flush()?;
    Ok(())
}
