//! A 5 × 7 pixel font for the words a preview writes on itself (upper case, digits and a few
//! signs), so that a PNG states its tone mapping and figures without a font file.

/// Rows of glyph `c` (upper-cased), bit 4 the leftmost column; a blank for a character the
/// font lacks.
fn glyph(c: char) -> [u8; 7] {
    let rows: &str = match c.to_ascii_uppercase() {
        'A' => "01110 10001 10001 11111 10001 10001 10001",
        'B' => "11110 10001 10001 11110 10001 10001 11110",
        'C' => "01110 10001 10000 10000 10000 10001 01110",
        'D' => "11110 10001 10001 10001 10001 10001 11110",
        'E' => "11111 10000 10000 11110 10000 10000 11111",
        'F' => "11111 10000 10000 11110 10000 10000 10000",
        'G' => "01110 10001 10000 10111 10001 10001 01111",
        'H' => "10001 10001 10001 11111 10001 10001 10001",
        'I' => "01110 00100 00100 00100 00100 00100 01110",
        'J' => "00111 00010 00010 00010 00010 10010 01100",
        'K' => "10001 10010 10100 11000 10100 10010 10001",
        'L' => "10000 10000 10000 10000 10000 10000 11111",
        'M' => "10001 11011 10101 10101 10001 10001 10001",
        'N' => "10001 10001 11001 10101 10011 10001 10001",
        'O' => "01110 10001 10001 10001 10001 10001 01110",
        'P' => "11110 10001 10001 11110 10000 10000 10000",
        'Q' => "01110 10001 10001 10001 10101 10010 01101",
        'R' => "11110 10001 10001 11110 10100 10010 10001",
        'S' => "01111 10000 10000 01110 00001 00001 11110",
        'T' => "11111 00100 00100 00100 00100 00100 00100",
        'U' => "10001 10001 10001 10001 10001 10001 01110",
        'V' => "10001 10001 10001 10001 10001 01010 00100",
        'W' => "10001 10001 10001 10101 10101 10101 01010",
        'X' => "10001 10001 01010 00100 01010 10001 10001",
        'Y' => "10001 10001 10001 01010 00100 00100 00100",
        'Z' => "11111 00001 00010 00100 01000 10000 11111",
        '0' => "01110 10001 10011 10101 11001 10001 01110",
        '1' => "00100 01100 00100 00100 00100 00100 01110",
        '2' => "01110 10001 00001 00010 00100 01000 11111",
        '3' => "11111 00010 00100 00010 00001 10001 01110",
        '4' => "00010 00110 01010 10010 11111 00010 00010",
        '5' => "11111 10000 11110 00001 00001 10001 01110",
        '6' => "00110 01000 10000 11110 10001 10001 01110",
        '7' => "11111 00001 00010 00100 01000 01000 01000",
        '8' => "01110 10001 10001 01110 10001 10001 01110",
        '9' => "01110 10001 10001 01111 00001 00010 01100",
        '.' => "00000 00000 00000 00000 00000 01100 01100",
        ',' => "00000 00000 00000 00000 01100 00100 01000",
        '%' => "11000 11001 00010 00100 01000 10011 00011",
        ':' => "00000 01100 01100 00000 01100 01100 00000",
        '-' => "00000 00000 00000 11111 00000 00000 00000",
        '+' => "00000 00100 00100 11111 00100 00100 00000",
        '/' => "00000 00001 00010 00100 01000 10000 00000",
        '(' => "00010 00100 01000 01000 01000 00100 00010",
        ')' => "01000 00100 00010 00010 00010 00100 01000",
        '=' => "00000 00000 11111 00000 11111 00000 00000",
        _ => "00000 00000 00000 00000 00000 00000 00000",
    };
    let mut out = [0u8; 7];
    for (o, r) in out.iter_mut().zip(rows.split(' ')) {
        *o = u8::from_str_radix(r, 2).unwrap_or(0);
    }
    out
}

/// Width in pixels of `text` at `scale` (6 columns a character: 5 and a gap).
pub fn width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * 6 * scale
}

/// Draws `text` into the `w`-wide RGB8 image `img` with its top left corner at (x, y), each
/// font pixel `scale` × `scale`; what falls outside the image is left out.
pub fn draw(img: &mut [[u8; 3]], w: u32, (x, y): (u32, u32), text: &str, scale: u32, ink: [u8; 3]) {
    let h = img.len() as u32 / w.max(1);
    for (k, c) in text.chars().enumerate() {
        let g = glyph(c);
        let x0 = x + k as u32 * 6 * scale;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5u32 {
                if bits & (0x10 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (x0 + col * scale + dx, y + row as u32 * scale + dy);
                        if px < w && py < h {
                            img[(py * w + px) as usize] = ink;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_has_seven_rows_of_five_columns_and_letters_differ() {
        let chars: Vec<char> = "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.,%:-+/()="
            .chars()
            .collect();
        let mut seen = std::collections::HashSet::new();
        for c in &chars {
            let g = glyph(*c);
            assert!(g.iter().all(|r| *r < 32), "{c}: a row wider than 5");
            assert!(g.iter().any(|r| *r != 0), "{c}: blank");
            assert!(seen.insert(g), "{c}: the same as another glyph");
        }
        assert_eq!(glyph('a'), glyph('A'));
        assert_eq!(glyph('~'), [0; 7]);
    }

    #[test]
    fn text_is_drawn_inside_the_image_only() {
        let w = 20;
        let mut img = vec![[0u8; 3]; (w * 10) as usize];
        draw(&mut img, w, (15, 5), "EE", 1, [255; 3]);
        // E's top row is full: columns 15..20 of row 5; rows 5 to 9 of the first E fit, the
        // second starts past the edge.
        assert!((15..20).all(|x| img[(5 * w + x) as usize] == [255; 3]));
        assert_eq!(
            img.iter().filter(|p| **p == [255; 3]).count(),
            5 + 1 + 1 + 4 + 1
        );
        assert_eq!(width("EE", 2), 24);
    }
}
