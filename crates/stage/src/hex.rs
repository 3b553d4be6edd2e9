//! Hex text input: pairs of hex digits, with or without whitespace, `#` comments.
//!
//! [`HexReader`] reads the text as it arrives, in chunks of any size, and keeps no line in
//! memory: a gigabyte of hex digits with no newline is read in constant memory.

use std::fmt;

/// Hex text that cannot be read: where, and why, in words ("line 3: 'G' in \"7G\" is not a
/// hex digit").
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HexError(String);

impl fmt::Display for HexError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for HexError {}

/// How many characters of a token an error message shows.
const SHOWN: usize = 24;

/// Reads hex text in chunks of any size: tokens separated by whitespace or commas, each with
/// an optional `0x` prefix and whole pairs of hex digits; `#` starts a comment running to the
/// end of the line. Errors name the line.
///
/// It keeps only its place: the line number, half a byte, the first characters of the token
/// being read (for error messages) and an unfinished UTF-8 character. Bytes are handed out as
/// soon as their second digit arrives, so on an error every byte before the fault has already
/// been given.
#[derive(Debug)]
pub struct HexReader {
    line: usize,
    comment: bool,
    token: Option<Token>,
    /// An unfinished multi-byte UTF-8 character: its bytes so far and its length.
    utf8: [u8; 4],
    utf8_have: u8,
    utf8_need: u8,
}

#[derive(Debug, Default)]
struct Token {
    /// Characters so far.
    chars: u64,
    /// The first digit of a byte whose second digit has not come yet.
    high: Option<u8>,
    /// The first [`SHOWN`] characters, for error messages.
    shown: String,
}

impl Token {
    fn shown(&self) -> String {
        if self.chars as usize > SHOWN {
            format!("{}…", self.shown)
        } else {
            self.shown.clone()
        }
    }
}

impl Default for HexReader {
    fn default() -> Self {
        Self::new()
    }
}

impl HexReader {
    /// A reader at the start of line 1.
    pub fn new() -> Self {
        Self::at_line(1)
    }

    /// A reader whose first line is numbered `line` in error messages.
    pub fn at_line(line: usize) -> Self {
        Self {
            line,
            comment: false,
            token: None,
            utf8: [0; 4],
            utf8_have: 0,
            utf8_need: 0,
        }
    }

    /// Reads the next chunk of text, appending its bytes to `out`.
    pub fn push(&mut self, text: &[u8], out: &mut Vec<u8>) -> Result<(), HexError> {
        for &b in text {
            if self.utf8_need > 0 {
                self.utf8_byte(b, out)?;
            } else if b < 0x80 {
                self.char(b as char, out)?;
            } else {
                self.utf8_need = match b {
                    0xC2..=0xDF => 2,
                    0xE0..=0xEF => 3,
                    0xF0..=0xF4 => 4,
                    _ => return Err(self.not_utf8(b)),
                };
                self.utf8[0] = b;
                self.utf8_have = 1;
            }
        }
        Ok(())
    }

    /// The end of the text: the last token ends.
    pub fn finish(&mut self) -> Result<(), HexError> {
        if self.utf8_need > 0 {
            return Err(self.not_utf8(self.utf8[0]));
        }
        self.end_token()
    }

    fn not_utf8(&self, b: u8) -> HexError {
        HexError(format!(
            "line {}: byte {b:#04x} is not UTF-8 text; write hex digits",
            self.line
        ))
    }

    fn utf8_byte(&mut self, b: u8, out: &mut Vec<u8>) -> Result<(), HexError> {
        if !(0x80..=0xBF).contains(&b) {
            return Err(self.not_utf8(self.utf8[0]));
        }
        self.utf8[self.utf8_have as usize] = b;
        self.utf8_have += 1;
        if self.utf8_have < self.utf8_need {
            return Ok(());
        }
        let n = self.utf8_need as usize;
        self.utf8_need = 0;
        let Some(c) = std::str::from_utf8(&self.utf8[..n])
            .ok()
            .and_then(|s| s.chars().next())
        else {
            return Err(self.not_utf8(self.utf8[0]));
        };
        self.char(c, out)
    }

    fn char(&mut self, c: char, out: &mut Vec<u8>) -> Result<(), HexError> {
        if self.comment {
            if c == '\n' {
                self.comment = false;
                self.line += 1;
            }
            return Ok(());
        }
        if c == '#' {
            self.end_token()?;
            self.comment = true;
        } else if c.is_whitespace() || c == ',' {
            self.end_token()?;
            if c == '\n' {
                self.line += 1;
            }
        } else {
            self.token_char(c, out)?;
        }
        Ok(())
    }

    fn token_char(&mut self, c: char, out: &mut Vec<u8>) -> Result<(), HexError> {
        let t = self.token.get_or_insert_with(Token::default);
        t.chars += 1;
        if t.chars as usize <= SHOWN {
            t.shown.push(c);
        }
        // "0x" or "0X" at the start of a token is a prefix: the 0 was not a digit.
        if t.chars == 2 && (c == 'x' || c == 'X') && t.shown.starts_with('0') {
            t.high = None;
            return Ok(());
        }
        let Some(digit) = c.to_digit(16) else {
            let mut token = t.shown();
            if t.chars as usize > SHOWN {
                token.push(c);
            }
            return Err(HexError(format!(
                "line {}: {c:?} in {token:?} is not a hex digit",
                self.line
            )));
        };
        match t.high.take() {
            Some(high) => out.push(high << 4 | digit as u8),
            None => t.high = Some(digit as u8),
        }
        Ok(())
    }

    fn end_token(&mut self) -> Result<(), HexError> {
        let Some(t) = self.token.take() else {
            return Ok(());
        };
        if t.high.is_some() {
            return Err(HexError(format!(
                "line {}: {:?} has an odd number of hex digits; write each byte as two digits",
                self.line,
                t.shown()
            )));
        }
        Ok(())
    }
}

/// Parses one line of hex text into bytes, appending them to `out`.
///
/// Tokens are separated by whitespace or commas and may carry a `0x` prefix; each token holds
/// whole pairs of digits. `#` starts a comment running to the end of the line. The same rules
/// as [`HexReader`], which it uses.
pub fn parse_line(line: &str, line_no: usize, out: &mut Vec<u8>) -> Result<(), HexError> {
    let mut reader = HexReader::at_line(line_no);
    reader.push(line.as_bytes(), out)?;
    reader.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<u8>, HexError> {
        let mut out = Vec::new();
        for (i, line) in text.lines().enumerate() {
            parse_line(line, i + 1, &mut out)?;
        }
        Ok(out)
    }

    /// The whole text through one reader, in chunks of `size` bytes.
    fn stream(text: &[u8], size: usize) -> (Vec<u8>, Result<(), HexError>) {
        let mut reader = HexReader::new();
        let mut out = Vec::new();
        for chunk in text.chunks(size.max(1)) {
            if let Err(e) = reader.push(chunk, &mut out) {
                return (out, Err(e));
            }
        }
        let end = reader.finish();
        (out, end)
    }

    #[test]
    fn pairs_with_and_without_whitespace_and_comments() {
        assert_eq!(
            parse("90 3C 7F # note on\n903c7f\n0x80,0x3C 00").unwrap(),
            vec![0x90, 0x3C, 0x7F, 0x90, 0x3C, 0x7F, 0x80, 0x3C, 0x00]
        );
    }

    #[test]
    fn odd_digits_and_non_hex_are_errors_naming_the_line() {
        let e = parse("90 3C\n9 3C").unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        assert!(parse("zz").is_err());
        let e = stream(b"90 3C\n# 9\n\n3C 0x7G", 3)
            .1
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("'G'"), "{e}");
    }

    #[test]
    fn any_chunking_reads_the_same_bytes_and_errors() {
        let texts: [&[u8]; 6] = [
            b"90 3C 7F # note on 0x zz\n903c7f\r\n0x80,0X3C 00\n",
            "90\u{a0}3C\u{2003}7F".as_bytes(),
            b"0x 0x00 00x1",
            b"90 3C 7",
            b"90 3C # comment\n 7F 0xx1",
            b"\xff 90",
        ];
        for text in texts {
            let (want, want_end) = stream(text, usize::MAX);
            let want_end = want_end.map_err(|e| e.to_string());
            for size in 1..text.len() {
                let (got, end) = stream(text, size);
                assert_eq!(got, want, "{text:?} in chunks of {size}");
                assert_eq!(end.map_err(|e| e.to_string()), want_end, "{text:?}");
            }
        }
    }

    #[test]
    fn unicode_whitespace_separates_and_a_prefix_needs_its_zero() {
        assert_eq!(
            parse("90\u{a0}3C\u{2003}7F").unwrap(),
            vec![0x90, 0x3C, 0x7F]
        );
        assert_eq!(parse("0x").unwrap(), Vec::<u8>::new());
        assert!(parse("x90").is_err());
        assert!(parse("00x1").is_err());
        assert!(parse("0x0x").is_err());
    }

    #[test]
    fn bytes_before_a_fault_are_given_and_a_long_token_is_shown_cut() {
        let (out, end) = stream(b"90 3C 7F3", 4);
        assert_eq!(out, vec![0x90, 0x3C, 0x7F]);
        let e = end.unwrap_err().to_string();
        assert!(e.contains("\"7F3\" has an odd number"), "{e}");
        let long = format!("{}zz", "0".repeat(1000));
        let e = stream(long.as_bytes(), 7).1.unwrap_err().to_string();
        assert!(e.contains("'z' in \"000000000000000000000000…z\""), "{e}");
        assert!(e.len() < 120, "{e}");
    }
}
