//! `orch decode`: raw MIDI bytes in, one message per line out, then the counters.

use std::io::{self, BufWriter, Write};

use orch_core::{Decoder, Message};

use crate::cli::DecodeArgs;
use crate::input;
use crate::show::{self, Shown};

/// How much of a System Exclusive message's payload is kept and shown: the first 1 MiB. A
/// longer one is shown with its first 1 MiB and its full length (text: "... (N more not
/// shown)"; JSON: a `"length"` beside `"data"`), so memory stays bounded however long it is.
pub const SYSEX_SHOWN: usize = 1 << 20;

pub fn run(args: &DecodeArgs) -> anyhow::Result<()> {
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let mut decoder = Decoder::<0>::new();
    // The decoder keeps no SysEx payload: every data byte between a SysExStart and the SysEx
    // end is payload, and the command keeps the first SYSEX_SHOWN of them itself.
    let mut sysex: Vec<u8> = Vec::new();
    let json = args.source.json;
    input::for_each_chunk(&args.source, |bytes| {
        for &byte in bytes {
            if decoder.in_sysex() && byte < 0x80 && sysex.len() < SYSEX_SHOWN {
                sysex.push(byte);
            }
            for message in decoder.push(byte) {
                match message {
                    Message::SysExStart => sysex.clear(),
                    Message::SysEx { len, terminated } => {
                        if json {
                            show::write_sysex_json(&mut out, &sysex, len)?;
                        } else {
                            show::write_sysex_text(&mut out, &sysex, len, terminated)?;
                        }
                        writeln!(out)?;
                    }
                    _ => {
                        let shown = Shown {
                            message,
                            sysex: &sysex,
                        };
                        if json {
                            if let Some(value) = show::json(&shown) {
                                writeln!(out, "{value}")?;
                            }
                        } else {
                            writeln!(out, "{}", show::text(&shown))?;
                        }
                    }
                }
            }
        }
        out.flush()?;
        Ok(())
    })?;
    let truncated = decoder.finish();
    let c = decoder.counters();
    if json {
        writeln!(out, "{}", show::counters_json(&c, truncated))?;
    } else {
        writeln!(out, "{}", show::counters_text(&c, truncated))?;
    }
    out.flush()?;
    Ok(())
}
