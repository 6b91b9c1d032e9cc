//! Split-sum shading (Karis 2013): the GPU's DFG table, prefiltered chain and shading against
//! their float64 twins, the furnace, and the technique's own error against the exact
//! integral and the Monte Carlo reference.

mod common;
#[path = "twins/split_sum.rs"]
mod twin;

use common::compare::Errors;
use common::scenes::{object, rel_rms, scene, sphere_camera, sphere_pixels, unit_sphere};
use envlight::math::brdf::{local_view, Brdf, Frame};
use envlight::math::split_sum::{self, dfg_table, prefiltered_chain, LevelSamples};
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::{mip, Mapping};
use envlight::render::Renderer;
use envlight::scene::{Scene, SplitSumSettings, Technique};
use envlight::EnvMap;

fn ggx(alpha: f64, correlated: bool) -> Brdf {
    Brdf::Ggx { alpha, correlated }
}

/// A split-sum scene of one unit sphere with `settings`.
fn split_scene(
    cam: envlight::math::camera::Camera,
    b: Brdf,
    dp: u32,
    s: SplitSumSettings,
) -> Scene {
    let mut sc = scene(
        cam,
        vec![object(unit_sphere(), b, [1.0; 3], Technique::SplitSum)],
        false,
        dp,
    );
    sc.split_sum = s;
    sc
}

/// Both Smith forms' tables, at endpoints and at texel centres, against
/// `math::split_sum::dfg_table_at`, entry by entry, absolute (A and B are fractions of 1).
/// Bound 2e-6: float32 sums of 4096 node weights each ≤ 1 (measured 1.5e-6). The two axes
/// differ by far more than that (a centres table read as endpoints fails).
#[test]
fn dfg_table_matches_its_float64_twin() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// Every level of the prefiltered chain against `math::split_sum::prefiltered_chain` reading
/// the float64 MIP chain of the same paraboloid: a smooth map, and the sky whose sun is
/// 5·10⁴ × the zenith (the hard case: a sample's lod rounds differently in float32 near a
/// level boundary, and next to the sun that moves the result most). Error relative to the
/// texel's own value, or to the level's mean where the texel is darker. Measured (printed)
/// 3.3e-7 smooth, 1.1e-6 sky; bounds 1e-5 and 2e-5 leave room for other drivers' lod
/// rounding, still far below any error of the technique.
#[test]
fn prefiltered_levels_match_their_float64_twin() {
    let ctx = common::ctx();
    twin::check_chain(&ctx);
    common::finish(ctx);
}

/// The render's split-sum pixels against `math::split_sum::shade` with the float64 chain and
/// table, on a smooth map: the chain's trilinear read and the table's bilinear one in float32.
/// Measured 1.2e-6 relative (printed); bound 1e-5. Again with `[split_sum] rough_boost = 4`
/// (level 2, 8², at 64 samples) for α 0.9, which reads mostly that level (lod 1.9), against
/// the twin chain at the same samples a level (measured 1.4e-6; a renderer that dropped the
/// option would err 1.3e-1).
#[test]
fn render_matches_its_float64_twin() {
    let ctx = common::ctx();
    {
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, smooth_env);
        let dp_size = 32;
        let dp = common::dp_f64(&env, dp_size);
        let settings = SplitSumSettings {
            size: Some(32),
            levels: 3,
            samples: 16,
            rough_boost: 1,
            bias: None,
            dfg_size: 16,
            taps: 1,
        };
        let chains = [1, 4].map(|rough_boost| {
            let samples = LevelSamples {
                base: 16,
                rough_boost,
            };
            let bias = envlight::scene::defaults::FIS_BIAS;
            (
                rough_boost,
                prefiltered_chain(&mip::chain(&dp), 32, 3, samples, bias),
            )
        });
        let cam = sphere_camera(24);
        let renderer = Renderer::new(&ctx);
        let flat = [
            (ggx(0.05, false), 1),
            (ggx(0.3, true), 1),
            (ggx(0.9, false), 1),
            (ggx(0.05, true), 8),
            (ggx(0.3, false), 4),
            (ggx(0.6, true), 16),
        ];
        let boosted = [(ggx(0.9, false), 1), (ggx(0.9, true), 1)];
        let cases =
            (flat.iter().map(|&c| (c, &chains[0]))).chain(boosted.iter().map(|&c| (c, &chains[1])));
        for ((b, taps), (rough_boost, chain)) in cases {
            let settings = SplitSumSettings {
                rough_boost: *rough_boost,
                ..settings
            };
            let Brdf::Ggx { alpha, correlated } = b else {
                unreachable!()
            };
            let table = dfg_table(16, correlated);
            // The pass alone: the chain holds the whole map (a smooth map still has texels
            // above the default extraction's 2 × the mean).
            let mut sc = split_scene(cam, b, dp_size, SplitSumSettings { taps, ..settings });
            sc.environment.lights = envlight::scene::LightsMode::None;
            let r = renderer.render(&sc, &env).unwrap();
            let mut errors = Errors::new();
            for (k, normal, d) in sphere_pixels(&cam) {
                let want = if taps == 1 {
                    split_sum::shade(chain, &table, 16, alpha, normal, -d)
                } else {
                    split_sum::shade_taps(chain, &table, 16, &b, normal, -d, taps)
                };
                for (c, (g, w)) in r.frame.texels[k].iter().zip(want).enumerate() {
                    errors.rel(*g, w, 0.0, (k, c));
                }
            }
            let worst = errors.worst();
            eprintln!(
                "{b:?} taps {taps} rough_boost {rough_boost}: worst {worst:.2e} at {:?}",
                errors.at()
            );
            assert!(
                worst < 1e-5,
                "{b:?} taps {taps} boost {rough_boost}: {worst:e}"
            );
        }
    }
    common::finish(ctx);
}

/// Under a white environment the prefiltered chain is 1 and the pixel is A + B read from the
/// table (32², the default): GGX's directional albedo (`Brdf::albedo`, float64 quadrature,
/// itself within ~1e-3) up to the table's bilinear interpolation. Measured worst (printed):
/// 1.9e-3 below 80°, 3.1e-3 beyond, both at α 0.1; bounds 1.3× those.
#[test]
fn furnace_shows_the_albedo() {
    let ctx = common::ctx();
    {
        let env = EnvMap::new(Mapping::LatLong, 16, 8, vec![[1.0; 3]; 16 * 8]);
        let cam = sphere_camera(20);
        let renderer = Renderer::new(&ctx);
        let mut bins: [Errors<usize>; 2] = [Errors::new(), Errors::new()];
        // Lobe taps are a weighted mean of the chain, normalised by their weights: 1 here.
        for (b, taps) in [
            (ggx(1e-4, false), 1),
            (ggx(0.1, true), 1),
            (ggx(0.5, false), 1),
            (ggx(1.0, true), 1),
            (ggx(0.1, false), 8),
            (ggx(0.5, true), 4),
        ] {
            let r = renderer
                .render(
                    &split_scene(
                        cam,
                        b,
                        16,
                        SplitSumSettings {
                            size: Some(16),
                            levels: 2,
                            taps,
                            ..SplitSumSettings::default()
                        },
                    ),
                    &env,
                )
                .unwrap();
            let pixels = sphere_pixels(&cam);
            let n = pixels.len();
            let mut worst = [Errors::new(), Errors::new()];
            for (k, normal, d) in pixels {
                let wo = local_view(&Frame::new(normal), -d);
                let grazing = wo.z < 80f64.to_radians().cos();
                worst[grazing as usize].abs(r.frame.texels[k][1], b.albedo(wo), k);
            }
            eprintln!(
                "{b:?} taps {taps}: {n} pixels, worst below 80° {:.1e}, beyond {:.1e}",
                worst[0].worst(),
                worst[1].worst()
            );
            assert!(n > 200);
            for (bin, w) in bins.iter_mut().zip(&worst) {
                bin.merge(w);
            }
        }
        assert!(bins[0].worst() < 2.5e-3, "below 80°: {:e}", bins[0].worst());
        assert!(bins[1].worst() < 4e-3, "beyond 80°: {:e}", bins[1].worst());
    }
    common::finish(ctx);
}

/// What users pay for split-sum: its error against the Monte Carlo reference (4096 samples
/// per pixel) on a soft probe (venice_sunset) and a sun probe (spiaggia_di_mondello, sun
/// ≈ 10⁴ × the sky), GGX α 0.1, 0.3, 0.6, default settings (7 levels, 512² chain), 256²
/// paraboloid, lights extracted (the default). Bounds at 1.3× the measured relative RMS:
/// venice 4.2%, 9.1%, 15.7%; spiaggia 5.0%, 10.8%, 29.3% (10.2%, 12.7%, 29.6% without light
/// extraction, which adds the sun at the material's α instead of lerping two levels). Most of
/// it is the n = v = r lobe at grazing views
/// (venice, pixels within 37° of the view axis: 1.8%, 3.6%, 6.8%); on the sun map α between
/// two levels also lerps two highlights of very different peaks (6 levels: 34% at α 0.1).
/// `cargo xtask lab recipes` scores every probe.
#[test]
fn split_sum_error_against_mc_on_real_probes() {
    let Some(dir) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    {
        let cam = sphere_camera(32);
        let renderer = Renderer::new(&ctx);
        let pixels = sphere_pixels(&cam);
        // (probe, α, bound)
        let cases = [
            (
                "venice_sunset_1k.hdr",
                [(0.1, 0.055), (0.3, 0.118), (0.6, 0.204)],
            ),
            (
                "spiaggia_di_mondello_1k.hdr",
                [(0.1, 0.0653), (0.3, 0.141), (0.6, 0.381)],
            ),
        ];
        let mut failures = Vec::new();
        for (file, alphas) in cases {
            let env =
                envlight::io::load(dir.join(file), &envlight::io::LoadOptions::default()).unwrap();
            for (alpha, bound) in alphas {
                let b = ggx(alpha, true);
                let ss = renderer
                    .render(&split_scene(cam, b, 256, SplitSumSettings::default()), &env)
                    .unwrap();
                let mut sc = split_scene(cam, b, 64, SplitSumSettings::default());
                sc.objects[0].material.technique = Some(Technique::Mc {
                    samples: 4096,
                    error: None,
                });
                let mc = renderer.render(&sc, &env).unwrap();
                let rms = rel_rms(&ss.frame, &mc.frame, &pixels);
                eprintln!(
                    "{file} GGX α {alpha}: split-sum vs MC 4096 spp relative RMS {:.2}% (MC's own estimate {:?})",
                    100.0 * rms,
                    mc.mc
                );
                if rms >= bound {
                    failures.push(format!("{file} α {alpha}: {rms:e}"));
                }
            }
        }
        assert!(failures.is_empty(), "{failures:?}");
    }
    common::finish(ctx);
}

/// With lights extracted (the default), on the sky whose sun is 5·10⁴ × the zenith: the
/// render's split-sum pixels against the float64 chain of the residual read as above, plus
/// the light texels at the material's α (`math::light_tree::LightTree::sum` over `chain_norm`), times
/// the same A + B. Bound 1e-4 (float32 light sums; measured: printed).
#[test]
fn render_with_lights_matches_its_float64_twin() {
    use envlight::math::brdf::local_view;
    use envlight::math::lights::{extract, prepare, ExtractOptions, LightKernel};
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, move |d| sky.radiance(d));
        let ex = extract(&env, &ExtractOptions::chain());
        assert!(!ex.lights.is_empty());
        let dp_size = 32;
        let dp = common::dp_f64_residual(&ex.residual, dp_size);
        let settings = SplitSumSettings {
            size: Some(32),
            levels: 3,
            samples: 16,
            rough_boost: 1,
            bias: None,
            dfg_size: 16,
            taps: 1,
        };
        let chain = prefiltered_chain(
            &mip::chain(&dp),
            32,
            3,
            LevelSamples::flat(16),
            envlight::scene::defaults::FIS_BIAS,
        );
        let cam = sphere_camera(24);
        let renderer = Renderer::new(&ctx);
        for b in [ggx(0.1, false), ggx(0.4, true)] {
            let Brdf::Ggx { alpha, correlated } = b else {
                unreachable!()
            };
            let tree = envlight::math::light_tree::LightTree::new(prepare(
                &env,
                &ex,
                glam::DMat3::IDENTITY,
                alpha,
            ));
            let table = dfg_table(16, correlated);
            let r = renderer
                .render(&split_scene(cam, b, dp_size, settings), &env)
                .unwrap();
            let norm = split_sum::chain_norm(alpha);
            let (mut errors, mut lit) = (Errors::new(), 0usize);
            for (k, normal, d) in sphere_pixels(&cam) {
                let v = -d;
                let base = split_sum::shade(&chain, &table, 16, alpha, normal, v);
                let rdir = 2.0 * normal.dot(v) * normal - v;
                let mu = local_view(&Frame::new(normal), v).z.clamp(0.0, 1.0);
                let ab = split_sum::dfg_lookup(&table, 16, mu, alpha);
                // The chain's own radiance, in the light sum's units.
                let chain_lum = envlight::math::envmap::luminance(base) / (ab[0] + ab[1]) * norm;
                let l = tree.sum(rdir, LightKernel::Ggx { alpha }, chain_lum);
                for c in 0..3 {
                    let want = base[c] + l[c] / norm * (ab[0] + ab[1]);
                    let g = r.frame.texels[k][c] as f64;
                    errors.rel(g, want, 0.0, (k, c));
                }
                if l[1] / norm > base[1] {
                    lit += 1;
                }
            }
            let worst = errors.worst();
            eprintln!("{b:?}: worst {worst:.2e}, {lit} pixels lit mostly by the sun");
            assert!(worst < 1e-4, "{b:?}: {worst:e}");
            assert!(lit > 5, "{lit}");
        }
        // The lobe taps recipe: its taps over the residual's chain, plus the light texels under
        // the BRDF itself (`LightTree::sum_brdf`, FIS's twin, its estimate the residual's).
        for b in [ggx(0.1, true), ggx(0.5, false)] {
            let Brdf::Ggx { alpha, correlated } = b else {
                unreachable!()
            };
            let tree = envlight::math::light_tree::LightTree::new(prepare(
                &env,
                &ex,
                glam::DMat3::IDENTITY,
                alpha,
            ));
            let table = dfg_table(16, correlated);
            let taps = 8;
            let r = renderer
                .render(
                    &split_scene(cam, b, dp_size, SplitSumSettings { taps, ..settings }),
                    &env,
                )
                .unwrap();
            let scale = alpha.max(envlight::math::brdf::GGX_ALPHA_MIN);
            let (mut errors, mut lit) = (Errors::new(), 0usize);
            for (k, normal, d) in sphere_pixels(&cam) {
                let v = -d;
                let base = split_sum::shade_taps(&chain, &table, 16, &b, normal, v, taps);
                let est = envlight::math::envmap::luminance(base);
                let l = tree.sum_brdf(&b, normal, v, scale, est);
                for c in 0..3 {
                    let want = base[c] + l[c];
                    let g = r.frame.texels[k][c] as f64;
                    errors.rel(g, want, 0.0, (k, c));
                }
                if l[1] > base[1] {
                    lit += 1;
                }
            }
            let worst = errors.worst();
            eprintln!("{b:?} taps {taps}: worst {worst:.2e}, {lit} pixels lit mostly by the sun");
            assert!(worst < 1e-4, "{b:?} taps {taps}: {worst:e}");
            assert!(lit > 5, "{lit}");
        }
    }
    common::finish(ctx);
}
