//! The records a render hands the GPU (each object's technique, data offsets and flags) and
//! the per-pass split of its timings.

use super::lights::Lit;
use super::plan::{ObjectPlan, PassKind, Plan};
use super::PassRecord;
use crate::abi::brdf::technique;
use crate::error::Result;
use crate::gpu::{Recorder, Timing};
use crate::math::brdf::Brdf;
use crate::math::split_sum::chain_norm;
use crate::passes::gbuffer::{shape_record, GpuObject};
use crate::passes::SplitSum;
use crate::scene::{Scene, SceneObject, Technique, DEFAULT_FIS_BIAS, DEFAULT_FIS_BIAS_RESIDUAL};

/// The GPU record of a scene object; `data_offset` locates its SH coefficients or its
/// prefiltered map (0 for other techniques).
pub fn object_record(o: &SceneObject, data_offset: u32) -> GpuObject {
    object_record_with(o, data_offset, 0)
}

/// [`object_record`] with the offset of the object's SH-BRDF table too (in floats).
pub fn object_record_with(o: &SceneObject, data_offset: u32, table_offset: u32) -> GpuObject {
    planned_record(o, &ObjectPlan::of(o, table_offset), data_offset)
}

/// The GPU record of object `o` planned as `p`, its data at `data_offset`.
fn planned_record(o: &SceneObject, p: &ObjectPlan, data_offset: u32) -> GpuObject {
    let mut g = shape_record(&o.shape);
    let brdf = p.brdf;
    let table_offset = p.table_offset;
    let params = brdf.params();
    let a = o.material.albedo;
    let off = data_offset as f32;
    let (tech, samples, extra) = match p.technique {
        Technique::Lookup => (technique::LOOKUP, 0, [0.0; 4]),
        Technique::Fis {
            samples,
            bias,
            rotate,
        } => (
            technique::FIS,
            samples,
            [
                bias.unwrap_or(DEFAULT_FIS_BIAS) as f32,
                0.0,
                0.0,
                rotate as u32 as f32,
            ],
        ),
        Technique::Sh { order } => (technique::SH, 0, [0.0, off, order as f32, 0.0]),
        Technique::Prefiltered { size } => {
            (technique::PREFILTERED, 0, [0.0, off, size as f32, 0.0])
        }
        Technique::Mc { .. } => (technique::MC, 0, [0.0; 4]),
        // The chain's last lod and the DFG table are set by the render (see split_record).
        Technique::SplitSum => (technique::SPLIT_SUM, 0, [0.0; 4]),
        Technique::ShBrdf { order, grid, .. } => (
            technique::SH_BRDF,
            0,
            [grid as f32, off, order as f32, table_offset as f32],
        ),
    };
    g.albedo = [a[0] as f32, a[1] as f32, a[2] as f32, tech as f32];
    g.brdf = [
        brdf.id() as f32,
        params[0] as f32,
        params[1] as f32,
        samples as f32,
    ];
    g.extra = extra;
    g
}

/// Sets a split-sum object's record: the chain's `levels`, its DFG table (`dfg_size` a side)
/// at entry `dfg_offset` of the tables, and its `taps` per pixel (brdf.w).
pub fn split_record(g: &mut GpuObject, levels: u32, dfg_offset: u32, dfg_size: u32, taps: u32) {
    g.brdf[3] = taps as f32;
    g.extra = [
        levels.saturating_sub(1) as f32,
        dfg_offset as f32,
        dfg_size as f32,
        0.0,
    ];
}

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
/// flags by which the shader adds back the lights `lit` holds. `chain_levels` is the
/// split-sum chain's.
pub(super) fn gpu_objects(
    scene: &Scene,
    plan: &Plan,
    lit: &Lit,
    (pre_offsets, sh_offsets): (&[u32], &[ShOffset]),
    chain_levels: Option<u32>,
) -> Vec<GpuObject> {
    let mut objects: Vec<GpuObject> = scene
        .objects
        .iter()
        .zip(&plan.objects)
        .zip(pre_offsets.iter().zip(sh_offsets))
        .map(|((o, p), (&off, sh))| match *sh {
            Some((offset, residual)) => sh_record(o, p, offset, residual),
            None => planned_record(o, p, off),
        })
        .collect();
    if let (Some(levels), Some(split)) = (chain_levels, &plan.split) {
        let ss = &scene.split_sum;
        for (g, p) in objects.iter_mut().zip(&plan.objects) {
            if let (Technique::SplitSum, Brdf::Ggx { correlated, .. }) = (p.technique, p.brdf) {
                let form = split
                    .forms
                    .iter()
                    .position(|&c| c == correlated)
                    .unwrap_or(0);
                let entries = (form * SplitSum::dfg_floats(ss.dfg_size) / 2) as u32;
                split_record(g, levels, entries, ss.dfg_size, ss.taps);
            }
        }
    }
    for ((g, p), &phong) in objects.iter_mut().zip(&plan.objects).zip(&lit.phong) {
        // extra.w = 1: the shader adds the light clusters' irradiance, or the light texels
        // under the Phong BRDF (extra.x: its lobe's scale).
        if lit.prefiltered && p.diffuse_prefiltered() {
            g.extra[3] = 1.0;
        }
        if let (true, Some(scale)) = (phong, p.lobe) {
            g.extra[0] = scale as f32;
            g.extra[3] = 1.0;
        }
    }
    if lit.dp {
        for (g, p) in objects.iter_mut().zip(&plan.objects) {
            match (p.technique, p.brdf) {
                // extra.y = 1: add the light texels; extra.z: the lobe's scale; extra.x:
                // the residual's default bias where the scene sets none.
                (Technique::Fis { bias, .. }, _) => {
                    if let Some(scale) = p.lobe {
                        g.extra[1] = 1.0;
                        g.extra[2] = scale as f32;
                        g.extra[0] = bias.unwrap_or(DEFAULT_FIS_BIAS_RESIDUAL) as f32;
                    }
                }
                // extra.w = 1/∫K at the material's α.
                (Technique::SplitSum, Brdf::Ggx { alpha, .. }) => {
                    g.extra[3] = (1.0 / chain_norm(alpha)) as f32;
                }
                _ => {}
            }
        }
    }
    objects
}

/// The record of an SH or SH-BRDF object: its coefficients start at `sh_offset` (in
/// coefficients); `residual` where they are the diffuse residual's, the light clusters added
/// by the shader.
fn sh_record(o: &SceneObject, p: &ObjectPlan, sh_offset: u32, residual: bool) -> GpuObject {
    let mut g = planned_record(o, p, sh_offset);
    if residual {
        // extra.w = 1: the shader adds the light clusters.
        g.extra[3] = 1.0;
    }
    g
}
