//! The shading stage: where each SH object's coefficients sit (packed on the GPU from the
//! projection), the Monte Carlo accumulation, and the draw that shades every pixel.

use super::inputs::{window_of, Inputs};
use super::lights::Lit;
use super::plan::PassKind;
use super::records::Marks;
use super::{Job, PassRecord};
use crate::error::{Error, Result};
use crate::gpu::{Recorder, Timed};

use crate::math::envmap::EnvMap;
use crate::math::{sh, Mapping};
use crate::passes::gbuffer::{target, GBuffer};
use crate::passes::map::Readback;
use crate::passes::mc::{McEnv, McOptions, McResult};
use crate::passes::shade::{Rotation, ShCoeffs, ShadeInputs};
use crate::passes::GpuEnvMap;
use crate::passes::{Converter, MonteCarlo, Shade};
use crate::scene::Technique;

/// Remarks where an SH-BRDF object's lighting, the map's radiance coefficients `c` windowed,
/// rings negative.
pub(super) fn ringing_notes(job: &Job<'_>, c: &[[f64; 3]]) -> Vec<String> {
    let mut ringing = Vec::new();
    for (k, p) in job.plan.objects.iter().enumerate() {
        let Technique::ShBrdf { order, window, .. } = p.technique else {
            continue;
        };
        let w = window_of(window);
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
    }
    ringing
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
    (env, env_gpu): (&EnvMap, &GpuEnvMap),
    gbuf: &GBuffer,
    records: &mut Vec<PassRecord>,
) -> Result<Option<McResult>> {
    let Some((samples, error)) = job.plan.mc else {
        return Ok(None);
    };
    let Timed {
        value: mc_env,
        timings: t,
    } = McEnv::for_map(job.ctx, converter, env, env_gpu, &job.orientation)?;
    if !t.is_empty() {
        records.push(PassRecord {
            kind: PassKind::LatLong,
            timings: t,
        });
    }
    let mc = &job.scene.mc;
    let Timed {
        value: res,
        timings: t,
    } = mc_pass.run(
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

/// What the draw reads besides the G-buffer and the inputs.
pub(super) struct Shading<'a> {
    pub mc: Option<&'a McResult>,
    pub sh_rotation: Rotation,
}

/// A draw before it is recorded: what it reads.
pub(super) struct Draw<'a> {
    pub inputs: ShadeInputs<'a>,
}

/// The draw that shades every pixel of `gbuf`, reading `env`, `inputs` and `lit`'s lights.
pub(super) fn draw<'a>(
    job: &Job<'a>,
    (inputs, lit, gbuf): (&'a Inputs, &'a Lit, &GBuffer),
    env: &'a GpuEnvMap,
    with: Shading<'a>,
) -> Result<Draw<'a>> {
    let inputs = ShadeInputs {
        env,
        orientation: job.orientation,
        sh: inputs.sh_packed.as_ref().map(ShCoeffs::Gpu),
        dp: inputs.dp.as_ref(),
        prefiltered: inputs.pre_buffer.as_ref(),
        mc: with.mc.map(|m| (&m.accum, m.samples)),
        brdf_sh: inputs.tables.as_ref(),
        sh_rotation: with.sh_rotation,
        split: inputs.split.as_ref().map(|s| (&s.0, &s.1)),
        shadows: job.scene.shadows,
        lights: lit.gpu.as_ref(),
        footprint: job.scene.footprint(inputs.dp.is_some(), lit.dp),
    };
    // The pipeline built from the plan's code is the one the draw takes.
    debug_assert_eq!(
        crate::passes::shade::code_mask(&inputs, gbuf),
        crate::passes::shade::code_bits(&job.plan.code)
    );
    Ok(Draw { inputs })
}

/// Records `draw` with `shade` into `frame` (a target of the G-buffer's size).
pub(super) fn record_draw(
    rec: &mut Recorder,
    marks: &mut Marks,
    shade: &Shade,
    gbuf: &GBuffer,
    draw: &Draw<'_>,
    frame: &GpuEnvMap,
) -> Result<()> {
    marks.record(rec, PassKind::Shade, |rec| {
        shade.record(rec, gbuf, &draw.inputs, frame)
    })
}

/// The frame a draw shades into, for `gbuf`.
pub(super) fn frame_target(job: &Job<'_>, gbuf: &GBuffer) -> Result<GpuEnvMap> {
    target(job.ctx, "shaded frame", gbuf.width, gbuf.height)
}

/// The shaded frame from its download (once the work has completed); a pixel that is not
/// finite is an error.
pub(super) fn frame_of(readback: &Readback, gbuf: &GBuffer) -> Result<EnvMap> {
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

/// Shades every pixel of `gbuf` with `shade` in a submission of its own (once `shade_built`
/// returns: its pipeline builds meanwhile) and reads the frame back.
pub(super) fn shade(
    job: &Job<'_>,
    shade: &Shade,
    (inputs, lit, gbuf): (&Inputs, &Lit, &GBuffer),
    env: &GpuEnvMap,
    with: Shading<'_>,
    shade_built: impl FnOnce() -> Result<()>,
    records: &mut Vec<PassRecord>,
) -> Result<EnvMap> {
    let draw = draw(job, (inputs, lit, gbuf), env, with)?;
    let frame = frame_target(job, gbuf)?;
    shade_built()?;
    let mut marks = Marks(Vec::new());
    let Timed {
        value: readback,
        timings: t,
    } = job.ctx.run("rendering: shading", |rec| {
        record_draw(rec, &mut marks, shade, gbuf, &draw, &frame)?;
        frame.record_download(rec, 0)
    })?;
    marks.split(&t, records);
    frame_of(&readback, gbuf)
}
