//! Human-friendly previews: a cube as a horizontal cross, a dual paraboloid as two discs side
//! by side, lat-long and angular maps as they are; and a contact sheet of several maps.

use crate::io::{tone_map, ToneMap};
use crate::EnvMap;
use crate::Mapping;
use image::RgbImage;

/// Tone-mapped preview of a map in its natural layout.
pub fn preview(map: &EnvMap, tm: ToneMap) -> RgbImage {
    let (w, h) = (map.width, map.height);
    let put = |img: &mut RgbImage, layer: u32, ox: u32, oy: u32| {
        for j in 0..h {
            for i in 0..w {
                img.put_pixel(
                    ox + i,
                    oy + j,
                    image::Rgb(tone_map(map.texel(layer, i, j), tm)),
                );
            }
        }
    };
    match map.mapping {
        Mapping::LatLong | Mapping::Angular => {
            let mut img = RgbImage::new(w, h);
            put(&mut img, 0, 0, 0);
            img
        }
        Mapping::Cube => {
            // Middle row −X, +Z, +X, −Z; +Y above +Z and −Y below: edges meet as on the cube.
            let mut img = RgbImage::new(4 * w, 3 * h);
            for (layer, (cx, cy)) in [
                (1, (0, 1)),
                (4, (1, 1)),
                (0, (2, 1)),
                (5, (3, 1)),
                (2, (1, 0)),
                (3, (1, 2)),
            ] {
                put(&mut img, layer, cx * w, cy * h);
            }
            img
        }
        Mapping::DualParaboloid => {
            let mut img = RgbImage::new(2 * w, h);
            put(&mut img, 0, 0, 0);
            put(&mut img, 1, w, 0);
            img
        }
    }
}

/// Places images side by side, each scaled (nearest texel) to `height`, with a gap between.
pub fn contact_sheet(images: &[RgbImage], height: u32) -> RgbImage {
    let gap = 8;
    let widths: Vec<u32> = images
        .iter()
        .map(|i| ((i.width() as u64 * height as u64) / i.height().max(1) as u64).max(1) as u32)
        .collect();
    let total = widths.iter().sum::<u32>() + gap * (images.len() as u32 + 1);
    let mut sheet = RgbImage::from_pixel(total, height + 2 * gap, image::Rgb([32, 32, 32]));
    let mut x0 = gap;
    for (img, &w) in images.iter().zip(&widths) {
        for y in 0..height {
            for x in 0..w {
                let sx = (x as u64 * img.width() as u64 / w as u64) as u32;
                let sy = (y as u64 * img.height() as u64 / height as u64) as u32;
                sheet.put_pixel(x0 + x, gap + y, *img.get_pixel(sx, sy));
            }
        }
        x0 += w + gap;
    }
    sheet
}
