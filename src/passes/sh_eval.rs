//! Irradiance evaluated from SH coefficients at every texel centre of a map (Ramamoorthi &
//! Hanrahan 2001, `glsl/sh_eval.comp`, float64 twin `crate::math::sh::eval`).

use super::brute::FilterTarget;
use super::map::GpuEnvMap;
use crate::abi::{binding, push::ShEvalPush, ShaderId, SH_MAX_LMAX, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups_2d, Bind, Buffer, Context, Pipeline, Recorder, Timed};
use crate::math::sh;
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use gpu_allocator::MemoryLocation;

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
    /// irradiance, pass `sh::irradiance_coeffs` of the radiance, windowed or not.
    pub fn record(&self, rec: &mut Recorder, coeffs: &[[f64; 3]], dst: &GpuEnvMap) -> Result<()> {
        let lmax = (coeffs.len() as f64).sqrt() as u32 - 1;
        if sh::count(lmax) != coeffs.len() || lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "{} SH coefficients are not a full set of bands up to {SH_MAX_LMAX}",
                coeffs.len()
            )));
        }
        let mut data: Vec<[f32; 4]> = coeffs
            .iter()
            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 1.0])
            .collect();
        // Nothing subtracted.
        data.resize(2 * coeffs.len(), [0.0; 4]);
        let buf = Buffer::storage(rec.context(), "sh eval coefficients", &data)?;
        self.dispatch(rec, buf, lmax, dst)
    }

    /// Records irradiance at every texel centre of `dst` from radiance coefficients the GPU
    /// holds: bands up to `lmax` at the start of `radiance` as [`ShProjector::record`] writes
    /// them (RGB f32 triples). They are copied into the evaluator's coefficients, whose alpha
    /// holds Â_l (`sh::cosine_lobe`), so no readback stands between projection and
    /// evaluation.
    ///
    /// [`ShProjector::record`]: super::ShProjector::record
    pub fn record_irradiance(
        &self,
        rec: &mut Recorder,
        radiance: &Buffer,
        lmax: u32,
        dst: &GpuEnvMap,
    ) -> Result<()> {
        self.record_irradiance_minus(rec, radiance, lmax, &[], dst)
    }

    /// [`ShEvaluator::record_irradiance`] less the irradiance coefficients `minus` (bands up
    /// to `lmax`, Â_l folded in; empty for none) before the clamp: the residual's irradiance
    /// from the whole map's coefficients and the SH of its extracted lights
    /// (`crate::math::lights::light_sh`).
    pub fn record_irradiance_minus(
        &self,
        rec: &mut Recorder,
        radiance: &Buffer,
        lmax: u32,
        minus: &[[f64; 3]],
        dst: &GpuEnvMap,
    ) -> Result<()> {
        if lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "SH order {lmax} is above the maximum, {SH_MAX_LMAX}"
            )));
        }
        let n = sh::count(lmax);
        if !minus.is_empty() && minus.len() != n {
            return Err(Error::Invalid(format!(
                "{} coefficients to subtract from order {lmax}'s {n}",
                minus.len()
            )));
        }
        let mut data = vec![[0.0f32; 4]; 2 * n];
        for l in 0..=lmax {
            for m in -(l as i32)..=(l as i32) {
                data[sh::index(l, m)][3] = sh::cosine_lobe(l) as f32;
            }
        }
        for (d, c) in data[n..].iter_mut().zip(minus) {
            *d = [c[0] as f32, c[1] as f32, c[2] as f32, 0.0];
        }
        let buf = Buffer::new(
            rec.context(),
            "sh eval coefficients (from the GPU)",
            (2 * n * 16) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::CpuToGpu,
        )?;
        let mut buf = buf;
        buf.write(&data);
        let regions: Vec<(u64, u64, u64)> = (0..n as u64).map(|k| (12 * k, 16 * k, 12)).collect();
        rec.copy_buffer_regions(radiance, &buf, &regions);
        self.dispatch(rec, buf, lmax, dst)
    }

    fn dispatch(&self, rec: &mut Recorder, buf: Buffer, lmax: u32, dst: &GpuEnvMap) -> Result<()> {
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
                groups_2d(dst.width, dst.height, dst.mapping.layers()),
            )
        })?;
        rec.keep(buf);
        poison::image(rec, PassId::ShEval, &dst.image, 0..1)
    }

    /// Evaluates into a new `target` map and waits (see [`ShEvaluator::record`]).
    pub fn run(&self, coeffs: &[[f64; 3]], target: FilterTarget) -> Result<Timed<GpuEnvMap>> {
        let (w, h) = target.extent();
        let dst = GpuEnvMap::new(&self.ctx, "sh irradiance", target.to, w, h)?;
        Ok(self
            .ctx
            .run("evaluating SH irradiance", |rec| {
                self.record(rec, coeffs, &dst)
            })?
            .map(|()| dst))
    }
}
