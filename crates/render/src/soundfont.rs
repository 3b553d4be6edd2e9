//! Which soundfont to play with: the user's, or one a Debian package installed.
//!
//! Debian puts General MIDI soundfonts in `/usr/share/sounds/sf2/` (`timgm6mb-soundfont`:
//! `TimGM6mb.sf2`, 6 MB, GPL-2; `fluid-soundfont-gm`: `FluidR3_GM.sf2`, 145 MB, MIT) and
//! points `default-GM.sf2` there at the one chosen by `update-alternatives`; some systems have
//! `/usr/share/soundfonts/default.sf2`. None is shipped with orch (their licences are their
//! own): the test command installs `timgm6mb-soundfont`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rustysynth::SoundFont;

use crate::error::RenderError;

/// Where a soundfont is looked for when none is given, in order, with the Debian package
/// that installs it. FluidR3 first: a user who installed the larger font wants it.
pub const SEARCHED: [(&str, &str); 4] = [
    ("/usr/share/sounds/sf2/FluidR3_GM.sf2", "fluid-soundfont-gm"),
    ("/usr/share/sounds/sf2/TimGM6mb.sf2", "timgm6mb-soundfont"),
    (
        "/usr/share/sounds/sf2/default-GM.sf2",
        "timgm6mb-soundfont or fluid-soundfont-gm",
    ),
    ("/usr/share/soundfonts/default.sf2", "fluid-soundfont-gm"),
];

/// The soundfont to use: `given` if there is one (it must exist), else the first of
/// [`SEARCHED`] for which `exists` says yes. Pure: the file system is asked through `exists`.
pub fn choose(
    given: Option<&Path>,
    exists: impl Fn(&Path) -> bool,
) -> Result<PathBuf, RenderError> {
    match given {
        Some(p) if exists(p) => Ok(p.to_path_buf()),
        Some(p) => Err(RenderError::SoundFontMissing(p.to_path_buf())),
        None => SEARCHED
            .iter()
            .map(|(p, _)| Path::new(p))
            .find(|p| exists(p))
            .map(Path::to_path_buf)
            .ok_or(RenderError::NoSoundFont),
    }
}

/// [`choose`] on this machine's file system.
pub fn find(given: Option<&Path>) -> Result<PathBuf, RenderError> {
    choose(given, Path::exists)
}

/// Reads and parses a SoundFont 2 file.
pub fn load(path: &Path) -> Result<Arc<SoundFont>, RenderError> {
    let file = std::fs::File::open(path).map_err(|source| RenderError::SoundFontUnreadable {
        path: path.to_path_buf(),
        source,
    })?;
    let mut reader = std::io::BufReader::new(file);
    SoundFont::new(&mut reader)
        .map(Arc::new)
        .map_err(|e| RenderError::SoundFontInvalid {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_given_soundfont_must_exist_and_none_found_names_the_package() {
        let nothing = |_: &Path| false;
        assert!(matches!(
            choose(Some(Path::new("/x.sf2")), nothing),
            Err(RenderError::SoundFontMissing(_))
        ));
        let e = choose(None, nothing).unwrap_err();
        assert!(e.to_string().contains("timgm6mb-soundfont"), "{e}");
        assert!(e.is_bad_input());
    }

    #[test]
    fn the_first_installed_debian_soundfont_is_chosen() {
        let only_tim = |p: &Path| p.ends_with("TimGM6mb.sf2") || p.ends_with("default.sf2");
        assert_eq!(
            choose(None, only_tim).unwrap(),
            PathBuf::from("/usr/share/sounds/sf2/TimGM6mb.sf2")
        );
        assert_eq!(
            choose(Some(Path::new("/mine.sf2")), |_| true).unwrap(),
            PathBuf::from("/mine.sf2")
        );
    }
}
