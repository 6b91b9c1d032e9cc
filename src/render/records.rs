//! The records a render hands the GPU (each object's technique, data offsets and flags) and
//! the per-pass split of its timings.

use super::lights::Lit;
use super::plan::{PassKind, Plan};
use super::PassRecord;
use crate::error::Result;
use crate::gpu::{Recorder, Timing};
use crate::math::brdf::Brdf;
use crate::math::split_sum::chain_norm;
use crate::passes::gbuffer::{object_record, ObjectRecord, Shading};
use crate::passes::SplitSum;
use crate::scene::{Scene, Technique, DEFAULT_FIS_BIAS_RESIDUAL};

/// Spans recorded per pass within one recording, to split its timings by pass.
pub(super) struct Marks(pub(super) Vec<(PassKind, usize, usize)>);

impl Marks {
    pub(super) fn record<R>(
        &mut self,
        rec: &mut Recorder,
        kind: PassKind,
        f: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<R> {
        let a = rec.spans();
        let r = f(rec)?;
        self.0.push((kind, a, rec.spans()));
        Ok(r)
    }

    pub(super) fn split(&self, timings: &[Timing], into: &mut Vec<PassRecord>) {
        for &(kind, a, b) in &self.0 {
            into.push(PassRecord {
                kind,
                timings: timings
                    .get(a..b)
                    .map(<[Timing]>::to_vec)
                    .unwrap_or_default(),
            });
        }
    }
}

/// Where an SH or SH-BRDF object's packed set starts (in coefficients), and whether it is
/// the diffuse residual's; `None` for other objects.
pub(super) type ShOffset = Option<(u32, bool)>;

/// The G-buffer's object records for `scene` under `plan`: each object's technique and data
/// offset (`pre_offsets`: its prefiltered map's, in texels; `sh_offsets`: an SH or SH-BRDF
/// object's packed set's, in coefficients, and whether it is the diffuse residual's), then the
/// lights `lit` holds, which the shader adds back. `chain_levels` is the split-sum chain's.
pub(super) fn gpu_objects(
    scene: &Scene,
    plan: &Plan,
    lit: &Lit,
    (pre_offsets, sh_offsets): (&[u32], &[ShOffset]),
    chain_levels: Option<u32>,
) -> Vec<ObjectRecord> {
    scene
        .objects
        .iter()
        .zip(&plan.objects)
        .zip(pre_offsets.iter().zip(sh_offsets))
        .enumerate()
        .map(|(i, ((o, p), (&pre, sh)))| {
            let offset = sh.map_or(pre, |(offset, _)| offset);
            let mut shading = o.material.shading(offset, p.table_offset);
            let phong = lit.phong.get(i).copied().unwrap_or(false);
            match &mut shading {
                // The residual's SH plus the light clusters.
                Shading::Sh { lights, .. } => *lights = sh.is_some_and(|(_, residual)| residual),
                // The residual's irradiance map plus the light clusters, or its Phong map plus
                // the light texels under the Phong lobe.
                Shading::Prefiltered { lights, .. } => {
                    if lit.prefiltered && p.diffuse_prefiltered() {
                        *lights = Some(0.0);
                    }
                    if let (true, Some(scale)) = (phong, p.lobe) {
                        *lights = Some(scale as f32);
                    }
                }
                // The residual's chain plus the light texels under the BRDF, at the residual's
                // default bias where the scene sets none.
                Shading::Fis {
                    lod_bias, lights, ..
                } => {
                    if let (true, Some(scale), Technique::Fis { bias, .. }) =
                        (lit.dp, p.lobe, p.technique)
                    {
                        *lights = Some(scale as f32);
                        *lod_bias = bias.unwrap_or(DEFAULT_FIS_BIAS_RESIDUAL) as f32;
                    }
                }
                Shading::SplitSum {
                    last_lod,
                    dfg_offset,
                    dfg_size,
                    taps,
                    lights,
                } => {
                    if let (Some(levels), Some(split), Brdf::Ggx { correlated, .. }) =
                        (chain_levels, &plan.split, p.brdf)
                    {
                        let ss = &scene.split_sum;
                        let form = split
                            .forms
                            .iter()
                            .position(|&c| c == correlated)
                            .unwrap_or(0);
                        *last_lod = levels.saturating_sub(1) as f32;
                        *dfg_offset = (form * SplitSum::dfg_floats(ss.dfg_size) / 2) as u32;
                        *dfg_size = ss.dfg_size;
                        *taps = ss.taps;
                    }
                    // The light texels under the chain's kernel, times 1/∫K at the material's α.
                    if let (true, Brdf::Ggx { alpha, .. }) = (lit.dp, p.brdf) {
                        *lights = Some((1.0 / chain_norm(alpha)) as f32);
                    }
                }
                _ => {}
            }
            object_record(&o.shape, o.material.albedo, &p.brdf, shading)
        })
        .collect()
}
