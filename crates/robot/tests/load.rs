//! `Robot::load`: files that cannot be read, and errors inside a file, name the file and the
//! field.

use std::path::PathBuf;

use orch_robot::{Robot, RobotError};

fn temp_file(name: &str, text: &str) -> PathBuf {
    let path = testkit::in_test(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_missing_file_is_a_read_error_naming_it() {
    let e = Robot::load("/nonexistent/robot.toml".as_ref()).unwrap_err();
    assert!(matches!(e, RobotError::Read { .. }), "{e:?}");
    assert_eq!(e.to_string(), "cannot read /nonexistent/robot.toml");
    let source = std::error::Error::source(&e).expect("the io error is the source");
    assert!(source.to_string().contains("No such file"), "{source}");
}

#[test]
fn an_error_in_a_file_names_the_file_and_the_field() {
    let path = temp_file("bad-hold.toml", "[guard]\nmax_hold = \"ten\"\n");
    let e = Robot::load(&path).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("bad-hold.toml"), "{text}");
    assert!(text.contains("guard.max_hold"), "{text}");
    assert_eq!(e.field_name(), Some("guard.max_hold"));
}

#[test]
fn a_good_file_loads() {
    let path = temp_file("good.toml", "[guard]\nmax_hold = \"5s\"\n");
    let robot = Robot::load(&path).unwrap();
    assert_eq!(
        robot.config.guard.max_hold,
        Some(orch_core::Duration::from_secs(5))
    );
    assert!(robot.interpreter().is_ok());
}
