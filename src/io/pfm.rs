//! Portable float map (PFM): "PF" (RGB) or "Pf" (grey), rows stored bottom to top, the sign of
//! the scale giving the byte order.

use super::{check_size, Raster};
use crate::error::{Error, Result};
use std::path::Path;

pub(crate) fn read(path: &Path, bytes: &[u8], max_texels: u64) -> Result<Raster> {
    let bad = |p: &str| Error::bad_file(path, format!("corrupt PFM: {p}"));
    let channels = match &bytes[..2] {
        b"PF" => 3usize,
        _ => 1usize,
    };
    // Header: magic, width, height, scale, separated by whitespace, then one whitespace byte.
    let mut tokens = Vec::new();
    let mut pos = 2;
    while tokens.len() < 3 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            return Err(bad("header ends early or holds an over-long field"));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1;
    let w: u64 = tokens[0]
        .parse()
        .map_err(|_| bad("width is not a number"))?;
    let h: u64 = tokens[1]
        .parse()
        .map_err(|_| bad("height is not a number"))?;
    let scale: f32 = tokens[2]
        .parse()
        .map_err(|_| bad("scale is not a number"))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(bad("scale must be a non-zero number"));
    }
    check_size(path, w, h, 1, max_texels)?;
    let need = (w * h) as usize * channels * 4;
    let data = bytes.get(pos..).unwrap_or(&[]);
    if data.len() < need {
        return Err(Error::bad_file(
            path,
            format!(
                "truncated PFM: {need} bytes of texels expected, {} present",
                data.len()
            ),
        ));
    }
    let little = scale < 0.0;
    let (w, h) = (w as usize, h as usize);
    let mut rgb = vec![[0.0f32; 3]; w * h];
    for (k, chunk) in data[..need].chunks_exact(4).enumerate() {
        let b = [chunk[0], chunk[1], chunk[2], chunk[3]];
        let v = if little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        };
        let texel = k / channels;
        let (x, y_from_bottom) = (texel % w, texel / w);
        let dst = &mut rgb[(h - 1 - y_from_bottom) * w + x];
        if channels == 3 {
            dst[k % 3] = v;
        } else {
            *dst = [v; 3];
        }
    }
    Ok(Raster {
        width: w as u32,
        height: h as u32,
        rgb,
        mapping_hint: None,
    })
}

/// Writes a little-endian RGB PFM (used by tests to make inputs).
pub fn write(path: &Path, w: u32, h: u32, rgb: &[[f32; 3]]) -> std::io::Result<()> {
    std::fs::write(path, bytes(w, h, rgb))
}

/// A little-endian RGB PFM of `w` × `h` texels, top row first in `rgb` (PFM stores the
/// bottom row first).
pub(crate) fn bytes(w: u32, h: u32, rgb: &[[f32; 3]]) -> Vec<u8> {
    let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for y in (0..h as usize).rev() {
        for x in 0..w as usize {
            for c in rgb[y * w as usize + x] {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    out
}
