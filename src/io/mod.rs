//! Reading and writing environment maps.
//!
//! Formats: OpenEXR (any RGB(A) channel order, half or float), Radiance `.hdr`, PFM, DDS (2D or
//! cube; RGBA16F, RGBA32F, RGB32F), PNG and JPEG (sRGB, decoded to linear), and six separate
//! face files. Written: float32 EXR, and tone-mapped PNG previews.
//!
//! # How the mapping of a file is decided
//! 1. the mapping the caller gives ([`LoadOptions::mapping`], `--mapping` on the command line);
//! 2. a DDS cube map, or six face files, is a cube;
//! 3. an EXR written by envlight carries its mapping in the `envlight.mapping` attribute;
//! 4. otherwise the aspect ratio decides: W = 2H is lat-long, W = H an angular probe, H = 6W a
//!    cube stored as a vertical strip of faces (+X on top, Vulkan face order), H = 2W a dual
//!    paraboloid stored as its upper half (y ≥ 0) above its lower half;
//! 5. any other shape is an error that asks for the mapping.
//!
//! These single-image layouts of cubes and dual paraboloids are also how [`save_exr`] writes
//! them, so envlight's own output always loads back.

mod dds;
mod exr_io;
pub mod ktx2;
mod pfm;
mod png_io;

use crate::error::{Error, Result};
use crate::math::envmap::EnvMap;
use crate::math::Mapping;
use std::path::{Path, PathBuf};

pub use dds::write_cube_rgba16f as write_dds_cube;
pub use exr_io::{save_exr, write_half_channels as write_exr_half_channels};
pub use pfm::write as write_pfm;
pub use png_io::{save_png, tone_map, ToneMap};

/// The map formats [`save_map`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MapFormat {
    Exr,
    Radiance,
    Pfm,
}

/// The format `path`'s extension names, or the refusal that names the file.
fn map_format(path: &Path) -> Result<MapFormat> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr") => Ok(MapFormat::Exr),
        Some("hdr") => Ok(MapFormat::Radiance),
        Some("pfm") => Ok(MapFormat::Pfm),
        other => Err(Error::bad_file(
            path,
            format!(
                "cannot write {}: envlight writes OpenEXR (.exr), Radiance (.hdr) and PFM (.pfm) \
                 maps; name the output with one of those extensions",
                match other {
                    Some(e) => format!("a .{e} file"),
                    None => "a file without an extension".to_string(),
                }
            ),
        )),
    }
}

/// Whether [`save_map`] can write `path` (its extension names a format it writes): what a
/// command checks before its work, so that a misnamed output is refused at once.
pub fn check_map_path(path: &Path) -> Result<()> {
    map_format(path).map(|_| ())
}

/// Writes `map` in the format its path's extension names: `.exr` float32 OpenEXR (with the
/// mapping recorded, [`save_exr`]), `.hdr` Radiance RGBE, `.pfm` float32 PFM; cubes and dual
/// paraboloids as the single image [`strip_extent`] describes, which loads back by its
/// aspect ratio. Any other extension, or none, is refused by name before anything is
/// written: a file never holds a format its name does not say. Radiance and PFM files are
/// written atomically ([`write_atomic`]).
pub fn save_map(map: &EnvMap, path: &Path) -> Result<()> {
    match map_format(path)? {
        MapFormat::Exr => save_exr(map, path),
        MapFormat::Radiance => write_atomic(path, &radiance_bytes(map, path)?),
        MapFormat::Pfm => {
            let (w, h) = strip_extent(map);
            write_atomic(path, &pfm::bytes(w, h, &map.texels))
        }
    }
}

/// `map` as a Radiance RGBE file (negative channels, which RGBE cannot hold, written as 0).
fn radiance_bytes(map: &EnvMap, path: &Path) -> Result<Vec<u8>> {
    let (w, h) = strip_extent(map);
    let texels: Vec<image::Rgb<f32>> = map
        .texels
        .iter()
        .map(|t| image::Rgb(t.map(|c| c.max(0.0))))
        .collect();
    let mut bytes = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut bytes)
        .encode(&texels, w as usize, h as usize)
        .map_err(|e| Error::bad_file(path, format!("cannot encode Radiance RGBE: {e}")))?;
    Ok(bytes)
}

/// Writes `bytes` to `path` atomically: into a temporary file in the same folder, then renamed
/// over `path`, so an interrupted run leaves either the old file or the new one, never half.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    std::fs::write(&tmp, bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}

/// The probe files of a folder: its .hdr, .exr, .dds and .pfm files (any case), sorted, as
/// `envlight bake DIR` and the benchmarks take a folder.
pub fn probes_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |source| Error::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && matches!(
                    p.extension()
                        .and_then(|e| e.to_str())
                        .map(|e| e.to_ascii_lowercase())
                        .as_deref(),
                    Some("hdr" | "exr" | "dds" | "pfm")
                )
        })
        .collect();
    v.sort();
    Ok(v)
}

/// What to do with NaN, infinite and negative texels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sanitize {
    /// Refuse the file with an error that counts them (the default: no silently wrong image).
    #[default]
    Reject,
    /// Replace each such channel by 0 and go on (`--sanitize` on the command line).
    Zero,
}

/// Options for [`load`]: [`LoadOptions::new`] or [`Default`], then the fields that differ.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct LoadOptions {
    /// The mapping, if the caller knows it; otherwise it is inferred (see the module docs).
    pub mapping: Option<Mapping>,
    /// Policy for NaN, infinite and negative texels.
    pub sanitize: Sanitize,
    /// Largest number of texels (all layers) accepted, a guard against absurd headers.
    pub max_texels: u64,
}

impl LoadOptions {
    /// A file of `mapping` (`None`: inferred), rejecting NaN, infinite and negative texels,
    /// with the default size guard.
    pub fn new(mapping: Option<Mapping>) -> Self {
        LoadOptions {
            mapping,
            ..Default::default()
        }
    }
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            mapping: None,
            sanitize: Sanitize::Reject,
            max_texels: 1 << 27,
        }
    }
}

/// A decoded image before a mapping is attached.
pub(crate) struct Raster {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[f32; 3]>,
    /// A mapping the file itself states (DDS cube flag, envlight's EXR attribute).
    pub mapping_hint: Option<Mapping>,
}

/// Checks a header's dimensions before anything is allocated.
pub(crate) fn check_size(path: &Path, w: u64, h: u64, layers: u64, max: u64) -> Result<()> {
    if w == 0 || h == 0 {
        return Err(Error::bad_file(
            path,
            format!("image has zero size ({w} x {h})"),
        ));
    }
    let n = w.saturating_mul(h).saturating_mul(layers);
    if n > max {
        return Err(Error::bad_file(
            path,
            format!(
                "image is {w} x {h}{} texels, above the limit of {max} texels \
                 (a corrupt header, or raise LoadOptions::max_texels)",
                if layers > 1 {
                    format!(" x {layers}")
                } else {
                    String::new()
                }
            ),
        ));
    }
    Ok(())
}

pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Loads an environment map from a file.
pub fn load(path: impl AsRef<Path>, opts: &LoadOptions) -> Result<EnvMap> {
    let path = path.as_ref();
    load_bytes(path, &read_file(path)?, opts)
}

/// Loads a cube map from six face files, in Vulkan face order +X, −X, +Y, −Y, +Z, −Z.
pub fn load_cube_faces(paths: &[PathBuf; 6], opts: &LoadOptions) -> Result<EnvMap> {
    let mut faces = Vec::with_capacity(6);
    for p in paths {
        let r = read_raster(p, opts)?;
        if r.width != r.height {
            return Err(Error::bad_file(
                p,
                format!("cube face is {} x {}, not square", r.width, r.height),
            ));
        }
        if let Some(first) = faces.first() {
            let first: &Raster = first;
            if first.width != r.width {
                return Err(Error::bad_file(
                    p,
                    format!(
                        "cube face is {0} x {0} but {1} is {2} x {2}",
                        r.width,
                        paths[0].display(),
                        first.width
                    ),
                ));
            }
        }
        faces.push(r);
    }
    let n = faces[0].width;
    let rgb = faces.into_iter().flat_map(|f| f.rgb).collect();
    let raster = Raster {
        width: n,
        height: n * 6,
        rgb,
        mapping_hint: Some(Mapping::Cube),
    };
    into_envmap(&paths[0], raster, Mapping::Cube, opts.sanitize)
}

/// Expands a path holding `{face}` into the six files px, nx, py, ny, pz, nz (three.js naming).
pub fn face_paths(pattern: &str) -> Option<[PathBuf; 6]> {
    pattern.contains("{face}").then(|| {
        ["px", "nx", "py", "ny", "pz", "nz"].map(|f| PathBuf::from(pattern.replace("{face}", f)))
    })
}

fn read_raster(path: &Path, opts: &LoadOptions) -> Result<Raster> {
    raster_from_bytes(path, &read_file(path)?, opts)
}

/// Decodes a map from the bytes of a file held in memory (an engine's pak file, a network
/// buffer). `name` is only used in error messages, and its extension in the format error.
/// The rules of [`load`] apply: same formats, mapping inference and [`Sanitize`] policy.
pub fn load_bytes(name: impl AsRef<Path>, bytes: &[u8], opts: &LoadOptions) -> Result<EnvMap> {
    let path = name.as_ref();
    let raster = raster_from_bytes(path, bytes, opts)?;
    let mapping = match opts.mapping.or(raster.mapping_hint) {
        Some(m) => m,
        None => infer_mapping(path, raster.width, raster.height)?,
    };
    into_envmap(path, raster, mapping, opts.sanitize)
}

fn raster_from_bytes(path: &Path, bytes: &[u8], opts: &LoadOptions) -> Result<Raster> {
    if bytes.is_empty() {
        return Err(Error::bad_file(path, "file is empty"));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        exr_io::read(path, bytes, opts.max_texels)
    } else if bytes.starts_with(b"DDS ") {
        dds::read(path, bytes, opts.max_texels)
    } else if bytes.starts_with(b"PF") || bytes.starts_with(b"Pf") {
        pfm::read(path, bytes, opts.max_texels)
    } else if bytes.starts_with(b"#?") {
        png_io::read_with_image_crate(path, bytes, opts.max_texels, false)
    } else if bytes.starts_with(&[0x89, b'P', b'N', b'G']) || bytes.starts_with(&[0xff, 0xd8]) {
        png_io::read_with_image_crate(path, bytes, opts.max_texels, true)
    } else {
        Err(Error::bad_file(
            path,
            format!(
                "unrecognised file format (extension '{ext}'); envlight reads OpenEXR, Radiance \
                 .hdr, PFM, DDS, PNG and JPEG"
            ),
        ))
    }
}

/// The mip levels of a prefiltered cube file, level 0 first, each a [`Mapping::Cube`] map in
/// the file's own frame: a KTX2 cube (any format [`ktx2::decode`] reads) or a DDS cube
/// (RGBA16F, RGBA32F or RGB32F, as cmft writes them). Anything else, or a file without six
/// faces, is refused with its name.
pub fn load_cube_levels(path: impl AsRef<Path>) -> Result<Vec<EnvMap>> {
    let path = path.as_ref();
    let bytes = read_file(path)?;
    let max = LoadOptions::default().max_texels;
    if bytes.starts_with(b"DDS ") {
        let (first, mips) = dds::read_level(path, &bytes, max, 0)?;
        if first.mapping_hint != Some(Mapping::Cube) {
            return Err(Error::bad_file(path, "DDS is not a cube map"));
        }
        let mut levels = vec![first];
        for k in 1..mips {
            levels.push(dds::read_level(path, &bytes, max, k)?.0);
        }
        return Ok(levels
            .into_iter()
            .map(|r| EnvMap::new(Mapping::Cube, r.width, r.width, r.rgb))
            .collect());
    }
    let tex = ktx2::decode(&bytes).map_err(|e| Error::bad_file(path, e.to_string()))?;
    if tex.faces != 6 || tex.width != tex.height {
        return Err(Error::bad_file(
            path,
            format!(
                "not a cube: {} faces of {} x {}",
                tex.faces, tex.width, tex.height
            ),
        ));
    }
    Ok(tex
        .levels
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let s = (tex.width >> k).max(1);
            EnvMap::new(
                Mapping::Cube,
                s,
                s,
                l.iter().map(|t| [t[0], t[1], t[2]]).collect(),
            )
        })
        .collect())
}

/// The aspect-ratio rule of the module docs.
pub fn infer_mapping(path: &Path, w: u32, h: u32) -> Result<Mapping> {
    let m = if w == 2 * h {
        Mapping::LatLong
    } else if w == h {
        Mapping::Angular
    } else if h == 6 * w {
        Mapping::Cube
    } else if h == 2 * w {
        Mapping::DualParaboloid
    } else {
        return Err(Error::bad_file(
            path,
            format!(
                "cannot tell the mapping of a {w} x {h} image (2:1 is lat-long, 1:1 angular, \
                 1:6 a cube strip, 1:2 a dual paraboloid); give it with --mapping"
            ),
        ));
    };
    Ok(m)
}

fn into_envmap(path: &Path, r: Raster, mapping: Mapping, sanitize: Sanitize) -> Result<EnvMap> {
    let layers = mapping.layers();
    if !r.height.is_multiple_of(layers)
        || (mapping != Mapping::LatLong && r.width != r.height / layers)
    {
        return Err(Error::bad_file(
            path,
            format!(
                "a {} x {} image cannot hold a {} map (expected {})",
                r.width,
                r.height,
                mapping.name(),
                match mapping {
                    Mapping::LatLong => "any W x H, usually 2:1",
                    Mapping::Angular => "a square",
                    Mapping::Cube => "six square faces stacked vertically",
                    Mapping::DualParaboloid => "two square halves stacked vertically",
                }
            ),
        ));
    }
    let mut map = EnvMap::new(mapping, r.width, r.height / layers, r.rgb);
    // Every stored texel counts, not only those on the sphere: bilinear lookups at an angular
    // or paraboloid rim read the corners too (the fuzzer found NaN corners accepted).
    let s = bad_texels(&map.texels);
    if s.nan + s.inf + s.negative > 0 {
        match sanitize {
            Sanitize::Reject => {
                return Err(Error::bad_file(
                    path,
                    format!(
                        "{} NaN, {} infinite and {} negative texels; radiance must be finite and \
                         non-negative (use --sanitize to replace them by 0)",
                        s.nan, s.inf, s.negative
                    ),
                ))
            }
            Sanitize::Zero => {
                for t in &mut map.texels {
                    for c in t.iter_mut() {
                        if !c.is_finite() || *c < 0.0 {
                            *c = 0.0;
                        }
                    }
                }
            }
        }
    }
    Ok(map)
}

/// Refuses values a half float cannot hold: half-float writers never turn a bright texel
/// (a sun of 10⁶) into Inf. Values that round to at most 65504 (`f16::MAX`) are written.
pub(crate) fn check_half(path: &Path, values: impl Iterator<Item = f32>) -> Result<()> {
    let (mut n, mut worst) = (0usize, 0.0f32);
    for v in values {
        if !v.is_finite() || half::f16::from_f32(v).is_infinite() {
            n += 1;
            // NaN has no magnitude to report; the count still includes it.
            if v.abs() > worst {
                worst = v.abs();
            }
        }
    }
    if n > 0 {
        return Err(Error::bad_file(
            path,
            format!(
                "{n} values overflow half float (largest magnitude {worst:e}, half holds at \
                 most 65504); write float32 instead, or scale the map down"
            ),
        ));
    }
    Ok(())
}

struct BadTexels {
    nan: usize,
    inf: usize,
    negative: usize,
}

fn bad_texels(texels: &[[f32; 3]]) -> BadTexels {
    let mut b = BadTexels {
        nan: 0,
        inf: 0,
        negative: 0,
    };
    for t in texels {
        if t.iter().any(|c| c.is_nan()) {
            b.nan += 1;
        } else if t.iter().any(|c| c.is_infinite()) {
            b.inf += 1;
        }
        if t.iter().any(|&c| c < 0.0) {
            b.negative += 1;
        }
    }
    b
}

/// Splits a map into the single image [`save_exr`] and [`save_png`] write: layers stacked
/// vertically (cube faces in Vulkan order, paraboloid upper half first).
pub fn strip_extent(map: &EnvMap) -> (u32, u32) {
    (map.width, map.height * map.layers())
}
