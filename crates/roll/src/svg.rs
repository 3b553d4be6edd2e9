//! A minimal SVG (XML) writer: elements one a line, attribute values and text escaped, numbers
//! to a tenth of a pixel so the same roll is the same text every time.

use std::fmt::Write as _;

/// Text escaped for XML character data and attribute values (`&`, `<`, `>`, `"`, `'`);
/// characters XML 1.0 does not allow (controls other than tab and newlines) are left out.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\t' | '\n' | '\r' => out.push(c),
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => {}
            c => out.push(c),
        }
    }
    out
}

/// A length or coordinate, to a tenth (`-0.0` written `0.0`).
pub fn num(x: f64) -> String {
    let r = (x * 10.0).round() / 10.0;
    if r == 0.0 || !r.is_finite() {
        "0.0".into()
    } else {
        format!("{r:.1}")
    }
}

/// The document being written.
#[derive(Debug, Default)]
pub struct Writer {
    out: String,
}

impl Writer {
    fn start(&mut self, name: &str, attrs: &[(&str, String)]) {
        self.out.push('<');
        self.out.push_str(name);
        for (k, v) in attrs {
            let _ = write!(self.out, " {k}=\"{}\"", escape(v));
        }
    }

    /// `<name attrs>`, to be closed by [`close`](Self::close).
    pub fn open(&mut self, name: &str, attrs: &[(&str, String)]) {
        self.start(name, attrs);
        self.out.push_str(">\n");
    }

    /// `</name>`.
    pub fn close(&mut self, name: &str) {
        let _ = writeln!(self.out, "</{name}>");
    }

    /// `<name attrs/>`.
    pub fn empty(&mut self, name: &str, attrs: &[(&str, String)]) {
        self.start(name, attrs);
        self.out.push_str("/>\n");
    }

    /// `<name attrs>text</name>`, the text escaped.
    pub fn text(&mut self, name: &str, attrs: &[(&str, String)], text: &str) {
        self.start(name, attrs);
        let _ = writeln!(self.out, ">{}</{name}>", escape(text));
    }

    /// Raw markup, written as given (for the XML declaration and fixed style text).
    pub fn raw(&mut self, markup: &str) {
        self.out.push_str(markup);
    }

    /// The text written.
    pub fn finish(self) -> String {
        self.out
    }
}

/// An attribute list entry: `a("x", 1.5)`.
pub fn a(name: &'static str, value: impl ToString) -> (&'static str, String) {
    (name, value.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_quotes_markup_and_leaves_out_controls() {
        assert_eq!(
            escape("a<b>&\"c'\u{1}d\n"),
            "a&lt;b&gt;&amp;&quot;c&apos;d\n"
        );
    }

    #[test]
    fn num_rounds_to_a_tenth_without_negative_zero() {
        assert_eq!(num(1.26), "1.3");
        assert_eq!(num(-0.01), "0.0");
        assert_eq!(num(12.0), "12.0");
        assert_eq!(num(f64::NAN), "0.0");
    }

    #[test]
    fn writer_escapes_attribute_values_and_text() {
        let mut w = Writer::default();
        w.text("title", &[a("data-x", "\"&\"")], "<C4>");
        assert_eq!(
            w.finish(),
            "<title data-x=\"&quot;&amp;&quot;\">&lt;C4&gt;</title>\n"
        );
    }
}
