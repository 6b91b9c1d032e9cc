//! A plain read and write of every texel of a map: the device's floor for passes that read a
//! map once, against which their times are reported as ratios.

use crate::abi::{binding, push::CopyPush, ShaderId, WORKGROUP_2D};
use crate::error::Result;
use crate::gpu::{groups_2d, Bind, Context, Pipeline, Recorder, Sampler, Timed};
use crate::passes::map::GpuEnvMap;

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

    /// Records the copy of `src` into `dst` (same mapping and size).
    pub fn record(&self, rec: &mut Recorder, src: &GpuEnvMap, dst: &GpuEnvMap) -> Result<()> {
        assert_eq!(
            (src.mapping, src.width, src.height),
            (dst.mapping, dst.width, dst.height)
        );
        rec.discard(&dst.image);
        rec.span("copy", |rec| {
            rec.dispatch(
                &self.pipeline,
                &[
                    (
                        binding::COPY_SRC,
                        Bind::Sampled(&src.image, &self.sampler, false),
                    ),
                    (binding::COPY_DST, Bind::Storage(&dst.image)),
                ],
                &CopyPush {
                    size: [src.width, src.height],
                    pad: [0; 2],
                },
                groups_2d(src.width, src.height, src.mapping.layers()),
            )
        })
    }

    /// Copies `src` into a new map of the same size; returns it and the GPU time.
    pub fn run(&self, src: &GpuEnvMap) -> Result<Timed<GpuEnvMap>> {
        let dst = GpuEnvMap::new(&self.ctx, "copy", src.mapping, src.width, src.height)?;
        Ok(self
            .ctx
            .run("copying a map", |rec| self.record(rec, src, &dst))?
            .map(|()| dst))
    }
}
