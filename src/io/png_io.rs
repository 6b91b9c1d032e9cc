//! Radiance `.hdr`, PNG and JPEG through the `image` crate, and tone-mapped PNG output.

use super::{check_size, strip_extent, Raster};
use crate::error::{Error, Result};
use crate::math::envmap::EnvMap;
use std::io::Cursor;
use std::path::Path;

pub(crate) fn read_with_image_crate(
    path: &Path,
    bytes: &[u8],
    max_texels: u64,
    srgb: bool,
) -> Result<Raster> {
    let kind = if srgb { "image" } else { "Radiance .hdr" };
    let bad =
        |e: image::ImageError| Error::bad_file(path, format!("corrupt or truncated {kind}: {e}"));
    let reader = || {
        image::ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| Error::bad_file(path, e.to_string()))
    };
    let (w, h) = reader()?.into_dimensions().map_err(bad)?;
    check_size(path, w as u64, h as u64, 1, max_texels)?;
    let mut r = reader()?;
    r.no_limits();
    // A decoder assertion on a corrupt file (the fuzzer found one in zune-jpeg's upsampler)
    // is a corrupt file, not a crash.
    let img = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| r.decode())) {
        // into_: a Radiance file decodes to rgb32f already, which then moves rather than copies.
        Ok(d) => d.map_err(bad)?.into_rgb32f(),
        Err(_) => {
            return Err(Error::bad_file(
                path,
                format!("corrupt {kind}: the decoder rejected its data"),
            ))
        }
    };
    let decode = |c: f32| {
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let raw = img.into_raw();
    // Linear data is the texels as they are: the buffer is reinterpreted, not copied (a 1k
    // map's 6 MB, and their pages to fault in), where its capacity is whole texels.
    let rgb = match srgb {
        true => raw
            .chunks_exact(3)
            .map(|c| [decode(c[0]), decode(c[1]), decode(c[2])])
            .collect(),
        false => bytemuck::allocation::try_cast_vec(raw)
            .unwrap_or_else(|(_, raw)| raw.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()),
    };
    Ok(Raster {
        width: w,
        height: h,
        rgb,
        mapping_hint: None,
    })
}

/// How radiance becomes an 8-bit sRGB preview: scale by 2^exposure, apply Reinhard's
/// x / (1 + x) per channel, then the sRGB transfer function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMap {
    /// Exposure in stops.
    pub exposure: f32,
}

impl Default for ToneMap {
    fn default() -> Self {
        ToneMap { exposure: 0.0 }
    }
}

impl ToneMap {
    /// Describes the operator, for printing beside the file written.
    pub fn describe(&self) -> String {
        format!(
            "Reinhard x/(1+x) per channel after exposure {:+.1} EV, sRGB encoded",
            self.exposure
        )
    }
}

/// Tone-maps linear RGB to 8-bit sRGB.
pub fn tone_map(t: [f32; 3], tm: ToneMap) -> [u8; 3] {
    let k = 2f32.powf(tm.exposure);
    t.map(|c| {
        let x = if c.is_finite() { (c * k).max(0.0) } else { 0.0 };
        let y = x / (1.0 + x);
        let s = if y <= 0.003_130_8 {
            12.92 * y
        } else {
            1.055 * y.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
    })
}

/// Writes a tone-mapped preview PNG (layers stacked vertically, like [`super::save_exr`]).
pub fn save_png(map: &EnvMap, path: impl AsRef<Path>, tm: ToneMap) -> Result<()> {
    let path = path.as_ref();
    let (w, h) = strip_extent(map);
    let mut img = image::RgbImage::new(w, h);
    for (p, t) in img.pixels_mut().zip(&map.texels) {
        p.0 = tone_map(*t, tm);
    }
    img.save(path)
        .map_err(|e| Error::bad_file(path, format!("cannot write PNG: {e}")))
}
