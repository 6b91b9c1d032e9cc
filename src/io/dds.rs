//! DirectDraw Surface: 2D images and cube maps in RGBA16F, RGBA32F or RGB32F, legacy or DX10
//! header. A map is its mip level 0; [`read_level`] reads any level (prefiltered cubes).

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
    read_level(path, bytes, max_texels, 0).map(|(r, _)| r)
}

/// Mip level `level` of the file (every face of it), and how many levels the file holds.
pub(crate) fn read_level(
    path: &Path,
    bytes: &[u8],
    max_texels: u64,
    level: u32,
) -> Result<(Raster, u32)> {
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
    if level as u64 >= mips {
        return Err(Error::bad_file(
            path,
            format!("DDS has {mips} mip levels, level {level} asked for"),
        ));
    }
    // Each face holds its whole mip chain; skip to `level` within each.
    let texel = format.bytes() as u64;
    let (mut face_bytes, mut skip) = (0u64, 0u64);
    let (mut w, mut h) = (width, height);
    let (mut lw, mut lh) = (width, height);
    for k in 0..mips {
        if k < level as u64 {
            skip += w * h * texel;
        } else if k == level as u64 {
            (lw, lh) = (w, h);
        }
        face_bytes += w * h * texel;
        w = (w / 2).max(1);
        h = (h / 2).max(1);
    }
    let (width, height) = (lw, lh);
    let need = face_bytes * (faces - 1) + skip + width * height * texel;
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
        let start = data_start + f * face_bytes as usize + skip as usize;
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
    Ok((
        Raster {
            width: width as u32,
            height: (height * faces) as u32,
            rgb,
            mapping_hint: cube.then_some(Mapping::Cube),
        },
        mips as u32,
    ))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4² RGBA16F cube of 3 levels, each face holding its chain (the DDS layout), every
    /// texel distinct: each level reads back its own texels, in face order; a level past the
    /// chain is refused.
    #[test]
    fn every_mip_level_of_a_cube_reads_back() {
        let value = |f: usize, k: usize, t: usize| (f * 100 + k * 20 + t) as f32;
        let dir = std::env::temp_dir().join(format!("envlight-dds-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let one = dir.join("one.dds");
        write_cube_rgba16f(&one, 4, &vec![[0.0; 3]; 6 * 16]).unwrap();
        let mut bytes = std::fs::read(&one).unwrap()[..HEADER].to_vec();
        bytes[28..32].copy_from_slice(&3u32.to_le_bytes());
        for f in 0..6 {
            for (k, n) in [16usize, 4, 1].into_iter().enumerate() {
                for t in 0..n {
                    for c in [value(f, k, t), 0.5, 0.25, 1.0] {
                        bytes.extend_from_slice(&half::f16::from_f32(c).to_le_bytes());
                    }
                }
            }
        }
        let path = Path::new("cube.dds");
        for (k, n) in [16usize, 4, 1].into_iter().enumerate() {
            let (r, mips) = read_level(path, &bytes, 1 << 20, k as u32).unwrap();
            assert_eq!(mips, 3);
            assert_eq!((r.width as usize).pow(2), n);
            for f in 0..6 {
                for t in 0..n {
                    assert_eq!(r.rgb[f * n + t], [value(f, k, t), 0.5, 0.25], "{k} {f} {t}");
                }
            }
        }
        let e = match read_level(path, &bytes, 1 << 20, 3) {
            Ok(_) => panic!("level 3 of 3 read"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains("cube.dds") && e.contains("3 mip levels"), "{e}");
        let short = &bytes[..bytes.len() - 8];
        assert!(read_level(path, short, 1 << 20, 2).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
