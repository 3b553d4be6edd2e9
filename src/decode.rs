//! `orch decode`: raw MIDI bytes in, one message per line out, then the counters.

use std::io::{self, BufWriter, Write};

use orch_core::{Decoder, Message};

use crate::cli::DecodeArgs;
use crate::input;
use crate::show::{self, Shown};

pub fn run(args: &DecodeArgs) -> anyhow::Result<()> {
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let mut decoder = Decoder::<0>::new();
    // The command has no SysEx length limit: it collects the payload itself, since every data
    // byte between a SysExStart and the SysEx end is payload.
    let mut sysex: Vec<u8> = Vec::new();
    let json = args.source.json;
    input::for_each_chunk(&args.source, |bytes| {
        for &byte in bytes {
            if decoder.in_sysex() && byte < 0x80 {
                sysex.push(byte);
            }
            for message in decoder.push(byte) {
                if message == Message::SysExStart {
                    sysex.clear();
                }
                let shown = Shown {
                    message,
                    sysex: &sysex,
                };
                if json {
                    if let Some(value) = show::json(&shown) {
                        writeln!(out, "{value}")?;
                    }
                } else if message != Message::SysExStart {
                    writeln!(out, "{}", show::text(&shown))?;
                }
            }
        }
        out.flush()?;
        Ok(())
    })?;
    let c = decoder.counters();
    if json {
        writeln!(out, "{}", show::counters_json(&c))?;
    } else {
        writeln!(out, "{}", show::counters_text(&c))?;
    }
    out.flush()?;
    Ok(())
}
