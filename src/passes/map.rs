//! Environment maps resident on the GPU as RGBA32F 2D array images (cube-compatible for
//! cubes), envlight's or the caller's, and the recorded copies that move them to and from
//! the host.

use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context, Image, ImageDesc, Recorder, Timed, Usage};
use crate::math::envmap::EnvMap;
use crate::math::Mapping;
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Texel format of maps on the GPU: float32 keeps a 10⁵ sun exact (half floats overflow at
/// 65504).
pub const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// The usage flags of maps envlight creates: written by passes, sampled, copied both ways.
pub const USAGE: vk::ImageUsageFlags = vk::ImageUsageFlags::from_raw(
    vk::ImageUsageFlags::STORAGE.as_raw()
        | vk::ImageUsageFlags::SAMPLED.as_raw()
        | vk::ImageUsageFlags::TRANSFER_SRC.as_raw()
        | vk::ImageUsageFlags::TRANSFER_DST.as_raw(),
);

/// An environment map on the GPU: an image and how to read it.
pub struct GpuEnvMap {
    /// Its mapping.
    pub mapping: Mapping,
    /// Width of a layer.
    pub width: u32,
    /// Height of a layer.
    pub height: u32,
    /// The image (layers = mapping's layers).
    pub image: Image,
}

/// The image description of a map of `mapping`, `width` × `height`, with `mips` levels.
pub fn map_desc(mapping: Mapping, width: u32, height: u32, mips: u32) -> ImageDesc {
    ImageDesc {
        width,
        height,
        layers: mapping.layers(),
        format: FORMAT,
        usage: USAGE,
        cube: mapping == Mapping::Cube,
        mips,
    }
}

/// Levels of a full MIP chain for a `width` × `height` image (Vulkan's sizes).
pub fn full_mips(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

impl GpuEnvMap {
    /// An uninitialised map for a pass to write (storage, sampled, transfer both ways).
    pub fn new(
        ctx: &Context,
        name: &str,
        mapping: Mapping,
        width: u32,
        height: u32,
    ) -> Result<GpuEnvMap> {
        GpuEnvMap::create(ctx, name, map_desc(mapping, width, height, 1), mapping)
    }

    /// An uninitialised map with a full MIP chain (Vulkan's sizes: level k is
    /// max(1, size >> k)), for passes to write level by level.
    pub fn with_mips(
        ctx: &Context,
        name: &str,
        mapping: Mapping,
        width: u32,
        height: u32,
    ) -> Result<GpuEnvMap> {
        let mips = full_mips(width, height);
        GpuEnvMap::create(ctx, name, map_desc(mapping, width, height, mips), mapping)
    }

    /// An uninitialised map of any description (a colour target, say).
    pub fn create(
        ctx: &Context,
        name: &str,
        desc: ImageDesc,
        mapping: Mapping,
    ) -> Result<GpuEnvMap> {
        if desc.width == 0 || desc.height == 0 {
            return Err(Error::Invalid(format!(
                "{name}: a map needs a non-zero size"
            )));
        }
        assert_eq!(desc.layers, mapping.layers());
        Ok(GpuEnvMap {
            mapping,
            width: desc.width,
            height: desc.height,
            image: Image::new(ctx, name, desc)?,
        })
    }

    /// A map over an image the caller owns (see [`Image::from_raw`]).
    pub fn from_image(image: Image, mapping: Mapping) -> GpuEnvMap {
        let d = *image.desc();
        assert_eq!(
            d.layers,
            mapping.layers(),
            "{mapping:?} needs {} layers",
            mapping.layers()
        );
        assert!(
            mapping != Mapping::Cube || d.cube,
            "a cube map needs a cube view"
        );
        GpuEnvMap {
            mapping,
            width: d.width,
            height: d.height,
            image,
        }
    }

    /// Its MIP levels.
    pub fn mips(&self) -> u32 {
        self.image.desc().mips
    }

    /// The size of MIP level `level`.
    pub fn level_size(&self, level: u32) -> (u32, u32) {
        ((self.width >> level).max(1), (self.height >> level).max(1))
    }

    /// Records the upload of `map` into level 0 of this map (same mapping and size); the
    /// staging buffer is kept by the recorder. Texels must be finite and non-negative (what
    /// [`crate::io::load`] guarantees); anything else is refused so that no pass ever sees
    /// or makes NaN.
    pub fn record_upload(&self, rec: &mut Recorder, map: &EnvMap) -> Result<()> {
        assert_eq!(
            (map.mapping, map.width, map.height),
            (self.mapping, self.width, self.height)
        );
        let n = map.texels.len();
        let mut staging = Buffer::new(
            rec.context(),
            "upload staging",
            (n * 16) as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        // One pass checks each texel and writes it as RGBA straight into the mapped staging
        // memory: no second pass over the map, no copy in host memory.
        staging.write_with(n, |rgba: &mut [[f32; 4]]| {
            for (k, (d, t)) in rgba.iter_mut().zip(&map.texels).enumerate() {
                if t.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
                    return Err(bad_texel(map, k));
                }
                *d = [t[0], t[1], t[2], 1.0];
            }
            Ok(())
        })?;
        rec.copy_buffer_to_image(&staging, &self.image, 0, true);
        rec.keep(staging);
        poison::image(rec, PassId::Map, &self.image, 0..1)
    }

    /// Uploads `map` into level 0 of this map (same mapping and size) in bands of rows
    /// through one staging buffer of at most `band_bytes` (at least a row), submitting and
    /// waiting for each band: the host memory an upload stages stays bounded, where
    /// [`GpuEnvMap::record_upload`] stages the whole map at once (16 bytes a texel). The
    /// queue runs the bands after the work submitted before them. Texels are checked as
    /// [`GpuEnvMap::record_upload`] checks them.
    pub fn upload_banded(&self, ctx: &Context, map: &EnvMap, band_bytes: u64) -> Result<()> {
        assert_eq!(
            (map.mapping, map.width, map.height),
            (self.mapping, self.width, self.height)
        );
        let (w, h) = (self.width, self.height);
        let rows = ((band_bytes / (w as u64 * 16)) as u32).clamp(1, h);
        let mut staging = Buffer::new(
            ctx,
            "banded upload staging",
            rows as u64 * w as u64 * 16,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        let layers = self.mapping.layers();
        for layer in 0..layers {
            for j0 in (0..h).step_by(rows as usize) {
                let j1 = (j0 + rows).min(h);
                let first = map.index(layer, 0, j0);
                let n = ((j1 - j0) * w) as usize;
                staging.write_with(n, |rgba: &mut [[f32; 4]]| {
                    let texels = &map.texels[first..first + n];
                    for (k, (d, t)) in rgba.iter_mut().zip(texels).enumerate() {
                        if t.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
                            return Err(bad_texel(map, first + k));
                        }
                        *d = [t[0], t[1], t[2], 1.0];
                    }
                    Ok(())
                })?;
                let last = layer + 1 == layers && j1 == h;
                ctx.run("uploading a band of rows", |rec| {
                    let discard = layer == 0 && j0 == 0;
                    rec.copy_buffer_to_image_rows(&staging, &self.image, layer, j0..j1, discard);
                    match last {
                        true => poison::image(rec, PassId::Map, &self.image, 0..1),
                        false => Ok(()),
                    }
                })?;
            }
        }
        Ok(())
    }

    /// Uploads a map into a new GPU map and waits (see [`GpuEnvMap::record_upload`]).
    pub fn upload(ctx: &Context, map: &EnvMap) -> Result<GpuEnvMap> {
        let g = GpuEnvMap::new(ctx, "uploaded map", map.mapping, map.width, map.height)?;
        ctx.run("uploading a map", |rec| g.record_upload(rec, map))?;
        Ok(g)
    }

    /// As [`GpuEnvMap::upload`], into level 0 of a map with a full MIP chain (the other
    /// levels undefined, for a pass to fill).
    pub fn upload_mipped(ctx: &Context, map: &EnvMap) -> Result<GpuEnvMap> {
        let g = GpuEnvMap::with_mips(ctx, "uploaded map", map.mapping, map.width, map.height)?;
        ctx.run("uploading a map", |rec| g.record_upload(rec, map))?;
        Ok(g)
    }

    /// Records the copy of level `level` (rgba, layer after layer, row after row) into a new
    /// host-visible buffer, which [`Readback::read`] reads once the work has completed.
    pub fn record_download(&self, rec: &mut Recorder, level: u32) -> Result<Readback> {
        assert!(level < self.mips(), "level {level} of {}", self.mips());
        let (w, h) = self.level_size(level);
        let n = (w * h * self.mapping.layers()) as usize;
        let buffer = Buffer::new(
            rec.context(),
            "download staging",
            (n * 16) as u64,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        rec.copy_image_to_buffer(&self.image, level, &buffer, 0);
        rec.use_buffer(&buffer, Usage::HostRead);
        Ok(Readback { buffer, texels: n })
    }

    /// Reads the map back (level 0) and waits.
    pub fn download(&self, ctx: &Context) -> Result<EnvMap> {
        let rgba = self.download_level(ctx, 0)?;
        Ok(EnvMap::new(
            self.mapping,
            self.width,
            self.height,
            rgba.into_iter().map(|t| [t[0], t[1], t[2]]).collect(),
        ))
    }

    /// Reads one MIP level back with its alpha channel, layer after layer, row after row.
    pub fn download_level(&self, ctx: &Context, level: u32) -> Result<Vec<[f32; 4]>> {
        let Timed { value: r, .. } =
            ctx.run("downloading a map", |rec| self.record_download(rec, level))?;
        Ok(r.read())
    }
}

/// Texels copied to a host-visible buffer by [`GpuEnvMap::record_download`].
pub struct Readback {
    buffer: Buffer,
    texels: usize,
}

impl Readback {
    /// The texels, rgba; valid once the recorded work has completed.
    pub fn read(&self) -> Vec<[f32; 4]> {
        self.buffer.read(self.texels)
    }
}

/// The error for texel `k`, which is not finite and non-negative radiance.
fn bad_texel(map: &EnvMap, k: usize) -> Error {
    Error::Invalid(format!(
        "texel {k} of the {} map is {:?}; radiance must be finite and non-negative",
        map.mapping.name(),
        map.texels[k]
    ))
}

/// The resident path's first pass: an engine's map copied into envlight's own image with
/// every texel that is not a finite, non-negative radiance zeroed and counted on the GPU, so
/// that no later pass sees NaN and a broken frame still shades finite pixels (float64 twin:
/// [`EnvMap::sanitized`]).
pub struct Sanitizer {
    pipeline: crate::gpu::Pipeline,
    sampler: crate::gpu::Sampler,
}

impl Sanitizer {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Sanitizer> {
        Ok(Sanitizer {
            pipeline: crate::gpu::Pipeline::compute(
                ctx,
                crate::abi::ShaderId::Sanitize,
                &crate::abi::WORKGROUP_2D,
            )?,
            sampler: crate::gpu::Sampler::linear_clamp(ctx, "sanitize sampler")?,
        })
    }

    /// Bytes of the count buffer [`Sanitizer::record`] writes (one u32).
    pub const COUNT_BYTES: u64 = 4;

    /// Records the copy of `src` into `dst` (same mapping and size), the texels zeroed counted
    /// into the first u32 of `count` (STORAGE and TRANSFER_DST usage; reset here).
    pub fn record(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        count: &Buffer,
    ) -> Result<()> {
        use crate::abi::{binding, push::SanitizePush};
        use crate::gpu::{groups_2d, Bind};
        if (src.mapping, src.width, src.height) != (dst.mapping, dst.width, dst.height) {
            return Err(Error::Invalid(format!(
                "image '{}': a {} {}x{} map, copied into '{}', a {} {}x{} one",
                src.image.name(),
                src.mapping.name(),
                src.width,
                src.height,
                dst.image.name(),
                dst.mapping.name(),
                dst.width,
                dst.height
            )));
        }
        rec.fill_buffer(count, Self::COUNT_BYTES, 0);
        rec.discard(&dst.image);
        rec.span("sanitize", |rec| {
            rec.dispatch(
                &self.pipeline,
                &[
                    (
                        binding::SANITIZE_SRC,
                        Bind::Sampled(&src.image, &self.sampler, false),
                    ),
                    (binding::SANITIZE_DST, Bind::Storage(&dst.image)),
                    (binding::SANITIZE_COUNT, Bind::Buffer(count)),
                ],
                &SanitizePush {
                    size: [src.width, src.height],
                    pad: [0; 2],
                },
                groups_2d(src.width, src.height, src.mapping.layers()),
            )
        })?;
        poison::image(rec, PassId::Map, &dst.image, 0..1)
    }
}

/// A map clamped in place at a luminance (glsl/clamp.comp): every texel of the mapping's
/// domain whose luminance Y exceeds τ keeps L·τ/Y, so that a bake makes the clamp rule's
/// residual of a light extraction from the source it already uploaded (float64-rule twin:
/// `crate::math::lights::clamp_residual`).
pub struct LuminanceClamp {
    pipeline: crate::gpu::Pipeline,
}

impl LuminanceClamp {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<LuminanceClamp> {
        Ok(LuminanceClamp {
            pipeline: crate::gpu::Pipeline::compute(
                ctx,
                crate::abi::ShaderId::Clamp,
                &crate::abi::WORKGROUP_2D,
            )?,
        })
    }

    /// Records the clamp of level 0 of `map` at luminance `threshold` (a finite, positive
    /// τ; an infinite one clamps nothing and records nothing).
    pub fn record(&self, rec: &mut Recorder, map: &GpuEnvMap, threshold: f64) -> Result<()> {
        use crate::abi::{binding, push::ClampPush};
        use crate::gpu::{groups_2d, Bind};
        if threshold == f64::INFINITY {
            return Ok(());
        }
        if !(threshold.is_finite() && threshold > 0.0) {
            return Err(Error::Invalid(format!(
                "image '{}': a luminance clamp at {threshold}; it must be positive",
                map.image.name()
            )));
        }
        rec.span("clamp", |rec| {
            rec.dispatch(
                &self.pipeline,
                &[(binding::CLAMP_MAP, Bind::Storage(&map.image))],
                &ClampPush {
                    size: [map.width, map.height],
                    mapping: map.mapping.id(),
                    threshold: threshold as f32,
                },
                groups_2d(map.width, map.height, map.mapping.layers()),
            )
        })?;
        poison::image(rec, PassId::Map, &map.image, 0..1)
    }
}
