//! Environment maps resident on the GPU as RGBA32F 2D array images (cube-compatible for cubes).
//! At rest an image is in `SHADER_READ_ONLY_OPTIMAL`; passes leave their outputs so.

use super::barrier::{
    cmd_image_barriers, cmd_memory_barrier, image_barrier, memory_barrier, Usage,
};
use super::context::Context;
use super::groups;
use super::layout::WORKGROUP_2D;
use super::pipeline::{DescriptorSet, Pipeline};
use super::resources::{Buffer, Image, ImageDesc};
use super::timing::{Spans, Timing};
use crate::envmap::EnvMap;
use crate::error::{Error, Result};
use crate::math::Mapping;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Texel format of maps on the GPU: float32 keeps a 10⁵ sun exact (half floats overflow at
/// 65504).
pub const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// An environment map on the GPU.
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

impl GpuEnvMap {
    /// An uninitialised map for a pass to write (storage + sampled + transfer source).
    pub fn new(
        ctx: &Context,
        name: &str,
        mapping: Mapping,
        width: u32,
        height: u32,
    ) -> Result<GpuEnvMap> {
        GpuEnvMap::with_usage(
            ctx,
            name,
            mapping,
            width,
            height,
            vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_SRC
                | vk::ImageUsageFlags::TRANSFER_DST,
        )
    }

    /// An uninitialised map with the given usage (transfer source is always added, for
    /// [`GpuEnvMap::download`]).
    pub fn with_usage(
        ctx: &Context,
        name: &str,
        mapping: Mapping,
        width: u32,
        height: u32,
        usage: vk::ImageUsageFlags,
    ) -> Result<GpuEnvMap> {
        GpuEnvMap::create(ctx, name, mapping, (width, height, 1), usage)
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
        let mips = 32 - width.max(height).max(1).leading_zeros();
        GpuEnvMap::create(
            ctx,
            name,
            mapping,
            (width, height, mips),
            vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_DST,
        )
    }

    fn create(
        ctx: &Context,
        name: &str,
        mapping: Mapping,
        (width, height, mips): (u32, u32, u32),
        usage: vk::ImageUsageFlags,
    ) -> Result<GpuEnvMap> {
        if width == 0 || height == 0 {
            return Err(Error::Invalid(format!(
                "{name}: a map needs a non-zero size"
            )));
        }
        let image = Image::new(
            ctx,
            name,
            ImageDesc {
                width,
                height,
                layers: mapping.layers(),
                format: FORMAT,
                usage: usage | vk::ImageUsageFlags::TRANSFER_SRC,
                cube: mapping == Mapping::Cube,
                mips,
            },
        )?;
        Ok(GpuEnvMap {
            mapping,
            width,
            height,
            image,
        })
    }

    /// Its MIP levels.
    pub fn mips(&self) -> u32 {
        self.image.desc().mips
    }

    /// Records one timed dispatch of `pipeline` over every texel of every layer of this map
    /// (2D workgroups of [`WORKGROUP_2D`]), with the barriers that take it from undefined to
    /// written to ready for sampling; submits, waits, and returns the span's time.
    pub(crate) fn fill<P: bytemuck::Pod>(
        &self,
        ctx: &Context,
        what: &'static str,
        label: &str,
        pipeline: &Pipeline,
        set: &DescriptorSet,
        push: &P,
    ) -> Result<Vec<Timing>> {
        let mut spans = Spans::new(ctx, 1)?;
        let d = ctx.device();
        let layers = self.mapping.layers();
        ctx.submit_and_wait(what, |cmd| {
            spans.reset(cmd);
            let before = image_barrier(
                self.image.raw,
                layers,
                Usage::Undefined,
                Usage::ComputeWrite,
            );
            cmd_image_barriers(d, cmd, &[before]);
            let span = spans.begin(cmd, label);
            pipeline.bind(cmd, Some(set), push);
            let (gx, gy) = (
                groups(self.width, WORKGROUP_2D[0]),
                groups(self.height, WORKGROUP_2D[1]),
            );
            // SAFETY: cmd is recording with a compute pipeline bound.
            unsafe { d.cmd_dispatch(cmd, gx, gy, layers) };
            spans.end(cmd, span);
            let after = image_barrier(
                self.image.raw,
                layers,
                Usage::ComputeWrite,
                Usage::ComputeSampled,
            );
            cmd_image_barriers(d, cmd, &[after]);
            Ok(())
        })?;
        spans.read()
    }

    /// Uploads a map. Texels must be finite and non-negative (what [`crate::io::load`]
    /// guarantees); anything else is refused so that no pass ever sees or makes NaN.
    pub fn upload(ctx: &Context, map: &EnvMap) -> Result<GpuEnvMap> {
        GpuEnvMap::upload_into(ctx, map, false)
    }

    /// As [`GpuEnvMap::upload`], into level 0 of a map with a full MIP chain (the other
    /// levels undefined, for a pass to fill).
    pub fn upload_mipped(ctx: &Context, map: &EnvMap) -> Result<GpuEnvMap> {
        GpuEnvMap::upload_into(ctx, map, true)
    }

    fn upload_into(ctx: &Context, map: &EnvMap, mips: bool) -> Result<GpuEnvMap> {
        if let Some(k) = map
            .texels
            .iter()
            .position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0))
        {
            return Err(Error::Invalid(format!(
                "texel {k} of the {} map is {:?}; radiance must be finite and non-negative",
                map.mapping.name(),
                map.texels[k]
            )));
        }
        let g = if mips {
            GpuEnvMap::with_mips(ctx, "uploaded map", map.mapping, map.width, map.height)?
        } else {
            GpuEnvMap::new(ctx, "uploaded map", map.mapping, map.width, map.height)?
        };
        let rgba: Vec<[f32; 4]> = map.texels.iter().map(|t| [t[0], t[1], t[2], 1.0]).collect();
        let bytes = (rgba.len() * 16) as u64;
        let mut staging = Buffer::new(
            ctx,
            "upload staging",
            bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(&rgba);
        let d = ctx.device();
        let layers = map.layers();
        ctx.submit_and_wait("uploading a map", |cmd| {
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    g.image.raw,
                    layers,
                    Usage::Undefined,
                    Usage::TransferDst,
                )],
            );
            let region = g.copy_region();
            // SAFETY: cmd is recording; buffer and image are live and large enough.
            unsafe {
                d.cmd_copy_buffer_to_image(
                    cmd,
                    staging.raw,
                    g.image.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                )
            };
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    g.image.raw,
                    layers,
                    Usage::TransferDst,
                    Usage::ComputeSampled,
                )],
            );
            Ok(())
        })?;
        Ok(g)
    }

    fn copy_region(&self) -> vk::BufferImageCopy {
        self.level_region(0)
    }

    fn level_region(&self, level: u32) -> vk::BufferImageCopy {
        let (w, h) = self.level_size(level);
        vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .mip_level(level)
                    .layer_count(self.mapping.layers()),
            )
            .image_extent(vk::Extent3D {
                width: w,
                height: h,
                depth: 1,
            })
    }

    /// The size of MIP level `level`.
    pub fn level_size(&self, level: u32) -> (u32, u32) {
        ((self.width >> level).max(1), (self.height >> level).max(1))
    }

    /// Reads the map back.
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
        assert!(level < self.mips(), "level {level} of {}", self.mips());
        let (w, h) = self.level_size(level);
        let n = (w * h * self.mapping.layers()) as usize;
        let readback = Buffer::new(
            ctx,
            "download staging",
            (n * 16) as u64,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let d = ctx.device();
        let layers = self.mapping.layers();
        ctx.submit_and_wait("downloading a map", |cmd| {
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    self.image.raw,
                    layers,
                    Usage::ComputeSampled,
                    Usage::TransferSrc,
                )],
            );
            // SAFETY: cmd is recording; image and buffer are live and large enough.
            unsafe {
                d.cmd_copy_image_to_buffer(
                    cmd,
                    self.image.raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    readback.raw,
                    &[self.level_region(level)],
                )
            };
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    self.image.raw,
                    layers,
                    Usage::TransferSrc,
                    Usage::ComputeSampled,
                )],
            );
            cmd_memory_barrier(d, cmd, memory_barrier(Usage::TransferDst, Usage::HostRead));
            Ok(())
        })?;
        Ok(readback.read(n))
    }
}
