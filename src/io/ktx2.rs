//! KTX 2.0 output (the Khronos container glTF-IBL-Sampler and engines load): 2D textures and
//! cube maps with any number of MIP levels, RGBA16F, RGBA32F, the packed unsigned floats
//! B10G11R11 and E5B9G9R9 (RGB, no alpha), or BC6H unsigned-float blocks; each optionally
//! supercompressed with Zstandard.
//!
//! Layout written (KTX 2.0 specification, §3): the 12-byte identifier; the header (vkFormat,
//! typeSize, pixelWidth, pixelHeight, pixelDepth = 0, layerCount (0, or 2 for a paraboloid's
//! halves), faceCount 1 or 6, levelCount, supercompressionScheme 0 or 2 = Zstandard); the index
//! (DFD, key/value data, no supercompression global data); the level index, level 0 first; the
//! Data Format Descriptor; the key/value data (`KTXwriter`); then the levels' data, the
//! smallest level first. Without supercompression each level starts at the smallest padding to
//! lcm(texel block bytes, 4) (§3.9.7: 8 bytes for RGBA16F, 16 for RGBA32F and BC6H, 4 for the
//! packed formats), and `ktx validate` refuses any other; with Zstandard, levels follow one
//! another unpadded, each one Zstandard frame of the level's whole data. Within a level, cube
//! faces follow Vulkan's order (+X, −X, +Y, −Y, +Z, −Z, as envlight's cube layers do), each
//! face's rows top to bottom (BC6H: rows of 4 × 4 blocks).
//!
//! The DFD is one basic descriptor block (BT.709 primaries, linear transfer, straight alpha),
//! as the Khronos Data Format specification (and KTX-Software's `vk2dfd`) describes each format:
//! - RGBA16F / RGBA32F (model RGBSDA, 1 × 1 texel blocks): one sample per channel R, G, B, A at
//!   bit offsets 0, n, 2n, 3n of n = 16 or 32 bits, qualifiers float | signed, lower and upper
//!   −1.0 and 1.0 as float bits.
//! - B10G11R11: samples R (bits 0–10), G (11–21), B (22–31), qualifier float (unsigned),
//!   lower and upper 0.0 and 1.0 as float bits; typeSize 4 (the packed word).
//! - E5B9G9R9: six samples, each channel's 9-bit mantissa (R bits 0–8, G 9–17, B 18–26, no
//!   qualifier, lower 0, upper 8448 = 1.0 at the bias) and the shared 5-bit exponent (bits
//!   27–31, qualifier exponent, lower 15 = the bias, upper 31) once per channel; typeSize 4.
//! - BC6H unsigned (model BC6H, 4 × 4 texel blocks of 16 bytes): one 128-bit colour sample,
//!   qualifier float, lower 0.0 and upper 1.0; typeSize 1. Blocks are encoded by Intel's ISPC
//!   texture compressor (`intel_tex_2`); a level smaller than a block repeats its edge texels.
//!
//! Packing rounds to nearest (even), as Vulkan's conversions to these formats do. Values a
//! format cannot hold (above its largest finite value, [`Ktx2Format::largest`]) are refused,
//! naming the value, and so are negative ones for the unsigned formats: a caller that wants
//! them kept clamps first ([`clamp_levels`]) and says what it clamped.

use crate::error::{Error, Result};
use std::path::Path;

// intel_tex_2's prebuilt static kernels carry C++ objects (its ASTC encoder, linked whole) that
// reference the C++ runtime's exception personality; Rust does not link libstdc++ by itself.
#[cfg(feature = "bc6h")]
#[link(name = "stdc++")]
extern "C" {}

/// The identifier every KTX 2.0 file starts with: «KTX 20»\r\n\x1A\n.
pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// Texel formats written (a bake file names them as [`Ktx2Format::name`] does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Ktx2Format {
    /// VK_FORMAT_R16G16B16A16_SFLOAT (97).
    Rgba16f,
    /// VK_FORMAT_R32G32B32A32_SFLOAT (109).
    Rgba32f,
    /// VK_FORMAT_B10G11R11_UFLOAT_PACK32 (122): R and G with 6 mantissa bits, B with 5, one
    /// 5-bit exponent each; largest value 65024 (B 64512).
    B10g11r11,
    /// VK_FORMAT_E5B9G9R9_UFLOAT_PACK32 (123): 9-bit mantissas under one shared 5-bit
    /// exponent; largest value 65408.
    E5b9g9r9,
    /// VK_FORMAT_BC6H_UFLOAT_BLOCK (143): 4 × 4 texels in 16 bytes, unsigned half floats;
    /// largest value 65504.
    Bc6h,
}

/// How the levels' bytes are stored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Supercompression {
    /// As they are (supercompressionScheme 0).
    #[default]
    None,
    /// One Zstandard frame per level (supercompressionScheme 2), as Bevy ships its maps.
    Zstd,
}

impl Supercompression {
    /// The header's supercompressionScheme.
    pub fn scheme(self) -> u32 {
        match self {
            Supercompression::None => 0,
            Supercompression::Zstd => 2,
        }
    }
}

impl Ktx2Format {
    /// The VkFormat value.
    pub fn vk_format(self) -> u32 {
        match self {
            Ktx2Format::Rgba16f => 97,
            Ktx2Format::Rgba32f => 109,
            Ktx2Format::B10g11r11 => 122,
            Ktx2Format::E5b9g9r9 => 123,
            Ktx2Format::Bc6h => 143,
        }
    }

    /// The header's typeSize: bytes per channel, of the packed word, or 1 for blocks.
    pub fn type_size(self) -> u32 {
        match self {
            Ktx2Format::Rgba16f => 2,
            Ktx2Format::Rgba32f | Ktx2Format::B10g11r11 | Ktx2Format::E5b9g9r9 => 4,
            Ktx2Format::Bc6h => 1,
        }
    }

    /// Bytes per texel block.
    pub fn block_bytes(self) -> u32 {
        match self {
            Ktx2Format::Rgba16f => 8,
            Ktx2Format::Rgba32f | Ktx2Format::Bc6h => 16,
            Ktx2Format::B10g11r11 | Ktx2Format::E5b9g9r9 => 4,
        }
    }

    /// Texels per side of a block (4 for BC6H, else 1).
    pub fn block_side(self) -> u32 {
        match self {
            Ktx2Format::Bc6h => 4,
            _ => 1,
        }
    }

    /// The largest value each of R, G and B can hold.
    pub fn largest(self) -> [f32; 3] {
        match self {
            Ktx2Format::Rgba32f => [f32::MAX; 3],
            Ktx2Format::Rgba16f | Ktx2Format::Bc6h => [65504.0; 3],
            Ktx2Format::B10g11r11 => [65024.0, 65024.0, 64512.0],
            Ktx2Format::E5b9g9r9 => [E5_MAX; 3],
        }
    }

    /// Whether the format holds no negative values.
    pub fn unsigned(self) -> bool {
        !matches!(self, Ktx2Format::Rgba16f | Ktx2Format::Rgba32f)
    }

    /// The name [`Ktx2Format::parse`] takes.
    pub fn name(self) -> &'static str {
        match self {
            Ktx2Format::Rgba16f => "rgba16f",
            Ktx2Format::Rgba32f => "rgba32f",
            Ktx2Format::B10g11r11 => "b10g11r11",
            Ktx2Format::E5b9g9r9 => "e5b9g9r9",
            Ktx2Format::Bc6h => "bc6h",
        }
    }

    /// Parses "rgba16f", "rgba32f", "b10g11r11", "e5b9g9r9" or "bc6h" (any case).
    pub fn parse(s: &str) -> Option<Ktx2Format> {
        match s.to_ascii_lowercase().as_str() {
            "rgba16f" | "half" => Some(Ktx2Format::Rgba16f),
            "rgba32f" | "float" => Some(Ktx2Format::Rgba32f),
            "b10g11r11" | "r11g11b10" => Some(Ktx2Format::B10g11r11),
            "e5b9g9r9" | "rgb9e5" => Some(Ktx2Format::E5b9g9r9),
            "bc6h" => Some(Ktx2Format::Bc6h),
            _ => None,
        }
    }
}

/// What [`clamp_levels`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Clamped {
    /// Channels lowered to the format's largest value.
    pub high: usize,
    /// Channels raised from below 0 to 0 (unsigned formats only).
    pub negative: usize,
}

/// Clamps every texel of `levels` into what `format` holds (non-finite channels are left for
/// [`encode`] to refuse): channels above [`Ktx2Format::largest`] to it, and for unsigned
/// formats negative channels to 0. Returns what it changed.
pub fn clamp_levels(format: Ktx2Format, levels: &mut [Vec<[f32; 4]>]) -> Clamped {
    let top = format.largest();
    let mut c = Clamped::default();
    for t in levels.iter_mut().flatten() {
        for (k, v) in t.iter_mut().take(3).enumerate() {
            if *v > top[k] {
                *v = top[k];
                c.high += 1;
            } else if format.unsigned() && *v < 0.0 {
                *v = 0.0;
                c.negative += 1;
            }
        }
    }
    c
}

/// Bias of the 5-bit exponents of the packed formats.
const BIAS: i32 = 15;

/// `v` ≥ 0 as an unsigned float of 5 exponent and `m` mantissa bits (10- and 11-bit floats),
/// rounded to nearest even; `None` above the largest finite value.
pub fn pack_ufloat(v: f32, m: u32) -> Option<u32> {
    if v.is_nan() || v < 0.0 {
        return None;
    }
    if v == 0.0 {
        return Some(0);
    }
    let v = v as f64;
    let one = (1u32 << m) as f64;
    let e = v.log2().floor() as i32;
    let bits = if e < 1 - BIAS {
        // Subnormal: v = 2^(1 − bias)·q/2^m; rounding up to 2^m gives the smallest normal.
        (v / 2f64.powi(1 - BIAS) * one).round_ties_even() as u32
    } else {
        // 2^e ≤ v < 2^(e+1) (log2's rounding checked below).
        let (e, f) = {
            let f = v / 2f64.powi(e);
            if f >= 2.0 {
                (e + 1, f / 2.0)
            } else if f < 1.0 {
                (e - 1, f * 2.0)
            } else {
                (e, f)
            }
        };
        let q = ((f - 1.0) * one).round_ties_even() as u32;
        (((e + BIAS) as u32) << m) + q
    };
    // The all-ones exponent holds Inf and NaN.
    (bits < (31 << m)).then_some(bits)
}

/// The largest E5B9G9R9 value: 511/512 · 2^16.
const E5_MAX: f32 = 65408.0;

/// (r, g, b) ≥ 0 as E5B9G9R9 (the shared-exponent rule of Vulkan's and
/// EXT_texture_shared_exponent's conversion, rounding to nearest); `None` above 65408.
pub fn pack_e5b9g9r9(c: [f32; 3]) -> Option<u32> {
    const N: i32 = 9;
    if c.iter().any(|v| !(*v >= 0.0 && *v <= E5_MAX)) {
        return None;
    }
    let c = c.map(|v| v as f64);
    let top = c[0].max(c[1]).max(c[2]);
    let mut e = if top > 0.0 {
        (top.log2().floor() as i32).max(-BIAS - 1) + 1 + BIAS
    } else {
        0
    };
    if top > 0.0 && (top / 2f64.powi(e - BIAS - N) + 0.5).floor() >= 512.0 {
        e += 1;
    }
    let q = c.map(|v| ((v / 2f64.powi(e - BIAS - N) + 0.5).floor() as u32).min(511));
    Some(q[0] | (q[1] << 9) | (q[2] << 18) | ((e as u32) << 27))
}

/// An image to write: `layers` array layers (0: not an array) of `faces` (1 or 6) faces of
/// `width` × `height` at level 0, and its levels, each layers × faces × rows × columns RGBA
/// texels (level k is max(1, size >> k)), as KTX 2.0 orders a level's data.
pub struct Ktx2Image<'a> {
    /// Level-0 width.
    pub width: u32,
    /// Level-0 height.
    pub height: u32,
    /// 1 (2D) or 6 (cube).
    pub faces: u32,
    /// Array layers (a dual paraboloid's two halves: 2), or 0 for a plain texture or cube.
    pub layers: u32,
    /// The levels, level 0 first.
    pub levels: &'a [Vec<[f32; 4]>],
}

impl<'a> Ktx2Image<'a> {
    /// A cube map `size` a side at level 0 holding `levels`.
    pub fn cube(size: u32, levels: &'a [Vec<[f32; 4]>]) -> Ktx2Image<'a> {
        Ktx2Image {
            width: size,
            height: size,
            faces: 6,
            layers: 0,
            levels,
        }
    }
}

/// One DFD sample: bit offset, bit length, channel id with its qualifier bits, lower, upper.
fn sample(d: &mut Vec<u8>, offset: u16, bits: u8, channel: u8, lower: u32, upper: u32) {
    d.extend(offset.to_le_bytes());
    d.push(bits - 1);
    d.push(channel);
    d.extend([0u8; 4]); // sample position 0, 0, 0, 0
    d.extend(lower.to_le_bytes());
    d.extend(upper.to_le_bytes());
}

/// Qualifier bits of a sample's channel byte.
const FLOAT: u8 = 0x80;
const SIGNED: u8 = 0x40;
const EXPONENT: u8 = 0x20;

/// Colour models of the basic descriptor block.
const MODEL_RGBSDA: u8 = 1;
const MODEL_BC6H: u8 = 133;

/// The Data Format Descriptor of `format` (dfdTotalSize first).
fn dfd(format: Ktx2Format) -> Vec<u8> {
    let samples: u16 = match format {
        Ktx2Format::Rgba16f | Ktx2Format::Rgba32f => 4,
        Ktx2Format::B10g11r11 => 3,
        Ktx2Format::E5b9g9r9 => 6,
        Ktx2Format::Bc6h => 1,
    };
    let block_size: u16 = 24 + 16 * samples;
    let mut d = Vec::new();
    d.extend((4 + block_size as u32).to_le_bytes());
    d.extend(0u32.to_le_bytes()); // vendorId 0 (Khronos), descriptorType 0 (basic)
    d.extend(2u16.to_le_bytes()); // versionNumber (KDF 1.3)
    d.extend(block_size.to_le_bytes());
    let model = match format {
        Ktx2Format::Bc6h => MODEL_BC6H,
        _ => MODEL_RGBSDA,
    };
    d.extend([model, 1, 1, 0]); // model, BT.709, linear, straight alpha
    let side = format.block_side() as u8 - 1;
    d.extend([side, side, 0, 0]); // texel block dimensions, each minus one
    let mut planes = [0u8; 8];
    planes[0] = format.block_bytes() as u8;
    d.extend(planes);
    let (one, minus_one) = (1.0f32.to_bits(), (-1.0f32).to_bits());
    match format {
        Ktx2Format::Rgba16f | Ktx2Format::Rgba32f => {
            let bits = 8 * format.type_size();
            // Channels R, G, B, A (ids 0, 1, 2, 15).
            for (k, id) in [0u8, 1, 2, 15].into_iter().enumerate() {
                let offset = (k as u32 * bits) as u16;
                sample(
                    &mut d,
                    offset,
                    bits as u8,
                    id | FLOAT | SIGNED,
                    minus_one,
                    one,
                );
            }
        }
        Ktx2Format::B10g11r11 => {
            for (id, offset, bits) in [(0u8, 0u16, 11u8), (1, 11, 11), (2, 22, 10)] {
                sample(&mut d, offset, bits, id | FLOAT, 0, one);
            }
        }
        Ktx2Format::E5b9g9r9 => {
            for id in 0u8..3 {
                sample(&mut d, 9 * id as u16, 9, id, 0, 8448);
                sample(&mut d, 27, 5, id | EXPONENT, 15, 31);
            }
        }
        // One 128-bit colour sample (channel 0), unsigned float.
        Ktx2Format::Bc6h => sample(&mut d, 0, 128, FLOAT, 0, one),
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

/// Checks that `image` is consistent: 1 or 6 faces, square cubes, at least one level, each
/// holding as many texels as its size says.
fn check_shape(image: &Ktx2Image<'_>) -> Result<()> {
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
        let (w, h) = level_extent(image, k);
        let n = w * h * (image.faces * image.layers.max(1)) as usize;
        if level.len() != n {
            return Err(Error::Invalid(format!(
                "KTX2: level {k} holds {} texels, not {n}",
                level.len(),
            )));
        }
    }
    Ok(())
}

/// Width and height of level `k`.
fn level_extent(image: &Ktx2Image<'_>, k: usize) -> (usize, usize) {
    (
        (image.width >> k).max(1) as usize,
        (image.height >> k).max(1) as usize,
    )
}

fn refuse(c: f32, name: &str) -> Error {
    Error::Invalid(format!(
        "KTX2 {name}: {c} does not fit (negative, or above the format's largest value; \
         clamp first or use rgba32f)"
    ))
}

/// One texel in one of the per-texel formats, appended to `out`.
fn pack_texel(format: Ktx2Format, t: &[f32; 4], out: &mut Vec<u8>) -> Result<()> {
    match format {
        Ktx2Format::Rgba32f => t.iter().for_each(|c| out.extend(c.to_le_bytes())),
        Ktx2Format::Rgba16f => {
            for &c in t {
                let h = half::f16::from_f32(c);
                if !h.is_finite() && c.is_finite() {
                    return Err(Error::Invalid(format!(
                        "KTX2 RGBA16F: {c} does not fit in a half float (clamp first or use \
                         rgba32f)"
                    )));
                }
                out.extend(h.to_bits().to_le_bytes());
            }
        }
        Ktx2Format::B10g11r11 => {
            let mut word = 0u32;
            for (k, (shift, m)) in [(0, 6), (11, 6), (22, 5)].into_iter().enumerate() {
                let v = pack_ufloat(t[k], m).ok_or_else(|| refuse(t[k], "B10G11R11"))?;
                word |= v << shift;
            }
            out.extend(word.to_le_bytes());
        }
        Ktx2Format::E5b9g9r9 => {
            let rgb = [t[0], t[1], t[2]];
            let word = pack_e5b9g9r9(rgb).ok_or_else(|| {
                let bad = rgb.into_iter().find(|v| !(*v >= 0.0 && *v <= E5_MAX));
                refuse(bad.unwrap_or(rgb[0]), "E5B9G9R9")
            })?;
            out.extend(word.to_le_bytes());
        }
        Ktx2Format::Bc6h => unreachable!("BC6H is packed a face at a time"),
    }
    Ok(())
}

/// One face (`w` × `h` texels, rows top to bottom) as BC6H blocks, rows of blocks top to
/// bottom. A face smaller than a block, or not a multiple of 4, repeats its last row and column
/// into the block (the texels a sampler never reads there).
fn bc6h_face(face: &[[f32; 4]], w: usize, h: usize) -> Result<Vec<u8>> {
    let (bw, bh) = (w.div_ceil(4) * 4, h.div_ceil(4) * 4);
    let mut halves = Vec::with_capacity(bw * bh * 8);
    for y in 0..bh {
        for x in 0..bw {
            let t = &face[y.min(h - 1) * w + x.min(w - 1)];
            for (k, &c) in t.iter().enumerate() {
                let v = if k == 3 { 1.0 } else { c };
                if !(0.0..=65504.0).contains(&v) {
                    return Err(refuse(v, "BC6H"));
                }
                halves.extend(half::f16::from_f32(v).to_bits().to_le_bytes());
            }
        }
    }
    compress_bc6h(&halves, bw as u32, bh as u32)
}

/// BC6H blocks of `bw` × `bh` texels of RGBA half floats, rows top to bottom.
#[cfg(feature = "bc6h")]
fn compress_bc6h(halves: &[u8], bw: u32, bh: u32) -> Result<Vec<u8>> {
    let surface = intel_tex_2::RgbaSurface {
        data: halves,
        width: bw,
        height: bh,
        stride: bw * 8,
    };
    Ok(intel_tex_2::bc6h::compress_blocks(
        &intel_tex_2::bc6h::basic_settings(),
        &surface,
    ))
}

/// Without the encoder (feature `bc6h` off): refused by name.
#[cfg(not(feature = "bc6h"))]
fn compress_bc6h(_halves: &[u8], _bw: u32, _bh: u32) -> Result<Vec<u8>> {
    Err(Error::Invalid(
        "BC6H texels need envlight's `bc6h` feature (Intel's encoder), which this build leaves out"
            .into(),
    ))
}

/// Level `k`'s bytes in `format`, before any supercompression.
fn level_bytes(image: &Ktx2Image<'_>, k: usize, format: Ktx2Format) -> Result<Vec<u8>> {
    let level = &image.levels[k];
    if format == Ktx2Format::Bc6h {
        let (w, h) = level_extent(image, k);
        let mut out = Vec::new();
        for face in level.chunks_exact(w * h) {
            out.extend(bc6h_face(face, w, h)?);
        }
        return Ok(out);
    }
    let mut out = Vec::with_capacity(level.len() * format.block_bytes() as usize);
    for t in level {
        pack_texel(format, t, &mut out)?;
    }
    Ok(out)
}

/// The bytes of a KTX 2.0 file holding `image` in `format`, levels stored as they are (texels
/// converted to the format; values it cannot hold are refused, naming the first).
pub fn encode(image: &Ktx2Image<'_>, format: Ktx2Format) -> Result<Vec<u8>> {
    encode_with(image, format, Supercompression::None)
}

/// [`encode`], each level supercompressed as `sc` says.
pub fn encode_with(
    image: &Ktx2Image<'_>,
    format: Ktx2Format,
    sc: Supercompression,
) -> Result<Vec<u8>> {
    check_shape(image)?;
    let n_levels = image.levels.len();
    let dfd = dfd(format);
    let kv = key_values();
    let header_len = 12 + 36 + 32 + 24 * n_levels;
    let dfd_offset = header_len;
    let kv_offset = dfd_offset + dfd.len();
    let mut data = vec![0; kv_offset + kv.len()];
    // §3.9.7: lcm(texel block bytes, 4) unsupercompressed (block bytes are 4, 8 or 16), else 1.
    let alignment = match sc {
        Supercompression::None => format.block_bytes().max(4) as usize,
        Supercompression::Zstd => 1,
    };
    // Levels smallest first: (offset, stored bytes, uncompressed bytes).
    let mut index = vec![(0u64, 0u64, 0u64); n_levels];
    for k in (0..n_levels).rev() {
        data.resize(data.len().next_multiple_of(alignment), 0);
        let bytes = level_bytes(image, k, format)?;
        let raw = bytes.len() as u64;
        let stored = match sc {
            Supercompression::None => bytes,
            Supercompression::Zstd => ruzstd::encoding::compress_to_vec(
                &bytes[..],
                ruzstd::encoding::CompressionLevel::Fastest,
            ),
        };
        index[k] = (data.len() as u64, stored.len() as u64, raw);
        data.extend(stored);
    }
    let mut head = Vec::with_capacity(header_len);
    head.extend(IDENTIFIER);
    for v in [
        format.vk_format(),
        format.type_size(),
        image.width,
        image.height,
        0,
        image.layers,
        image.faces,
        n_levels as u32,
        sc.scheme(),
    ] {
        head.extend(v.to_le_bytes());
    }
    head.extend((dfd_offset as u32).to_le_bytes());
    head.extend((dfd.len() as u32).to_le_bytes());
    head.extend((kv_offset as u32).to_le_bytes());
    head.extend((kv.len() as u32).to_le_bytes());
    head.extend(0u64.to_le_bytes());
    head.extend(0u64.to_le_bytes());
    for (offset, len, raw) in index {
        head.extend(offset.to_le_bytes());
        head.extend(len.to_le_bytes());
        head.extend(raw.to_le_bytes());
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

/// A KTX 2.0 texture read back ([`decode`]): its format and shape, and every level as RGBA
/// floats (A = 1 for the formats without alpha), laid out as [`Ktx2Image`] lays them.
#[derive(Clone, Debug, PartialEq)]
pub struct Ktx2Texture {
    /// Texel format.
    pub format: Ktx2Format,
    /// How the levels were stored.
    pub supercompression: Supercompression,
    /// Level-0 width.
    pub width: u32,
    /// Level-0 height.
    pub height: u32,
    /// 1 or 6.
    pub faces: u32,
    /// Array layers (0: not an array).
    pub layers: u32,
    /// The levels, level 0 first.
    pub levels: Vec<Vec<[f32; 4]>>,
}

impl Ktx2Format {
    /// The format of a VkFormat value envlight reads.
    pub fn from_vk(vk: u32) -> Option<Ktx2Format> {
        [
            Ktx2Format::Rgba16f,
            Ktx2Format::Rgba32f,
            Ktx2Format::B10g11r11,
            Ktx2Format::E5b9g9r9,
            Ktx2Format::Bc6h,
        ]
        .into_iter()
        .find(|f| f.vk_format() == vk)
    }
}

/// Largest level side [`decode`] accepts (a header claiming more is refused before anything
/// is allocated).
const MAX_SIDE: u32 = 16384;

/// Most texels in one level [`decode`] accepts (2²⁶: 1 GiB as RGBA floats; a 4096² cube).
const MAX_TEXELS: usize = 1 << 26;

/// Reads a KTX 2.0 file in any format envlight writes (and glTF-IBL-Sampler's RGBA16F and
/// RGBA32F files), inflating Zstandard levels and decoding BC6H blocks (`bcdec_rs`). Refuses,
/// saying what is wrong, anything else: another identifier or format, a depth, more than 6
/// faces, a level outside the file or of the wrong length, BasisLZ or ZLIB.
pub fn decode(bytes: &[u8]) -> Result<Ktx2Texture> {
    let bad = |m: String| Error::Invalid(format!("KTX2: {m}"));
    if bytes.len() < 80 || bytes[..12] != IDENTIFIER {
        return Err(bad("not a KTX 2.0 file (no «KTX 20» identifier)".into()));
    }
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let vk = word(12);
    let format = Ktx2Format::from_vk(vk).ok_or_else(|| {
        bad(format!(
            "vkFormat {vk} is not one envlight reads (rgba16f 97, rgba32f 109, b10g11r11 122, \
             e5b9g9r9 123, bc6h 143)"
        ))
    })?;
    let (width, height, depth, layers, faces) = (word(20), word(24), word(28), word(32), word(36));
    let n_levels = word(40).max(1) as usize;
    let supercompression = match word(44) {
        0 => Supercompression::None,
        2 => Supercompression::Zstd,
        s => {
            return Err(bad(format!(
                "supercompression scheme {s} (envlight reads none and Zstandard)"
            )))
        }
    };
    if depth != 0
        || !(faces == 1 || faces == 6)
        || width == 0
        || width > MAX_SIDE
        || height > MAX_SIDE
        || layers > 64
    {
        return Err(bad(format!(
            "a {width} × {height} × {depth} texture of {faces} faces and {layers} layers is not \
             one envlight reads (2D or cube, sides 1 to {MAX_SIDE}, at most 64 layers)"
        )));
    }
    if n_levels > 32 || bytes.len() < 80 + 24 * n_levels {
        return Err(bad(format!("{n_levels} levels do not fit the level index")));
    }
    let height = height.max(1);
    let mut levels = Vec::with_capacity(n_levels);
    for k in 0..n_levels {
        let at = 80 + 24 * k;
        let long = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap_or([0; 8]));
        let (offset, len, raw) = (long(at), long(at + 8), long(at + 16));
        let end = offset.checked_add(len).filter(|&e| e <= bytes.len() as u64);
        let Some(end) = end else {
            return Err(bad(format!("level {k} lies outside the file")));
        };
        let stored = &bytes[offset as usize..end as usize];
        let (w, h) = ((width >> k).max(1) as usize, (height >> k).max(1) as usize);
        let planes = faces as usize * layers.max(1) as usize;
        let side = format.block_side() as usize;
        let want = w.div_ceil(side) * h.div_ceil(side) * planes * format.block_bytes() as usize;
        if w * h * planes > MAX_TEXELS {
            return Err(bad(format!(
                "level {k} has {} texels, more than the {MAX_TEXELS} envlight reads",
                w * h * planes
            )));
        }
        let data = match supercompression {
            Supercompression::None => stored.to_vec(),
            Supercompression::Zstd => {
                inflate(stored, want).map_err(|m| bad(format!("level {k}: {m}")))?
            }
        };
        if data.len() != want || (supercompression == Supercompression::Zstd && raw != want as u64)
        {
            return Err(bad(format!(
                "level {k} holds {} bytes, not the {want} a {w} × {h} level of {planes} faces takes",
                data.len()
            )));
        }
        levels.push(unpack(format, &data, w, h, planes));
    }
    Ok(Ktx2Texture {
        format,
        supercompression,
        width,
        height,
        faces,
        layers,
        levels,
    })
}

/// One Zstandard frame inflated, refusing more than `limit` bytes.
fn inflate(stored: &[u8], limit: usize) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    let d =
        ruzstd::decoding::StreamingDecoder::new(stored).map_err(|e| format!("Zstandard: {e}"))?;
    let mut out = Vec::new();
    d.take(limit as u64 + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("Zstandard: {e}"))?;
    Ok(out)
}

/// An unsigned float of 5 exponent and `m` mantissa bits.
fn unpack_ufloat(bits: u32, m: u32) -> f32 {
    let (e, q) = ((bits >> m) as i32, (bits & ((1 << m) - 1)) as f32);
    let one = (1u32 << m) as f32;
    if e == 0 {
        2f32.powi(-14) * q / one
    } else if e == 31 {
        f32::INFINITY
    } else {
        2f32.powi(e - BIAS) * (1.0 + q / one)
    }
}

/// A level's bytes (its length checked) as RGBA floats.
fn unpack(format: Ktx2Format, data: &[u8], w: usize, h: usize, planes: usize) -> Vec<[f32; 4]> {
    let word = |c: &[u8]| u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    match format {
        Ktx2Format::Rgba32f => data
            .chunks_exact(16)
            .map(|c| {
                [0, 1, 2, 3].map(|k| {
                    f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
                })
            })
            .collect(),
        Ktx2Format::Rgba16f => data
            .chunks_exact(8)
            .map(|c| {
                [0, 1, 2, 3].map(|k| half::f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f32())
            })
            .collect(),
        Ktx2Format::B10g11r11 => data
            .chunks_exact(4)
            .map(|c| {
                let v = word(c);
                [
                    unpack_ufloat(v & 0x7ff, 6),
                    unpack_ufloat((v >> 11) & 0x7ff, 6),
                    unpack_ufloat(v >> 22, 5),
                    1.0,
                ]
            })
            .collect(),
        Ktx2Format::E5b9g9r9 => data
            .chunks_exact(4)
            .map(|c| {
                let v = word(c);
                let s = 2f32.powi((v >> 27) as i32 - BIAS - 9);
                let q = [v & 511, (v >> 9) & 511, (v >> 18) & 511].map(|q| q as f32 * s);
                [q[0], q[1], q[2], 1.0]
            })
            .collect(),
        Ktx2Format::Bc6h => {
            let (bw, bh) = (w.div_ceil(4), h.div_ceil(4));
            let mut out = vec![[0.0f32; 4]; planes * w * h];
            for (f, plane) in data.chunks_exact(bw * bh * 16).enumerate() {
                for (b, block) in plane.chunks_exact(16).enumerate() {
                    let mut px = [0.0f32; 48];
                    bcdec_rs::bc6h_float(block, &mut px, 12, false);
                    let (bx, by) = (b % bw, b / bw);
                    for y in 0..4 {
                        for x in 0..4 {
                            let (i, j) = (bx * 4 + x, by * 4 + y);
                            if i < w && j < h {
                                let p = &px[y * 12 + x * 3..y * 12 + x * 3 + 3];
                                out[(f * h + j) * w + i] = [p[0], p[1], p[2], 1.0];
                            }
                        }
                    }
                }
            }
            out
        }
    }
}

#[cfg(test)]
mod tests;
