//! The dual-paraboloid MIP chain (`glsl/mip.comp`, float64 twin [`crate::math::mip`]):
//! premultiplies level 0 by each texel's solid-angle weight, then box-filters level after
//! level down to 1 × 1. Lookups divide rgb by alpha.

use crate::error::{Error, Result};
use crate::gpu::barrier::{
    cmd_image_barriers, cmd_memory_barrier, image_barrier, memory_barrier, Usage,
};
use crate::gpu::layout::{binding, WORKGROUP_2D};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{groups, Context, GpuEnvMap, Timing};
use crate::math::Mapping;

/// Push constants of `glsl/mip.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MipPush {
    /// Side of the level read.
    pub src_size: u32,
    /// Side of the level written.
    pub dst_size: u32,
    /// 0: premultiply level 0 in place; 1: filter down.
    pub mode: u32,
    /// Padding.
    pub pad: u32,
}

/// The MIP chain pass.
pub struct MipChain {
    ctx: Context,
    pipeline: Pipeline,
}

impl MipChain {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<MipChain> {
        Ok(MipChain {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::Mip, &WORKGROUP_2D)?,
        })
    }

    /// Fills every level of `dp`, a dual paraboloid with a MIP chain whose level 0 holds
    /// radiance (as [`crate::passes::Converter::run_mipped`] leaves it), ready for sampling.
    /// Returns one timing per dispatch ("mip premultiply", "mip level k").
    pub fn run(&self, dp: &GpuEnvMap) -> Result<Vec<Timing>> {
        if dp.mapping != Mapping::DualParaboloid || dp.width != dp.height {
            return Err(Error::Invalid(
                "a MIP chain is built on a square dual-paraboloid map".into(),
            ));
        }
        let levels = dp.mips();
        let sets = (0..levels)
            .map(|k| {
                let (src, dst) = (k.saturating_sub(1), k);
                DescriptorSet::new(
                    &self.ctx,
                    &self.pipeline,
                    &[
                        (binding::MIP_SRC, Bind::StorageLevel(&dp.image, src)),
                        (binding::MIP_DST, Bind::StorageLevel(&dp.image, dst)),
                    ],
                )
            })
            .collect::<Result<Vec<_>>>()?;
        let mut spans = Spans::new(&self.ctx, levels)?;
        let d = self.ctx.device();
        self.ctx.submit_and_wait("building the MIP chain", |cmd| {
            spans.reset(cmd);
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    dp.image.raw,
                    2,
                    Usage::ComputeSampled,
                    Usage::ComputeReadWrite,
                )],
            );
            for (k, set) in sets.iter().enumerate() {
                let k = k as u32;
                let size = (dp.width >> k).max(1);
                let push = MipPush {
                    src_size: if k == 0 {
                        size
                    } else {
                        (dp.width >> (k - 1)).max(1)
                    },
                    dst_size: size,
                    mode: (k > 0) as u32,
                    pad: 0,
                };
                let label = if k == 0 {
                    "mip premultiply".to_string()
                } else {
                    format!("mip level {k}")
                };
                let span = spans.begin(cmd, &label);
                self.pipeline.bind(cmd, Some(set), &push);
                let g = groups(size, WORKGROUP_2D[0]);
                // SAFETY: cmd is recording with the compute pipeline bound.
                unsafe { d.cmd_dispatch(cmd, g, groups(size, WORKGROUP_2D[1]), 2) };
                spans.end(cmd, span);
                cmd_memory_barrier(
                    d,
                    cmd,
                    memory_barrier(Usage::ComputeReadWrite, Usage::ComputeReadWrite),
                );
            }
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    dp.image.raw,
                    2,
                    Usage::ComputeReadWrite,
                    Usage::ComputeSampled,
                )],
            );
            Ok(())
        })?;
        spans.read()
    }
}
