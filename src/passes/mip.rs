//! The dual-paraboloid MIP chain (`glsl/mip.comp`, float64 twin `crate::math::mip`):
//! premultiplies level 0 by each texel's solid-angle weight, then box-filters level after
//! level down to 1 × 1. Lookups divide rgb by alpha.

use super::map::GpuEnvMap;
use crate::abi::{binding, push::MipPush, ShaderId, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups_2d, Bind, Context, Pipeline, Recorder, Timing};
use crate::math::Mapping;
use crate::passes::testing::poison::{self, PassId};

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

    /// Records the filling of every level of `dp`, a square dual paraboloid with a MIP
    /// chain whose level 0 holds radiance (as [`crate::passes::Converter::record`] leaves it).
    /// Spans: "mip premultiply", then "mip level k".
    pub fn record(&self, rec: &mut Recorder, dp: &GpuEnvMap) -> Result<()> {
        self.record_from(rec, dp, 0)
    }

    /// [`MipChain::record`] of a map whose level 0 is already premultiplied (as
    /// [`crate::passes::Converter::record_split`] writes it): levels 1 and up.
    /// Spans: "mip level k".
    pub fn record_premultiplied(&self, rec: &mut Recorder, dp: &GpuEnvMap) -> Result<()> {
        self.record_from(rec, dp, 1)
    }

    fn record_from(&self, rec: &mut Recorder, dp: &GpuEnvMap, first: u32) -> Result<()> {
        if dp.mapping != Mapping::DualParaboloid || dp.width != dp.height {
            return Err(Error::Invalid(
                "a MIP chain is built on a square dual-paraboloid map".into(),
            ));
        }
        for k in first..dp.mips() {
            let size = (dp.width >> k).max(1);
            let push = MipPush {
                src_size: (dp.width >> k.saturating_sub(1)).max(1),
                dst_size: size,
                mode: (k > 0) as u32,
                pad: 0,
            };
            let label = if k == 0 {
                "mip premultiply".to_string()
            } else {
                format!("mip level {k}")
            };
            rec.span(&label, |rec| {
                rec.dispatch(
                    &self.pipeline,
                    &[
                        (
                            binding::MIP_SRC,
                            Bind::StorageLevel(&dp.image, k.saturating_sub(1)),
                        ),
                        (binding::MIP_DST, Bind::StorageLevel(&dp.image, k)),
                    ],
                    &push,
                    groups_2d(size, size, 2),
                )
            })?;
        }
        poison::image(rec, PassId::Mip, &dp.image, 0..dp.mips())
    }

    /// Fills every level of `dp` (see [`MipChain::record`]) and waits; returns one timing per
    /// dispatch.
    pub fn run(&self, dp: &GpuEnvMap) -> Result<Vec<Timing>> {
        Ok(self
            .ctx
            .run("building the MIP chain", |rec| self.record(rec, dp))?
            .timings)
    }
}
