//! DirectDraw Surface: 2D images and cube maps in RGBA16F, RGBA32F or RGB32F, legacy or DX10
//! header. Only mip level 0 is read.

use super::{check_size, Raster};
use crate::error::{Error, Result};
use crate::math::Mapping;
use std::path::Path;

const HEADER: usize = 128;
const DX10_HEADER: usize = 20;
const CAPS2_CUBEMAP: u32 = 0x200;
const DX10_MISC_CUBE: u32 = 0x4;

#[derive(Clone, Copy)]
enum Format {
    Rgba16f,
    Rgba32f,
    Rgb32f,
}

impl Format {
    fn bytes(self) -> usize {
        match self {
            Format::Rgba16f => 8,
            Format::Rgba32f => 16,
            Format::Rgb32f => 12,
        }
    }
}

fn u32_at(b: &[u8], off: usize) -> u32 {
    u32::from_le_bytes([b[off], b[off + 1], b[off + 2], b[off + 3]])
}

pub(crate) fn read(path: &Path, bytes: &[u8], max_texels: u64) -> Result<Raster> {
    if bytes.len() < HEADER {
        return Err(Error::bad_file(
            path,
            format!(
                "truncated DDS: header needs {HEADER} bytes, file has {}",
                bytes.len()
            ),
        ));
    }
    if u32_at(bytes, 4) != 124 {
        return Err(Error::bad_file(path, "corrupt DDS: header size is not 124"));
    }
    let height = u32_at(bytes, 12) as u64;
    let width = u32_at(bytes, 16) as u64;
    let mips = u32_at(bytes, 28).max(1) as u64;
    let fourcc = u32_at(bytes, 84);
    let caps2 = u32_at(bytes, 112);
    let mut cube = caps2 & CAPS2_CUBEMAP != 0;
    let mut data_start = HEADER;
    let format = if &bytes[84..88] == b"DX10" {
        if bytes.len() < HEADER + DX10_HEADER {
            return Err(Error::bad_file(path, "truncated DDS: DX10 header missing"));
        }
        data_start += DX10_HEADER;
        cube |= u32_at(bytes, HEADER + 8) & DX10_MISC_CUBE != 0;
        match u32_at(bytes, HEADER) {
            10 => Format::Rgba16f,
            2 => Format::Rgba32f,
            6 => Format::Rgb32f,
            other => {
                return Err(Error::bad_file(
                    path,
                    format!(
                        "unsupported DDS DXGI format {other} (envlight reads R16G16B16A16_FLOAT, \
                         R32G32B32A32_FLOAT and R32G32B32_FLOAT)"
                    ),
                ))
            }
        }
    } else {
        match fourcc {
            113 => Format::Rgba16f,
            116 => Format::Rgba32f,
            other => {
                return Err(Error::bad_file(
                    path,
                    format!(
                        "unsupported DDS pixel format (fourCC {other}); envlight reads \
                         A16B16G16R16F (113) and A32B32G32R32F (116)"
                    ),
                ))
            }
        }
    };
    let faces: u64 = if cube { 6 } else { 1 };
    check_size(path, width, height, faces, max_texels)?;
    if mips > 32 {
        return Err(Error::bad_file(
            path,
            format!("corrupt DDS: {mips} mip levels"),
        ));
    }
    if cube && width != height {
        return Err(Error::bad_file(
            path,
            format!("corrupt DDS: cube faces are {width} x {height}, not square"),
        ));
    }
    // Each face holds its whole mip chain; skip all but level 0.
    let texel = format.bytes() as u64;
    let mut face_bytes = 0u64;
    let (mut w, mut h) = (width, height);
    for _ in 0..mips {
        face_bytes += w * h * texel;
        w = (w / 2).max(1);
        h = (h / 2).max(1);
    }
    let need = face_bytes * (faces - 1) + width * height * texel;
    let have = (bytes.len() - data_start) as u64;
    if have < need {
        return Err(Error::bad_file(
            path,
            format!("truncated DDS: {need} bytes of texel data expected, {have} present"),
        ));
    }
    let n = (width * height) as usize;
    let mut rgb = Vec::with_capacity(n * faces as usize);
    for f in 0..faces as usize {
        let start = data_start + f * face_bytes as usize;
        let face = &bytes[start..start + n * format.bytes()];
        match format {
            Format::Rgba16f => rgb.extend(face.chunks_exact(8).map(|c| {
                let h = |k: usize| half::f16::from_le_bytes([c[k], c[k + 1]]).to_f32();
                [h(0), h(2), h(4)]
            })),
            Format::Rgba32f | Format::Rgb32f => {
                rgb.extend(face.chunks_exact(format.bytes()).map(|c| {
                    let g = |k: usize| f32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
                    [g(0), g(4), g(8)]
                }))
            }
        }
    }
    Ok(Raster {
        width: width as u32,
        height: (height * faces) as u32,
        rgb,
        mapping_hint: cube.then_some(Mapping::Cube),
    })
}

/// Writes an RGBA16F DDS cube map (faces in Vulkan order; used by tests to make inputs).
/// Values a half cannot hold (above 65504, or not finite) are refused, not written as Inf.
pub fn write_cube_rgba16f(path: &Path, n: u32, faces: &[[f32; 3]]) -> std::io::Result<()> {
    super::check_half(path, faces.iter().flatten().copied())
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()))?;
    let mut h = vec![0u8; HEADER];
    h[..4].copy_from_slice(b"DDS ");
    let put =
        |h: &mut Vec<u8>, off: usize, v: u32| h[off..off + 4].copy_from_slice(&v.to_le_bytes());
    put(&mut h, 4, 124);
    put(&mut h, 8, 0x1 | 0x2 | 0x4 | 0x1000);
    put(&mut h, 12, n);
    put(&mut h, 16, n);
    put(&mut h, 28, 1);
    put(&mut h, 76, 32);
    put(&mut h, 80, 0x4);
    put(&mut h, 84, 113);
    put(&mut h, 108, 0x1000 | 0x8);
    put(&mut h, 112, CAPS2_CUBEMAP | 0xFC00);
    for t in faces {
        for c in [t[0], t[1], t[2], 1.0] {
            h.extend_from_slice(&half::f16::from_f32(c).to_le_bytes());
        }
    }
    std::fs::write(path, h)
}
