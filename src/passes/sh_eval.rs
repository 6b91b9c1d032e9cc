//! Irradiance evaluated from SH coefficients at every texel centre of a map (Ramamoorthi &
//! Hanrahan 2001, `glsl/sh_eval.comp`, float64 twin [`crate::math::sh::eval`]).

use super::brute::FilterTarget;
use super::map::GpuEnvMap;
use crate::abi::{binding, push::ShEvalPush, ShaderId, SH_MAX_LMAX, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups, Bind, Buffer, Context, Pipeline, Recorder, Timing};
use crate::math::sh;

/// The SH evaluation pass: irradiance (or any zonal convolution whose per-band factors the
/// caller folds into the coefficients) at every texel centre of a map.
pub struct ShEvaluator {
    ctx: Context,
    pipeline: Pipeline,
}

impl ShEvaluator {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<ShEvaluator> {
        Ok(ShEvaluator {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::ShEval, &WORKGROUP_2D)?,
        })
    }

    /// Records Σ c_lm·Y_lm(d) (clamped at 0) at every texel centre d of `dst`. For
    /// irradiance, pass [`sh::irradiance_coeffs`] of the radiance, windowed or not.
    pub fn record(&self, rec: &mut Recorder, coeffs: &[[f64; 3]], dst: &GpuEnvMap) -> Result<()> {
        let lmax = (coeffs.len() as f64).sqrt() as u32 - 1;
        if sh::count(lmax) != coeffs.len() || lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "{} SH coefficients are not a full set of bands up to {SH_MAX_LMAX}",
                coeffs.len()
            )));
        }
        let data: Vec<[f32; 4]> = coeffs
            .iter()
            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
            .collect();
        let buf = Buffer::storage(rec.context(), "sh eval coefficients", &data)?;
        let push = ShEvalPush {
            dst_size: [dst.width, dst.height],
            dst_mapping: dst.mapping.id(),
            lmax,
        };
        rec.discard(&dst.image);
        rec.span("sh eval", |rec| {
            rec.dispatch(
                &self.pipeline,
                &[
                    (binding::SH_EVAL_COEFFS, Bind::Buffer(&buf)),
                    (binding::SH_EVAL_DST, Bind::Storage(&dst.image)),
                ],
                &push,
                [
                    groups(dst.width, WORKGROUP_2D[0]),
                    groups(dst.height, WORKGROUP_2D[1]),
                    dst.mapping.layers(),
                ],
            )
        })?;
        rec.keep(buf);
        Ok(())
    }

    /// Evaluates into a new `target` map and waits (see [`ShEvaluator::record`]).
    pub fn run(
        &self,
        coeffs: &[[f64; 3]],
        target: FilterTarget,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let (w, h) = target.extent();
        let dst = GpuEnvMap::new(&self.ctx, "sh irradiance", target.to, w, h)?;
        let ((), t) = self.ctx.run("evaluating SH irradiance", |rec| {
            self.record(rec, coeffs, &dst)
        })?;
        Ok((dst, t))
    }
}
