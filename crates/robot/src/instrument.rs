//! The robot.toml of each kind of instrument `orch config --instrument` prints.

use crate::BoardKind;

/// A kind of robot with a ready configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Instrument {
    /// The thesis's 61-key piano robot ([`DEFAULT_TOML`](crate::DEFAULT_TOML)).
    Piano,
    /// A General MIDI drum kit on channel 10: kick, snare, hi-hat and its pedal, three toms,
    /// crash and ride.
    Drums,
    /// A glockenspiel of 30 bars, G5 to C8 (MIDI 79–108), sounding as written.
    Glockenspiel,
    /// A soprano recorder, C5 to D7 (MIDI 72–98), sounding as written: a valve and eleven
    /// finger solenoids, baroque fingering.
    Recorder,
}

impl Instrument {
    /// Every instrument, in the order `orch config --help` lists them.
    pub const ALL: [Instrument; 4] = [
        Instrument::Piano,
        Instrument::Drums,
        Instrument::Glockenspiel,
        Instrument::Recorder,
    ];

    /// Its name on the command line: `piano`, `drums`, `glockenspiel`.
    pub fn name(self) -> &'static str {
        match self {
            Instrument::Piano => "piano",
            Instrument::Drums => "drums",
            Instrument::Glockenspiel => "glockenspiel",
            Instrument::Recorder => "recorder",
        }
    }
}

/// The complete, commented robot.toml of `instrument`, its boards all of `kind`: what
/// `orch config --instrument NAME [--boards KIND]` prints.
pub fn instrument_toml(instrument: Instrument, kind: BoardKind) -> String {
    let text = match instrument {
        Instrument::Piano => return crate::default_toml(kind),
        Instrument::Drums => DRUMS_TOML,
        Instrument::Glockenspiel => GLOCKENSPIEL_TOML,
        Instrument::Recorder => RECORDER_TOML,
    };
    let text = format!("{text}{COMMON_TOML}");
    match kind {
        BoardKind::OnOff => text,
        BoardKind::Pwm => text
            .replace("kind = \"pca9555\"", "kind = \"pca9685\"")
            .replace("address = 0x21", "address = 0x40")
            .replace("address = 0x22", "address = 0x41")
            .replace("clock = \"400kHz\"", "clock = \"1MHz\""),
    }
}

/// The drum kit.
const DRUMS_TOML: &str = r#"# orch robot configuration (robot.toml): a General MIDI drum kit
# Every field is optional; a missing one takes the value shown here.

# No keyboard: this robot is the kit below.
[keys]
enabled = false

# One board drives the kit's ten outputs, in the order of the [[strike.output]] tables:
# output 0 (the kick) on bit 0, output 9 (the hi-hat's lift) on bit 9. kind: "pca9555": on/off, velocity
# played as the pulse's length; "pca9685": velocity as the pulse's length and its duty.
[[boards]]
kind = "pca9555"
address = 0x21
keys = 10
first_bit = 0

# A strike group: each note fires its output for a pulse that ends by itself, whatever the
# note's length; the Note-Off does nothing. Durations like "8ms".
#   pulse_soft, pulse_loud: the pulse of velocity 1 and of velocity 127 (linear between).
#     8 ms is what the open drum builds fire (Adafruit's solenoid drummer, jzkmath's kit,
#     NeilFraser's glockenspiel); 20 ms (glloq's xylophone) throws the beater harder.
#   rebound: the shortest time from one strike of a beater to its next. 40 ms: 25 strikes a
#     second, faster than a drummer's single-stroke roll. A strike sooner than that waits for
#     it (or is dropped as too fast past guard.late_limit).
#   flight: from the pulse's start to the beater sounding, at full power; soft_flight: at the
#     softest duty that sounds (PCA9685 boards; on/off boards always strike at full power).
#     The performer sends each strike early by it, so it sounds on the beat.
#   min_pulse: the shortest pulse that sounds; shorter fires a blank.
#   return_delay: from the pulse's end until the beater is back at rest.
#   mute_after: the longest a beater may stay powered against the head once it struck; longer
#     chokes the sound (the virtual robot counts it as muted). 20 ms: the loudest pulses here
#     rest on the head for at most 15 ms (the kick's 30 ms pulse less its 15 ms flight).
# Each [[strike.output]] names its notes (General MIDI's drum map) and may give any of those
# figures where it differs from the group's. A note the kit has no output for is dropped as
# "unmapped". An output with no notes of its own is either
#   a lead: `leads` lists the notes it fires before their own output, `lead` how long before
#     (the open hi-hat's lift below), or
#   a damper: `damps` names the output whose notes' Note-Offs fire it (a cymbal's choke), once
#     that output's pulse is over and not while the channel's sustain pedal holds (when
#     [keys] sustain is on). A strike of its drum cuts its pulse.
[[strike]]
name = "drums"
channels = [10]
pulse_soft = "8ms"
pulse_loud = "20ms"
rebound = "40ms"
flight = "10ms"
soft_flight = "20ms"
min_pulse = "4ms"
return_delay = "15ms"
mute_after = "20ms"

[[strike.output]]
name = "kick"
notes = [35, 36]          # acoustic and electric bass drum
# A kick's solenoid is bigger and its beater travels further: a longer pulse and flight.
pulse_soft = "15ms"
pulse_loud = "30ms"
flight = "15ms"
soft_flight = "25ms"
rebound = "60ms"

[[strike.output]]
name = "snare"
notes = [38, 40]          # acoustic and electric snare

[[strike.output]]
name = "hi-hat"
notes = [42, 46]          # closed and open hi-hat, struck by the stick
rebound = "35ms"

[[strike.output]]
name = "hi-hat pedal"
notes = [44]              # the pedal closing the hats

[[strike.output]]
name = "floor tom"
notes = [41, 43]          # low floor tom, high floor tom

[[strike.output]]
name = "mid tom"
notes = [45, 47]          # low tom, low-mid tom

[[strike.output]]
name = "high tom"
notes = [48, 50]          # hi-mid tom, high tom

[[strike.output]]
name = "crash"
notes = [49, 57]          # crash cymbals 1 and 2
# A cymbal needs a firmer hit to speak and swings longer before it can be struck again.
pulse_soft = "10ms"
pulse_loud = "25ms"
rebound = "60ms"

[[strike.output]]
name = "ride"
notes = [51, 59]          # ride cymbals 1 and 2
pulse_soft = "10ms"
pulse_loud = "25ms"
rebound = "50ms"

# The open hi-hat (46) lifts the top cymbal off the bottom one before the stick strikes
# (crunchysteve/SoleBot fires two outputs for it): the lift fires 15 ms (its travel) before
# the stick, and holds the hats apart 60 ms, through the stick's flight and the open ring.
# The performer sends the note early by the lead too, so the stick still sounds on the beat.
[[strike.output]]
name = "hi-hat lift"
leads = [46]
lead = "15ms"
pulse_soft = "60ms"
pulse_loud = "60ms"
rebound = "80ms"
"#;

/// The glockenspiel.
const GLOCKENSPIEL_TOML: &str = r#"# orch robot configuration (robot.toml): a glockenspiel of 30 bars, G5 to C8
# Every field is optional; a missing one takes the value shown here.

# No keyboard: this robot is the glockenspiel below.
[keys]
enabled = false

# Two boards drive the 30 bars' beaters, lowest first: G5..A#6 on the first, B6..C8 on the
# second. kind: "pca9555": on/off, velocity played as the pulse's length; "pca9685": velocity as
# the pulse's length and its duty.
[[boards]]
kind = "pca9555"
address = 0x21
keys = 16
first_bit = 0

[[boards]]
kind = "pca9555"
address = 0x22
keys = 14
first_bit = 0

# A pitched strike group: one beater a bar, MIDI notes low..=high as written (79 = G5,
# 108 = C8), notes outside folded by octaves ("fold") or dropped ("drop"). Each note fires its
# bar's beater for a pulse that ends by itself; the Note-Off does nothing (a glockenspiel
# rings on). Durations like "8ms".
#   pulse_soft, pulse_loud: the pulse of velocity 1 and 127. A mallet on a small bar needs
#     little: 6 ms soft to 12 ms loud, around NeilFraser's glockenspiel's 8 ms; longer and the
#     mallet rests on the bar and mutes it.
#   rebound: the shortest time between two strikes of one bar's beater: 30 ms, a light mallet
#     bouncing straight back.
#   flight: from the pulse's start to the bar sounding at full power (6 ms: the mallet sits
#     close to its bar); soft_flight: at the softest duty (PCA9685 boards).
#   min_pulse: the shortest pulse that sounds (3 ms); return_delay: back at rest after it.
#   mute_after: the longest a mallet may stay powered on its bar once it struck: a bar rings
#     only when the mallet leaves it, and the loudest pulse here rests on it 6 ms.
# program: the General MIDI program `orch render` plays it with (10: glockenspiel).
# damper_pulse: give it (such as "20ms") for a glockenspiel with a damper on each bar
# (versioduo's glockenspiel-37 has them): one more output a bar, after the bars on the boards,
# fired for that pulse at the bar's Note-Off, once its beater's pulse is over and not while
# the sustain pedal holds (when [keys] sustain is on). None here: a glockenspiel rings on.
[[strike]]
name = "glockenspiel"
channels = "melodic"
low = 79
high = 108
out_of_range = "fold"
program = 10
pulse_soft = "6ms"
pulse_loud = "12ms"
rebound = "30ms"
flight = "6ms"
soft_flight = "12ms"
min_pulse = "3ms"
return_delay = "10ms"
mute_after = "10ms"
"#;

/// The soprano recorder.
const RECORDER_TOML: &str = r#"# orch robot configuration (robot.toml): a soprano recorder, C5 to D7 (MIDI 72-98)
# Every field is optional but the fingering table; a missing one takes the value shown here.

# No keyboard: this robot is the recorder below.
[keys]
enabled = false

# One board drives the valve and the eleven fingers, in the order of fingered.fingers after
# the valve: the valve on bit 0, the thumb on bit 1, 7b on bit 11.
[[boards]]
kind = "pca9555"
address = 0x21
keys = 12
first_bit = 0

# A fingered group: one note at a time. A new note closes the valve, sets the fingers once the
# air has stopped, waits for them to settle and opens the valve; the valve is never open while
# a finger moves. The performer sends each note early by that time, so it sounds on the beat.
#   channels: the channels it plays ("melodic": all but 10).
#   voice: which note of a chord it plays: "highest" (the melody), "lowest" or "last". The
#     others are dropped as "monophonic".
#   fingers: the finger solenoids' names, in board order after the valve. A soprano recorder
#     has a thumb hole, seven finger holes and double holes for 6 and 7 (6a 6b, 7a 7b);
#     "pinch" is a second pad that leaves the thumb hole a crack open, for the upper octave.
#   close: from the valve closing to the air stopping (the fingers move after it).
#   settle: from the fingers moving to the valve opening: a solenoid's travel and bounce (30 ms;
#     glloq's servo flute needs 105 ms for its servos).
#   air: from the valve opening to the note sounding.
#   program: the General MIDI program `orch render` plays it with (75: recorder).
# Each [[fingered.note]] gives a note's fingering (the fingers closed) and its breath (the
# valve's duty at velocity 127 on a PCA9685 board: high notes need more air; on/off boards
# open the valve fully). The table is the baroque (English) fingering of a soprano recorder
# as Dolmetsch's recorder method writes it (0 1 2 3 4 5 6 7; "6" is both 6a and 6b), sounding
# as written. The third octave's fingerings vary most between instruments (C#7 and D7
# especially): check yours. Notes outside fold by octaves.
[[fingered]]
name = "recorder"
channels = "melodic"
voice = "highest"
out_of_range = "fold"
program = 75
fingers = ["thumb", "pinch", "1", "2", "3", "4", "5", "6a", "6b", "7a", "7b"]
close = "5ms"
settle = "30ms"
air = "15ms"

[[fingered.note]]
note = 72   # C5
fingers = "thumb 1 2 3 4 5 6a 6b 7a 7b"
breath = "45%"

[[fingered.note]]
note = 73   # C#5
fingers = "thumb 1 2 3 4 5 6a 6b 7a"
breath = "47%"

[[fingered.note]]
note = 74   # D5
fingers = "thumb 1 2 3 4 5 6a 6b"
breath = "49%"

[[fingered.note]]
note = 75   # D#5
fingers = "thumb 1 2 3 4 5 6a"
breath = "51%"

[[fingered.note]]
note = 76   # E5
fingers = "thumb 1 2 3 4 5"
breath = "53%"

[[fingered.note]]
note = 77   # F5
fingers = "thumb 1 2 3 4 6a 6b 7a 7b"
breath = "56%"

[[fingered.note]]
note = 78   # F#5
fingers = "thumb 1 2 3 5 6a 6b"
breath = "58%"

[[fingered.note]]
note = 79   # G5
fingers = "thumb 1 2 3"
breath = "60%"

[[fingered.note]]
note = 80   # G#5
fingers = "thumb 1 2 4 5"
breath = "62%"

[[fingered.note]]
note = 81   # A5
fingers = "thumb 1 2"
breath = "64%"

[[fingered.note]]
note = 82   # A#5
fingers = "thumb 1 3 4"
breath = "66%"

[[fingered.note]]
note = 83   # B5
fingers = "thumb 1"
breath = "68%"

[[fingered.note]]
note = 84   # C6
fingers = "thumb 2"
breath = "70%"

[[fingered.note]]
note = 85   # C#6
fingers = "1 2"
breath = "72%"

[[fingered.note]]
note = 86   # D6
fingers = "2"
breath = "75%"

[[fingered.note]]
note = 87   # D#6
fingers = "2 3 4 5 6a 6b"
breath = "77%"

[[fingered.note]]
note = 88   # E6
fingers = "pinch 1 2 3 4 5"
breath = "79%"

[[fingered.note]]
note = 89   # F6
fingers = "pinch 1 2 3 4 6a 6b"
breath = "81%"

[[fingered.note]]
note = 90   # F#6
fingers = "pinch 1 2 3 5"
breath = "83%"

[[fingered.note]]
note = 91   # G6
fingers = "pinch 1 2 3"
breath = "85%"

[[fingered.note]]
note = 92   # G#6
fingers = "pinch 1 2 4"
breath = "87%"

[[fingered.note]]
note = 93   # A6
fingers = "pinch 1 2"
breath = "89%"

[[fingered.note]]
note = 94   # A#6
fingers = "pinch 1 2 4 5 6a 6b"
breath = "92%"

[[fingered.note]]
note = 95   # B6
fingers = "pinch 1 2 4 5"
breath = "94%"

[[fingered.note]]
note = 96   # C7
fingers = "pinch 1 4 5"
breath = "96%"

[[fingered.note]]
note = 97   # C#7
fingers = "pinch 1 2 4 6a 6b"
breath = "98%"

[[fingered.note]]
note = 98   # D7
fingers = "pinch 1 2 4 5 7a 7b"
breath = "100%"
"#;

/// What every strike or wind robot shares with the piano: bus, guard, PWM and dynamics.
const COMMON_TOML: &str = r#"
# The I2C bus to the boards: "100kHz", "400kHz" or "1MHz" (any clock from 1 kHz to 1 MHz).
# The PCA9555 is rated for 400 kHz, the PCA9685 for 1 MHz.
[bus]
clock = "400kHz"

# The safety guard (as for a keyboard). max_pulse: the hard limit on any strike's pulse, and
# no output may be given a longer one. 100 ms is above the 75 ms TheDitis/AutoDrum gives its
# biggest solenoids' loudest strikes; a beater held on its head or bar longer mutes it. A
# strike counts against max_keys_down while its pulse is on (by its duty on PCA9685 boards),
# so simultaneous hits cannot sag the supply past it.
[guard]
enabled = true
max_hold = "10s"
max_keys_down = 16
restrike_gap = "60ms"
min_press = "20ms"
watchdog = "4s"
late_limit = "30ms"
duty_window = "60s"
duty_max_on = "30s"
max_pulse = "100ms"

# The PCA9685 boards' PWM frequency (24 Hz to 1526 Hz).
[pwm]
frequency = "1526Hz"

# On PCA9685 boards a strike's duty follows velocity too: velocity 1 at softest (the softest
# duty whose strike still sounds), 127 at loudest, for the whole pulse (a strike has no hold).
[dynamics]
softest = "45%"
loudest = "100%"
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GroupKind, Robot};

    #[test]
    fn every_instrument_reads_back_with_either_kind_of_board() {
        for instrument in Instrument::ALL {
            for kind in [BoardKind::OnOff, BoardKind::Pwm] {
                let text = instrument_toml(instrument, kind);
                let robot = Robot::from_toml(&text)
                    .unwrap_or_else(|e| panic!("{instrument:?} {kind:?}: {e:#}"));
                assert!(robot.kinds.iter().all(|k| *k == kind));
                assert!(robot.interpreter().is_ok());
            }
        }
    }

    #[test]
    fn the_kit_maps_every_gm_note_the_issue_names_and_the_glockenspiel_has_30_bars() {
        let kit = Robot::from_toml(&instrument_toml(Instrument::Drums, BoardKind::OnOff)).unwrap();
        let g = &kit.groups[0];
        assert_eq!(g.kind, GroupKind::Kit);
        let named: Vec<&str> = g.outputs.iter().map(String::as_str).collect();
        for drum in [
            "kick",
            "snare",
            "hi-hat",
            "hi-hat pedal",
            "floor tom",
            "mid tom",
            "high tom",
            "crash",
            "ride",
            "hi-hat lift",
        ] {
            assert!(named.contains(&drum), "{drum}");
        }
        let mapped: Vec<u8> = g.notes.iter().flatten().copied().collect();
        for n in [
            35, 36, 38, 40, 42, 44, 46, 41, 43, 45, 47, 48, 50, 49, 57, 51, 59,
        ] {
            assert!(mapped.contains(&n), "GM note {n}");
        }
        let glock =
            Robot::from_toml(&instrument_toml(Instrument::Glockenspiel, BoardKind::OnOff)).unwrap();
        let g = &glock.groups[0];
        assert_eq!(
            (g.kind, g.outputs.len(), g.program),
            (GroupKind::Pitched, 30, Some(10))
        );
        assert_eq!(
            (g.outputs[0].as_str(), g.outputs[29].as_str()),
            ("G5", "C8")
        );
    }
}
