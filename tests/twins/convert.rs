//! The conversion pass against its float64 twin: what `tests/convert.rs` runs, and what
//! `tests/mutation.rs` runs on poisoned outputs.
#![allow(dead_code)]

use crate::common::compare::Errors;
use envlight::gpu::{Context, Timed};
use envlight::math::synth::smooth_env;
use envlight::math::Mapping;
use envlight::passes::{ConvertOptions, Converter};
use envlight::GpuEnvMap;
use envlight::{EnvMap, Orientation};
use std::f64::consts::PI;

/// The smallest bound [`check`] holds the pass to (relative, 2D sources).
pub const BOUND: f64 = 1e-5;

/// Source size per mapping (lat-long width; others their side).
pub fn src_size(m: Mapping) -> u32 {
    match m {
        Mapping::LatLong => 256,
        Mapping::Angular => 192,
        Mapping::Cube => 64,
        Mapping::DualParaboloid => 96,
    }
}

/// Largest angular size of a texel of a map, in radians (its longest side on the sphere).
pub fn texel_angle(m: Mapping, size: u32) -> f64 {
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

/// What [`convert`]'s output holds before the conversion: no conversion of the tests' maps
/// (a 10⁵ sun at most) writes it, and every comparison's error is then ~1e25 (an upload
/// refuses NaN).
pub const UNWRITTEN: f32 = 1e30;

/// `src` converted on the GPU to `to` at `size`, the source oriented as `o`, into a map
/// that holds [`UNWRITTEN`] before the conversion, so that a texel the conversion leaves
/// unwritten fails its test (lavapipe keeps an image's memory through the pass's discard; a
/// fresh image there may hold the bytes of a freed staging buffer: the source's own texels).
pub fn convert(
    ctx: &Context,
    conv: &Converter,
    src: &EnvMap,
    to: Mapping,
    size: u32,
    o: Orientation,
) -> EnvMap {
    let g = GpuEnvMap::upload(ctx, src).unwrap();
    let (w, h) = to.extent_for_size(size);
    let unwritten = [UNWRITTEN; 3];
    let before = EnvMap::new(to, w, h, vec![unwritten; (w * h * to.layers()) as usize]);
    let out = GpuEnvMap::upload(ctx, &before).unwrap();
    let opts = ConvertOptions::new(to, size).with_orientation(o);
    let Timed { timings: t, .. } = ctx
        .run("converting over a sentinel", |rec| {
            conv.record(rec, &g, &out, &opts)
        })
        .unwrap();
    assert!(t.iter().all(|t| t.ms >= 0.0 && t.ms.is_finite()));
    out.download(ctx).unwrap()
}

/// The GPU pass against its float64 twin (`envlight::math::convert`), same algorithm and
/// sample positions. What remains is float32 arithmetic (directions to ~1e-7 rad, texel
/// values to 6e-8 relative) and, for cube sources, the hardware's bilinear weights, which
/// Vulkan quantises to subTexelPrecisionBits (at least 4; 8 on lavapipe): a weight error of up
/// to 2⁻⁹ times the difference of neighbouring texels (≤ G·h_s ≈ 0.06 here), and the filtering
/// of cube corners, which Vulkan leaves to the implementation. Tolerances: 1e-5 relative to the
/// map's scale (about 1) for 2D sources (1.5e-6 seen on lavapipe); 3e-4 for cube sources.
pub fn check(ctx: &Context) {
    let conv = Converter::new(ctx).unwrap();
    let o = Orientation {
        flip_u: false,
        flip_v: true,
        rotate_y_degrees: 17.0,
    };
    for from in Mapping::ALL {
        let n = src_size(from) / 2;
        let (w, h) = from.extent_for_size(n);
        // A sharper function than smooth_env so that reconstruction matters.
        let src = EnvMap::from_fn(from, w, h, 4, |d| {
            let l = smooth_env(d);
            let s = (20.0 * (d.dot(glam::DVec3::new(0.6, 0.0, -0.8)) - 1.0)).exp() * 5.0;
            [l[0] + s, l[1], l[2] + 0.5 * s]
        });
        for to in Mapping::ALL {
            let size = src_size(to) / 4;
            let (ow, oh) = to.extent_for_size(size);
            let ss = Converter::supersampling((from, w, h), (to, ow, oh));
            let gpu = convert(ctx, &conv, &src, to, size, o);
            let opts = ConvertOptions::new(to, size).with_orientation(o);
            let area = conv.uses_area((from, w, h), &opts);
            let cpu = if area {
                envlight::math::convert::latlong_area(&src, to, size, o.world_to_file())
            } else {
                envlight::math::convert::convert(&src, to, size, o.world_to_file(), ss)
            };
            let tol = if from == Mapping::Cube { 3e-4 } else { BOUND };
            let mut errors = Errors::new();
            for layer in 0..gpu.layers() {
                for j in 0..gpu.height {
                    for i in 0..gpu.width {
                        let (a, b) = (gpu.texel(layer, i, j), cpu.texel(layer, i, j));
                        // Area paraboloid texels outside the disc hold a nearest texel
                        // (area_conversion_matches_its_float64_twin checks them).
                        if area && !to.texel_in_domain(gpu.width, gpu.height, i, j) {
                            continue;
                        }
                        for k in 0..3 {
                            errors.rel(a[k], b[k], 1.0, (layer, i, j));
                        }
                    }
                }
            }
            let (worst, at) = (errors.worst(), errors.at().copied());
            eprintln!(
                "{from:?} -> {to:?} ({}): GPU vs f64 worst {worst:.2e} at {at:?}",
                if area {
                    "area".to_string()
                } else {
                    format!("ss {ss}")
                }
            );
            if worst > tol {
                crate::common::dump_pair(&format!("ref_{}_{}", from.name(), to.name()), &gpu, &cpu);
            }
            assert!(
                errors.count() > 0 && worst <= tol,
                "{from:?} -> {to:?}: GPU vs f64 {worst:e} > {tol:e} at {at:?}"
            );
            if area {
                check_planned(ctx, &conv, &src, &opts);
            } else if from == Mapping::LatLong && to == Mapping::DualParaboloid {
                // Turned upside down it is sampled; upright it takes areas, and a plan.
                check_planned(ctx, &conv, &src, &ConvertOptions::new(to, size));
            }
        }
    }
}

/// The same conversion from a plan (`Converter::plan`, `run_planned`) against the same twin:
/// the plan's float64 weights, rounded to float32, and float32 sums (3e-7 seen); BOUND.
fn check_planned(ctx: &Context, conv: &Converter, src: &EnvMap, opts: &ConvertOptions) {
    let g = GpuEnvMap::upload(ctx, src).unwrap();
    let plan = conv
        .plan((src.mapping, src.width, src.height), opts)
        .unwrap();
    let gpu = conv
        .run_planned(&g, &plan)
        .unwrap()
        .value
        .download(ctx)
        .unwrap();
    let w2f = opts.orientation.world_to_file();
    let cpu = envlight::math::convert::latlong_area(src, opts.to, opts.size, w2f);
    let mut errors = Errors::new();
    for (t, (a, b)) in gpu.texels.iter().zip(&cpu.texels).enumerate() {
        for k in 0..3 {
            errors.rel(a[k], b[k], 1.0, t);
        }
    }
    let (worst, at) = (errors.worst(), errors.at().copied());
    eprintln!(
        "latlong -> {:?} (planned): GPU vs f64 worst {worst:.2e}",
        opts.to
    );
    assert!(
        errors.count() > 0 && worst <= BOUND,
        "latlong -> {:?} planned: GPU vs f64 {worst:e} > {BOUND:e} at {at:?}",
        opts.to
    );
}

/// `Converter::record_split` against its twin: the float64 conversion (the same sample
/// positions) of the map and of its residual (`math::lights::clamp_residual`), each
/// premultiplied as the MIP chain keeps level 0 (`math::mip::level0`). From lat-long, angular
/// and paraboloid sources with a sun 10⁵× the sky, turned and mirrored; the threshold at the
/// texels' median luminance, so that half of the sky and the sun are clamped; into a
/// paraboloid whose rim texels take fractional weights. What remains is the 2D conversion's
/// float32 error (BOUND) and the clamp's ~4 ε (`map::CLAMP_BOUND`), relative to the map's
/// scale (about 1); the weights (clipped Gauss–Legendre in float32) within 1e-6.
pub fn check_split(ctx: &Context) {
    use envlight::math::envmap::luminance;
    use envlight::math::lights::clamp_residual;
    use envlight::math::mip::level0;
    let conv = Converter::new(ctx).unwrap();
    let o = Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: -31.0,
    };
    let to = Mapping::DualParaboloid;
    for from in [Mapping::LatLong, Mapping::Angular, Mapping::DualParaboloid] {
        let n = src_size(from) / 2;
        let (w, h) = from.extent_for_size(n);
        // The sun, 10⁵× the sky, a Gaussian 1.5 texels wide: sharp enough that the clamp
        // changes it and its rim, smooth enough that float32 sample positions (~1e-6 of a
        // texel) move no texel by more than the bound.
        let sun = glam::DVec3::new(0.5, 0.4, -0.3).normalize();
        let width = 1.5 * texel_angle(from, n);
        let src = EnvMap::from_fn(from, w, h, 4, |d| {
            let l = smooth_env(d);
            let s = 1.0e5 * ((d.dot(sun) - 1.0) / (width * width)).exp();
            [l[0] + s, 0.5 * l[1] + 0.25 + 0.9 * s, l[2] + 0.7 * s]
        });
        let mut lum: Vec<f64> = src
            .texels
            .iter()
            .map(|t| luminance(t.map(f64::from)))
            .collect();
        lum.sort_by(f64::total_cmp);
        let tau = lum[lum.len() / 2];
        let size = src_size(to) / 4;
        let (ow, oh) = to.extent_for_size(size);
        let opts = ConvertOptions::new(to, size).with_orientation(o);
        let g = GpuEnvMap::upload(ctx, &src).unwrap();
        let whole = GpuEnvMap::new(ctx, "split: whole", to, ow, oh).unwrap();
        let residual = GpuEnvMap::new(ctx, "split: residual", to, ow, oh).unwrap();
        ctx.run("a split conversion", |rec| {
            conv.record_split(rec, &g, (&whole, &residual), tau, &opts)
        })
        .unwrap();
        let ss = Converter::supersampling((from, w, h), (to, ow, oh));
        let w2f = o.world_to_file();
        let twin = |m: &EnvMap| level0(&envlight::math::convert::convert(m, to, size, w2f, ss));
        let clamped = clamp_residual(&src, tau);
        let changed = clamped
            .texels
            .iter()
            .zip(&src.texels)
            .filter(|(a, b)| a != b)
            .count();
        assert!(changed > 0, "{from:?}: the threshold clamps nothing");
        for (name, gpu, cpu) in [
            ("whole", &whole, twin(&src)),
            ("residual", &residual, twin(&clamped)),
        ] {
            let back = gpu.download_level(ctx, 0).unwrap();
            assert_eq!(back.len(), cpu.texels.len(), "{from:?} {name}");
            let mut errors = Errors::new();
            let mut weights = Errors::new();
            for (t, (a, b)) in back.iter().zip(&cpu.texels).enumerate() {
                for k in 0..3 {
                    errors.rel(a[k], b[k], 1.0, (t, k));
                }
                weights.abs(a[3], b[3], t);
            }
            let (worst, at) = (errors.worst(), errors.at().copied());
            eprintln!("{from:?} -> split {name}: GPU vs f64 worst {worst:.2e} at {at:?}");
            assert!(
                errors.count() > 0 && worst <= BOUND,
                "{from:?} -> split {name}: GPU vs f64 {worst:e} > {BOUND:e} at {at:?}"
            );
            weights.assert_within(1e-6, &format!("{from:?} -> split {name}: weights"));
        }
    }
    // A cube source is refused by name (its hardware filtering cannot clamp texel by texel).
    let cube = EnvMap::from_fn(Mapping::Cube, 8, 8, 1, smooth_env);
    let g = GpuEnvMap::upload(ctx, &cube).unwrap();
    let out = GpuEnvMap::new(ctx, "split: refused", to, 16, 16).unwrap();
    let refused = ctx.run("a refused split", |rec| {
        conv.record_split(rec, &g, (&out, &out), 1.0, &ConvertOptions::new(to, 16))
    });
    let msg = format!("{:#}", refused.expect_err("a cube source is refused"));
    assert!(msg.contains("cube"), "{msg}");
}
