//! The Monte Carlo reference on the GPU against its float64 twin, and filtered importance
//! sampling against the converged reference on real probes.

mod common;
#[path = "twins/mc.rs"]
mod twin;

use common::compare::{finite, Errors};
use common::scenes::{fis, object, scene, sphere_camera, unit_sphere};
use envlight::math::brdf::Brdf;
use envlight::math::camera::trace;
use envlight::math::envmap::luminance;
use envlight::render::render;
use envlight::scene::Technique;

/// GPU and CPU estimates of the same pixels with independent seeds agree within their
/// combined statistical error: per pixel, z = (Y_gpu − Y_cpu)/√(σ²_gpu + σ²_cpu) of the mean
/// luminance. With ~100 pixels of 512 samples each, |z| < 5 everywhere and the mean z² near 1
/// (0.4 to 2) if both estimators target the same value and report their variance truthfully.
/// The scene has a sun 5·10⁴ × the sky, shadows, a rotated environment, and four BRDFs.
#[test]
fn gpu_monte_carlo_matches_the_float64_estimator() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// FIS at N = 64 against the Monte Carlo reference (MIS, 4096 samples per pixel) on a studio
/// map and on a map whose sun holds half the power in 2·10⁻⁴ sr, for GGX α ∈ {0.05, 0.3} and
/// Phong n ∈ {10, 1000}, on a sphere seen from normal incidence to grazing.
/// With lights extracted (the scenes' default) FIS reads the residual and adds the light
/// texels exactly. Measured relative RMS over the sphere (luminance), GGX α 0.05, 0.3, Phong
/// 10, 1000: studio 3.6%, 4.0%, 5.0%, 1.8%; quarry 2.1%, 2.4%, 1.4%, 2.2% (before extraction:
/// 5–8% and 18–33%, whose 15% and 40% bounds hid regressions). Each case is bounded at 1.3×
/// its measured error, MC's own noise (about 0.5–1% at 4096 samples) included; and no pixel
/// may exceed the reference by more than 2.1× plus 1% of the image's mean (measured 1.58×: a
/// firefly bound), nor be NaN or Inf.
#[test]
fn fis_converges_towards_monte_carlo_on_real_probes() {
    let Some(probes) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    {
        let cam = sphere_camera(24);
        // Bounds per BRDF below, in this order.
        for (file, tols) in [
            ("photo_studio_01_1k.hdr", [0.047, 0.052, 0.065, 0.024]),
            ("quarry_01_1k.hdr", [0.028, 0.031, 0.019, 0.029]),
        ] {
            let env = envlight::io::load(probes.join(file), &Default::default()).unwrap();
            for (kind, tol) in [
                Brdf::Ggx {
                    alpha: 0.05,
                    correlated: false,
                },
                Brdf::Ggx {
                    alpha: 0.3,
                    correlated: false,
                },
                Brdf::Phong { n: 10.0 },
                Brdf::Phong { n: 1000.0 },
            ]
            .into_iter()
            .zip(tols)
            {
                let f = render(
                    &ctx,
                    &scene(
                        cam,
                        vec![object(unit_sphere(), kind, [1.0; 3], fis(64))],
                        false,
                        256,
                    ),
                    &env,
                )
                .unwrap();
                let m = render(
                    &ctx,
                    &scene(
                        cam,
                        vec![object(
                            unit_sphere(),
                            kind,
                            [1.0; 3],
                            Technique::Mc {
                                samples: 4096,
                                error: None,
                            },
                        )],
                        false,
                        256,
                    ),
                    &env,
                )
                .unwrap();
                let (mut se, mut sr, mut n, mut ratios) = (0.0, 0.0, 0, Errors::new());
                let mean_ref: f64 = m
                    .frame
                    .texels
                    .iter()
                    .map(|t| luminance(t.map(f64::from)))
                    .sum::<f64>()
                    / m.frame.texels.len() as f64;
                for (k, (a, b)) in f.frame.texels.iter().zip(&m.frame.texels).enumerate() {
                    assert!(
                        a.iter().all(|v| v.is_finite()),
                        "{file} {kind:?}: pixel {k} {a:?}"
                    );
                    let (o, d) = cam.ray(k as u32 % cam.width, k as u32 / cam.width);
                    if trace(&[unit_sphere()], o, d).is_none_or(|h| h.margin < 1e-3) {
                        continue;
                    }
                    let (la, lb) = (luminance(a.map(f64::from)), luminance(b.map(f64::from)));
                    se += (la - lb).powi(2);
                    sr += lb * lb;
                    n += 1;
                    let ratio = finite(la, "FIS", &k) / finite(lb + 0.01 * mean_ref, "MC", &k);
                    ratios.add(ratio, k);
                }
                let worst_ratio = ratios.worst();
                let rel = (se / sr).sqrt();
                eprintln!("{file} {kind:?}: FIS-64 relative RMS {rel:.3} over {n} pixels, worst ratio to reference {worst_ratio:.2}");
                assert!(rel < tol, "{file} {kind:?}: {rel}");
                assert!(worst_ratio < 2.1, "{file} {kind:?}: firefly {worst_ratio}");
            }
        }
    }
    common::finish(ctx);
}

/// The report's noise-free reference (`render::score::exact_truth`: every texel's ∫ f·cos,
/// nothing sampled) against 2 × 65 536 samples a pixel of Monte Carlo (`score::truth`: 16
/// independent renders of 8192) on a sun probe (a sun 10⁵× its sky) and a studio, diffuse,
/// GGX 0.3 and 0.05, on a 32² sphere: the two target one integral, so the exact frame
/// differs from the renders' mean by about that mean's own noise (the replicas' spread),
/// not more. Bound 1.35× it: across 24 independent groups of 16 renders (4 seed sets × these
/// 6 cases) the ratio read 0.65–1.17 (0.94–1.11 but for GGX 0.05 on the sun probe; this
/// seed set 0.97–1.12). Mean bias within 0.4× the noise (measured −0.32 … +0.25×; this set
/// −0.23 … +0.25×). A reference 0.3% too bright fails it.
#[test]
fn the_exact_reference_agrees_with_monte_carlo_within_its_noise() {
    use envlight::render::score::{errors, exact_truth, sphere_pixels, truth};
    use envlight::render::Renderer;
    use envlight::scene::SplitSumSettings;
    let Some(probes) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    {
        let renderer = Renderer::new(&ctx);
        let cam = sphere_camera(32);
        let pixels = sphere_pixels(&cam);
        let turn = envlight::math::Orientation::default().world_to_file();
        for file in ["spiaggia_di_mondello_1k.hdr", "studio_small_08_1k.hdr"] {
            let env = envlight::io::load(probes.join(file), &Default::default()).unwrap();
            for brdf in [
                Brdf::Lambert,
                envlight::math::split_sum::ggx(0.3, true),
                envlight::math::split_sum::ggx(0.05, true),
            ] {
                let split = SplitSumSettings::default();
                let (mc, noise) = truth(&renderer, cam, brdf, None, split, 65536, &env).unwrap();
                let exact = exact_truth(&cam, brdf, &env, turn);
                let (rms, bias, _) = errors(&exact, &mc, &pixels);
                eprintln!(
                    "{file} {brdf:?}: exact vs MC {:.3}%, bias {:+.3}%, MC noise {:.3}% ({:.2}×)",
                    100.0 * rms,
                    100.0 * bias,
                    100.0 * noise,
                    rms / noise
                );
                assert!(
                    rms <= 1.35 * noise,
                    "{file} {brdf:?}: {rms} against noise {noise}"
                );
                assert!(
                    bias.abs() <= 0.4 * noise,
                    "{file} {brdf:?}: bias {bias}, noise {noise}"
                );
            }
        }
    }
    common::finish(ctx);
}
