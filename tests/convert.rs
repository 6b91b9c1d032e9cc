//! The conversion pass against analytic truth, a chain of conversions, orientation options.

mod common;
#[path = "twins/convert.rs"]
mod twin;

use twin::{convert, src_size, texel_angle};

use common::compare::{max_abs, max_of, rel_err, Errors};
use envlight::gpu::Timed;
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::Mapping;
use envlight::passes::{ConvertOptions, Converter};
use envlight::GpuEnvMap;
use envlight::{EnvMap, Orientation};
use std::f64::consts::PI;

/// Error statistics of a map against a truth, split between ordinary texels and those near
/// the angular map's −Z singularity.
#[derive(Default, Debug)]
struct SplitErrors {
    regular: Errors<(u32, u32, u32)>,
    singular: Errors<(u32, u32, u32)>,
}

impl SplitErrors {
    fn rms(&self) -> f64 {
        self.regular.rms()
    }
    fn max(&self) -> f64 {
        self.regular.worst()
    }
    fn max_singular(&self) -> f64 {
        self.singular.worst()
    }
}

/// Compares every texel the output mapping reads against `truth(layer, i, j)`. `singular`
/// marks texels near the angular map's rim (−Z), whose errors are first-order (see below).
fn compare(
    out: &EnvMap,
    singular: impl Fn(u32, u32, u32) -> bool,
    truth: impl Fn(u32, u32, u32) -> Option<[f64; 3]>,
) -> SplitErrors {
    let mut e = SplitErrors::default();
    for layer in 0..out.layers() {
        for j in 0..out.height {
            for i in 0..out.width {
                if !out.mapping.texel_in_domain(out.width, out.height, i, j) {
                    continue;
                }
                let t = out.texel(layer, i, j);
                let Some(x) = truth(layer, i, j) else {
                    continue;
                };
                let part = if singular(layer, i, j) {
                    &mut e.singular
                } else {
                    &mut e.regular
                };
                for k in 0..3 {
                    part.abs(t[k], x[k], (layer, i, j));
                }
            }
        }
    }
    e
}

/// Largest gradient G and second derivative M of f along great circles (per channel), by
/// central differences over 4000 directions × 8 tangent directions.
fn derivative_bounds(f: impl Fn(glam::DVec3) -> [f64; 3]) -> (f64, f64) {
    let (mut gs, mut ms) = (Vec::new(), Vec::new());
    let step = 1e-3;
    for d in envlight::math::synth::fibonacci_sphere(4000) {
        let t0 = d.any_orthonormal_vector();
        let t1 = d.cross(t0);
        for k in 0..8 {
            let a = k as f64 * PI / 8.0;
            let t = t0 * a.cos() + t1 * a.sin();
            let at = |s: f64| f(d * s.cos() + t * s.sin());
            let (p, z, n) = (at(step), at(0.0), at(-step));
            for c in 0..3 {
                gs.push((p[c] - n[c]) / (2.0 * step));
                ms.push((p[c] - 2.0 * z[c] + n[c]) / (step * step));
            }
        }
    }
    (max_abs(gs), max_abs(ms))
}

/// Every mapping to every other, against two truths.
///
/// `smooth_env` has values about 1; G and M bound its gradient and second derivative along
/// great circles (measured: about 1.7 and 5.2). With h_s, h_d the largest texel angles of
/// source and output:
///
/// 1. Against the exact footprint mean of each output texel (the f64 oracle bakes it with
///    16×16 solid-angle-weighted samples), the errors are the source's own texel means
///    (≤ M·h_s²/24) and their bilinear reconstruction. Bilinear interpolation in a map's own
///    coordinates errs by h²/8 times the second derivative along its coordinate lines, which
///    is M plus G times the lines' curvature on the sphere (≤ 2 for all four mappings away
///    from the angular rim); lat-long rows are interpolated between their solid-angle
///    centroids, so the poles stay second order. The GPU's ss×ss footprint quadrature adds
///    O(h_d²/ss²). Tolerance (M + 2G)·h_s²/4, 1.5 times the sum; RMS a quarter of it.
/// 2. Against the function at the texel centre, a filtered texel also differs by its
///    footprint's spread (≤ M·h_d²/24) and, where the density vanishes (lat-long poles), by
///    the offset of its solid-angle centroid from its centre (up to h_d/6, a first-order term
///    G·h_d/6). Tolerance G·h_d/6 + M·(h_s²/6 + h_d²/12).
///
/// The angular map's rim is the single direction −Z: there its density vanishes like
/// sin(πr), varying by more than 30% across a texel within 6 texels of the rim, so texel
/// centroids sit off their centres and footprint quadrature is coarse. Near −Z (within 3
/// source texels, 3·h_s, when reading an angular map; within 6 texels of the rim when writing
/// one) the error is first order. So it is next to a dual paraboloid's seam (within 1.5
/// source texels of the horizon when reading one): its rim texels hold the mean over their part
/// inside the disc, so that ∑ L·Ω is the power, and that mean's centroid is off the texel's
/// centre. Those texels are held to G·(h_s + h_d)/2 plus the tolerance of 2.
#[test]
fn every_mapping_to_every_other_matches_the_analytic_environment() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let mut failures = Vec::new();
        let (g, m) = derivative_bounds(smooth_env);
        eprintln!("smooth_env: |gradient| <= {g:.3}, |second derivative| <= {m:.3}");
        for from in Mapping::ALL {
            let n = src_size(from);
            let (w, h) = from.extent_for_size(n);
            let src = EnvMap::from_fn(from, w, h, 6, smooth_env);
            for to in Mapping::ALL {
                let m_out = src_size(to) / 2;
                let out = convert(&ctx, &conv, &src, to, m_out, Orientation::default());
                let hs = texel_angle(from, n);
                let hd = texel_angle(to, m_out);
                let singular = |layer: u32, i: u32, j: u32| {
                    let d = out.texel_dir(layer, i, j);
                    let near_rim_src =
                        from == Mapping::Angular && d.angle_between(-glam::DVec3::Z) < 3.0 * hs;
                    let c = Mapping::texel_center(out.width, out.height, layer, i, j);
                    let r = (2.0 * c.u - 1.0).hypot(2.0 * c.v - 1.0);
                    let near_rim_dst = to == Mapping::Angular && r > 1.0 - 12.0 / out.width as f64;
                    // Paraboloid rim texels hold the mean over their part inside the disc,
                    // whose centroid is off their centre: reading next to the seam is first order.
                    let near_seam_src = from == Mapping::DualParaboloid && d.y.abs() < 1.5 * hs;
                    near_rim_src || near_rim_dst || near_seam_src
                };
                let mean = EnvMap::from_fn(to, out.width, out.height, 16, smooth_env);
                let em = compare(&out, singular, |l, i, j| {
                    Some(mean.texel(l, i, j).map(f64::from))
                });
                let ec = compare(&out, singular, |l, i, j| {
                    // A paraboloid texel centred outside the disc holds its part inside.
                    let c = Mapping::texel_center(out.width, out.height, l, i, j);
                    let outside = (2.0 * c.u - 1.0).hypot(2.0 * c.v - 1.0) > 1.0;
                    (!(to == Mapping::DualParaboloid && outside))
                        .then(|| smooth_env(out.texel_dir(l, i, j)))
                });
                let tol_m = (m + 2.0 * g) * hs * hs / 4.0;
                let tol_c = g * hd / 6.0 + m * (hs * hs / 6.0 + hd * hd / 12.0);
                let tol_s = g * (hs + hd) / 2.0 + tol_c;
                eprintln!(
                    "{from:?} -> {to:?}: vs mean max {:.2e} at {:?} rms {:.2e} (tol {tol_m:.2e}); vs centre max {:.2e} \
                     rms {:.2e} (tol {tol_c:.2e}); near -Z or the seam {:.2e} (tol {tol_s:.2e})",
                    em.max(), em.regular.at(), em.rms(), ec.max(), ec.rms(),
                    max_of([em.max_singular(), ec.max_singular()])
                );
                let ok = em.regular.count() > 0
                    && em.max() <= tol_m
                    && em.rms() <= tol_m / 4.0
                    && ec.max() <= tol_c
                    && ec.rms() <= tol_c / 4.0
                    && max_of([em.max_singular(), ec.max_singular()]) <= tol_s;
                if !ok {
                    common::dump_pair(
                        &format!("convert_{}_{}", from.name(), to.name()),
                        &out,
                        &mean,
                    );
                    failures.push(format!("{from:?} -> {to:?}"));
                }
            }
        }
        assert!(failures.is_empty(), "outside tolerance: {failures:?}");
    }
    common::finish(ctx);
}

/// The GPU pass against its float64 twin (`envlight::math::convert`), same algorithm and
/// sample positions. What remains is float32 arithmetic (directions to ~1e-7 rad, texel
/// values to 6e-8 relative) and, for cube sources, the hardware's bilinear weights, which
/// Vulkan quantises to subTexelPrecisionBits (at least 4; 8 on lavapipe): a weight error of up
/// to 2⁻⁹ times the difference of neighbouring texels (≤ G·h_s ≈ 0.06 here), and the filtering
/// of cube corners, which Vulkan leaves to the implementation. Tolerances: 1e-5 relative to the
/// map's scale (about 1) for 2D sources (1.5e-6 seen on lavapipe); 3e-4 for cube sources.
#[test]
fn gpu_matches_the_float64_reference_conversion() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// One read of a 2D source into the whole map's and its residual's paraboloids
/// (`Converter::record_split`, the bake's path) against its float64 twin; a cube source
/// refused. Tolerances in `twins::convert::check_split`.
#[test]
fn split_conversion_matches_its_float64_twin() {
    let ctx = common::ctx();
    twin::check_split(&ctx);
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
        let cube = convert(
            &ctx,
            &conv,
            &start,
            Mapping::Cube,
            96,
            Orientation::default(),
        );
        let dp = convert(
            &ctx,
            &conv,
            &cube,
            Mapping::DualParaboloid,
            160,
            Orientation::default(),
        );
        let ang = convert(
            &ctx,
            &conv,
            &dp,
            Mapping::Angular,
            320,
            Orientation::default(),
        );
        let back = convert(
            &ctx,
            &conv,
            &ang,
            Mapping::LatLong,
            256,
            Orientation::default(),
        );
        let mut errors = Errors::new();
        for j in 0..back.height {
            for i in 0..back.width {
                let d = back.texel_dir(0, i, j);
                if d.z < -(10f64.to_radians().cos()) {
                    continue;
                }
                let (a, b) = (back.texel(0, i, j), start.texel(0, i, j));
                for k in 0..3 {
                    errors.rel(a[k], b[k], 0.1, (i, j, k));
                }
            }
        }
        let (worst, rms) = (errors.worst(), errors.rms());
        eprintln!("chain: max rel {worst:.2e} rms {rms:.2e}");
        if worst > 1e-2 {
            common::dump_pair("chain", &back, &start);
        }
        assert!(
            worst < 1e-2 && rms < 2e-3,
            "chain: max {worst:e} rms {rms:e}"
        );
    }
    common::finish(ctx);
}

/// --flip-u, --flip-v and --rotate-y turn the environment as documented, in every mapping.
#[test]
fn orientation_options_transform_directions() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let o = Orientation {
            flip_u: true,
            flip_v: true,
            rotate_y_degrees: 30.0,
        };
        let m = o.world_to_file();
        for from in [Mapping::LatLong, Mapping::Cube] {
            let (w, h) = from.extent_for_size(src_size(from));
            let src = EnvMap::from_fn(from, w, h, 6, smooth_env);
            let out = convert(&ctx, &conv, &src, Mapping::LatLong, 128, o);
            // The world sees at d what the file stores at world_to_file · d.
            let oriented = compare(
                &out,
                |_, _, _| false,
                |l, i, j| Some(smooth_env(m * out.texel_dir(l, i, j))),
            );
            assert!(
                oriented.regular.count() > 0 && oriented.max() < 0.02,
                "{from:?}: oriented conversion off by {:e}",
                oriented.max()
            );
            let plain = compare(
                &out,
                |_, _, _| false,
                |l, i, j| Some(smooth_env(out.texel_dir(l, i, j))),
            );
            assert!(plain.max() > 0.1, "{from:?}: orientation had no effect");
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
                // n = 1 is a 1×1 map in every mapping: one texel covering the sphere (lat-long),
                // the disc and its corners (angular), one per face or half.
                let (w, h) = if n == 1 {
                    (1, 1)
                } else {
                    from.extent_for_size(n)
                };
                let src = EnvMap::from_fn(from, w, h, 4, smooth_env);
                for to in Mapping::ALL {
                    for size in [1u32, 5, 33] {
                        let out = convert(&ctx, &conv, &src, to, size, Orientation::default());
                        let s = out.stats();
                        assert_eq!(s.nan + s.inf + s.negative, 0, "{from:?}{n} -> {to:?}{size}");
                        // A one-texel map (lat-long, angular) is a constant, reproduced
                        // exactly; a 1×1 cube or paraboloid has a texel per layer.
                        if n == 1 && src.texels.len() == 1 {
                            let want = src.texels[0];
                            let (ow, oh) = (out.width, out.height);
                            // Angular corners lie off the sphere and stay 0.
                            let inside = |k: usize| {
                                let k = k as u32 % (ow * oh);
                                to.texel_in_domain(ow, oh, k % ow, k / ow)
                            };
                            for (_, t) in out.texels.iter().enumerate().filter(|(k, _)| inside(*k))
                            {
                                for c in 0..3 {
                                    assert!(
                                        (t[c] - want[c]).abs() <= 1e-6 * want[c].max(1.0),
                                        "{from:?} 1x1 -> {to:?}{size}: {t:?} vs {want:?}"
                                    );
                                }
                            }
                        }
                        // Everything lies within the range of the source's texels.
                        let smax = src.stats().max;
                        for (out_max, src_max) in s.max.iter().zip(smax) {
                            assert!(
                                *out_max <= src_max * 1.0001,
                                "{from:?}{n} -> {to:?}{size}: overshoot"
                            );
                        }
                    }
                }
            }
        }
    }
    common::finish(ctx);
}

/// The benchmark's floor, the copy pass, returns its input bit for bit in every mapping.
#[test]
fn copy_pass_is_exact() {
    let ctx = common::ctx();
    {
        let copy = envlight::passes::testing::copy::CopyPass::new(&ctx).unwrap();
        for m in Mapping::ALL {
            let (w, h) = m.extent_for_size(17);
            let map = EnvMap::from_fn(m, w, h, 2, smooth_env);
            let g = GpuEnvMap::upload(&ctx, &map).unwrap();
            let Timed {
                value: out,
                timings: t,
            } = copy.run(&g).unwrap();
            assert_eq!(t.len(), 1);
            assert_eq!(out.download(&ctx).unwrap(), map, "{m:?}");
        }
    }
    common::finish(ctx);
}

/// A cube or lat-long converted to itself at its own size with one sample a texel, in the
/// file's own orientation, reads each texel's own centre: the pass copies it (what the dynamic
/// path's mirror level takes from a residual of the chain's side), so every texel must come
/// back bit for bit, a 1e5 sun and odd sizes included. Turned 90° about y the same conversion
/// must still be the sampled one: it matches its float64 twin and moves the sun.
#[test]
fn same_mapping_at_one_sample_is_a_copy() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        for (mapping, size) in [(Mapping::Cube, 13), (Mapping::LatLong, 58)] {
            let (w, h) = mapping.extent_for_size(size);
            let mut src = EnvMap::from_fn(mapping, w, h, 2, smooth_env);
            src.texels[(w * h / 2 + w / 3) as usize] = [1e5, 9e4, 8e4];
            let g = GpuEnvMap::upload(&ctx, &src).unwrap();
            for nearest in [false, true] {
                let opts = ConvertOptions::new(mapping, size)
                    .with_supersample(Some(1))
                    .with_nearest(nearest);
                let Timed {
                    value: out,
                    timings,
                } = conv.run(&g, &opts).unwrap();
                assert!(
                    timings.iter().any(|t| t.label.ends_with("(a copy)")),
                    "{mapping:?}"
                );
                assert_eq!(
                    out.download(&ctx).unwrap(),
                    src,
                    "{mapping:?} nearest {nearest}"
                );
            }
            let turned = Orientation {
                rotate_y_degrees: 90.0,
                ..Orientation::default()
            };
            let mut opts = ConvertOptions::new(mapping, size).with_supersample(Some(1));
            opts.orientation = turned;
            let Timed {
                value: out,
                timings,
            } = conv.run(&g, &opts).unwrap();
            assert!(
                !timings.iter().any(|t| t.label.ends_with("(a copy)")),
                "{mapping:?}"
            );
            let out = out.download(&ctx).unwrap();
            let want = envlight::math::convert::convert_with(
                &src,
                mapping,
                size,
                turned.world_to_file(),
                1,
                false,
            );
            let mut errors = Errors::new();
            for (k, (a, b)) in out.texels.iter().zip(&want.texels).enumerate() {
                for c in 0..3 {
                    errors.rel(a[c], b[c], 1e-3, (k, c));
                }
            }
            assert!(
                errors.worst() < 1e-4,
                "{mapping:?} turned: {:e}",
                errors.worst()
            );
            assert_ne!(out, src, "{mapping:?}: turning moved nothing");
        }
    }
    common::finish(ctx);
}

/// The nearest-texel conversion (`ConvertOptions::nearest`, what footprint-filtered mirrors'
/// chain is built from) against its float64 twin (`math::convert::convert_with`), on maps
/// whose every texel differs from its neighbours (a hash), so any sample reading the wrong
/// texel shows: lat-long, angular and cube sources to a dual paraboloid. Texels with a sample
/// within 1e-5 texel of a source texel's edge are left out (ties: the paraboloid's diagonals
/// meet the cube's edges exactly, where float32 and float64 may pick either side); every other
/// texel must agree within 1e-5 relative (float32 sums of 9 samples).
#[test]
fn nearest_conversion_matches_its_float64_twin() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let hash = |layer: u32, i: u32, j: u32| {
            let h = (layer.wrapping_mul(73856093)
                ^ i.wrapping_mul(19349663)
                ^ j.wrapping_mul(83492791))
            .wrapping_mul(2654435761);
            0.1 + (h >> 8) as f32 / (1u32 << 24) as f32
        };
        let (size, ss) = (29, 3);
        let (dw, dh) = Mapping::DualParaboloid.extent_for_size(size);
        for (mapping, w, h) in [
            (Mapping::LatLong, 58, 29),
            (Mapping::Angular, 45, 45),
            (Mapping::Cube, 13, 13),
        ] {
            let texels = (0..mapping.layers())
                .flat_map(|l| (0..h).flat_map(move |j| (0..w).map(move |i| (l, i, j))))
                .map(|(l, i, j)| {
                    let v = hash(l, i, j);
                    [v, 0.5 * v, 1.0 - 0.5 * v]
                })
                .collect();
            let src = EnvMap::new(mapping, w, h, texels);
            let g = GpuEnvMap::upload(&ctx, &src).unwrap();
            let opts = ConvertOptions::new(Mapping::DualParaboloid, size)
                .with_supersample(Some(ss))
                .with_nearest(true);
            let Timed { value: out, .. } = conv.run(&g, &opts).unwrap();
            let out = out.download(&ctx).unwrap();
            let want = envlight::math::convert::convert_with(
                &src,
                Mapping::DualParaboloid,
                size,
                Orientation::default().world_to_file(),
                ss,
                true,
            );
            let tie = |k: usize| {
                let (layer, i, j) = (k as u32 / (dw * dh), k as u32 % dw, (k as u32 / dw) % dh);
                (0..ss * ss).any(|s| {
                    let c = envlight::math::Coord {
                        layer,
                        u: (i as f64 + ((s % ss) as f64 + 0.5) / ss as f64) / dw as f64,
                        v: (j as f64 + ((s / ss) as f64 + 0.5) / ss as f64) / dh as f64,
                    };
                    let e = mapping.dir_to_coord(Mapping::DualParaboloid.coord_to_dir(c));
                    let (x, y) = (e.u * w as f64, e.v * h as f64);
                    (x - x.round()).abs() < 1e-5 || (y - y.round()).abs() < 1e-5
                })
            };
            let (mut errors, mut ties) = (Errors::new(), 0);
            for (k, (a, b)) in out.texels.iter().zip(&want.texels).enumerate() {
                if tie(k) {
                    ties += 1;
                    continue;
                }
                for c in 0..3 {
                    errors.rel(a[c], b[c], 1e-3, (k, c));
                }
            }
            let worst = errors.worst();
            eprintln!("{mapping:?}: worst {worst:.1e}, {ties} texels at ties left out");
            assert!(ties * 4 < out.texels.len(), "{mapping:?}: {ties} ties");
            assert!(worst < 1e-5, "{mapping:?}: worst {worst}");
        }
    }
    common::finish(ctx);
}

/// A lat-long map with the hard cases of the area conversion: a texel at each pole and on the
/// seam 10⁵ × the sky, another mid-sky, over smooth texel-to-texel variation.
fn suns_at_poles_and_seam(w: u32) -> EnvMap {
    let h = w / 2;
    let mut m = EnvMap::from_fn(Mapping::LatLong, w, h, 1, |d| {
        let s = (13.0 * d.x + 7.0 * d.y).sin();
        [1.0 + 0.5 * s, 1.0 + 0.25 * (5.0 * d.z).cos(), 1.0]
    });
    let (w, h) = (w as usize, h as usize);
    for (i, j) in [
        (0, 0),
        (w / 2, 0),
        (0, h / 2),
        (w - 1, h / 3),
        (w / 3, h - 1),
        (w / 5, h / 2),
    ] {
        m.texels[j * w + i] = [1e5, 2e5, 5e4];
    }
    m
}

/// The options of a conversion to `to` at `size` with orientation `o` and the defaults else.
fn default_opts(to: Mapping, size: u32, o: Orientation) -> ConvertOptions {
    ConvertOptions::new(to, size).with_orientation(o)
}

/// Lat-long to cube and dual paraboloid by exact footprint areas, on the GPU against its
/// float64 twin (`math::convert::latlong_area`, the same polygons and band walks; at sizes
/// from 32 the fast path's clamped edges away from the poles and, on a paraboloid, inside its
/// disc), at even and odd sizes (a
/// pole on a corner or inside a texel) and turned and flipped. What differs
/// is float32: polygon points to ~1e-7 of a column, so a share of ~1e-5 of a source texel can
/// move between neighbouring output texels; on this map (texel values 0.5–2, no suns) that
/// is ~1e-5 of a value; tolerance 5e-5 relative. Paraboloid texels outside their disc hold a
/// nearest source texel, whose choice float32 may flip where a direction falls on a column's
/// edge: they are checked to hold a value of the map instead.
#[test]
fn area_conversion_matches_its_float64_twin() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let src = EnvMap::from_fn(Mapping::LatLong, 96, 48, 1, |d| {
            let s = (13.0 * d.x + 7.0 * d.y).sin();
            [
                1.0 + 0.5 * s,
                1.0 + 0.5 * (9.0 * d.z).cos(),
                1.25 + 0.75 * d.y,
            ]
        });
        let turned = |flip_v| Orientation {
            flip_u: true,
            flip_v,
            rotate_y_degrees: 33.0,
        };
        for (to, size, o) in [
            (Mapping::Cube, 8, Orientation::default()),
            (Mapping::Cube, 7, Orientation::default()),
            (Mapping::Cube, 13, turned(true)),
            (Mapping::DualParaboloid, 8, Orientation::default()),
            (Mapping::DualParaboloid, 7, Orientation::default()),
            (Mapping::DualParaboloid, 13, turned(false)),
            // Tiny: one texel a half holds its pole and its whole rim; two meet at the pole.
            (Mapping::DualParaboloid, 1, Orientation::default()),
            (Mapping::DualParaboloid, 2, Orientation::default()),
            (Mapping::Cube, 1, Orientation::default()),
            // Large enough for the fast path away from the poles (and the general walk over
            // the window about them, and a paraboloid's rim): even and odd, upright and
            // turned upside down.
            (Mapping::Cube, 40, Orientation::default()),
            (Mapping::Cube, 33, turned(true)),
            (Mapping::DualParaboloid, 40, Orientation::default()),
            (Mapping::DualParaboloid, 33, turned(false)),
        ] {
            assert!(conv.uses_area((Mapping::LatLong, 96, 48), &default_opts(to, size, o)));
            let gpu = convert(&ctx, &conv, &src, to, size, o);
            let cpu = envlight::math::convert::latlong_area(&src, to, size, o.world_to_file());
            let mut errors = Errors::new();
            for layer in 0..gpu.layers() {
                for j in 0..gpu.height {
                    for i in 0..gpu.width {
                        let (a, b) = (gpu.texel(layer, i, j), cpu.texel(layer, i, j));
                        if !to.texel_in_domain(gpu.width, gpu.height, i, j) {
                            assert!(
                                src.texels.contains(&a),
                                "{to:?} {size}: ({layer}, {i}, {j}) {a:?} vs {b:?}"
                            );
                            continue;
                        }
                        for k in 0..3 {
                            errors.rel(a[k], b[k], 0.0, (layer, i, j));
                        }
                    }
                }
            }
            let worst = errors.worst();
            eprintln!("area, {to:?} {size}: GPU vs f64 worst {worst:.2e}");
            assert!(worst <= 5e-5, "{to:?} {size}: GPU vs f64 {worst:e}");
        }
        // A paraboloid upside down (its axis against the lat-long's) is sampled.
        let opts = default_opts(Mapping::DualParaboloid, 8, turned(true));
        assert!(!conv.uses_area((Mapping::LatLong, 96, 48), &opts));
    }
    common::finish(ctx);
}

/// Chords per paraboloid texel edge (`ConvertOptions::edge_points`, each with its sliver;
/// the default 2) follow their float64 twin (5e-5 on the smooth map above),
/// and keep power at either count: 1024 × 512 with suns 10⁵ × the sky at both poles, on the
/// seam and mid-sky, to paraboloids of 256, 128 and 32: 2.0e-6, 3.1e-6, 1.7e-6 at 1 chord
/// and 2.7e-6, 3.0e-6, 1.5e-6 at 2 (float32's: the twin keeps it to 1e-8; rim edges take the
/// parts of their chords' slivers inside the half, without which the suns on the seam's
/// equator lose 1.2e-5 and 2.7e-5 at 128 and 32); its residual (lights extracted, as FIS's
/// chain) 3.9e-9, 2.8e-9, 1.6e-8 at 1 and 4.0e-9, 2.1e-9, 2.3e-8 at 2. Bounds 1.3× the
/// worst. Counts outside 1 ..= POLE_STEPS are refused.
#[test]
fn chords_follow_their_twin_and_keep_power() {
    const SUNS_BOUND: f64 = 4e-6;
    const RESIDUAL_BOUND: f64 = 3e-8;
    use common::abi::area;
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let run = |src: &EnvMap, size: u32, points: u32| -> EnvMap {
            let g = GpuEnvMap::upload(&ctx, src).unwrap();
            let opts =
                ConvertOptions::new(Mapping::DualParaboloid, size).with_edge_points(Some(points));
            conv.run(&g, &opts).unwrap().value.download(&ctx).unwrap()
        };
        let smooth = EnvMap::from_fn(Mapping::LatLong, 96, 48, 1, |d| {
            let s = (13.0 * d.x + 7.0 * d.y).sin();
            [
                1.0 + 0.5 * s,
                1.0 + 0.5 * (9.0 * d.z).cos(),
                1.25 + 0.75 * d.y,
            ]
        });
        let w2f = Orientation::default().world_to_file();
        for (size, points) in [(32, 1), (29, 1), (32, 2), (40, 3)] {
            let gpu = run(&smooth, size, points);
            let cpu = envlight::math::convert::latlong_area_points(
                &smooth,
                Mapping::DualParaboloid,
                size,
                w2f,
                points,
            );
            let mut errors = Errors::new();
            for layer in 0..2 {
                for j in 0..gpu.height {
                    for i in 0..gpu.width {
                        if !Mapping::DualParaboloid.texel_in_domain(gpu.width, gpu.height, i, j) {
                            continue;
                        }
                        let (a, b) = (gpu.texel(layer, i, j), cpu.texel(layer, i, j));
                        for k in 0..3 {
                            errors.rel(a[k], b[k], 0.0, (layer, i, j));
                        }
                    }
                }
            }
            let worst = errors.worst();
            eprintln!("paraboloid {size}, {points} chords: GPU vs f64 worst {worst:.2e}");
            assert!(worst <= 5e-5, "{size}, {points} chords: {worst:e}");
        }
        let suns = suns_at_poles_and_seam(1024);
        let ex = envlight::math::lights::extract(
            &suns,
            &envlight::math::lights::ExtractOptions::chain(),
        );
        let power_error = |out: &EnvMap, src: &EnvMap| {
            let (p, q) = (out.power(), src.power());
            max_of((0..3).map(|c| rel_err(p[c], q[c], 0.0, c)))
        };
        for size in [256, 128, 32] {
            for (what, map, bound) in [
                ("suns", &suns, SUNS_BOUND),
                ("residual", &ex.residual, RESIDUAL_BOUND),
            ] {
                let e = [1, 2].map(|points| power_error(&run(map, size, points), map));
                eprintln!(
                    "{what}, paraboloid {size}: power error {:.2e} at 1 chord, {:.2e} at 2",
                    e[0], e[1]
                );
                for e in e {
                    assert!(e <= bound, "{what} {size}: power off by {e:e}");
                }
            }
        }
        assert_eq!(area::PARABOLOID_EDGE_STEPS, 2);
        let g = GpuEnvMap::upload(&ctx, &smooth).unwrap();
        for points in [0, area::POLE_STEPS + 1] {
            let opts =
                ConvertOptions::new(Mapping::DualParaboloid, 8).with_edge_points(Some(points));
            let e = conv.run(&g, &opts).err().expect("refused").to_string();
            assert!(e.contains("points per paraboloid texel edge"), "{e}");
        }
    }
    common::finish(ctx);
}

/// The area conversion conserves power to the 1e-5: with suns 10⁵ × the sky at both
/// poles, on the seam and mid-sky, at 1024 → cube and paraboloid 256 and 255/127 turned
/// (float64 twin: 5e-6 at cube 256, the chords of the footprint polygons, 7e-9 at paraboloid
/// 256; GPU measured 3.4e-6, 7.5e-6, 2.7e-6, 2.7e-6; supersampling errs by 2.2e-3 on this map), and on the
/// analytic sky, whose sun disc (5·10⁴ × the zenith) lies at 40° of azimuth, where U = φ·W/2π
/// is a column index in the hundreds: held there in float32, the points would move by ~1e-4
/// of a texel and the sun texels' areas with them, so footprints count U from a column near
/// them (twin 5e-7; GPU measured 4.3e-7 and 6.6e-7). At sizes as small as FIS's lobe-sized
/// paraboloids, whose texels hold the pole suns on a corner: a cube of 16 to 1e-5 (its chords
/// take slivers, as every cube below the fast path's size; GPU measured 4.1e-6; chords
/// alone would lose 1.4e-4), a paraboloid of 32 to 1e-5 too (its rim's chords take the parts of
/// their slivers inside the half: twin 1.1e-8, GPU measured 1.5e-6; chords alone there lose
/// 1.6e-5; a sun that only touches a footprint is never the texel its sums are taken relative
/// to, which cost 1.9e-3 here); and a constant map stays constant to float32
/// rounding.
#[test]
fn area_conversion_conserves_power() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let src = suns_at_poles_and_seam(1024);
        let sky = EnvMap::from_fn(Mapping::LatLong, 1024, 512, 2, |d| {
            Sky::default().radiance(d)
        });
        let turned = |flip_v| Orientation {
            flip_u: false,
            flip_v,
            rotate_y_degrees: 17.0,
        };
        for (src, to, size, o, bound) in [
            (&src, Mapping::Cube, 256, Orientation::default(), 1e-5),
            (&src, Mapping::Cube, 255, turned(true), 1e-5),
            (
                &src,
                Mapping::DualParaboloid,
                256,
                Orientation::default(),
                1e-5,
            ),
            (&src, Mapping::DualParaboloid, 127, turned(false), 1e-5),
            (&sky, Mapping::Cube, 256, Orientation::default(), 1e-5),
            (
                &sky,
                Mapping::DualParaboloid,
                256,
                Orientation::default(),
                1e-5,
            ),
            (&src, Mapping::Cube, 16, Orientation::default(), 1e-5),
            (
                &src,
                Mapping::DualParaboloid,
                32,
                Orientation::default(),
                1e-5,
            ),
        ] {
            assert!(conv.uses_area((Mapping::LatLong, 1024, 512), &default_opts(to, size, o)));
            let out = convert(&ctx, &conv, src, to, size, o);
            let (p, q) = (out.power(), src.power());
            let worst = max_of((0..3).map(|c| rel_err(p[c], q[c], 0.0, c)));
            let what = if std::ptr::eq(src, &sky) {
                "sky"
            } else {
                "suns"
            };
            eprintln!("area, {what}, {to:?} {size}: power error {worst:.2e}");
            assert!(worst <= bound, "{to:?} {size}: power off by {worst:e}");
            assert!(out
                .texels
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0));
        }
        let flat = EnvMap::new(Mapping::LatLong, 64, 32, vec![[2.0, 3.0, 4.0]; 64 * 32]);
        for (to, size) in [
            (Mapping::Cube, 5),
            (Mapping::Cube, 16),
            (Mapping::DualParaboloid, 5),
            (Mapping::DualParaboloid, 16),
        ] {
            let out = convert(&ctx, &conv, &flat, to, size, Orientation::default());
            let worst = max_of(
                out.texels
                    .iter()
                    .enumerate()
                    .map(|(k, t)| rel_err(t[1], 3.0, 0.0, k)),
            );
            assert!(
                worst <= 2e-6,
                "constant map, {to:?} {size}: off by {worst:e}"
            );
        }
    }
    common::finish(ctx);
}

/// A 4096 × 2048 source takes exact areas: each of its two slope buffers (dL/dU, dL/dz) is
/// 128 MiB, within Vulkan's least maxStorageBufferRange (2^27 bytes, lavapipe's), where the
/// two as one buffer would not be; the validation layers check each binding's range. With suns
/// 10⁵ × the sky at both poles, on the seam and mid-sky, power holds to the 1e-5 (a
/// sun texel's footprints split on either side of a face's edge, as at 1024) and no texel is
/// negative or not finite.
#[test]
fn a_4096_source_takes_exact_areas() {
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let src = suns_at_poles_and_seam(4096);
        for (to, size) in [(Mapping::Cube, 128), (Mapping::DualParaboloid, 256)] {
            let opts = default_opts(to, size, Orientation::default());
            assert!(
                conv.uses_area((Mapping::LatLong, 4096, 2048), &opts),
                "{to:?} {size} from 4096 x 2048 is not taken by areas"
            );
            let out = convert(&ctx, &conv, &src, to, size, Orientation::default());
            let (p, q) = (out.power(), src.power());
            let worst = max_of((0..3).map(|c| rel_err(p[c], q[c], 0.0, c)));
            eprintln!("area, 4096 x 2048, {to:?} {size}: power error {worst:.2e}");
            assert!(worst <= 1e-5, "{to:?} {size}: power off by {worst:e}");
            assert!(out
                .texels
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0));
        }
    }
    common::finish(ctx);
}

/// A planned conversion (`Converter::plan`, then `record_planned`) against the float64 twin
/// of the unplanned one (`math::convert::latlong_area_points`): the plan holds the float64
/// walk's weights, so what differs is their rounding to float32 and the GPU's float32 slopes
/// and sums: ~1e-7 of the largest term per term, so most where a footprint holds a sun and
/// many sky texels (measured 2.7e-6 at paraboloid 13, 3e-7 at cube 40; the unplanned
/// conversion's bound is 5e-5); tolerance 5e-6 relative, on a smooth map with suns
/// 10⁵ × the sky at the poles, on the seam and mid-sky, to cube and paraboloid at tiny, odd
/// and fast-path sizes, turned and flipped, at 2 and 8 points per paraboloid edge. The same
/// map converted again with the same plan (already on the GPU) is the same bit for bit; its
/// power is the unplanned conversion's; a plan is refused a map or output of another size,
/// and a conversion that does not take areas has none.
#[test]
fn planned_conversion_matches_its_float64_twin() {
    use envlight::math::convert::latlong_area_points;
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let src = suns_at_poles_and_seam(96);
        let g = GpuEnvMap::upload(&ctx, &src).unwrap();
        let turned = Orientation {
            flip_u: true,
            flip_v: false,
            rotate_y_degrees: 33.0,
        };
        let mut all = Errors::new();
        for (to, size, o, points) in [
            (Mapping::Cube, 1, Orientation::default(), 8),
            (Mapping::Cube, 7, Orientation::default(), 8),
            (Mapping::Cube, 40, Orientation::default(), 8),
            (Mapping::Cube, 33, turned, 8),
            (Mapping::DualParaboloid, 2, Orientation::default(), 8),
            (Mapping::DualParaboloid, 13, turned, 8),
            (Mapping::DualParaboloid, 48, Orientation::default(), 2),
            (Mapping::DualParaboloid, 33, Orientation::default(), 8),
        ] {
            let opts = default_opts(to, size, o).with_edge_points(Some(points));
            let plan = conv.plan((Mapping::LatLong, 96, 48), &opts).unwrap();
            assert!(plan.serves((Mapping::LatLong, 96, 48), &opts));
            let gpu = conv
                .run_planned(&g, &plan)
                .unwrap()
                .value
                .download(&ctx)
                .unwrap();
            let again = conv
                .run_planned(&g, &plan)
                .unwrap()
                .value
                .download(&ctx)
                .unwrap();
            assert!(
                gpu.texels == again.texels,
                "{to:?} {size}: a second run differs"
            );
            let cpu = latlong_area_points(&src, to, size, o.world_to_file(), points);
            let mut errors = Errors::new();
            for (t, (a, b)) in gpu.texels.iter().zip(&cpu.texels).enumerate() {
                for k in 0..3 {
                    errors.rel(a[k], b[k], 0.0, t);
                }
            }
            let e = errors.worst();
            eprintln!("planned, {to:?} {size}, {points} points: GPU vs f64 worst {e:.2e}");
            assert!(e <= 5e-6, "{to:?} {size}: planned GPU vs f64 {e:e}");
            all.merge(&errors);
            let live = conv.run(&g, &opts).unwrap().value.download(&ctx).unwrap();
            let (p, q) = (gpu.power(), live.power());
            for c in 0..3 {
                let e = rel_err(p[c], q[c], 0.0, c);
                assert!(e <= 1e-5, "{to:?} {size}: planned power vs unplanned {e:e}");
            }
        }
        eprintln!("planned conversions: worst {:.2e}", all.worst());
        let opts = ConvertOptions::new(Mapping::Cube, 8);
        let plan = conv.plan((Mapping::LatLong, 96, 48), &opts).unwrap();
        let other = GpuEnvMap::upload(&ctx, &suns_at_poles_and_seam(64)).unwrap();
        let e = conv.run_planned(&other, &plan).err().expect("refused");
        assert!(e.to_string().contains("was given latlong 64x32"), "{e}");
        assert!(!plan.serves((Mapping::LatLong, 64, 32), &opts));
        let sampled = opts.with_supersample(Some(2));
        let e = conv
            .plan((Mapping::LatLong, 96, 48), &sampled)
            .err()
            .expect("refused");
        assert!(e.to_string().contains("no plan"), "{e}");
    }
    common::finish(ctx);
}
