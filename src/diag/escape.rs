//! Text from outside (model replies, provider error bodies, server messages) made safe to print:
//! a reply holding `ESC [ 2 J` must not clear the user's terminal, move the cursor, retitle the
//! window or reorder the line. Every place that shows such text goes through [`terminal_safe`].

use std::borrow::Cow;
use std::fmt::Write as _;

/// `text` with control characters (C0 but newline and tab, DEL, C1 — which holds the one-byte
/// CSI) and bidirectional overrides written as `\u{…}` escapes. Backslashes are left alone, so
/// the function is idempotent and ordinary text comes back borrowed.
pub fn terminal_safe(text: &str) -> Cow<'_, str> {
    if !text.chars().any(unsafe_char) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if unsafe_char(c) {
            let _ = write!(out, "\\u{{{:x}}}", c as u32);
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// A writer that passes everything through [`terminal_safe`]: the plain-text output of the
/// commands that print what a run folder holds (model and domain names, concept names, paths),
/// which a shared or downloaded run folder controls. JSON output needs no wrapper (serde escapes
/// control characters) and must not get one (`\u{…}` is no JSON escape).
pub struct TerminalSafe<W>(pub W);

impl<W: std::io::Write> std::io::Write for TerminalSafe<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        // `write!` hands over whole `str` pieces, so a character is never split between calls;
        // bytes that are no UTF-8 have their control bytes escaped one by one.
        match std::str::from_utf8(buf) {
            Ok(s) => self.0.write_all(terminal_safe(s).as_bytes())?,
            Err(_) => {
                for &b in buf {
                    if (b < 0x20 && b != b'\n' && b != b'\t') || b == 0x7f {
                        write!(self.0, "\\u{{{b:x}}}")?;
                    } else {
                        self.0.write_all(&[b])?;
                    }
                }
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

fn unsafe_char(c: char) -> bool {
    (c.is_control() && c != '\n' && c != '\t') || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_sequences_and_keeps_plain_text() {
        assert!(matches!(terminal_safe("Answer: B\n\tok ü"), Cow::Borrowed(_)));
        assert_eq!(terminal_safe("\u{1b}[2J\u{1b}]0;owned\u{7}x"), "\\u{1b}[2J\\u{1b}]0;owned\\u{7}x");
        assert_eq!(terminal_safe("a\rb\u{9b}31m\u{7f}"), "a\\u{d}b\\u{9b}31m\\u{7f}");
        assert_eq!(terminal_safe("abc\u{202e}cba"), "abc\\u{202e}cba");
        let once = terminal_safe("\u{1b}[31m").into_owned();
        assert_eq!(terminal_safe(&once), once, "idempotent");
    }

    #[test]
    fn the_writer_escapes_what_passes_through() {
        use std::io::Write as _;
        let mut w = TerminalSafe(Vec::new());
        let name = "x\u{1b}]0;owned\u{7}";
        writeln!(w, "model {name}").unwrap();
        w.write_all(b"\xff\x1b[2J").unwrap();
        assert_eq!(w.0, b"model x\\u{1b}]0;owned\\u{7}\n\xff\\u{1b}[2J");
    }
}
