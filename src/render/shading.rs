//! The shading stage: the SH coefficients each object reads (read back from the projection),
//! the Monte Carlo accumulation, and the draw that shades every pixel.

use super::inputs::Inputs;
use super::lights::Lit;
use super::plan::PassKind;
use super::records::{sh_record, Marks};
use super::{Job, PassRecord};
use crate::error::{Error, Result};

use crate::math::envmap::EnvMap;
use crate::math::sh::Window;
use crate::math::{sh, Mapping};
use crate::passes::gbuffer::{target, GBuffer, GpuObject};
use crate::passes::mc::{McEnv, McOptions, McResult};
use crate::passes::shade::{Rotation, ShadeInputs};
use crate::passes::{Converter, MonteCarlo, ShCoefficients, Shade};
use crate::scene::Technique;

/// Each SH object's coefficients, concatenated (with Â_l folded in for SH irradiance), and
/// remarks where an SH-BRDF object's lighting rings negative. Rewrites the G-buffer's records
/// of SH objects (`objects`) with their coefficients' offsets.
pub(super) fn sh_coefficients(
    job: &Job<'_>,
    inputs: &Inputs,
    lit: &Lit,
    objects: &[GpuObject],
    gbuf: &mut GBuffer,
) -> (Vec<[f64; 3]>, Vec<String>) {
    let mut sh_coeffs: Vec<[f64; 3]> = Vec::new();
    let mut ringing = Vec::new();
    let Some(out) = &inputs.sh_out else {
        return (sh_coeffs, ringing);
    };
    let flat: Vec<f32> = out.read(sh::count(job.plan.lmax) * 3);
    let c = ShCoefficients::from_f32(job.plan.lmax, &flat).coeffs;
    // The residual's: the whole map's less the light texels'.
    let c_res: Option<Vec<[f64; 3]>> = lit.sh_coeffs.as_ref().map(|l| {
        c.iter()
            .zip(l)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
            .collect()
    });
    let mut objects = objects.to_vec();
    let planned = job.scene.objects.iter().zip(&job.plan.objects);
    for (k, (o, p)) in planned.enumerate() {
        let offset = sh_coeffs.len() as u32;
        match p.technique {
            Technique::Sh { order } => {
                objects[k] = sh_record(o, p, offset, c_res.is_some());
                let c = c_res.as_ref().unwrap_or(&c);
                sh_coeffs.extend(sh::irradiance_coeffs(&c[..sh::count(order)]));
            }
            Technique::ShBrdf { order, window, .. } => {
                objects[k] = sh_record(o, p, offset, false);
                let w = match window {
                    Some(width) => Window::Hanning { width },
                    None => Window::None,
                };
                let lighting = w.apply(&c[..sh::count(order)]);
                let neg = sh::negativity(&lighting, &ringing_directions());
                if neg.fraction > 0.0 {
                    ringing.push(format!(
                        "ringing: object {k}'s order-{order} lighting ({w:?}) is negative \
                         on {:.1}% of the sphere, down to {:.2}% of its mean",
                        100.0 * neg.fraction,
                        100.0 * neg.worst
                    ));
                }
                sh_coeffs.extend(lighting);
            }
            _ => {}
        }
    }
    gbuf.objects.write(&objects);
    (sh_coeffs, ringing)
}

/// Directions on which SH lighting's ringing is measured: a 64 × 32 lat-long grid's centres.
fn ringing_directions() -> Vec<glam::DVec3> {
    let (w, h) = (64u32, 32u32);
    (0..w * h)
        .map(|k| {
            Mapping::LatLong.coord_to_dir(crate::math::Coord {
                layer: 0,
                u: ((k % w) as f64 + 0.5) / w as f64,
                v: ((k / w) as f64 + 0.5) / h as f64,
            })
        })
        .collect()
}

/// The Monte Carlo accumulation for every MC material at the plan's budget, where there is
/// one; its passes' times go to `records`.
pub(super) fn monte_carlo(
    job: &Job<'_>,
    (converter, mc_pass): (&Converter, &MonteCarlo),
    inputs: &Inputs,
    gbuf: &GBuffer,
    records: &mut Vec<PassRecord>,
) -> Result<Option<McResult>> {
    let Some((samples, error)) = job.plan.mc else {
        return Ok(None);
    };
    let (mc_env, t) = McEnv::for_map(job.ctx, converter, job.env, &inputs.env, &job.orientation)?;
    if !t.is_empty() {
        records.push(PassRecord {
            kind: PassKind::LatLong,
            timings: t,
        });
    }
    let mc = &job.scene.mc;
    let (res, t) = mc_pass.run(
        gbuf,
        &mc_env,
        &McOptions {
            samples,
            target_error: error,
            mis: mc.mis,
            seed: mc.seed,
            shadows: job.scene.shadows,
            per_frame: mc.per_frame,
        },
    )?;
    records.push(PassRecord {
        kind: PassKind::MonteCarlo,
        timings: t,
    });
    Ok(Some(res))
}

/// What the draw reads besides the G-buffer.
pub(super) struct Shading<'a> {
    pub sh: &'a [[f64; 3]],
    pub mc: Option<&'a McResult>,
    pub sh_rotation: Rotation,
}

/// Shades every pixel of `gbuf` with `shade` (once `shade_built` returns: its pipeline builds
/// meanwhile) and reads the frame back; a pixel that is not finite is an error.
pub(super) fn shade(
    job: &Job<'_>,
    shade: &Shade,
    (inputs, lit, gbuf): (&Inputs, &Lit, &GBuffer),
    with: Shading<'_>,
    shade_built: impl FnOnce() -> Result<()>,
    records: &mut Vec<PassRecord>,
) -> Result<EnvMap> {
    let frame = target(job.ctx, "shaded frame", gbuf.width, gbuf.height)?;
    let inputs = ShadeInputs {
        env: &inputs.env,
        orientation: job.orientation,
        sh: (!with.sh.is_empty()).then_some(with.sh),
        dp: inputs.dp.as_ref(),
        prefiltered: inputs.pre_buffer.as_ref(),
        mc: with.mc.map(|m| (&m.accum, m.samples)),
        brdf_sh: inputs.tables.as_ref(),
        sh_rotation: with.sh_rotation,
        split: inputs.split.as_ref().map(|s| (&s.0, &s.1)),
        shadows: job.scene.shadows,
        lights: lit.gpu.as_ref(),
        footprint: super::plan::footprint_of(job.scene, inputs.dp.is_some(), lit.dp),
    };
    // The pipeline built from the plan's code is the one the draw takes.
    debug_assert_eq!(
        crate::passes::shade::code_mask(&inputs, gbuf),
        crate::passes::shade::code_bits(&job.plan.code)
    );
    shade_built()?;
    let mut marks = Marks(Vec::new());
    let (readback, t) = job.ctx.run("rendering: shading", |rec| {
        marks.record(rec, PassKind::Shade, |rec| {
            shade.record(rec, gbuf, &inputs, &frame)
        })?;
        frame.record_download(rec, 0)
    })?;
    marks.split(&t, records);
    let frame = EnvMap::new(
        Mapping::LatLong,
        gbuf.width,
        gbuf.height,
        readback
            .read()
            .into_iter()
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
    );
    if let Some(k) = frame
        .texels
        .iter()
        .position(|t| t.iter().any(|c| !c.is_finite()))
    {
        return Err(Error::Invalid(format!(
            "pixel ({}, {}) of the frame is not finite: {:?}",
            k as u32 % frame.width,
            k as u32 / frame.width,
            frame.texels[k]
        )));
    }
    Ok(frame)
}
