//! Reading the input bytes: a file or standard input, raw or hex text, as they arrive, in
//! bounded memory (the reading is `orch_stage::bytes`'). A Standard MIDI File is read whole
//! by `orch_stage::load`.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

use crate::cli::Source;
use crate::error::bad_input;

/// Calls `each` with every chunk of input bytes as it arrives, so a live stream (a pipe from
/// a MIDI port) is shown as it plays. See [`orch_stage::bytes::for_each_chunk`].
pub fn for_each_chunk(
    source: &Source,
    each: impl FnMut(&[u8]) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let reader: Box<dyn Read> = match source.file.as_deref() {
        None => Box::new(io::stdin().lock()),
        Some(p) if p == Path::new("-") => Box::new(io::stdin().lock()),
        Some(p) => Box::new(
            File::open(p).map_err(|e| bad_input(format!("cannot open {}: {e}", p.display())))?,
        ),
    };
    orch_stage::bytes::for_each_chunk(reader, source.hex, each)
}
