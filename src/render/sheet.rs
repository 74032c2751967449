//! Contact sheets: images in a grid, each with a caption, so a reader sees many scenes at once
//! (`revelio render --grid`, `--all`). Captions use a built-in 5×7 pixel font: no font files,
//! identical output everywhere.

use image::{Rgba, RgbaImage};

/// Glyph rows, top to bottom, 5 columns each (`#` = ink). Letters are drawn lower-case; those
/// with descenders are shifted down when drawn (see `draw_text`), so a line is 9 rows.
const GLYPHS: &[(char, [&str; 7])] = &[
    ('a', ["     ", "     ", " ### ", "    #", " ####", "#   #", " ####"]),
    ('b', ["#    ", "#    ", "#### ", "#   #", "#   #", "#   #", "#### "]),
    ('c', ["     ", "     ", " ### ", "#    ", "#    ", "#    ", " ### "]),
    ('d', ["    #", "    #", " ####", "#   #", "#   #", "#   #", " ####"]),
    ('e', ["     ", "     ", " ### ", "#   #", "#####", "#    ", " ### "]),
    ('f', ["  ## ", " #   ", "#### ", " #   ", " #   ", " #   ", " #   "]),
    ('g', ["     ", " ####", "#   #", "#   #", " ####", "    #", " ### "]),
    ('h', ["#    ", "#    ", "#### ", "#   #", "#   #", "#   #", "#   #"]),
    ('i', ["  #  ", "     ", " ##  ", "  #  ", "  #  ", "  #  ", " ### "]),
    ('j', ["   # ", "     ", "  ## ", "   # ", "   # ", "#  # ", " ##  "]),
    ('k', ["#    ", "#    ", "#  # ", "# #  ", "##   ", "# #  ", "#  # "]),
    ('l', [" ##  ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "]),
    ('m', ["     ", "     ", "## # ", "# # #", "# # #", "# # #", "# # #"]),
    ('n', ["     ", "     ", "#### ", "#   #", "#   #", "#   #", "#   #"]),
    ('o', ["     ", "     ", " ### ", "#   #", "#   #", "#   #", " ### "]),
    ('p', ["     ", "#### ", "#   #", "#   #", "#### ", "#    ", "#    "]),
    ('q', ["     ", " ####", "#   #", "#   #", " ####", "    #", "    #"]),
    ('r', ["     ", "     ", "# ## ", "##  #", "#    ", "#    ", "#    "]),
    ('s', ["     ", "     ", " ####", "#    ", " ### ", "    #", "#### "]),
    ('t', [" #   ", " #   ", "#### ", " #   ", " #   ", " #  #", "  ## "]),
    ('u', ["     ", "     ", "#   #", "#   #", "#   #", "#  ##", " ## #"]),
    ('v', ["     ", "     ", "#   #", "#   #", "#   #", " # # ", "  #  "]),
    ('w', ["     ", "     ", "#   #", "#   #", "# # #", "# # #", " # # "]),
    ('x', ["     ", "     ", "#   #", " # # ", "  #  ", " # # ", "#   #"]),
    ('y', ["     ", "#   #", "#   #", "#   #", " ####", "    #", " ### "]),
    ('z', ["     ", "     ", "#####", "   # ", "  #  ", " #   ", "#####"]),
    ('0', [" ### ", "#   #", "#  ##", "# # #", "##  #", "#   #", " ### "]),
    ('1', ["  #  ", " ##  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "]),
    ('2', [" ### ", "#   #", "    #", "   # ", "  #  ", " #   ", "#####"]),
    ('3', ["#####", "   # ", "  #  ", "   # ", "    #", "#   #", " ### "]),
    ('4', ["   # ", "  ## ", " # # ", "#  # ", "#####", "   # ", "   # "]),
    ('5', ["#####", "#    ", "#### ", "    #", "    #", "#   #", " ### "]),
    ('6', ["  ## ", " #   ", "#    ", "#### ", "#   #", "#   #", " ### "]),
    ('7', ["#####", "    #", "   # ", "  #  ", " #   ", " #   ", " #   "]),
    ('8', [" ### ", "#   #", "#   #", " ### ", "#   #", "#   #", " ### "]),
    ('9', [" ### ", "#   #", "#   #", " ####", "    #", "   # ", " ##  "]),
    ('_', ["     ", "     ", "     ", "     ", "     ", "     ", "#####"]),
    ('-', ["     ", "     ", "     ", "#####", "     ", "     ", "     "]),
    ('.', ["     ", "     ", "     ", "     ", "     ", " ##  ", " ##  "]),
    (',', ["     ", "     ", "     ", "     ", " ##  ", "  #  ", " #   "]),
    (':', ["     ", " ##  ", " ##  ", "     ", " ##  ", " ##  ", "     "]),
    ('+', ["     ", "  #  ", "  #  ", "#####", "  #  ", "  #  ", "     "]),
    ('=', ["     ", "     ", "#####", "     ", "#####", "     ", "     "]),
    ('(', ["   # ", "  #  ", " #   ", " #   ", " #   ", "  #  ", "   # "]),
    (')', [" #   ", "  #  ", "   # ", "   # ", "   # ", "  #  ", " #   "]),
    ('/', ["     ", "    #", "   # ", "  #  ", " #   ", "#    ", "     "]),
    ('?', [" ### ", "#   #", "    #", "   # ", "  #  ", "     ", "  #  "]),
];

/// Pixels per glyph cell, spacing included.
const ADVANCE: u32 = 6;
const LINE: u32 = 9;

fn glyph(c: char) -> Option<&'static [&'static str; 7]> {
    let c = c.to_ascii_lowercase();
    GLYPHS
        .iter()
        .find(|(g, _)| *g == c)
        .map(|(_, rows)| rows)
        .or_else(|| GLYPHS.iter().find(|(g, _)| *g == '?').map(|(_, r)| r))
}

/// Width in pixels of `text` at `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * ADVANCE * scale
}

/// Draw `text` with its top-left corner at `(x, y)`; clipped at the image edges.
pub fn draw_text(img: &mut RgbaImage, x: u32, y: u32, text: &str, scale: u32, color: Rgba<u8>) {
    for (i, c) in text.chars().enumerate() {
        if c == ' ' {
            continue;
        }
        let Some(rows) = glyph(c) else { continue };
        let gx = x + i as u32 * ADVANCE * scale;
        // Letters with descenders sit two rows lower, below the baseline.
        let y = if "gjpqy".contains(c.to_ascii_lowercase()) { y + 2 * scale } else { y };
        for (ry, row) in rows.iter().enumerate() {
            for (rx, b) in row.bytes().enumerate() {
                if b != b'#' {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (gx + rx as u32 * scale + dx, y + ry as u32 * scale + dy);
                        if px < img.width() && py < img.height() {
                            img.put_pixel(px, py, color);
                        }
                    }
                }
            }
        }
    }
}

/// Darken a band at the top of a tile and write the caption in it, scaled up when it fits.
pub fn caption(img: &mut RgbaImage, text: &str) {
    let scale = if text_width(text, 2) + 8 <= img.width() { 2 } else { 1 };
    let band = (LINE * scale + 4).min(img.height());
    for y in 0..band {
        for x in 0..img.width() {
            let p = img.get_pixel_mut(x, y);
            for ch in &mut p.0[..3] {
                *ch = (*ch as u32 * 2 / 7) as u8;
            }
        }
    }
    draw_text(img, 4, 3, text, scale, Rgba([255, 255, 255, 255]));
}

/// Lay `tiles` (all the same size) out in a grid of `columns`, separated by a 2-pixel gutter.
pub fn grid(tiles: &[RgbaImage], columns: u32) -> RgbaImage {
    const GUTTER: u32 = 2;
    let Some(first) = tiles.first() else { return RgbaImage::new(1, 1) };
    let (tw, th) = first.dimensions();
    let columns = columns.clamp(1, tiles.len() as u32);
    let rows = (tiles.len() as u32).div_ceil(columns);
    let mut sheet = RgbaImage::from_pixel(
        columns * tw + (columns - 1) * GUTTER,
        rows * th + (rows - 1) * GUTTER,
        Rgba([24, 24, 24, 255]),
    );
    for (i, t) in tiles.iter().enumerate() {
        let (c, r) = (i as u32 % columns, i as u32 / columns);
        image::imageops::replace(&mut sheet, t, (c * (tw + GUTTER)) as i64, (r * (th + GUTTER)) as i64);
    }
    sheet
}

/// Columns for `n` tiles of aspect `w/h` so that the sheet is roughly 4:3.
pub fn columns_for(n: usize, w: u32, h: u32) -> u32 {
    let n = n.max(1) as f64;
    let c = (n * 4.0 / 3.0 * h as f64 / w as f64).sqrt().ceil();
    (c as u32).clamp(1, n as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_is_five_by_seven() {
        for (c, rows) in GLYPHS {
            assert!(rows.iter().all(|r| r.len() == 5), "glyph `{c}`");
            assert!(rows.iter().any(|r| r.contains('#')), "glyph `{c}` is empty");
        }
    }

    #[test]
    fn caption_writes_white_ink_in_a_dark_band() {
        let mut img = RgbaImage::from_pixel(200, 50, Rgba([210, 210, 210, 255]));
        caption(&mut img, "cone_far");
        let ink = img.pixels().filter(|p| p.0 == [255, 255, 255, 255]).count();
        assert!(ink > 40, "ink pixels: {ink}");
        assert!(img.get_pixel(199, 2).0[0] < 100, "band is darkened");
        assert_eq!(img.get_pixel(100, 40).0, [210, 210, 210, 255], "below the band is untouched");
    }

    #[test]
    fn grid_places_tiles_in_rows() {
        let tiles: Vec<_> = (0..5).map(|i| RgbaImage::from_pixel(10, 6, Rgba([i * 40, 0, 0, 255]))).collect();
        let sheet = grid(&tiles, 3);
        assert_eq!(sheet.dimensions(), (3 * 10 + 4, 2 * 6 + 2));
        assert_eq!(sheet.get_pixel(12 + 1, 1).0[0], 40);
        assert_eq!(sheet.get_pixel(12 + 1, 8 + 1).0[0], 160);
    }

    #[test]
    fn columns_make_a_landscape_sheet() {
        assert_eq!(columns_for(30, 320, 180), 5);
        assert_eq!(columns_for(1, 320, 180), 1);
    }
}
