//! Reading the input bytes: a file or standard input, raw or hex text, as they arrive, in
//! bounded memory. (A Standard MIDI File is read whole by `orch_stage::load`.)

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

use anyhow::Context;

use crate::cli::Source;
use crate::error::bad_input;
use crate::hex::HexReader;

/// How many bytes are read at a time.
const CHUNK: usize = 64 * 1024;

/// Calls `each` with every chunk of input bytes as it arrives, so a live stream (a pipe from
/// a MIDI port) is shown as it plays.
///
/// Memory stays bounded whatever the input: raw bytes are read 64 KiB at a time, and hex text
/// is read by a [`HexReader`], which keeps no line (a gigabyte without a newline is fine). On
/// bad hex text, the bytes before the fault are handed to `each` first, then the error is
/// returned.
pub fn for_each_chunk(
    source: &Source,
    mut each: impl FnMut(&[u8]) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut reader: Box<dyn Read> = match source.file.as_deref() {
        None => Box::new(io::stdin().lock()),
        Some(p) if p == Path::new("-") => Box::new(io::stdin().lock()),
        Some(p) => Box::new(
            File::open(p).map_err(|e| bad_input(format!("cannot open {}: {e}", p.display())))?,
        ),
    };
    let mut buf = vec![0u8; CHUNK];
    let mut hex = source.hex.then(HexReader::new);
    let mut bytes = Vec::new();
    loop {
        let n = match reader.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) if hex.is_some() => return Err(bad_input(format!("reading hex text: {e}"))),
            Err(e) => return Err(e).context("reading MIDI bytes"),
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
        read?;
        if n == 0 {
            return Ok(());
        }
    }
}
