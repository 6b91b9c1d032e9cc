//! OpenEXR through the `exr` crate: any layout with R, G and B channels (in any order, half or
//! float; A is ignored), written back as float32 RGB with the mapping in an attribute.

use super::{check_size, strip_extent, Raster};
use crate::envmap::EnvMap;
use crate::error::{Error, Result};
use crate::math::Mapping;
use exr::prelude::*;
use std::path::Path;

/// Name of the attribute holding the mapping in files envlight writes.
pub const MAPPING_ATTRIBUTE: &str = "envlight.mapping";

pub(crate) fn read(path: &Path, max_texels: u64) -> Result<Raster> {
    let bad = |e: exr::error::Error| {
        Error::bad_file(path, format!("corrupt or unsupported OpenEXR: {e}"))
    };
    // Read the header first so an absurd data window is refused before any allocation.
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(bad)?;
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
    let hint = header
        .own_attributes
        .other
        .get(&Text::from(MAPPING_ATTRIBUTE))
        .and_then(|a| match a {
            AttributeValue::Text(t) => Mapping::parse(&t.to_string()),
            _ => None,
        });
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0.0f32; 3]; res.width() * res.height()]),
        |px: &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = px.0;
            px.1[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .map_err(bad)?;
    let layer = image.layer_data;
    Ok(Raster {
        width: layer.size.width() as u32,
        height: layer.size.height() as u32,
        rgb: layer.channel_data.pixels.1,
        mapping_hint: hint,
    })
}

/// Writes a map as a float32 RGB EXR (ZIP compressed); cubes and dual paraboloids are stored
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
        Encoding::SMALL_FAST_LOSSLESS,
        channels,
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| Error::bad_file(path, format!("cannot write OpenEXR: {e}")))
}
