//! The conversion pass against analytic truth, a chain of conversions, orientation options.

mod common;

use envlight::gpu::{Context, GpuEnvMap};
use envlight::math::synth::smooth_env;
use envlight::math::Mapping;
use envlight::passes::{ConvertOptions, Converter};
use envlight::{EnvMap, Orientation};
use std::f64::consts::PI;

/// Source size per mapping (lat-long width; others their side).
fn src_size(m: Mapping) -> u32 {
    match m {
        Mapping::LatLong => 256,
        Mapping::Angular => 192,
        Mapping::Cube => 64,
        Mapping::DualParaboloid => 96,
    }
}

/// Largest angular size of a texel of a map, in radians (its longest side on the sphere).
fn texel_angle(m: Mapping, size: u32) -> f64 {
    let n = size as f64;
    match m {
        Mapping::LatLong => 2.0 * PI / n,
        // θ = πr: a texel spans π·(2/n) radially.
        Mapping::Angular => 2.0 * PI / n,
        // At a face centre a texel spans 2/n; that is the largest.
        Mapping::Cube => 2.0 / n,
        // At the disc centre dω/ds = 2, so a texel spans 2·(2/n).
        Mapping::DualParaboloid => 4.0 / n,
    }
}

fn convert(ctx: &Context, conv: &Converter, src: &EnvMap, to: Mapping, size: u32, o: Orientation) -> EnvMap {
    let g = GpuEnvMap::upload(ctx, src).unwrap();
    let (out, t) = conv.run(&g, &ConvertOptions { to, size, orientation: o, supersample: None }).unwrap();
    assert!(t.iter().all(|t| t.ms >= 0.0 && t.ms.is_finite()));
    out.download(ctx).unwrap()
}

/// Compares every texel the mapping reads with f at its centre; returns (max, rms) relative
/// error (relative to the map's mean, which is about 1).
fn compare_with(map: &EnvMap, f: impl Fn(glam::DVec3) -> [f64; 3]) -> (f64, f64) {
    let (mut worst, mut sq, mut n) = (0.0f64, 0.0f64, 0usize);
    for layer in 0..map.layers() {
        for j in 0..map.height {
            for i in 0..map.width {
                if !map.mapping.texel_in_domain(map.width, map.height, i, j) {
                    continue;
                }
                // Paraboloid rim texels hold the mean over their part inside the disc; their
                // centre may be outside it, so compare at the mean of the disc part's direction.
                let t = map.texel(layer, i, j);
                assert!(t.iter().all(|c| c.is_finite()), "non-finite texel");
                let e = f(map.texel_dir(layer, i, j));
                if map.mapping == Mapping::DualParaboloid {
                    let c = Mapping::texel_center(map.width, map.height, layer, i, j);
                    let (a, b) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
                    if a * a + b * b > 1.0 {
                        continue;
                    }
                }
                for k in 0..3 {
                    let err = (t[k] as f64 - e[k]).abs();
                    worst = worst.max(err);
                    sq += err * err;
                    n += 1;
                }
            }
        }
    }
    (worst, (sq / n as f64).sqrt())
}

/// Every mapping to every other, against the analytic function at the output texel centres.
///
/// Tolerance: the error of a texel has three parts, each bounded by the function's second
/// derivative along the sphere (|∇²L| ≤ M = 3 for `smooth_env`, whose lobe has sharpness 4)
/// times a squared texel size: baking the source (mean over a texel vs. centre, ≤ M·h_s²/24),
/// bilinear reconstruction (≤ M·h_s²/8) and the output footprint (≤ M·h_d²/24). We allow
/// M·(h_s²/6 + h_d²/12) with h the largest texel angle of each map, which is about 2× the sum of
/// the bounds. The RMS must be 4× smaller than that.
#[test]
fn every_mapping_to_every_other_matches_the_analytic_environment() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        for from in Mapping::ALL {
            let n = src_size(from);
            let (w, h) = from.extent_for_size(n);
            let src = EnvMap::from_fn(from, w, h, 6, smooth_env);
            for to in Mapping::ALL {
                let m_out = src_size(to) / 2;
                let out = convert(&ctx, &conv, &src, to, m_out, Orientation::default());
                let (worst, rms) = compare_with(&out, smooth_env);
                let hs = texel_angle(from, n);
                let hd = texel_angle(to, m_out);
                let tol = 3.0 * (hs * hs / 6.0 + hd * hd / 12.0);
                eprintln!("{from:?} -> {to:?}: max {worst:.2e} rms {rms:.2e} (tol {tol:.2e})");
                if worst > tol || rms > tol / 4.0 {
                    let truth = EnvMap::from_fn(to, out.width, out.height, 1, smooth_env);
                    common::dump_pair(&format!("convert_{}_{}", from.name(), to.name()), &out, &truth);
                }
                assert!(worst <= tol, "{from:?} -> {to:?}: max error {worst:e} > {tol:e}");
                assert!(rms <= tol / 4.0, "{from:?} -> {to:?}: rms error {rms:e} > {:e}", tol / 4.0);
            }
        }
    }
    common::finish(ctx);
}

/// lat-long → cube → dual paraboloid → angular → lat-long returns the original.
///
/// Each step is a resampling of a smooth map at comparable resolution, so the error is the sum
/// of four steps' bilinear and footprint errors (each ≲ 1e-3 here); directions within 10° of −Z
/// are excluded because the angular map squeezes that cap into its outermost ring of texels,
/// where its resolution tends to zero (that loss is the angular map's, not the chain's).
#[test]
fn chain_of_conversions_returns_the_original() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let start = EnvMap::from_fn(Mapping::LatLong, 256, 128, 6, smooth_env);
        let cube = convert(&ctx, &conv, &start, Mapping::Cube, 96, Orientation::default());
        let dp = convert(&ctx, &conv, &cube, Mapping::DualParaboloid, 160, Orientation::default());
        let ang = convert(&ctx, &conv, &dp, Mapping::Angular, 320, Orientation::default());
        let back = convert(&ctx, &conv, &ang, Mapping::LatLong, 256, Orientation::default());
        let (mut worst, mut sq, mut n) = (0.0f64, 0.0, 0);
        for j in 0..back.height {
            for i in 0..back.width {
                let d = back.texel_dir(0, i, j);
                if d.z < -(10f64.to_radians().cos()) {
                    continue;
                }
                let (a, b) = (back.texel(0, i, j), start.texel(0, i, j));
                for k in 0..3 {
                    let e = (a[k] - b[k]).abs() as f64 / (b[k] as f64).max(0.1);
                    worst = worst.max(e);
                    sq += e * e;
                    n += 1;
                }
            }
        }
        let rms = (sq / n as f64).sqrt();
        eprintln!("chain: max rel {worst:.2e} rms {rms:.2e}");
        if worst > 1e-2 {
            common::dump_pair("chain", &back, &start);
        }
        assert!(worst < 1e-2 && rms < 2e-3, "chain: max {worst:e} rms {rms:e}");
    }
    common::finish(ctx);
}

/// --flip-u, --flip-v and --rotate-y turn the environment as documented, in every mapping.
#[test]
fn orientation_options_transform_directions() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let o = Orientation { flip_u: true, flip_v: true, rotate_y_degrees: 30.0 };
        let m = o.world_to_file();
        for from in [Mapping::LatLong, Mapping::Cube] {
            let (w, h) = from.extent_for_size(src_size(from));
            let src = EnvMap::from_fn(from, w, h, 6, smooth_env);
            let out = convert(&ctx, &conv, &src, Mapping::LatLong, 128, o);
            // The world sees at d what the file stores at world_to_file · d.
            let (worst, _) = compare_with(&out, |d| smooth_env(m * d));
            assert!(worst < 0.02, "{from:?}: oriented conversion off by {worst:e}");
            let (unrotated, _) = compare_with(&out, smooth_env);
            assert!(unrotated > 0.1, "{from:?}: orientation had no effect");
        }
    }
    common::finish(ctx);
}

/// Tiny and non-power-of-two outputs and inputs stay finite and sane.
#[test]
fn tiny_and_odd_sizes() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        for from in Mapping::ALL {
            for n in [1u32, 3, 7] {
                let (w, h) = from.extent_for_size(n.max(2));
                let src = EnvMap::from_fn(from, w, h, 4, smooth_env);
                for to in Mapping::ALL {
                    for size in [1u32, 5, 33] {
                        let out = convert(&ctx, &conv, &src, to, size, Orientation::default());
                        let s = out.stats();
                        assert_eq!(s.nan + s.inf + s.negative, 0, "{from:?}{n} -> {to:?}{size}");
                        // Everything lies within the range of the source's texels.
                        let smax = src.stats().max;
                        for k in 0..3 {
                            assert!(s.max[k] <= smax[k] * 1.0001, "{from:?}{n} -> {to:?}{size}: overshoot");
                        }
                    }
                }
            }
        }
    }
    common::finish(ctx);
}
