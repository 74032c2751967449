//! Positions: byte offsets (what spans hold) to LSP line/character pairs and back. LSP counts
//! characters in UTF-16 code units unless client and server agree on another encoding
//! (`positionEncoding`, LSP 3.17); counting `char`s would put every column after a non-ASCII
//! character in the wrong place.

use lsp_types::{Position, Range};

/// How the `character` of a position counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Utf8,
    Utf16,
    Utf32,
}

impl Encoding {
    fn units(self, c: char) -> u32 {
        match self {
            Encoding::Utf8 => c.len_utf8() as u32,
            Encoding::Utf16 => c.len_utf16() as u32,
            Encoding::Utf32 => 1,
        }
    }
}

/// Line starts of one text, for converting positions.
#[derive(Debug, Clone)]
pub struct LineIndex {
    starts: Vec<u32>,
    len: u32,
}

impl LineIndex {
    pub fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i as u32 + 1));
        LineIndex { starts, len: text.len() as u32 }
    }

    /// The position of byte `offset` (clamped to the text; a `\r` before `\n` ends its line).
    pub fn position(&self, text: &str, offset: u32, enc: Encoding) -> Position {
        let offset = offset.min(self.len);
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        let start = self.starts[line] as usize;
        let mut end = offset as usize;
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let character = text[start..end].chars().map(|c| enc.units(c)).sum();
        Position { line: line as u32, character }
    }

    pub fn range(&self, text: &str, start: u32, end: u32, enc: Encoding) -> Range {
        Range { start: self.position(text, start, enc), end: self.position(text, end, enc) }
    }

    /// The byte offset of `pos`; a position past the end of its line is the line's end, a line
    /// past the end of the text is the text's end.
    pub fn offset(&self, text: &str, pos: Position, enc: Encoding) -> u32 {
        let Some(&start) = self.starts.get(pos.line as usize) else { return self.len };
        let line_end = self.starts.get(pos.line as usize + 1).map_or(self.len, |&s| s - 1);
        let line = &text[start as usize..line_end as usize];
        let mut units = 0;
        for (i, c) in line.char_indices() {
            if units >= pos.character {
                return start + i as u32;
            }
            units += enc.units(c);
        }
        line_end
    }

    /// The position just after the last character.
    pub fn end(&self, text: &str, enc: Encoding) -> Position {
        self.position(text, self.len, enc)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utf16_counts_surrogate_pairs_and_utf8_counts_bytes() {
        let text = "ab\ndé𝄞x\n";
        let idx = LineIndex::new(text);
        let x = text.find('x').unwrap() as u32;
        assert_eq!(idx.position(text, x, Encoding::Utf16), Position::new(1, 4));
        assert_eq!(idx.position(text, x, Encoding::Utf8), Position::new(1, 7));
        assert_eq!(idx.position(text, x, Encoding::Utf32), Position::new(1, 3));
        for enc in [Encoding::Utf8, Encoding::Utf16, Encoding::Utf32] {
            assert_eq!(idx.offset(text, idx.position(text, x, enc), enc), x);
        }
        assert_eq!(idx.offset(text, Position::new(0, 99), Encoding::Utf16), 2, "past the line's end");
        assert_eq!(idx.offset(text, Position::new(9, 0), Encoding::Utf16), text.len() as u32);
        assert_eq!(idx.end(text, Encoding::Utf16), Position::new(2, 0));
    }
}
