//! What an analysis finds, in words: the guard off, how many notes will sound, each kind of
//! trouble counted (folded, dropped and why, cut, smeared, too soft or loud), drums on a
//! piano.

use orch_perform::Report;
use orch_robot::Robot;
use orch_seq::Song;

/// What will go wrong when `robot` plays `song` as `r` reports, in words: a finding a line
/// ("nothing will go wrong" when nothing else is found).
pub fn findings(song: &Song, robot: &Robot, r: &Report) -> Vec<String> {
    let mut f = Vec::new();
    if !robot.config.guard.enabled {
        f.push(
            "WARNING: the safety guard is OFF in this robot.toml: no hold limit, duty limit, \
             power budget or watchdog protects the solenoids. Never play a robot like this."
                .into(),
        );
    }
    if r.notes == 0 {
        f.push("the file has no notes to play".into());
        return f;
    }
    let o = &r.outcomes;
    let share = |n: u64| 100.0 * n as f64 / r.notes.max(1) as f64;
    let heard = o.on_time + o.late + o.early + o.unison;
    f.push(format!(
        "{} of {} notes ({:.1}%) will sound: {} on time, {} late, {} in unison; {:.3} s long",
        heard,
        r.notes,
        share(heard),
        o.on_time,
        o.late,
        o.unison,
        song.duration_us() as f64 / 1e6
    ));
    let d = &o.dropped;
    let budget = robot.config.guard.max_keys_down;
    let counted: [(u64, String); 19] = [
        (
            o.joined,
            "notes land on a key already down for another note and make no sound of their own"
                .into(),
        ),
        (
            r.folded,
            "notes are outside the keys and will be folded by octaves".into(),
        ),
        (
            d.range,
            "notes are outside the keys and will not be played".into(),
        ),
        (
            d.channel,
            "notes are on channels the robot does not listen to".into(),
        ),
        (
            d.percussion,
            "notes are drums on channel 10 (General MIDI's percussion): the keyboard leaves them \
             alone; a drum group would play them (`orch config --instrument drums`)"
                .into(),
        ),
        (
            d.unmapped,
            "notes are drums the kit has no output for and will not be played".into(),
        ),
        (
            d.power,
            format!(
                "notes would pass the power budget of {budget} keys at once and will be refused"
            ),
        ),
        (
            d.too_fast,
            "notes repeat a key too fast to strike it again within the late limit and will be dropped"
                .into(),
        ),
        (
            d.monophonic,
            "notes are in chords the one-voice (fingered) group plays one note of, and will not be played"
                .into(),
        ),
        (
            r.cut_by_hold_limit,
            "keys are held past the hold limit and will be cut short".into(),
        ),
        (
            r.cut_by_duty_limit,
            "keys are energised past the duty limit and will be cut".into(),
        ),
        (
            r.unmatched,
            "notes strike but are too short for the key to sound".into(),
        ),
        (
            r.smeared,
            "presses come before the key is back up and will smear".into(),
        ),
        (
            r.muted,
            "strikes keep their beater on the drum head or bar long enough to mute it \
             (shorten the output's pulse_loud, or raise its mute_after if the robot does not)"
                .into(),
        ),
        (
            d.cancelled,
            "re-strikes waiting for their key's rest will be cancelled".into(),
        ),
        (
            d.too_soft,
            "notes will strike too softly to sound (below the key's softest duty: raise \
             dynamics.softest, or lower mechanics.softest if the keys sound softer than that)"
                .into(),
        ),
        (
            d.cracked,
            "wind notes will crack: the valve opens before the fingers settle (raise the \
             fingered group's settle to the fingers' travel)"
                .into(),
        ),
        (
            r.velocity_error.map_or(0, |v| v.softer),
            "notes will sound softer than their velocity by more than 2 steps (robot.toml's \
             [dynamics] curve is below what the keys need)"
                .into(),
        ),
        (
            r.velocity_error.map_or(0, |v| v.louder),
            "notes will sound louder than their velocity by more than 2 steps (robot.toml's \
             [dynamics] curve is above what the keys need)"
                .into(),
        ),
    ];
    f.extend(
        counted
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{n} {what}")),
    );
    let drums = song
        .events()
        .iter()
        .filter(|e| e.bytes.note_on().is_some_and(|(ch, _, _)| ch == 9))
        .count();
    let ten = orch_core::Channel::new(9).expect("channel 10");
    let kit_listens = robot
        .config
        .strikes
        .groups()
        .iter()
        .any(|g| g.channels.contains(ten));
    let keyboard = robot.config.keyboard_keys() > 0;
    if drums > 0 && keyboard && robot.config.channels.contains(ten) && !kit_listens {
        f.push(format!(
            "{drums} notes are drums on channel 10: a piano plays them as pitches; \
             consider `channels = \"melodic\"` in robot.toml"
        ));
    }
    if f.len() == 1 {
        f.push("nothing will go wrong".into());
    }
    f
}
