//! Loading what a session plays: a Standard MIDI File (checked from its first bytes, its size
//! capped before it is read) and the robot (`robot.toml`, or the thesis's robot; with its
//! text, for a changed copy of it).

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

use orch_robot::{Robot, RobotError};
use orch_seq::Song;

use crate::StageError;

/// The largest Standard MIDI File orch reads: 64 MiB.
///
/// Real files are far smaller (the largest of the test corpus is 185 KB; a long piano
/// performance is well under 1 MB), and a file is parsed whole into memory, its events taking
/// several times its size. Anything larger is refused before it is read past the cap.
pub const MAX_MIDI_FILE_BYTES: u64 = 64 << 20;

/// Reads and parses a Standard MIDI File; any damage is bad input. The header is checked
/// from the first bytes and the size capped before the file is read ([`read_midi_file`]):
/// `/dev/urandom` is refused at once.
pub fn load_song(path: &Path) -> Result<Song, StageError> {
    let bytes = read_midi_file(path)?;
    song(&bytes, &path.display().to_string())
}

/// Parses the bytes of a Standard MIDI File read whole (by [`read_midi`], say); `name` is
/// what error messages call it.
pub fn song(bytes: &[u8], name: &str) -> Result<Song, StageError> {
    Song::parse(bytes).map_err(|source| StageError::Song {
        name: name.to_string(),
        source,
    })
}

/// The robot in `path`'s robot.toml, or the thesis's robot when there is none.
pub fn load_robot(path: Option<&Path>) -> Result<Robot, RobotError> {
    match path {
        Some(p) => Robot::load(p),
        None => Ok(Robot::thesis()),
    }
}

/// The robot in `path`'s robot.toml and the file's text, or the thesis's robot and its text
/// ([`orch_robot::DEFAULT_TOML`]) when there is none: what a calibrated copy is written from.
pub fn load_robot_text(path: Option<&Path>) -> Result<(Robot, String), RobotError> {
    match path {
        Some(p) => Robot::load_with_text(p),
        None => Ok((Robot::thesis(), orch_robot::DEFAULT_TOML.to_string())),
    }
}

/// Reads a Standard MIDI File whole, checking its first bytes before reading on.
///
/// Refused at once, as bad input naming the file: a file that cannot be opened, an empty one,
/// one that does not start with `MThd` (after reading only 4 bytes, so `/dev/urandom` or a
/// live port is refused at once), and one larger than [`MAX_MIDI_FILE_BYTES`] (a regular file
/// by its size, anything else once it has gone past the cap). What follows the header is
/// checked by [`Song::parse`].
pub fn read_midi_file(path: &Path) -> Result<Vec<u8>, StageError> {
    let name = path.display().to_string();
    let file = File::open(path).map_err(|source| StageError::Read {
        name: name.clone(),
        source,
    })?;
    if let Ok(meta) = file.metadata() {
        if meta.is_file() && meta.len() > MAX_MIDI_FILE_BYTES {
            return Err(too_large(&name, MAX_MIDI_FILE_BYTES));
        }
    }
    read_midi(file, &name, MAX_MIDI_FILE_BYTES)
}

/// [`read_midi_file`]'s checks on any reader, with the size cap `limit`; `name` is what
/// error messages call it.
pub fn read_midi(mut reader: impl Read, name: &str, limit: u64) -> Result<Vec<u8>, StageError> {
    let read_error = |source: io::Error| StageError::Read {
        name: name.to_string(),
        source,
    };
    let mut head = Vec::with_capacity(4);
    (&mut reader)
        .take(4)
        .read_to_end(&mut head)
        .map_err(read_error)?;
    if head.is_empty() {
        return Err(StageError::BadInput(format!(
            "{name} is not a MIDI file: it is empty"
        )));
    }
    if head != b"MThd" {
        let shown: Vec<String> = head.iter().map(|b| format!("{b:02X}")).collect();
        let hint = if head == b"RIFF" {
            " (a RIFF file: an RMID wrapper is not unwrapped; extract the MThd file inside)"
        } else {
            ""
        };
        return Err(StageError::BadInput(format!(
            "{name} is not a Standard MIDI File: it starts with {} instead of MThd (4D 54 68 64){hint}",
            shown.join(" ")
        )));
    }
    let mut bytes = head;
    reader
        .take(limit.saturating_sub(4).saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(read_error)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(name, limit));
    }
    Ok(bytes)
}

fn too_large(name: &str, limit: u64) -> StageError {
    StageError::BadInput(format!(
        "{name} is larger than the {} MiB a MIDI file may be",
        limit >> 20
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_comes_with_its_files_text_or_the_theses() {
        let (robot, text) = load_robot_text(None).unwrap();
        assert_eq!(text, orch_robot::DEFAULT_TOML);
        assert_eq!(robot.config, Robot::thesis().config);
        let path = testkit::in_test("robot.toml");
        let written = format!("# mine\n{}", orch_robot::DEFAULT_TOML);
        std::fs::write(&path, &written).unwrap();
        let (robot, text) = load_robot_text(Some(&path)).unwrap();
        assert_eq!(text, written);
        assert_eq!(robot.config, Robot::thesis().config);
        let missing = testkit::in_test("none.toml");
        assert!(matches!(
            load_robot_text(Some(&missing)),
            Err(RobotError::Read { .. })
        ));
    }

    /// A reader of endless bytes that counts what was read from it.
    struct Endless<'a> {
        head: &'a [u8],
        fill: u8,
        read: u64,
    }

    impl Read for Endless<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let n = buf.len().min(4096);
            for (i, b) in buf[..n].iter_mut().enumerate() {
                let at = self.read as usize + i;
                *b = self.head.get(at).copied().unwrap_or(self.fill);
            }
            self.read += n as u64;
            Ok(n)
        }
    }

    #[test]
    fn a_stream_that_is_not_midi_is_refused_after_its_first_bytes() {
        let mut noise = Endless {
            head: b"\x8f\x12\xa0\x07",
            fill: 0x55,
            read: 0,
        };
        let e = read_midi(&mut noise, "noise", MAX_MIDI_FILE_BYTES).unwrap_err();
        assert!(noise.read <= 4096, "read {} bytes", noise.read);
        let text = e.to_string();
        assert!(
            text.contains("noise") && text.contains("8F 12 A0 07"),
            "{text}"
        );
        assert!(e.is_bad_input());
    }

    #[test]
    fn a_midi_stream_past_the_cap_is_refused_once_past_it() {
        let mut endless = Endless {
            head: b"MThd\0\0\0\x06\0\0\0\x01\x01\xe0",
            fill: 0,
            read: 0,
        };
        let e = read_midi(&mut endless, "big.mid", 1 << 20).unwrap_err();
        assert!(
            endless.read <= (1 << 20) + 8192,
            "read {} bytes",
            endless.read
        );
        assert!(e.to_string().contains("larger than the 1 MiB"), "{e}");
    }

    #[test]
    fn a_file_at_the_cap_is_read_whole() {
        let mut file = b"MThd".to_vec();
        file.resize(1000, 7);
        let got = read_midi(&file[..], "f", 1000).unwrap();
        assert_eq!(got, file);
        assert!(read_midi(&file[..], "f", 999).is_err());
    }

    #[test]
    fn empty_short_and_riff_files_are_refused_naming_what_they_are() {
        let e = read_midi(&b""[..], "e.mid", 100).unwrap_err().to_string();
        assert!(e.contains("e.mid") && e.contains("empty"), "{e}");
        let e = read_midi(&b"MT"[..], "s.mid", 100).unwrap_err().to_string();
        assert!(e.contains("4D 54 instead of MThd"), "{e}");
        let e = read_midi(&b"RIFF\0\0\0\0RMID"[..], "r.rmi", 100)
            .unwrap_err()
            .to_string();
        assert!(e.contains("RMID"), "{e}");
    }

    #[test]
    fn read_midi_file_refuses_dev_urandom_at_once() {
        let path = Path::new("/dev/urandom");
        if !path.exists() {
            return;
        }
        let start = std::time::Instant::now();
        let e = read_midi_file(path).unwrap_err().to_string();
        assert!(
            e.contains("/dev/urandom") && e.contains("instead of MThd"),
            "{e}"
        );
        assert!(start.elapsed() < std::time::Duration::from_secs(2));
    }
}
