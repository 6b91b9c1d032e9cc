//! KTX 2.0 output (the Khronos container glTF-IBL-Sampler and engines load): 2D textures and
//! cube maps with any number of MIP levels, RGBA16F or RGBA32F, no supercompression.
//!
//! Layout written (KTX 2.0 specification, §3): the 12-byte identifier; the header (vkFormat,
//! typeSize, pixelWidth, pixelHeight, pixelDepth = 0, layerCount = 0, faceCount 1 or 6,
//! levelCount, supercompressionScheme = 0); the index (DFD, key/value data, no supercompression
//! global data); the level index, level 0 first; the Data Format Descriptor; the key/value data
//! (`KTXwriter`); then the levels' data, the smallest level first, each aligned to 16 bytes
//! (a multiple of both texel sizes and of 4). Within a level, cube faces follow Vulkan's order
//! (+X, −X, +Y, −Y, +Z, −Z, as envlight's cube layers do), each face's rows top to bottom.
//!
//! The DFD is one basic descriptor block (KHR_DF_MODEL_RGBSDA, BT.709 primaries, linear
//! transfer, straight alpha, 1 × 1 × 1 × 1 texel blocks) with one sample per channel R, G, B,
//! A: bit offsets 0, n, 2n, 3n of n = 16 or 32 bits, qualifiers float | signed, and the lower
//! and upper values −1.0 and 1.0 as the float bit patterns, as the KTX 2.0 specification's
//! Table 4 requires for float formats.

use crate::error::{Error, Result};
use std::path::Path;

/// The identifier every KTX 2.0 file starts with: «KTX 20»\r\n\x1A\n.
pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// Texel formats written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ktx2Format {
    /// VK_FORMAT_R16G16B16A16_SFLOAT (97).
    Rgba16f,
    /// VK_FORMAT_R32G32B32A32_SFLOAT (109).
    Rgba32f,
}

impl Ktx2Format {
    /// The VkFormat value.
    pub fn vk_format(self) -> u32 {
        match self {
            Ktx2Format::Rgba16f => 97,
            Ktx2Format::Rgba32f => 109,
        }
    }

    /// Bytes per channel.
    pub fn channel_bytes(self) -> u32 {
        match self {
            Ktx2Format::Rgba16f => 2,
            Ktx2Format::Rgba32f => 4,
        }
    }

    /// Parses "rgba16f" or "rgba32f".
    pub fn parse(s: &str) -> Option<Ktx2Format> {
        match s.to_ascii_lowercase().as_str() {
            "rgba16f" | "half" => Some(Ktx2Format::Rgba16f),
            "rgba32f" | "float" => Some(Ktx2Format::Rgba32f),
            _ => None,
        }
    }
}

/// An image to write: `faces` (1 or 6) faces of `width` × `height` at level 0, and its levels,
/// each faces × rows × columns RGBA texels (level k is max(1, size >> k)).
pub struct Ktx2Image<'a> {
    /// Level-0 width.
    pub width: u32,
    /// Level-0 height.
    pub height: u32,
    /// 1 (2D) or 6 (cube).
    pub faces: u32,
    /// The levels, level 0 first.
    pub levels: &'a [Vec<[f32; 4]>],
}

const ALIGN: usize = 16;

fn align(v: &mut Vec<u8>) {
    while v.len() % ALIGN != 0 {
        v.push(0);
    }
}

/// The Data Format Descriptor of `format` (dfdTotalSize first).
fn dfd(format: Ktx2Format) -> Vec<u8> {
    let bits = 8 * format.channel_bytes();
    let block_size: u16 = 24 + 16 * 4;
    let mut d = Vec::new();
    d.extend((4 + block_size as u32).to_le_bytes());
    d.extend(0u32.to_le_bytes()); // vendorId 0 (Khronos), descriptorType 0 (basic)
    d.extend(2u16.to_le_bytes()); // versionNumber (KDF 1.3)
    d.extend(block_size.to_le_bytes());
    d.extend([1, 1, 1, 0]); // RGBSDA, BT.709, linear, straight alpha
    d.extend([0, 0, 0, 0]); // texel block 1 × 1 × 1 × 1 (each dimension minus one)
    let mut planes = [0u8; 8];
    planes[0] = (4 * format.channel_bytes()) as u8;
    d.extend(planes);
    // Channels R, G, B, A (ids 0, 1, 2, 15), float | signed qualifiers.
    for (k, id) in [0u8, 1, 2, 15].into_iter().enumerate() {
        d.extend(((k as u32 * bits) as u16).to_le_bytes());
        d.push((bits - 1) as u8);
        d.push(id | 0x80 | 0x40);
        d.extend([0u8; 4]);
        d.extend((-1.0f32).to_bits().to_le_bytes());
        d.extend(1.0f32.to_bits().to_le_bytes());
    }
    d
}

fn key_values() -> Vec<u8> {
    let mut kv = Vec::new();
    let entry = format!("KTXwriter\0envlight {}\0", env!("CARGO_PKG_VERSION"));
    kv.extend((entry.len() as u32).to_le_bytes());
    kv.extend(entry.as_bytes());
    while kv.len() % 4 != 0 {
        kv.push(0);
    }
    kv
}

/// The bytes of a KTX 2.0 file holding `image` in `format` (texels converted to it; values a
/// half cannot hold are refused for RGBA16F, naming the first).
pub fn encode(image: &Ktx2Image<'_>, format: Ktx2Format) -> Result<Vec<u8>> {
    let n_levels = image.levels.len();
    if !(image.faces == 1 || image.faces == 6) || n_levels == 0 {
        return Err(Error::Invalid(format!(
            "KTX2: {} faces and {n_levels} levels (1 or 6 faces, at least one level)",
            image.faces
        )));
    }
    if image.faces == 6 && image.width != image.height {
        return Err(Error::Invalid("KTX2: cube faces must be square".into()));
    }
    for (k, level) in image.levels.iter().enumerate() {
        let (w, h) = (
            (image.width >> k).max(1) as usize,
            (image.height >> k).max(1) as usize,
        );
        if level.len() != w * h * image.faces as usize {
            return Err(Error::Invalid(format!(
                "KTX2: level {k} holds {} texels, not {}",
                level.len(),
                w * h * image.faces as usize
            )));
        }
    }
    let level_bytes = |level: &[[f32; 4]]| -> Result<Vec<u8>> {
        let mut out = Vec::with_capacity(level.len() * 4 * format.channel_bytes() as usize);
        for t in level {
            for &c in t {
                match format {
                    Ktx2Format::Rgba32f => out.extend(c.to_le_bytes()),
                    Ktx2Format::Rgba16f => {
                        let h = half::f16::from_f32(c);
                        if !h.is_finite() && c.is_finite() {
                            return Err(Error::Invalid(format!(
                                "KTX2 RGBA16F: {c} does not fit in a half float (use rgba32f)"
                            )));
                        }
                        out.extend(h.to_bits().to_le_bytes());
                    }
                }
            }
        }
        Ok(out)
    };
    let dfd = dfd(format);
    let kv = key_values();
    let header_len = 12 + 36 + 32 + 24 * n_levels;
    let dfd_offset = header_len;
    let kv_offset = dfd_offset + dfd.len();
    let mut data = vec![0; kv_offset + kv.len()];
    align(&mut data);
    // Levels smallest first.
    let mut index = vec![(0u64, 0u64); n_levels];
    for k in (0..n_levels).rev() {
        align(&mut data);
        let bytes = level_bytes(&image.levels[k])?;
        index[k] = (data.len() as u64, bytes.len() as u64);
        data.extend(bytes);
    }
    let mut head = Vec::with_capacity(header_len);
    head.extend(IDENTIFIER);
    for v in [
        format.vk_format(),
        format.channel_bytes(),
        image.width,
        image.height,
        0,
        0,
        image.faces,
        n_levels as u32,
        0,
    ] {
        head.extend(v.to_le_bytes());
    }
    head.extend((dfd_offset as u32).to_le_bytes());
    head.extend((dfd.len() as u32).to_le_bytes());
    head.extend((kv_offset as u32).to_le_bytes());
    head.extend((kv.len() as u32).to_le_bytes());
    head.extend(0u64.to_le_bytes());
    head.extend(0u64.to_le_bytes());
    for (offset, len) in index {
        head.extend(offset.to_le_bytes());
        head.extend(len.to_le_bytes());
        head.extend(len.to_le_bytes());
    }
    data[..header_len].copy_from_slice(&head);
    data[dfd_offset..kv_offset].copy_from_slice(&dfd);
    data[kv_offset..kv_offset + kv.len()].copy_from_slice(&kv);
    Ok(data)
}

/// Writes `image` to `path` as KTX 2.0 (atomically: a temporary file beside it, renamed).
pub fn write(path: &Path, image: &Ktx2Image<'_>, format: Ktx2Format) -> Result<()> {
    let bytes = encode(image, format)?;
    super::write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dfd_is_the_basic_block_for_four_float_channels() {
        let d = dfd(Ktx2Format::Rgba16f);
        assert_eq!(d.len(), 4 + 24 + 64);
        assert_eq!(u32::from_le_bytes(d[0..4].try_into().unwrap()), 92);
        assert_eq!(d[20], 8); // bytesPlane0: 4 × 2 bytes
                              // Alpha's sample: offset 48, 16 bits, channel 15 | float | signed.
        let a = &d[28 + 48..28 + 64];
        assert_eq!(u16::from_le_bytes([a[0], a[1]]), 48);
        assert_eq!((a[2], a[3]), (15, 15 | 0xC0));
    }

    #[test]
    fn refuses_inconsistent_images() {
        let level = vec![[0.0f32; 4]; 3];
        let img = Ktx2Image {
            width: 2,
            height: 2,
            faces: 1,
            levels: std::slice::from_ref(&level),
        };
        assert!(encode(&img, Ktx2Format::Rgba32f).is_err());
        let big = vec![[1e6f32; 4]; 4];
        let img = Ktx2Image {
            width: 2,
            height: 2,
            faces: 1,
            levels: std::slice::from_ref(&big),
        };
        assert!(encode(&img, Ktx2Format::Rgba16f).is_err());
        assert!(encode(&img, Ktx2Format::Rgba32f).is_ok());
    }
}
