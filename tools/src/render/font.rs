//! A 3x5 pixel digit font, enough to label a legend with numbers.

use super::Image;

/// Glyph rows for `0`..`9`, then `.`: 3 bits a row, the high bit leftmost.
const GLYPHS: [[u8; 5]; 11] = [
    [0b111, 0b101, 0b101, 0b101, 0b111],
    [0b010, 0b110, 0b010, 0b010, 0b111],
    [0b111, 0b001, 0b111, 0b100, 0b111],
    [0b111, 0b001, 0b111, 0b001, 0b111],
    [0b101, 0b101, 0b111, 0b001, 0b001],
    [0b111, 0b100, 0b111, 0b001, 0b111],
    [0b111, 0b100, 0b111, 0b101, 0b111],
    [0b111, 0b001, 0b010, 0b010, 0b010],
    [0b111, 0b101, 0b111, 0b101, 0b111],
    [0b111, 0b101, 0b111, 0b001, 0b111],
    [0b000, 0b000, 0b000, 0b000, 0b010],
];

/// Width of one character cell (glyph plus a column of space), unscaled.
pub(crate) const ADVANCE: u32 = 4;
/// Height of a glyph, unscaled.
pub(crate) const HEIGHT: u32 = 5;

/// The width in pixels of `text` drawn at `scale`.
pub(crate) fn text_width(text: &str, scale: u32) -> u32 {
    (text.len() as u32 * ADVANCE).saturating_sub(1) * scale
}

/// Draws `text` (digits and `.`; anything else is a space) with its top
/// left corner at `(x, y)`, each font pixel a `scale` x `scale` square.
pub(crate) fn draw_text(img: &mut Image, text: &str, x: u32, y: u32, scale: u32, colour: [u8; 3]) {
    for (i, ch) in text.chars().enumerate() {
        let glyph = match ch {
            '0'..='9' => GLYPHS.get(ch as usize - '0' as usize),
            '.' => GLYPHS.get(10),
            _ => None,
        };
        let Some(glyph) = glyph else { continue };
        let x0 = x + i as u32 * ADVANCE * scale;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..3 {
                if bits >> (2 - col) & 1 == 1 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            img.set(x0 + col * scale + dx, y + row as u32 * scale + dy, colour);
                        }
                    }
                }
            }
        }
    }
}
