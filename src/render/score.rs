//! How a technique is scored (`envlight report`, the benchmarks): the sphere scene rendered,
//! the pixels scored, the errors reported, and the references: the exact texel sums (no
//! noise) or the Monte Carlo reference, the mean of 16 renders, with its own noise.

use crate::error::Result;
use crate::math::brdf::Brdf;
use crate::math::camera::{trace, Camera, Shape};
use crate::math::exact::{ExactFilter, Query};
use crate::passes::{ExactShader, GpuEnvMap};
use crate::render::Renderer;
use crate::scene::{Material, Scene, SceneObject, SplitSumSettings, Technique};
use crate::EnvMap;
use glam::{DMat3, DVec3};

/// The report's scene: `brdf` on a unit sphere at the origin under technique `t`, seen by
/// `cam`, with the FIS paraboloid size `dp`, the MC seed and split-sum settings given.
pub fn scene(
    cam: Camera,
    brdf: Brdf,
    t: Technique,
    dp: Option<u32>,
    seed: u32,
    split: SplitSumSettings,
) -> Scene {
    let object = SceneObject {
        shape: Shape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        },
        material: Material {
            kind: brdf,
            albedo: [1.0; 3],
            technique: Some(t),
        },
    };
    let mut sc = Scene::new(cam, vec![object]);
    sc.fis.size = dp;
    sc.split_sum = split;
    sc.mc.seed = seed;
    sc
}

/// Pixels that see the sphere away from its silhouette, with their tile (8 × 8 pixels).
pub fn sphere_pixels(cam: &Camera) -> Vec<(usize, u32)> {
    let tiles_x = cam.width.div_ceil(8);
    let sphere = [Shape::Sphere {
        center: [0.0; 3],
        radius: 1.0,
    }];
    let mut v = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            if trace(&sphere, o, d).is_some_and(|h| h.margin >= 1e-3) {
                v.push(((j * cam.width + i) as usize, (j / 8) * tiles_x + i / 8));
            }
        }
    }
    v
}

/// (relative RMS, mean bias, worst tile) of `a` against `m` over `pixels`, all channels; tiles
/// with fewer than 16 sphere pixels are left out of the worst.
pub fn errors(a: &EnvMap, m: &EnvMap, pixels: &[(usize, u32)]) -> (f64, f64, f64) {
    let (mut se, mut sm2, mut sa, mut sm) = (0.0, 0.0, 0.0, 0.0);
    let mut tiles: std::collections::BTreeMap<u32, (f64, f64, u32)> = Default::default();
    for &(k, tile) in pixels {
        let t = tiles.entry(tile).or_default();
        for ch in 0..3 {
            let (x, y) = (a.texels[k][ch] as f64, m.texels[k][ch] as f64);
            se += (x - y).powi(2);
            sm2 += y * y;
            sa += x;
            sm += y;
            t.0 += x;
            t.1 += y;
        }
        t.2 += 1;
    }
    let worst = tiles
        .values()
        .filter(|t| t.2 >= 16 && t.1 > 0.0)
        .map(|t| (t.0 - t.1).abs() / t.1)
        .fold(0.0, f64::max);
    ((se / sm2).sqrt(), (sa - sm) / sm, worst)
}

/// Independent Monte Carlo renders a [`truth`] reference is the mean of.
pub const REPLICAS: u32 = 16;

/// The Monte Carlo reference frame of `brdf` on the sphere: `2 × samples` samples a pixel,
/// drawn as [`REPLICAS`] independent MIS renders (seeds 1 …) of `2 × samples / REPLICAS`
/// each, rounded up. Their mean is the reference; its noise is the relative RMS standard
/// error of that mean, from the replicas' spread at each pixel (`sqrt(Σ s² / K / Σ mean²)`
/// over the scored pixels and channels). Two renders would give one sample of spread per
/// pixel, no estimate at a sharp lobe on a sun probe, where a few pixels carry the error:
/// across 16 independent pairs their half difference read 0.17–11.9× their error.
pub fn truth(
    renderer: &Renderer,
    cam: Camera,
    brdf: Brdf,
    dp: Option<u32>,
    split: SplitSumSettings,
    samples: u32,
    env: &EnvMap,
) -> Result<(EnvMap, f64)> {
    let each = (2 * samples).div_ceil(REPLICAS).max(1);
    let t = Technique::Mc {
        samples: each,
        error: None,
    };
    let mut frames = Vec::with_capacity(REPLICAS as usize);
    for seed in 1..=REPLICAS {
        let r = renderer.render(&scene(cam, brdf, t, dp, seed, split), env)?;
        frames.push(r.frame);
    }
    let mean = mean_of(&frames);
    let noise = spread_noise(&frames, &mean, &sphere_pixels(&cam));
    Ok((mean, noise))
}

/// The texel-wise mean of frames of one size.
fn mean_of(frames: &[EnvMap]) -> EnvMap {
    let mut out = frames[0].clone();
    let k = frames.len() as f64;
    for (i, o) in out.texels.iter_mut().enumerate() {
        for (ch, x) in o.iter_mut().enumerate() {
            let sum: f64 = frames.iter().map(|f| f64::from(f.texels[i][ch])).sum();
            *x = (sum / k) as f32;
        }
    }
    out
}

/// The relative RMS standard error of `mean`, the mean of `frames`, over `pixels`: each
/// pixel's and channel's sample variance across the frames over their count, summed, against
/// the sum of the mean's squares.
fn spread_noise(frames: &[EnvMap], mean: &EnvMap, pixels: &[(usize, u32)]) -> f64 {
    let k = frames.len() as f64;
    let (mut var, mut sq) = (0.0, 0.0);
    for &(p, _) in pixels {
        for ch in 0..3 {
            let m = f64::from(mean.texels[p][ch]);
            let s2: f64 = frames
                .iter()
                .map(|f| (f64::from(f.texels[p][ch]) - m).powi(2))
                .sum::<f64>()
                / (k - 1.0);
            var += s2 / k;
            sq += m * m;
        }
    }
    if sq > 0.0 {
        (var / sq).sqrt()
    } else {
        0.0
    }
}

/// The reference frame of `brdf` on the sphere with no noise: each pixel that sees it away
/// from its silhouette ([`sphere_pixels`], the ones scored) shaded by the exact sum over
/// `env`'s texels (`math::exact::ExactFilter::shade`, float64: every texel's ∫ f·cos, nothing
/// sampled; the sphere alone shadows nothing), the others black. `world_to_file` turns world
/// directions into the map's (the scene's orientation). Its own error is the texel rule's,
/// below 1e-4 of a pixel (its tests); on the host, all pixels in one pass over the map.
pub fn exact_truth(cam: &Camera, brdf: Brdf, env: &EnvMap, world_to_file: DMat3) -> EnvMap {
    let (at, queries) = sphere_queries(cam);
    let queries: Vec<Query> = queries
        .into_iter()
        .map(|(n, v)| Query::Shade { brdf, n, v })
        .collect();
    let values = ExactFilter::new(env, world_to_file.transpose()).evaluate(&queries);
    frame_of(cam, &at, &values)
}

/// The pixels [`exact_truth`] shades (their index in the frame) with their (normal, towards
/// the eye), world.
fn sphere_queries(cam: &Camera) -> (Vec<usize>, Vec<(DVec3, DVec3)>) {
    let sphere = [Shape::Sphere {
        center: [0.0; 3],
        radius: 1.0,
    }];
    let mut at = Vec::new();
    let mut queries = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            if let Some(h) = trace(&sphere, o, d).filter(|h| h.margin >= 1e-3) {
                at.push((j * cam.width + i) as usize);
                queries.push((h.normal, -d));
            }
        }
    }
    (at, queries)
}

/// A frame of the camera's size holding `values` at pixels `at`, black elsewhere.
fn frame_of(cam: &Camera, at: &[usize], values: &[[f64; 3]]) -> EnvMap {
    let mut texels = vec![[0.0f32; 3]; (cam.width * cam.height) as usize];
    for (&k, v) in at.iter().zip(values) {
        texels[k] = v.map(|x| x as f32);
    }
    EnvMap::new(crate::Mapping::LatLong, cam.width, cam.height, texels)
}

/// `count` of the (normal, view) `queries` spread over them (all where fewer): their indices
/// and their shade queries of `brdf`.
fn spread(queries: &[(DVec3, DVec3)], brdf: Brdf, count: usize) -> (Vec<usize>, Vec<Query>) {
    let step = queries.len().div_ceil(count.max(1)).max(1);
    let picked: Vec<usize> = (0..queries.len()).step_by(step).collect();
    let q = picked
        .iter()
        .map(|&k| Query::Shade {
            brdf,
            n: queries[k].0,
            v: queries[k].1,
        })
        .collect();
    (picked, q)
}

/// [`exact_truth`] on the GPU: the frame, its GPU ms, and the worst relative error of its
/// values against the float64 twin's at `checked` pixels spread over the sphere (all where
/// fewer), each against at least 1e-4 of the frame's largest value.
pub struct ExactFrame {
    /// The frame.
    pub frame: EnvMap,
    /// GPU milliseconds of the sums.
    pub ms: f64,
    /// Worst relative error of the checked pixels against the float64 twin.
    pub twin: f64,
    /// How many pixels were checked.
    pub checked: usize,
}

/// [`exact_truth`] of `env` (on the GPU as `gpu`) by [`ExactShader`], with `checked` of its
/// pixels taken again by the float64 twin ([`ExactFrame`]).
pub fn exact_truth_gpu(
    pass: &ExactShader,
    cam: &Camera,
    brdf: Brdf,
    (env, gpu): (&EnvMap, &GpuEnvMap),
    world_to_file: DMat3,
    checked: usize,
) -> Result<ExactFrame> {
    let (at, queries) = sphere_queries(cam);
    let got = pass.run(gpu, world_to_file, brdf, &queries)?;
    let ms = crate::gpu::total_ms(&got.timings);
    let (picked, twin) = spread(&queries, brdf, checked);
    let want = ExactFilter::new(env, world_to_file.transpose()).evaluate(&twin);
    let top = got
        .value
        .iter()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(b.abs()));
    let mut worst = 0.0f64;
    for (&k, w) in picked.iter().zip(&want) {
        for (g, w) in got.value[k].iter().zip(w) {
            let e = (g - w).abs() / w.abs().max(1e-4 * top);
            // A NaN is the worst error there is.
            worst = if e.is_nan() {
                f64::INFINITY
            } else {
                worst.max(e)
            };
        }
    }
    Ok(ExactFrame {
        frame: frame_of(cam, &at, &got.value),
        ms,
        twin: worst,
        checked: picked.len(),
    })
}

/// The exact reference's own error, estimated by refinement: the worst relative change of
/// `count` of [`exact_truth`]'s pixels spread over the sphere (all where fewer) when the
/// texel rule takes twice the cells per lobe scale (its Gauss cells converge as the fourth
/// power of their size, so the change bounds the error at the rule's own), each against at
/// least 1e-4 of `frame`'s largest value. `frame` is the reference found (either twin).
pub fn exact_own_error(
    cam: &Camera,
    brdf: Brdf,
    env: &EnvMap,
    world_to_file: DMat3,
    frame: &EnvMap,
    count: usize,
) -> f64 {
    let (at, queries) = sphere_queries(cam);
    let (picked, q) = spread(&queries, brdf, count);
    let per_width = 2.0 * crate::math::exact::PER_WIDTH;
    let refined = ExactFilter::new(env, world_to_file.transpose()).evaluate_with(&q, per_width);
    let top = frame
        .texels
        .iter()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(f64::from(b).abs()));
    let mut worst = 0.0f64;
    for (&k, r) in picked.iter().zip(&refined) {
        for (g, r) in frame.texels[at[k]].iter().zip(r) {
            let e = (f64::from(*g) - r).abs() / r.abs().max(1e-4 * top);
            worst = if e.is_nan() {
                f64::INFINITY
            } else {
                worst.max(e)
            };
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_measure_rms_bias_and_tiles() {
        let m = EnvMap::new(crate::Mapping::LatLong, 8, 8, vec![[1.0; 3]; 64]);
        let mut a = m.clone();
        for t in &mut a.texels[..32] {
            *t = [1.5; 3];
        }
        let pixels: Vec<(usize, u32)> = (0..64).map(|k| (k, (k / 32) as u32)).collect();
        let (rms, bias, tile) = errors(&a, &m, &pixels);
        assert!((rms - (0.25f64 * 32.0 / 64.0).sqrt()).abs() < 1e-12);
        assert!((bias - 0.25).abs() < 1e-12);
        assert!((tile - 0.5).abs() < 1e-12);
    }

    /// The exact reference's own error by refinement tracks its error: on a synthetic sky
    /// with a sun 10⁵ × it, a sharp GGX lobe on a coarse map (the rule's hard case), the
    /// estimate is positive and within a factor 3 of the rule's change from 4 to 16 cells per
    /// lobe scale at the same pixels (Gauss cells converge as the fourth power: 4 → 8 holds
    /// most of it); an estimate that did not refine would be 0.
    #[test]
    fn the_exact_sums_own_error_is_estimated_by_refinement() {
        let sky = crate::math::synth::Sky::default();
        let env = EnvMap::from_fn(crate::Mapping::LatLong, 128, 64, 1, |d| sky.radiance(d));
        let cam = crate::math::camera::sphere_camera(12);
        let brdf = Brdf::Ggx {
            alpha: 0.05,
            correlated: true,
        };
        let w2f = DMat3::IDENTITY;
        let frame = exact_truth(&cam, brdf, &env, w2f);
        let own = exact_own_error(&cam, brdf, &env, w2f, &frame, 1000);
        let (at, queries) = sphere_queries(&cam);
        let q: Vec<Query> = queries
            .iter()
            .map(|&(n, v)| Query::Shade { brdf, n, v })
            .collect();
        let fine = ExactFilter::new(&env, w2f).evaluate_with(&q, 16.0);
        let top = frame.texels.iter().flatten().fold(0.0f32, |a, &b| a.max(b)) as f64;
        let truth_err = at
            .iter()
            .zip(&fine)
            .flat_map(|(&k, f)| (0..3).map(move |c| (k, f[c], c)))
            .map(|(k, f, c)| (f64::from(frame.texels[k][c]) - f).abs() / f.abs().max(1e-4 * top))
            .fold(0.0, f64::max);
        eprintln!("own error estimate {own:.2e}, against 16 cells a scale {truth_err:.2e}");
        assert!(own > 0.0 && truth_err > 0.0);
        assert!(
            own <= 3.0 * truth_err && truth_err <= 3.0 * own,
            "{own} vs {truth_err}"
        );
    }
}
