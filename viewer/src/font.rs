//! A 5×7 bitmap font for the on-screen readout: upper-case ASCII, digits and the punctuation
//! the readout uses, drawn from an atlas texture as one quad per character. A hand-written
//! table costs nothing to compile, unlike a font-rendering crate.

/// Glyph cell size in font pixels.
pub const GLYPH_WIDTH: u32 = 5;
pub const GLYPH_HEIGHT: u32 = 7;
/// Distance between characters and between lines, in font pixels.
pub const ADVANCE: u32 = 6;
pub const LINE_HEIGHT: u32 = 10;

/// Rows top to bottom; bit 4 is the leftmost pixel.
const GLYPHS: &[(char, [u8; 7])] = &[
    (' ', [0, 0, 0, 0, 0, 0, 0]),
    (
        '0',
        [
            0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110,
        ],
    ),
    (
        '1',
        [
            0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
    ),
    (
        '2',
        [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111,
        ],
    ),
    (
        '3',
        [
            0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110,
        ],
    ),
    (
        '4',
        [
            0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010,
        ],
    ),
    (
        '5',
        [
            0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110,
        ],
    ),
    (
        '6',
        [
            0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        '7',
        [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000,
        ],
    ),
    (
        '8',
        [
            0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        '9',
        [
            0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100,
        ],
    ),
    (
        'A',
        [
            0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
    ),
    (
        'B',
        [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110,
        ],
    ),
    (
        'C',
        [
            0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110,
        ],
    ),
    (
        'D',
        [
            0b11100, 0b10010, 0b10001, 0b10001, 0b10001, 0b10010, 0b11100,
        ],
    ),
    (
        'E',
        [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111,
        ],
    ),
    (
        'F',
        [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
    ),
    (
        'G',
        [
            0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111,
        ],
    ),
    (
        'H',
        [
            0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
    ),
    (
        'I',
        [
            0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
    ),
    (
        'J',
        [
            0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
        ],
    ),
    (
        'K',
        [
            0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001,
        ],
    ),
    (
        'L',
        [
            0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111,
        ],
    ),
    (
        'M',
        [
            0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001,
        ],
    ),
    (
        'N',
        [
            0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001,
        ],
    ),
    (
        'O',
        [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        'P',
        [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
    ),
    (
        'Q',
        [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101,
        ],
    ),
    (
        'R',
        [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001,
        ],
    ),
    (
        'S',
        [
            0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110,
        ],
    ),
    (
        'T',
        [
            0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
    ),
    (
        'U',
        [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        'V',
        [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100,
        ],
    ),
    (
        'W',
        [
            0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010,
        ],
    ),
    (
        'X',
        [
            0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001,
        ],
    ),
    (
        'Y',
        [
            0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100,
        ],
    ),
    (
        'Z',
        [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111,
        ],
    ),
    (
        '.',
        [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100,
        ],
    ),
    (
        ',',
        [
            0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b00100, 0b01000,
        ],
    ),
    (
        ':',
        [
            0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000,
        ],
    ),
    (
        '-',
        [
            0b00000, 0b00000, 0b00000, 0b11111, 0b00000, 0b00000, 0b00000,
        ],
    ),
    (
        '+',
        [
            0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000,
        ],
    ),
    (
        '/',
        [
            0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000,
        ],
    ),
    (
        '(',
        [
            0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010,
        ],
    ),
    (
        ')',
        [
            0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000,
        ],
    ),
    (
        '[',
        [
            0b01110, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01110,
        ],
    ),
    (
        ']',
        [
            0b01110, 0b00010, 0b00010, 0b00010, 0b00010, 0b00010, 0b01110,
        ],
    ),
    (
        '=',
        [
            0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000,
        ],
    ),
    (
        '%',
        [
            0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011,
        ],
    ),
    (
        '°',
        [
            0b01100, 0b10010, 0b10010, 0b01100, 0b00000, 0b00000, 0b00000,
        ],
    ),
    (
        '_',
        [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b11111,
        ],
    ),
    (
        '?',
        [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b00000, 0b00100,
        ],
    ),
    (
        '!',
        [
            0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00000, 0b00100,
        ],
    ),
    (
        '#',
        [
            0b01010, 0b01010, 0b11111, 0b01010, 0b11111, 0b01010, 0b01010,
        ],
    ),
    (
        '\'',
        [
            0b01100, 0b00100, 0b01000, 0b00000, 0b00000, 0b00000, 0b00000,
        ],
    ),
    (
        '|',
        [
            0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
    ),
    // Not a character: a full cell, drawn behind the text as its panel.
    ('\u{2588}', [0b11111; 7]),
];

/// The glyph drawn for characters the font lacks.
const UNKNOWN: char = '?';
/// The full cell, for backgrounds.
pub const SOLID: char = '\u{2588}';

/// The atlas: every glyph side by side in one row, one byte per pixel (0 or 255).
pub fn atlas() -> (u32, u32, Vec<u8>) {
    let width = GLYPH_WIDTH * GLYPHS.len() as u32;
    let mut pixels = vec![0u8; (width * GLYPH_HEIGHT) as usize];
    for (g, (_, rows)) in GLYPHS.iter().enumerate() {
        for (y, row) in rows.iter().enumerate() {
            for x in 0..GLYPH_WIDTH {
                if row >> (GLYPH_WIDTH - 1 - x) & 1 == 1 {
                    pixels[y * width as usize + g * GLYPH_WIDTH as usize + x as usize] = 255;
                }
            }
        }
    }
    (width, GLYPH_HEIGHT, pixels)
}

/// The atlas index of a character (lower case drawn as upper case).
pub fn glyph(c: char) -> u32 {
    let c = c.to_ascii_uppercase();
    let find = |c: char| GLYPHS.iter().position(|(g, _)| *g == c);
    find(c).or_else(|| find(UNKNOWN)).expect("the font has '?'") as u32
}

/// One character placed on screen, in font pixels from the top-left corner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placed {
    pub x: u32,
    pub y: u32,
    pub glyph: u32,
}

/// Lays out text (with `\n` line breaks) from the origin; returns the characters and the
/// size of the block in font pixels.
pub fn layout(text: &str) -> (Vec<Placed>, (u32, u32)) {
    let mut placed = Vec::new();
    let (mut width, mut lines) = (0, 0);
    for (line, row) in text.lines().enumerate() {
        let mut x = 0;
        for c in row.chars() {
            if c != ' ' {
                placed.push(Placed {
                    x,
                    y: line as u32 * LINE_HEIGHT,
                    glyph: glyph(c),
                });
            }
            x += ADVANCE;
        }
        width = width.max(x);
        lines = line as u32 + 1;
    }
    let height = lines.saturating_sub(1) * LINE_HEIGHT + GLYPH_HEIGHT;
    (placed, (width, height))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_fits_its_cell_and_is_listed_once() {
        for (i, (c, rows)) in GLYPHS.iter().enumerate() {
            assert!(rows.iter().all(|r| *r < 1 << GLYPH_WIDTH), "{c}");
            assert!(!GLYPHS[..i].iter().any(|(d, _)| d == c), "{c} twice");
        }
    }

    #[test]
    fn the_readout_needs_no_missing_glyph() {
        let text = "PRT  12.5 FPS  ORDER 8  TEXTURES ON\nLIGHT 1/8 SUN  THETA -50.0°  PHI 120.5°\nARROWS/MOUSE CAMERA  1-8 LIGHT  Q/A THETA  W/E PHI  T N L  F1 PHONG  F2 PRT\nBLINN-PHONG HEMISPHERE ENVIRONMENT DIRECTIONAL CONSTANT SPHERE";
        let question = glyph('?');
        for c in text.chars().filter(|c| !c.is_whitespace()) {
            assert_ne!(glyph(c), question, "no glyph for {c:?}");
        }
        assert_eq!(glyph('é'), question);
    }

    #[test]
    fn layout_advances_and_breaks_lines() {
        let (placed, size) = layout("AB\nC D");
        assert_eq!(
            placed.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>(),
            [
                (0, 0),
                (ADVANCE, 0),
                (0, LINE_HEIGHT),
                (2 * ADVANCE, LINE_HEIGHT)
            ]
        );
        assert_eq!(size, (3 * ADVANCE, LINE_HEIGHT + GLYPH_HEIGHT));
    }
}
