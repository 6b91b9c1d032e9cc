//! The SH evaluation pass (`passes::sh_eval`): irradiance maps against the float64 evaluation
//! and a clamped-cosine sky's closed form, within the truncation bound; windowing.

mod common;
#[path = "twins/sh_eval.rs"]
mod twin;

use common::compare::{abs_err, max_of};
use envlight::gpu::Timed;
use envlight::math::filter::{self, at_centres, Kernel};
use envlight::math::sh::{self, Window};
use envlight::math::synth::{fibonacci_sphere, smooth_env, Sky};
use envlight::math::Mapping;
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::passes::{FilterTarget, ShEvaluator};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// Exact irradiance of L(d) = max(0, d.y) at a normal β from +Y:
/// ∫ max(0, y·ω)·max(0, n·ω) dω = (2/3)·((π − β)·cos β + sin β).
fn clamped_cosine_sky_irradiance(n: DVec3) -> f64 {
    let b = n.y.clamp(-1.0, 1.0).acos();
    2.0 / 3.0 * ((PI - b) * b.cos() + b.sin())
}

/// By Funk–Hecke both the sky and the kernel are zonal clamped cosines, so the irradiance's
/// band l is Â_l²·(2l+1)/4π·P_l(cos β), and truncating after band L errs by at most
/// Σ_{l>L} Â_l²·(2l+1)/4π (|P_l| ≤ 1), summed here to l = 20 000 (the tail beyond is O(l⁻³)).
fn truncation_bound(lmax: u32) -> f64 {
    (lmax + 1..20_000)
        .map(|l| sh::cosine_lobe(l).powi(2) * (2 * l + 1) as f64 / (4.0 * PI))
        .sum()
}

#[test]
fn clamped_cosine_sky_closed_form_is_right() {
    // The closed form against the Funk–Hecke series to l = 400, and the series truncated at L
    // within the bound (and the bound not vacuous: the error reaches a third of it).
    let p_l = |l: u32, x: f64| {
        let (mut p0, mut p1) = (1.0, x);
        if l == 0 {
            return p0;
        }
        for k in 2..=l {
            let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
            p0 = p1;
            p1 = p2;
        }
        p1
    };
    let series = |lmax: u32, x: f64| {
        (0..=lmax)
            .map(|l| sh::cosine_lobe(l).powi(2) * (2 * l + 1) as f64 / (4.0 * PI) * p_l(l, x))
            .sum::<f64>()
    };
    for k in 0..=40 {
        let b = PI * k as f64 / 40.0;
        let n = DVec3::new(b.sin(), b.cos(), 0.0);
        let exact = clamped_cosine_sky_irradiance(n);
        assert!((series(400, b.cos()) - exact).abs() < 1e-6, "β = {b}");
    }
    for lmax in [1, 2, 4, 8] {
        let bound = truncation_bound(lmax);
        let worst = max_of((0..=400).map(|k| {
            let b = PI * k as f64 / 400.0;
            abs_err(
                series(lmax, b.cos()),
                clamped_cosine_sky_irradiance(DVec3::new(b.sin(), b.cos(), 0.0)),
                k,
            )
        }));
        eprintln!("L = {lmax}: worst {worst:.3e}, bound {bound:.3e}");
        assert!(
            worst <= bound * (1.0 + 1e-9) && worst > bound / 3.0,
            "L = {lmax}"
        );
    }
}

/// The GPU path (bake max(0, y) into a 256×128 lat-long, project, evaluate SH irradiance into
/// a cube map) matches the closed form within the truncation bound plus what the map's
/// discretisation adds to the coefficients, bounded by Σ_l Â_l·Σ_m |Δc_lm|·max|Y_lm| with Δc
/// the f64 projection of the map minus the analytic coefficients, plus 1e-5 for f32.
#[test]
fn sh_irradiance_of_clamped_cosine_sky_is_within_truncation_error() {
    let ctx = common::ctx();
    {
        let map = EnvMap::from_fn(Mapping::LatLong, 256, 128, 4, |d| [d.y.max(0.0); 3]);
        let projector = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let eval = ShEvaluator::new(&ctx).unwrap();
        let g = GpuEnvMap::upload(&ctx, &map).unwrap();
        let cpu = sh::project(&map, 8);
        for lmax in [1u32, 2, 4, 8] {
            let Timed { value: c, .. } = projector.run(&g, lmax).unwrap();
            // Analytic coefficients: only m = 0 about +Y is non-zero in a frame with Y as
            // the pole; in ours (pole +Z), project the exact function in f64 at high
            // resolution instead and take the difference to the map's projection.
            let exact = analytic_coefficients(lmax);
            let mut disc = 0.0;
            for l in 0..=lmax {
                let ymax = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * 2f64.sqrt();
                for m in -(l as i32)..=(l as i32) {
                    let k = sh::index(l, m);
                    disc += sh::cosine_lobe(l) * (cpu[k][0] - exact[k]).abs() * ymax;
                }
            }
            let bound = truncation_bound(lmax) + disc + 1e-5;
            let irr = sh::irradiance_coeffs(&c.coeffs);
            let target = FilterTarget {
                to: Mapping::Cube,
                size: 8,
            };
            let Timed { value: out, .. } = eval.run(&irr, target).unwrap();
            let out = out.download(&ctx).unwrap();
            let truth = at_centres(Mapping::Cube, 8, 8, |d| {
                [clamped_cosine_sky_irradiance(d); 3]
            });
            let neg = sh::negativity(&irr, &fibonacci_sphere(2000));
            // The pass clamps ringing at 0; so does the comparison.
            let worst = max_of(
                out.texels
                    .iter()
                    .zip(&truth)
                    .enumerate()
                    .map(|(k, (g, t))| abs_err(g[0], t[0], k)),
            );
            eprintln!(
                "L = {lmax}: worst {worst:.3e}, truncation {:.3e}, discretisation {disc:.1e}, negative {:.1}% of directions",
                truncation_bound(lmax),
                100.0 * neg.fraction
            );
            assert!(worst <= bound, "L = {lmax}: {worst} > {bound}");
        }
    }
    common::finish(ctx);
}

/// SH coefficients of max(0, d.y) by Funk–Hecke: the zonal coefficients about +Y are
/// Â_l·√((2l+1)/4π); rotating the pole from +Y onto our basis means Y_l0 about +Y is the
/// basis evaluated with (x, y, z) → its own expansion, which we get exactly by projecting
/// Â_l·√((2l+1)/4π)·Y_l0^{(+Y)} = Σ_m c_lm Y_lm with c_lm = Â_l·Y_lm(+Y) (addition theorem).
fn analytic_coefficients(lmax: u32) -> Vec<f64> {
    let y = sh::basis(lmax, DVec3::Y);
    let mut c = vec![0.0; sh::count(lmax)];
    for l in 0..=lmax {
        for m in -(l as i32)..=(l as i32) {
            let k = sh::index(l, m);
            c[k] = sh::cosine_lobe(l) * y[k];
        }
    }
    c
}

/// The SH evaluation pass against the float64 evaluation of the same coefficients, windowed
/// and not, in every output mapping: f32 basis and coefficients, ~1e-6 relative of |E|.
#[test]
fn sh_eval_matches_float64() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// Low-order SH of a sun map rings negative on the far side; the smallest Sloan window found
/// removes it (and is the smallest: 3% less λ still rings). On a smooth map that window is
/// none at all (λ = 0), and a Hanning window changes the order-2 irradiance by at most the
/// stated bound Σ_l (1 − w_l)·Â_l·Σ_m |c_lm|·max|Y_lm|, which the test checks against the
/// measured change and against the error to the f64 brute force.
#[test]
fn windowing_removes_negative_irradiance() {
    let dirs = fibonacci_sphere(4000);
    let sky = Sky::default();
    let map = EnvMap::from_fn(Mapping::LatLong, 128, 64, 4, |d| sky.radiance(d));
    let radiance = sh::project(&map, 8);
    for lmax in [2u32, 4, 8] {
        let r = &radiance[..sh::count(lmax)];
        let raw = sh::negativity(&sh::irradiance_coeffs(r), &dirs);
        eprintln!(
            "sun map L = {lmax}: unwindowed min {:.3} of the mean at {:?}, {:.1}% negative",
            raw.worst,
            raw.at,
            100.0 * raw.fraction
        );
        assert!(raw.fraction > 0.0, "the sun map should ring at L = {lmax}");
        let lambda = sh::smallest_nonnegative_window(r, &dirs);
        let fixed = sh::negativity(
            &sh::irradiance_coeffs(&Window::Sloan { lambda }.apply(r)),
            &dirs,
        );
        assert_eq!(fixed.fraction, 0.0);
        // Smallest: 2% less λ still rings.
        let less = sh::negativity(
            &sh::irradiance_coeffs(
                &Window::Sloan {
                    lambda: lambda * 0.97,
                }
                .apply(r),
            ),
            &dirs,
        );
        assert!(less.fraction > 0.0, "λ = {lambda} is not the smallest");
        eprintln!("  smallest Sloan λ = {lambda:.4e}");
    }
    // A smooth map does not ring: λ = 0, and its order-2 error against the f64 brute force
    // stays within 3% of the mean irradiance with or without Hanning.
    let smooth = EnvMap::from_fn(Mapping::LatLong, 64, 32, 4, smooth_env);
    let r = sh::project(&smooth, 2);
    assert_eq!(sh::smallest_nonnegative_window(&r, &dirs), 0.0);
    let prepared = filter::Prepared::new(&smooth, DMat3::IDENTITY);
    let normals = fibonacci_sphere(200);
    let brute: Vec<f64> = normals
        .iter()
        .map(|&n| prepared.convolve(Kernel::Cosine, n)[0])
        .collect();
    let mean = brute.iter().sum::<f64>() / brute.len() as f64;
    let plain = sh::irradiance_coeffs(&r);
    let error = |irr: &[[f64; 3]]| {
        max_of(
            normals
                .iter()
                .zip(&brute)
                .map(|(&n, &b)| abs_err(sh::eval(irr, n)[0], b, n)),
        )
    };
    let base = error(&plain);
    for width in [3.0, 6.0] {
        let window = Window::Hanning { width };
        let w = window.weights(2);
        let mut bound = 0.0;
        for l in 0..=2u32 {
            let ymax = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * 2f64.sqrt();
            for m in -(l as i32)..=(l as i32) {
                bound +=
                    (1.0 - w[l as usize]) * sh::cosine_lobe(l) * r[sh::index(l, m)][0].abs() * ymax;
            }
        }
        let irr = sh::irradiance_coeffs(&window.apply(&r));
        let change = max_of(
            normals
                .iter()
                .map(|&n| abs_err(sh::eval(&irr, n)[0], sh::eval(&plain, n)[0], n)),
        );
        let err = error(&irr);
        eprintln!(
            "smooth map, Hanning {width}: change {:.2e}, bound {:.2e}, error {:.2e} (unwindowed {:.2e}) of the mean",
            change / mean,
            bound / mean,
            err / mean,
            base / mean
        );
        assert!(change <= bound && err <= base + bound);
    }
}
