//! A scratch folder for one test: made fresh in the system's temporary folder, removed when
//! the test ends. A [`Scratch`] a test holds is kept, and named, when the test fails;
//! [`in_test`] names a file in the running test's own folder, made when first asked for.

use std::ffi::OsStr;
use std::ops::Deref;
use std::path::{Path, PathBuf};

thread_local! {
    static TEST: Scratch = Scratch::new(&test_tag());
}

/// `name` in the running test's own scratch folder, removed when the test ends, failed or
/// not (a [`Scratch`] the test holds is kept when it fails).
///
/// The test harness runs each test on a thread of its own, so the folder is the thread's: a
/// thread the test spawns has another one, removed when that thread ends. Files a test
/// needs from such a thread are named on the test's thread and handed over.
///
/// ```
/// let robot = testkit::in_test("robot.toml");
/// std::fs::write(&robot, "[keys]\n").unwrap();
/// assert_eq!(robot.parent(), testkit::in_test("x").parent());
/// ```
pub fn in_test(name: &str) -> PathBuf {
    TEST.with(|dir| dir.join(name))
}

/// The running thread's name (the test's, under the harness) as a folder name's part.
fn test_tag() -> String {
    let name = std::thread::current().name().unwrap_or("thread").to_owned();
    let tag: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .take(48)
        .collect();
    format!("test-{tag}")
}

/// A scratch folder, named `orch-TAG-…`; a [`Path`] by deref, so `scratch.join("robot.toml")`
/// names a file in it. Hold it while its files are needed: `Scratch::new(tag).join(name)`
/// removes the folder at the end of the statement (for a file alone, see [`in_test`]).
///
/// ```
/// let scratch = testkit::Scratch::new("doc");
/// std::fs::write(scratch.join("robot.toml"), "[keys]\n").unwrap();
/// let kept = scratch.to_path_buf();
/// drop(scratch);
/// assert!(!kept.exists());
/// ```
pub struct Scratch(Option<tempfile::TempDir>);

impl Scratch {
    /// A new, empty folder whose name starts `orch-TAG-`.
    pub fn new(tag: &str) -> Self {
        let dir = tempfile::Builder::new()
            .prefix(&format!("orch-{tag}-"))
            .tempdir()
            .expect("a scratch folder in the temporary folder");
        Self(Some(dir))
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        self.0.as_ref().expect("until dropped").path()
    }
}

impl Deref for Scratch {
    type Target = Path;

    fn deref(&self) -> &Path {
        self.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.path()
    }
}

impl AsRef<OsStr> for Scratch {
    fn as_ref(&self) -> &OsStr {
        self.path().as_os_str()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let dir = self.0.take().expect("dropped once");
        if std::thread::panicking() {
            eprintln!(
                "the failed test's scratch folder is kept: {}",
                dir.keep().display()
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_test_thread_has_a_folder_of_its_own_removed_when_it_ends() {
        let here = in_test("a");
        std::fs::write(&here, "a").unwrap();
        let there = std::thread::spawn(|| {
            let there = in_test("a");
            std::fs::write(&there, "b").unwrap();
            there
        })
        .join()
        .unwrap();
        assert_ne!(here.parent(), there.parent());
        assert!(!there.parent().unwrap().exists());
        assert_eq!(std::fs::read_to_string(&here).unwrap(), "a");
        assert!(
            here.to_string_lossy().contains("each-test-thread"),
            "{}",
            here.display()
        );
    }

    #[test]
    fn a_failed_test_keeps_its_folder() {
        let kept = std::thread::spawn(|| {
            let scratch = Scratch::new("kept");
            let path = scratch.to_path_buf();
            let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
                let _scratch = scratch;
                panic!("a failing test");
            }));
            path
        })
        .join()
        .unwrap();
        assert!(kept.is_dir());
        std::fs::remove_dir(&kept).unwrap();
    }
}
