//! `orch decode`: raw MIDI bytes in, one message per line out, then the counters. The
//! decoding and the formats are `orch_stage::messages`'; here: reading and printing.

use std::io::{self, BufWriter, Write};

use orch_core::Message;
use orch_stage::messages::{self as show, Messages};

use crate::cli::DecodeArgs;
use crate::input;

pub fn run(args: &DecodeArgs) -> anyhow::Result<()> {
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let mut messages = Messages::new();
    let json = args.source.json;
    input::for_each_chunk(&args.source, |bytes| {
        for &byte in bytes {
            messages.push(byte, |shown| -> io::Result<()> {
                match shown.message {
                    Message::SysExStart => Ok(()),
                    // A payload is written straight from its bytes (up to 1 MiB of them).
                    Message::SysEx { len, .. } if json => {
                        show::write_sysex_json(&mut out, shown.sysex, len)?;
                        writeln!(out)
                    }
                    Message::SysEx { len, terminated } => {
                        show::write_sysex_text(&mut out, shown.sysex, len, terminated)?;
                        writeln!(out)
                    }
                    _ if json => match show::json(&shown) {
                        Some(value) => writeln!(out, "{value}"),
                        None => Ok(()),
                    },
                    _ => writeln!(out, "{}", show::text(&shown)),
                }
            })?;
        }
        out.flush()?;
        Ok(())
    })?;
    let (c, truncated) = messages.finish();
    if json {
        writeln!(out, "{}", show::counters_json(&c, truncated))?;
    } else {
        writeln!(out, "{}", show::counters_text(&c, truncated))?;
    }
    out.flush()?;
    Ok(())
}
