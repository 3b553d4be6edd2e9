//! How a robot plays a song: the performance's [`Setup`] for a robot, the tempo factors a
//! front end may ask for, and a performance on the virtual clock (as fast as the machine
//! goes: a ten-minute piece in a few tens of ms).

use orch_perform::follow::FACTOR_RANGE;
use orch_perform::{song_events, Control, Performer, Played, Setup, Spread, Tempo};
use orch_robot::Robot;
use orch_seq::Song;

use crate::session::{lane_events, Ended, Lane};
use crate::StageError;

/// The tempo `factor` (1.0: as written), if it is in [`FACTOR_RANGE`] (a twentieth to
/// twenty times as written, as a conductor may ask).
pub fn tempo(factor: f64) -> Result<Tempo, StageError> {
    let (low, high) = FACTOR_RANGE;
    Tempo::new(factor)
        .filter(|t| (low..=high).contains(&t.get()))
        .ok_or(StageError::Tempo(factor))
}

/// How `robot` plays, with or without compensation, at `tempo`, on this host.
pub fn setup(robot: &Robot, compensation: bool, tempo: Tempo) -> Setup {
    Setup::for_robot(robot)
        .with_compensation(compensation)
        .with_tempo(tempo)
}

/// Plays `song` on the virtual robot alone, on the virtual clock.
pub fn play_fast(song: &Song, setup: &Setup) -> Result<Played, StageError> {
    Ok(Performer::new(setup, song_events(song), song.notes()).run()?)
}

/// Plays `song` on every lane's virtual robot in turn, on the virtual clock, from `from_us`
/// (µs of score time: a jump there before the first note) if given; each robot's end, in lane
/// order. Only the virtual robot plays this fast: a lane with an output is refused.
pub fn play_lanes_fast(
    song: &Song,
    lanes: Vec<Lane>,
    from_us: Option<u64>,
) -> Result<Vec<Ended>, StageError> {
    lanes
        .into_iter()
        .map(|l| {
            if l.out.is_some() {
                return Err(StageError::BadInput(format!(
                    "on the virtual clock only the virtual robot plays, not {}",
                    l.spec.text
                )));
            }
            let (events, notes) = lane_events(song, l.spec.channels);
            let control = from_us.map(|t| {
                let c = Control::new();
                c.jump_to(t);
                c
            });
            let mut performer = Performer::new(&l.setup, events.into_iter(), notes);
            if let Some(c) = control.as_deref() {
                performer = performer.control(c);
            }
            let played = performer.run()?;
            Ok(Ended {
                spec: l.spec,
                played,
                stats: None,
            })
        })
        .collect()
}

/// The onset error of the same piece without compensation, for comparison (none when
/// `setup` plays without it already).
pub fn uncompensated(song: &Song, setup: &Setup) -> Result<Option<Spread>, StageError> {
    if !setup.compensation {
        return Ok(None);
    }
    let plain = setup.clone().with_compensation(false);
    Ok(Some(Spread::of_onsets(&play_fast(song, &plain)?.records)))
}
