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
            },
        )?;
        Ok(GpuEnvMap {
            mapping,
            width,
            height,
            image,
        })
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
        let g = GpuEnvMap::new(ctx, "uploaded map", map.mapping, map.width, map.height)?;
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
        vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .layer_count(self.mapping.layers()),
            )
            .image_extent(vk::Extent3D {
                width: self.width,
                height: self.height,
                depth: 1,
            })
    }

    /// Reads the map back.
    pub fn download(&self, ctx: &Context) -> Result<EnvMap> {
        let n = (self.width * self.height * self.mapping.layers()) as usize;
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
                    &[self.copy_region()],
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
        let rgba: Vec<[f32; 4]> = readback.read(n);
        Ok(EnvMap::new(
            self.mapping,
            self.width,
            self.height,
            rgba.into_iter().map(|t| [t[0], t[1], t[2]]).collect(),
        ))
    }
}
