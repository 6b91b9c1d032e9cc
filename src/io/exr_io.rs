//! OpenEXR through the `exr` crate: R, G and B channels in any order and precision (A and other
//! channels ignored), or a Y or single channel read as grey; written back as float32 RGB with
//! the mapping in an attribute.

use super::{check_size, strip_extent, Raster};
use crate::error::{Error, Result};
use crate::math::envmap::EnvMap;
use crate::math::Mapping;
use exr::prelude::*;
use std::path::Path;

/// Name of the attribute holding the mapping in files envlight writes.
pub const MAPPING_ATTRIBUTE: &str = "envlight.mapping";

/// Largest block (scan-line group or tile) read, decompressed: 64 MiB, which holds 16 lines of
/// a 65 536-texel-wide RGBA float image.
const MAX_BLOCK_BYTES: u64 = 64 << 20;

pub(crate) fn read(path: &Path, bytes: &[u8], max_texels: u64) -> Result<Raster> {
    let bad = |e: exr::error::Error| {
        Error::bad_file(path, format!("corrupt or unsupported OpenEXR: {e}"))
    };
    // Read the header first so an absurd data window is refused before any allocation.
    let meta =
        exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).map_err(bad)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| Error::bad_file(path, "OpenEXR file has no layer"))?;
    let size = header.layer_size;
    check_size(
        path,
        size.width() as u64,
        size.height() as u64,
        1,
        max_texels,
    )?;
    // The exr crate allocates a block buffer of the header's largest block size and an offset
    // table of its chunk count before reading either; the fuzzer found headers that claim
    // gigabytes of both in a file of a few hundred bytes. Neither can exceed the file.
    for h in &meta.headers {
        let table = (h.chunk_count as u64).saturating_mul(8);
        if h.deep || table > bytes.len() as u64 {
            return Err(Error::bad_file(
                path,
                if h.deep {
                    "deep OpenEXR data is not an environment map".to_string()
                } else {
                    format!(
                        "corrupt OpenEXR: {} chunks need a {table}-byte offset table, but the \
                         file holds {} bytes",
                        h.chunk_count,
                        bytes.len()
                    )
                },
            ));
        }
        let block = h.max_block_byte_size() as u64;
        if block > MAX_BLOCK_BYTES {
            return Err(Error::bad_file(
                path,
                format!(
                    "corrupt or unsupported OpenEXR: blocks of {block} bytes ({} bytes per \
                     pixel), above envlight's limit of {MAX_BLOCK_BYTES}",
                    h.channels.bytes_per_pixel
                ),
            ));
        }
    }
    let hint = header
        .own_attributes
        .other
        .get(&Text::from(MAPPING_ATTRIBUTE))
        .and_then(|a| match a {
            AttributeValue::Text(t) => Mapping::parse(&t.to_string()),
            _ => None,
        });
    // The crate asserts on some inconsistent files instead of returning an error (found by
    // the fuzzer: "line should have been filtered"); such a file is corrupt, not a crash.
    let decoded = std::panic::catch_unwind(|| {
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(bytes))
    });
    let image = match decoded {
        Ok(r) => r.map_err(bad)?,
        Err(_) => {
            return Err(Error::bad_file(
                path,
                "corrupt OpenEXR: the decoder rejected its block layout",
            ))
        }
    };
    let layer = image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let channels = &layer.channel_data.list;
    // Channel names may carry a layer prefix ("diffuse.R"); match on the last component.
    let find = |want: &str| {
        channels.iter().find(|c| {
            let name = c.name.to_string();
            name.rsplit('.')
                .next()
                .is_some_and(|n| n.eq_ignore_ascii_case(want))
        })
    };
    let as_f32 = |c: &AnyChannel<FlatSamples>| -> Result<Vec<f32>> {
        if c.sampling != Vec2(1, 1) {
            return Err(Error::bad_file(
                path,
                format!(
                    "OpenEXR channel {} is subsampled; envlight reads full-resolution channels",
                    c.name
                ),
            ));
        }
        Ok(match &c.sample_data {
            FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
        })
    };
    let planes: [Vec<f32>; 3] = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => [as_f32(r)?, as_f32(g)?, as_f32(b)?],
        (_, _, _, Some(y)) => {
            let y = as_f32(y)?;
            [y.clone(), y.clone(), y]
        }
        _ if channels.len() == 1 => {
            let y = as_f32(&channels[0])?;
            [y.clone(), y.clone(), y]
        }
        _ => {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(Error::bad_file(
                path,
                format!("OpenEXR has channels {names:?}; envlight needs R, G and B, or Y, or a single channel"),
            ));
        }
    };
    if planes.iter().any(|p| p.len() != w * h) {
        return Err(Error::bad_file(
            path,
            "OpenEXR channel sizes do not match the data window",
        ));
    }
    let rgb = (0..w * h)
        .map(|i| [planes[0][i], planes[1][i], planes[2][i]])
        .collect();
    Ok(Raster {
        width: w as u32,
        height: h as u32,
        rgb,
        mapping_hint: hint,
    })
}

/// Writes named channels as half floats (for tests of "any channel layout", such as B, G, R
/// half like pbrt's grace_latlong.exr, or Y alone).
/// Values a half cannot hold are refused (see docs/CONTRIBUTING.md's hard cases), not written as Inf.
pub fn write_half_channels(path: &Path, w: u32, h: u32, channels: &[(&str, &[f32])]) -> Result<()> {
    super::check_half(path, channels.iter().flat_map(|(_, v)| v.iter().copied()))?;
    let list: Vec<_> = channels
        .iter()
        .map(|(name, v)| {
            AnyChannel::new(
                *name,
                FlatSamples::F16(v.iter().map(|&x| f16::from_f32(x)).collect()),
            )
        })
        .collect();
    let layer = Layer::new(
        (w as usize, h as usize),
        LayerAttributes::named("test"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| Error::bad_file(path, format!("cannot write OpenEXR: {e}")))
}

/// Writes a map as a float32 RGB EXR (uncompressed); cubes and dual paraboloids are stored
/// with their layers stacked vertically (see the module docs of [`crate::io`]).
pub fn save_exr(map: &EnvMap, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    let (w, h) = strip_extent(map);
    let texels = &map.texels;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let t = texels[pos.y() * w as usize + pos.x()];
        (t[0], t[1], t[2])
    });
    let mut attrs = LayerAttributes::named("rgb");
    attrs.other.insert(
        Text::from(MAPPING_ATTRIBUTE),
        AttributeValue::Text(Text::from(map.mapping.name())),
    );
    let layer = Layer::new(
        (w as usize, h as usize),
        attrs,
        Encoding::UNCOMPRESSED,
        channels,
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| Error::bad_file(path, format!("cannot write OpenEXR: {e}")))
}
