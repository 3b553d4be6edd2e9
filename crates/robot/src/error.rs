//! What can be wrong with a `robot.toml`.

use std::fmt;
use std::io;
use std::path::PathBuf;

/// Why a robot configuration was refused. Every message names what is wrong: the file that
/// could not be read, or the field (`guard.max_hold`, `boards[2].keys`) and what to write
/// instead.
#[derive(Debug)]
#[non_exhaustive]
pub enum RobotError {
    /// The file could not be read.
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// The text is not TOML, or does not have the shape of a `robot.toml` (an unknown field,
    /// a string where a table belongs). The message is the TOML reader's, with the line.
    Syntax(String),
    /// A field holds a value the robot cannot use.
    Field {
        /// The field, as written in the file: `keys.low`, `boards[1].address`,
        /// `mechanics.key[0].note`.
        field: String,
        /// What is wrong and what to write instead.
        message: String,
    },
    /// An error in the configuration file at `path`.
    InFile {
        /// The file.
        path: PathBuf,
        /// What is wrong in it (never [`RobotError::Read`] or another `InFile`).
        error: Box<RobotError>,
    },
}

impl RobotError {
    /// A bad value in `field`.
    pub fn field(field: impl Into<String>, message: impl Into<String>) -> Self {
        RobotError::Field {
            field: field.into(),
            message: message.into(),
        }
    }

    /// The field at fault, if the error is about one field.
    pub fn field_name(&self) -> Option<&str> {
        match self {
            RobotError::Field { field, .. } => Some(field),
            RobotError::InFile { error, .. } => error.field_name(),
            _ => None,
        }
    }
}

impl fmt::Display for RobotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RobotError::Read { path, .. } => write!(f, "cannot read {}", path.display()),
            RobotError::Syntax(message) => f.write_str(message),
            RobotError::Field { field, message } => write!(f, "{field}: {message}"),
            RobotError::InFile { path, error } => {
                write!(f, "in robot configuration {}: {error}", path.display())
            }
        }
    }
}

impl std::error::Error for RobotError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            RobotError::Read { source, .. } => Some(source),
            // The inner error's text is part of this one's; its own source (none today) is next.
            RobotError::InFile { error, .. } => error.source(),
            _ => None,
        }
    }
}
