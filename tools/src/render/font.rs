//! A 3x5 pixel digit font, enough to label a legend with numbers.

use super::Image;

/// The glyph of `ch`: five rows of 3 bits, the high bit leftmost. Digits,
/// `.`, `+`, `:` and the capitals the heatmap's legend spells; `None` for
/// anything else (drawn as a space).
fn glyph(ch: char) -> Option<[u8; 5]> {
    Some(match ch {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b010, 0b010, 0b010],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        '+' => [0b000, 0b010, 0b111, 0b010, 0b000],
        ':' => [0b000, 0b010, 0b000, 0b010, 0b000],
        'A' => [0b010, 0b101, 0b111, 0b101, 0b101],
        'C' => [0b011, 0b100, 0b100, 0b100, 0b011],
        'D' => [0b110, 0b101, 0b101, 0b101, 0b110],
        'E' => [0b111, 0b100, 0b110, 0b100, 0b111],
        'G' => [0b011, 0b100, 0b101, 0b101, 0b011],
        'I' => [0b111, 0b010, 0b010, 0b010, 0b111],
        'L' => [0b100, 0b100, 0b100, 0b100, 0b111],
        'N' => [0b110, 0b101, 0b101, 0b101, 0b101],
        'O' => [0b010, 0b101, 0b101, 0b101, 0b010],
        'P' => [0b110, 0b101, 0b110, 0b100, 0b100],
        'R' => [0b110, 0b101, 0b110, 0b101, 0b101],
        'S' => [0b011, 0b100, 0b010, 0b001, 0b110],
        'T' => [0b111, 0b010, 0b010, 0b010, 0b010],
        'V' => [0b101, 0b101, 0b101, 0b101, 0b010],
        'Y' => [0b101, 0b101, 0b010, 0b010, 0b010],
        _ => return None,
    })
}

/// Whether every character of `text` has a glyph (a space is a gap).
#[cfg(test)]
pub(crate) fn can_draw(text: &str) -> bool {
    text.chars().all(|c| c == ' ' || glyph(c).is_some())
}

/// Width of one character cell (glyph plus a column of space), unscaled.
pub(crate) const ADVANCE: u32 = 4;
/// Height of a glyph, unscaled.
pub(crate) const HEIGHT: u32 = 5;

/// The width in pixels of `text` drawn at `scale`.
pub(crate) fn text_width(text: &str, scale: u32) -> u32 {
    (text.len() as u32 * ADVANCE).saturating_sub(1) * scale
}

/// Draws `text` (see [`glyph`]; anything else is a space) with its top
/// left corner at `(x, y)`, each font pixel a `scale` x `scale` square.
pub(crate) fn draw_text(img: &mut Image, text: &str, x: u32, y: u32, scale: u32, colour: [u8; 3]) {
    for (i, ch) in text.chars().enumerate() {
        let Some(glyph) = glyph(ch) else { continue };
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
