//! Hex text input: pairs of hex digits, with or without whitespace, `#` comments.

use crate::error::bad_input;

/// Parses one line of hex text into bytes, appending them to `out`.
///
/// Tokens are separated by whitespace or commas and may carry a `0x` prefix; each token holds
/// whole pairs of digits. `#` starts a comment running to the end of the line.
pub fn parse_line(line: &str, line_no: usize, out: &mut Vec<u8>) -> anyhow::Result<()> {
    let code = line.split('#').next().unwrap_or("");
    for token in code.split(|c: char| c.is_whitespace() || c == ',') {
        let digits = token
            .strip_prefix("0x")
            .or_else(|| token.strip_prefix("0X"))
            .unwrap_or(token);
        if let Some(bad) = digits.chars().find(|c| !c.is_ascii_hexdigit()) {
            return Err(bad_input(format!(
                "line {line_no}: {bad:?} in {token:?} is not a hex digit"
            )));
        }
        if digits.len() % 2 != 0 {
            return Err(bad_input(format!(
                "line {line_no}: {token:?} has an odd number of hex digits; write each byte as two digits"
            )));
        }
        for pair in digits.as_bytes().chunks(2) {
            let text = std::str::from_utf8(pair).expect("ASCII hex digits");
            out.push(u8::from_str_radix(text, 16).expect("checked hex digits"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> anyhow::Result<Vec<u8>> {
        let mut out = Vec::new();
        for (i, line) in text.lines().enumerate() {
            parse_line(line, i + 1, &mut out)?;
        }
        Ok(out)
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
    }
}
