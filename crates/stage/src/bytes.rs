//! MIDI bytes as they arrive from a reader (a file, standard input, a pipe from a port): raw,
//! or hex text read by a [`HexReader`], in bounded memory, handed on chunk by chunk so a live
//! stream is shown as it plays.

use std::fmt;
use std::io::{self, Read};

use crate::hex::{HexError, HexReader};

/// How many bytes are read at a time.
const CHUNK: usize = 64 * 1024;

/// Why the bytes could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// Raw bytes: the reader failed.
    Raw(io::Error),
    /// Hex text: the reader failed.
    Text(io::Error),
    /// Hex text that is not hex text.
    Hex(HexError),
}

impl ReadError {
    /// Whether the user's input is at fault: hex text that cannot be read.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, ReadError::Raw(_))
    }
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Raw(_) => f.write_str("reading MIDI bytes"),
            ReadError::Text(_) => f.write_str("reading hex text"),
            ReadError::Hex(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for ReadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ReadError::Raw(e) | ReadError::Text(e) => Some(e),
            ReadError::Hex(_) => None,
        }
    }
}

/// Calls `each` with every chunk of bytes from `reader` as it arrives; `hex`: the reader gives
/// hex text. Stops at the first error `each` returns.
///
/// Memory stays bounded whatever the input: raw bytes are read 64 KiB at a time, and hex text
/// is read by a [`HexReader`], which keeps no line (a gigabyte without a newline is fine). On
/// bad hex text, the bytes before the fault are handed to `each` first, then the error is
/// returned.
pub fn for_each_chunk<E: From<ReadError>>(
    mut reader: impl Read,
    hex: bool,
    mut each: impl FnMut(&[u8]) -> Result<(), E>,
) -> Result<(), E> {
    let mut buf = vec![0u8; CHUNK];
    let mut hex = hex.then(HexReader::new);
    let mut bytes = Vec::new();
    loop {
        let n = match reader.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) if hex.is_some() => return Err(ReadError::Text(e).into()),
            Err(e) => return Err(ReadError::Raw(e).into()),
        };
        let Some(hex) = hex.as_mut() else {
            if n == 0 {
                return Ok(());
            }
            each(&buf[..n])?;
            continue;
        };
        bytes.clear();
        let read = if n == 0 {
            hex.finish()
        } else {
            hex.push(&buf[..n], &mut bytes)
        };
        if !bytes.is_empty() {
            each(&bytes)?;
        }
        read.map_err(ReadError::Hex)?;
        if n == 0 {
            return Ok(());
        }
    }
}
