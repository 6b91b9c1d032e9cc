//! Conversion of an environment map from any mapping to any other, at any resolution
//! (`glsl/convert.comp`, float64 twin [`crate::math::convert`]); strong minification first
//! reduces the source (`glsl/reduce.comp`).

use super::map::GpuEnvMap;
use crate::abi::{
    binding,
    push::{ConvertPush, ReducePush},
    ShaderId, WORKGROUP_2D,
};
use crate::error::Result;
use crate::gpu::{groups, mat3_rows, Bind, Context, Pipeline, Recorder, Sampler, Timing};
use crate::math::convert::Sampling;
use crate::math::{Mapping, Orientation};
use std::sync::OnceLock;

/// Per-call options of [`Converter::run`].
#[derive(Clone, Copy, Debug)]
pub struct ConvertOptions {
    /// Output mapping.
    pub to: Mapping,
    /// Output size: lat-long width (height is half), angular side, cube face side, or
    /// paraboloid half side.
    pub size: u32,
    /// How the source file is oriented relative to the world frame.
    pub orientation: Orientation,
    /// Samples per axis per output texel, read from the source itself; `None` picks the
    /// reduction level and the rate from the resolutions ([`Sampling::for_conversion`]).
    pub supersample: Option<u32>,
}

/// The conversion pass. Pipelines are built on first use, one per source kind.
pub struct Converter {
    ctx: Context,
    /// One pipeline per (source, destination) mapping pair, specialised on both.
    pipelines: [OnceLock<Pipeline>; 16],
    /// The reduction, one per source mapping (lat-long and cube are used).
    reduce: [OnceLock<Pipeline>; 4],
    sampler: Sampler,
}

impl Converter {
    /// Prepares the pass (no pipeline is built until a run needs it).
    pub fn new(ctx: &Context) -> Result<Converter> {
        Ok(Converter {
            ctx: ctx.clone(),
            pipelines: Default::default(),
            reduce: Default::default(),
            sampler: Sampler::linear_clamp(ctx, "convert sampler")?,
        })
    }

    fn pipeline(&self, from: Mapping, to: Mapping) -> Result<&Pipeline> {
        let cell = &self.pipelines[(4 * from.id() + to.id()) as usize];
        let id = if from == Mapping::Cube {
            ShaderId::ConvertCube
        } else {
            ShaderId::Convert2d
        };
        let spec = [WORKGROUP_2D[0], WORKGROUP_2D[1], from.id(), to.id()];
        Pipeline::compute_once(cell, &self.ctx, id, &spec)
    }

    /// How a conversion of `src` into `opts` samples: the forced rate at level 0, or
    /// [`Sampling::for_conversion`].
    pub fn sampling(src: &GpuEnvMap, opts: &ConvertOptions) -> Sampling {
        let (w, h) = opts.to.extent_for_size(opts.size);
        match opts.supersample {
            Some(ss) => Sampling::at(ss),
            None => Sampling::for_conversion((src.mapping, src.width, src.height), (opts.to, w, h)),
        }
    }

    /// Records the reduction of `src` by `factor` per axis into a new map, which the caller
    /// hands to `rec` to keep once its last use is recorded.
    fn record_reduce(&self, rec: &mut Recorder, src: &GpuEnvMap, factor: u32) -> Result<GpuEnvMap> {
        let (w, h) = (src.width / factor, src.height / factor);
        let out = GpuEnvMap::new(
            &self.ctx,
            &format!("{} reduced by {factor}", src.mapping.name()),
            src.mapping,
            w,
            h,
        )?;
        let cell = &self.reduce[src.mapping.id() as usize];
        let spec = [WORKGROUP_2D[0], WORKGROUP_2D[1], src.mapping.id()];
        let pipeline = Pipeline::compute_once(cell, &self.ctx, ShaderId::Reduce, &spec)?;
        let push = ReducePush {
            src_size: [src.width, src.height],
            dst_size: [w, h],
            factor,
            pad: [0; 3],
        };
        rec.discard(&out.image);
        rec.span(
            &format!("reduce {} by {factor}", src.mapping.name()),
            |rec| {
                rec.dispatch(
                    pipeline,
                    &[
                        (
                            binding::REDUCE_SRC,
                            Bind::Sampled(&src.image, &self.sampler, false),
                        ),
                        (binding::REDUCE_DST, Bind::Storage(&out.image)),
                    ],
                    &push,
                    [
                        groups(w, WORKGROUP_2D[0]),
                        groups(h, WORKGROUP_2D[1]),
                        src.mapping.layers(),
                    ],
                )
            },
        )?;
        Ok(out)
    }

    /// Records the conversion of `src` into `dst`, whose mapping and size must be
    /// `opts.to` at `opts.size`. `dst` may have MIP levels: only level 0 is written.
    pub fn record(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        opts: &ConvertOptions,
    ) -> Result<()> {
        let (w, h) = opts.to.extent_for_size(opts.size);
        assert_eq!(
            (dst.mapping, dst.width, dst.height),
            (opts.to, w, h),
            "the output does not match the options"
        );
        let sampling = Converter::sampling(src, opts);
        let reduced = if sampling.level > 0 {
            Some(self.record_reduce(rec, src, 1 << sampling.level)?)
        } else {
            None
        };
        let src = reduced.as_ref().unwrap_or(src);
        let ss = sampling.ss;
        let push = ConvertPush {
            world_to_file: mat3_rows(opts.orientation.checked_world_to_file()?),
            src_size: [src.width, src.height],
            dst_size: [w, h],
            src_mapping: src.mapping.id(),
            dst_mapping: opts.to.id(),
            ss,
            pad: 0,
        };
        let cube = src.mapping == Mapping::Cube;
        let pipeline = self.pipeline(src.mapping, opts.to)?;
        let label = format!(
            "convert {} -> {} {w}x{h}",
            src.mapping.name(),
            opts.to.name()
        );
        rec.discard(&dst.image);
        rec.span(&label, |rec| {
            rec.dispatch(
                pipeline,
                &[
                    (
                        binding::CONVERT_SRC,
                        Bind::Sampled(&src.image, &self.sampler, cube),
                    ),
                    (binding::CONVERT_DST, Bind::Storage(&dst.image)),
                ],
                &push,
                [
                    groups(w, WORKGROUP_2D[0]),
                    groups(h, WORKGROUP_2D[1]),
                    opts.to.layers(),
                ],
            )
        })?;
        if let Some(r) = reduced {
            rec.keep(r);
        }
        Ok(())
    }

    /// Converts `src` to `opts.to` at `opts.size`; returns the new map and the GPU time.
    pub fn run(&self, src: &GpuEnvMap, opts: &ConvertOptions) -> Result<(GpuEnvMap, Vec<Timing>)> {
        self.run_into(src, opts, false)
    }

    /// As [`Converter::run`], into a map with a full MIP chain of which only level 0 is
    /// written (for [`crate::passes::mip::MipChain`] to fill).
    pub fn run_mipped(
        &self,
        src: &GpuEnvMap,
        opts: &ConvertOptions,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        self.run_into(src, opts, true)
    }

    fn run_into(
        &self,
        src: &GpuEnvMap,
        opts: &ConvertOptions,
        mips: bool,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let (w, h) = opts.to.extent_for_size(opts.size);
        let name = format!("{} {}", opts.to.name(), opts.size);
        let dst = if mips {
            GpuEnvMap::with_mips(&self.ctx, &name, opts.to, w, h)?
        } else {
            GpuEnvMap::new(&self.ctx, &name, opts.to, w, h)?
        };
        let ((), t) = self
            .ctx
            .run("converting a map", |rec| self.record(rec, src, &dst, opts))?;
        Ok((dst, t))
    }
}
