//! Reading the input bytes: a file or standard input, raw or hex text, as they arrive.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use anyhow::Context;

use crate::cli::Source;
use crate::error::bad_input;
use crate::hex;

/// Calls `each` with every chunk of input bytes as it arrives, so a live stream (a pipe from
/// a MIDI port) is shown as it plays.
pub fn for_each_chunk(
    source: &Source,
    mut each: impl FnMut(&[u8]) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let reader: Box<dyn Read> = match source.file.as_deref() {
        None => Box::new(io::stdin().lock()),
        Some(p) if p == Path::new("-") => Box::new(io::stdin().lock()),
        Some(p) => Box::new(
            File::open(p).map_err(|e| bad_input(format!("cannot open {}: {e}", p.display())))?,
        ),
    };
    let mut reader = BufReader::new(reader);
    if source.hex {
        let mut line = String::new();
        let mut bytes = Vec::new();
        let mut line_no = 0;
        loop {
            line.clear();
            let n = reader
                .read_line(&mut line)
                .map_err(|e| bad_input(format!("reading hex text: {e}")))?;
            if n == 0 {
                return Ok(());
            }
            line_no += 1;
            bytes.clear();
            hex::parse_line(&line, line_no, &mut bytes)?;
            each(&bytes)?;
        }
    } else {
        let mut buf = [0u8; 4096];
        loop {
            let n = match reader.read(&mut buf) {
                Ok(0) => return Ok(()),
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e).context("reading MIDI bytes"),
            };
            each(&buf[..n])?;
        }
    }
}
