//! A plain read and write of every texel of a map: the device's floor for passes that read a
//! map once, against which their times are reported as ratios.

use crate::error::Result;
use crate::gpu::barrier::{cmd_image_barriers, image_barrier, Usage};
use crate::gpu::layout::{binding, WORKGROUP_2D};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{groups, Context, GpuEnvMap, Sampler, Timing};

/// Push constants of `glsl/copy.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CopyPush {
    /// Layer size.
    pub size: [u32; 2],
    /// Padding.
    pub pad: [u32; 2],
}

/// The copy pass.
pub struct CopyPass {
    ctx: Context,
    pipeline: Pipeline,
    sampler: Sampler,
}

impl CopyPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<CopyPass> {
        Ok(CopyPass {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::Copy, &WORKGROUP_2D)?,
            sampler: Sampler::linear_clamp(ctx, "copy sampler")?,
        })
    }

    /// Copies `src` into a new map of the same size; returns it and the GPU time.
    pub fn run(&self, src: &GpuEnvMap) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let dst = GpuEnvMap::new(&self.ctx, "copy", src.mapping, src.width, src.height)?;
        let set = DescriptorSet::new(
            &self.ctx,
            &self.pipeline,
            &[
                (
                    binding::COPY_SRC,
                    Bind::Sampled(&src.image, &self.sampler, false),
                ),
                (binding::COPY_DST, Bind::Storage(&dst.image)),
            ],
        )?;
        let push = CopyPush {
            size: [src.width, src.height],
            pad: [0; 2],
        };
        let mut spans = Spans::new(&self.ctx, 1)?;
        let d = self.ctx.device();
        let layers = src.mapping.layers();
        self.ctx.submit_and_wait("copying a map", |cmd| {
            spans.reset(cmd);
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    dst.image.raw,
                    layers,
                    Usage::Undefined,
                    Usage::ComputeWrite,
                )],
            );
            let span = spans.begin(cmd, "copy");
            self.pipeline.bind(cmd, Some(&set), &push);
            // SAFETY: cmd is recording with the compute pipeline bound.
            unsafe {
                d.cmd_dispatch(
                    cmd,
                    groups(src.width, WORKGROUP_2D[0]),
                    groups(src.height, WORKGROUP_2D[1]),
                    layers,
                )
            };
            spans.end(cmd, span);
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    dst.image.raw,
                    layers,
                    Usage::ComputeWrite,
                    Usage::ComputeSampled,
                )],
            );
            Ok(())
        })?;
        let timings = spans.read()?;
        Ok((dst, timings))
    }
}
