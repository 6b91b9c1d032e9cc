//! A plain read and write of every texel of a map: the device's floor for passes that read a
//! map once, against which their times are reported as ratios.

use crate::error::Result;
use crate::gpu::layout::{binding, WORKGROUP_2D};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::{Context, GpuEnvMap, Sampler, Timing};

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
        let timings = dst.fill(
            &self.ctx,
            "copying a map",
            "copy",
            &self.pipeline,
            &set,
            &push,
        )?;
        Ok((dst, timings))
    }
}
