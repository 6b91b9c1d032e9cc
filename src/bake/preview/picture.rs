//! The preview as a PNG: the row tone-mapped, its caption (labels, files against intent, the
//! tone mapping) and the heat maps of recipe against reference.

use super::reference::{RecipeCheck, COMPARED, SIDE};
use super::{font, Picture, PreviewCheck, CAPTION, DEPTH, FOCAL, SPACING, SPHERES, WIDTH};
use crate::error::{Error, Result};
use crate::io::{tone_map, ToneMap};

/// Height of the heat maps' row, pixels.
pub const HEAT: u32 = 132;
/// Heat-map pixels a reference pixel; the error at full colour.
const ZOOM: u32 = 3;
const FULL: f64 = 0.5;
const GROUND: [u8; 3] = [24, 24, 24];
const GREY: [u8; 3] = [200, 200, 200];

/// Magma-like colours from 0 to [`FULL`].
fn colour(e: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 4.0],
        [87.0, 16.0, 110.0],
        [188.0, 55.0, 84.0],
        [249.0, 142.0, 9.0],
        [252.0, 255.0, 164.0],
    ];
    if e.is_nan() {
        return GROUND;
    }
    let t = (e / FULL).clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    [0, 1, 2].map(|c| (STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f).round() as u8)
}

fn caption(img: &mut [[u8; 3]], p: &Picture, check: &PreviewCheck) {
    let w = p.width;
    let first = WIDTH as f64 / 2.0 - FOCAL * SPACING * (SPHERES.len() - 1) as f64 / 2.0 / DEPTH;
    for (k, s) in SPHERES.iter().enumerate() {
        let text = s.label();
        let cx = first + FOCAL * SPACING * k as f64 / DEPTH;
        let x = (cx - font::width(&text, 1) as f64 / 2.0).max(0.0) as u32;
        font::draw(img, w, (x, p.height + 4), &text, 1, GREY);
    }
    let line = format!("FILES VS INTENT, WORST SPHERE: {:.3}%", 100.0 * check.worst);
    let ink = if check.worst <= 0.01 {
        [140, 220, 140]
    } else {
        [255, 120, 100]
    };
    font::draw(img, w, (4, p.height + 17), &line, 2, ink);
    let tone = format!(
        "TONE: REINHARD X/(1+X) PER CHANNEL, {:+.1} EV, SRGB. LINEAR DATA IS COMPARED.",
        check.exposure
    );
    font::draw(img, w, (4, p.height + 38), &tone, 1, GREY);
}

/// `map` ([`SIDE`]², computed on even rows and columns, NaN elsewhere and off the sphere)
/// with each pixel showing its 2 × 2 block's computed one.
fn fill_blocks(map: &[f64]) -> Vec<f64> {
    (0..SIDE * SIDE)
        .map(|k| {
            let (x, y) = (k % SIDE, k / SIDE);
            map[((y & !1) * SIDE + (x & !1)) as usize]
        })
        .collect()
}

/// The heat maps of `recipe`, each sphere's error at [`ZOOM`]×, with its relative RMS.
fn heat(img: &mut [[u8; 3]], w: u32, y0: u32, recipe: Option<&RecipeCheck>) {
    let Some(r) = recipe else {
        font::draw(
            img,
            w,
            (4, y0 + 4),
            "RECIPE VS REFERENCE: NOT COMPUTED (NO SOURCE)",
            1,
            GREY,
        );
        return;
    };
    font::draw(
        img,
        w,
        (4, y0 + 4),
        "RECIPE VS REFERENCE (FIS + LIGHTS, THE REPORT VIEW): LUMINANCE ERROR / SPHERE MEAN",
        1,
        GREY,
    );
    let side = SIDE * ZOOM;
    for (k, (s, map)) in COMPARED.iter().zip(&r.heat).enumerate() {
        let x0 = 8 + k as u32 * 146;
        let filled = fill_blocks(map);
        for y in 0..side {
            for x in 0..side {
                let e = filled[((y / ZOOM) * SIDE + x / ZOOM) as usize];
                img[((y0 + 16 + y) * w + x0 + x) as usize] = colour(e);
            }
        }
        let text = format!("{} {:.1}%", s.label(), 100.0 * r.errors[k]);
        font::draw(img, w, (x0, y0 + 20 + side), &text, 1, GREY);
    }
    // The scale: a bar from 0 (bottom) to FULL (top).
    let x0 = 8 + COMPARED.len() as u32 * 146;
    for y in 0..side {
        let c = colour(FULL * (side - 1 - y) as f64 / (side - 1) as f64);
        for x in 0..10 {
            img[((y0 + 16 + y) * w + x0 + x) as usize] = c;
        }
    }
    font::draw(img, w, (x0 + 14, y0 + 16), "50%", 1, GREY);
    font::draw(img, w, (x0 + 14, y0 + 10 + side), "0", 1, GREY);
}

/// The picture tone-mapped, with its caption and the recipe's heat maps.
pub fn png(p: &Picture, check: &PreviewCheck, recipe: Option<&RecipeCheck>) -> Result<Vec<u8>> {
    let (w, h) = (p.width, p.height + CAPTION + HEAT);
    let tm = ToneMap {
        exposure: check.exposure as f32,
    };
    let mut img: Vec<[u8; 3]> = p
        .rgb
        .iter()
        .map(|c| tone_map(c.map(|x| x as f32), tm))
        .collect();
    img.resize((w * h) as usize, GROUND);
    caption(&mut img, p, check);
    heat(&mut img, w, p.height + CAPTION, recipe);
    let mut out = Vec::new();
    let bytes: Vec<u8> = img.iter().flatten().copied().collect();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut out),
        &bytes,
        w,
        h,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| Error::Invalid(format!("preview PNG: {e}")))?;
    Ok(out)
}
