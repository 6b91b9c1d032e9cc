//! The brute-force pass (`passes::brute`): irradiance and Phong prefilters against the float64
//! convolution with the same per-texel rules, at every mapping, size, split and lane count, and
//! its visit floor.

mod common;
#[path = "twins/brute.rs"]
mod twin;

use twin::{brute_gpu, worst_relative};

use common::compare::{max_of, min_of, rel_err};
use envlight::gpu::Timed;
use envlight::math::filter::{self, at_centres, Kernel};
use envlight::math::synth::Sky;
use envlight::math::{Mapping, Orientation};
use envlight::passes::{BruteFilter, FilterTarget};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// Brute-force irradiance and Phong prefilters of a 64×32 map against the float64
/// convolution with the same per-texel rules. Both sum the same ~2k texels; the GPU's error
/// is f32 rounding of node directions and kernel values (~1e-6 each, compensated sums), so
/// 1e-4 relative leaves two orders of margin while catching any rule that differs.
#[test]
fn brute_force_matches_float64_convolution() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// The normalised Phong lobe integrates to 1 for n from 1 to 10⁴: prefiltering a constant map
/// of 1 on the GPU gives 1 everywhere (and the cosine gives π). The per-texel rule's
/// quadrature error is under 2e-5 on the CPU (`math::filter` unit test); 1e-4 allows f32.
#[test]
fn phong_lobe_is_normalised_up_to_n_1e4() {
    let ctx = common::ctx();
    {
        let pass = BruteFilter::new(&ctx).unwrap();
        for (m, size) in [(Mapping::LatLong, 64), (Mapping::Cube, 12)] {
            let (w, h) = m.extent_for_size(size);
            let map = EnvMap::new(m, w, h, vec![[1.0; 3]; (w * h * m.layers()) as usize]);
            for (kernel, truth) in [
                (Kernel::Cosine, PI),
                (Kernel::Phong { n: 1.0 }, 1.0),
                (Kernel::Phong { n: 10.0 }, 1.0),
                (Kernel::Phong { n: 100.0 }, 1.0),
                (Kernel::Phong { n: 1e3 }, 1.0),
                (Kernel::Phong { n: 1e4 }, 1.0),
            ] {
                let target = FilterTarget {
                    to: Mapping::Cube,
                    size: 4,
                };
                let out = brute_gpu(&ctx, &pass, &map, kernel, target);
                let worst = max_of(
                    out.texels
                        .iter()
                        .enumerate()
                        .map(|(k, t)| rel_err(t[0], truth, 0.0, k)),
                );
                eprintln!("{m:?} {kernel:?}: worst {worst:.2e}");
                assert!(worst < 1e-4, "{m:?} {kernel:?}: {worst:e}");
            }
        }
    }
    common::finish(ctx);
}

/// A source of 131 072 texels is more than llvmpipe lets one loop run (65 535 iterations):
/// the pass must split it into chunks and still sum every texel (a constant map gives π).
#[test]
fn large_sources_are_summed_whole() {
    let ctx = common::ctx();
    {
        let pass = BruteFilter::new(&ctx).unwrap();
        let (w, h) = (512, 256);
        let map = EnvMap::new(Mapping::LatLong, w, h, vec![[1.0; 3]; (w * h) as usize]);
        let target = FilterTarget {
            to: Mapping::Cube,
            size: 2,
        };
        let out = brute_gpu(&ctx, &pass, &map, Kernel::Cosine, target);
        for t in &out.texels {
            assert!((t[0] as f64 / PI - 1.0).abs() < 1e-5, "{} vs π", t[0]);
        }
    }
    common::finish(ctx);
}

/// A 4096 × 2048 source: its shapes (3 vec4 a texel, 384 MB) exceeded lavapipe's 128 MiB
/// storage-buffer range while the pass kept them in buffers, and it refused the job; they are
/// images now. A map linear in the direction, L(ω) = c₀ + C·ω per channel, convolved with a
/// normalised Phong lobe about a gives c₀ + (C·a)·(n+1)/(n+2) exactly (the lobe's mean cosine),
/// so n = 10⁵ (resolved at 4k: n·ρ² ≈ 0.05) into a cube 2 is checked against that, within
/// 1e-4: f32 directions carry ~6e-8 in x = a·ω, so ln K = n·ln x errs by up to n·θ·6e-8 ≈
/// 1e-4 at the lobe's edge; summed, the error measured 2.0e-5 here (8.5e-7 at n = 10³ and
/// 5.9e-6 at 10⁴ on the same map), besides the map's texels being constant (O(texel²)).
#[test]
fn sources_past_a_storage_buffer_filter() {
    let ctx = common::ctx();
    {
        let pass = BruteFilter::new(&ctx).unwrap();
        let c0 = [1.0, 1.0, 1.0];
        let c = [
            DVec3::new(0.0, 0.5, 0.0),
            DVec3::new(-0.3, 0.0, 0.1),
            DVec3::new(0.2, -0.2, 0.4),
        ];
        let map = EnvMap::from_fn(Mapping::LatLong, 4096, 2048, 1, |d| {
            [0, 1, 2].map(|k| c0[k] + c[k].dot(d))
        });
        let n = 1e5;
        let target = FilterTarget {
            to: Mapping::Cube,
            size: 2,
        };
        let exact = at_centres(Mapping::Cube, 2, 2, |a| {
            [0, 1, 2].map(|k| c0[k] + c[k].dot(a) * (n + 1.0) / (n + 2.0))
        });
        let out = brute_gpu(&ctx, &pass, &map, Kernel::Phong { n }, target);
        let worst = worst_relative(&out, &exact);
        eprintln!("4096 x 2048, Phong 1e5 into a cube 2: worst {worst:.2e}");
        assert!(worst < 1e-4, "{worst:e}");
    }
    common::finish(ctx);
}

/// On CPU devices the texels whose rule asks for Gauss cells (the lat-long rows next to the
/// poles, which are not parallelograms, and texels near the lobe's cut-off where its log
/// curves fast) are summed in a second walk over the same slots, so an invocation that meets
/// one runs the texel loop twice: the chunks must leave llvmpipe's loop limit room for both
/// walks, or those sums silently lose texels (they lost 4% at the poles of a Phong n = 2049
/// cube 64 from a 1k map when the chunks counted one walk; this test then erred by 5e-3). A
/// 256 × 128 sky with a sun (32 768 slots, more than one chunk) and n = 10 (one cell a texel,
/// so the chunks are long, and a lobe that covers most of them), one part per output texel,
/// into a cube 8, with the CPU devices' structure (the second walk, the device's lanes an
/// output walking rows) and the GPUs' (one walk, one lane an output walking tiles): every
/// texel within 1e-4 of the float64 twin (the convolution test's bound), and the two within
/// 2e-6 of each other (the same compensated terms in another order, ~1e-7).
#[test]
fn both_walks_fit_the_loop_limit() {
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let map = EnvMap::from_fn(Mapping::LatLong, 256, 128, 1, |d| sky.radiance(d));
        let kernel = Kernel::Phong { n: 10.0 };
        let target = FilterTarget {
            to: Mapping::Cube,
            size: 8,
        };
        let fine = filter::Prepared::new(&map, DMat3::IDENTITY);
        let exact = at_centres(Mapping::Cube, 8, 8, |d| fine.convolve(kernel, d));
        let mut outs = Vec::new();
        for cells_walk in [true, false] {
            let mut pass = BruteFilter::new(&ctx).unwrap();
            // One part per texel: each invocation walks whole chunks, as a large output's do.
            pass.set_target_invocations(1);
            pass.set_cells_walk(cells_walk);
            if !cells_walk {
                pass.set_texel_lanes(1);
            }
            let out = brute_gpu(&ctx, &pass, &map, kernel, target);
            let worst = worst_relative(&out, &exact);
            eprintln!("Phong 10, 256 x 128 to cube 8, cells walk {cells_walk}: worst {worst:.2e}");
            assert!(worst < 1e-4, "cells walk {cells_walk}: {worst:e}");
            outs.push(out);
        }
        let as_f64: Vec<[f64; 3]> = outs[1].texels.iter().map(|t| t.map(f64::from)).collect();
        let apart = worst_relative(&outs[0], &as_f64);
        eprintln!("the two walks apart: {apart:.2e}");
        assert!(apart < 2e-6, "{apart:e}");
    }
    common::finish(ctx);
}

/// On CPU devices several invocations (SIMD lanes) sum one output texel, each every L-th slot:
/// in a lat-long source, of each row's columns within the lobe's reach (the cap above the
/// cut-off, wrapping at the seam, every column where the cap holds a pole); elsewhere one
/// invocation walks every tile. Both must sum the same terms. A 256 × 128 sky
/// with a sun 5·10⁴ × the zenith, turned 200° about +Y and mirrored (the window is found in
/// the file's frame), into a 32 × 16 lat-long (outputs next to both poles and on the seam)
/// with Phong n = 2000 (a reach of a few texels, except next to the poles) and n = 3, and
/// the cosine; each with 1, 2, 8 and 32 lanes, one invocation group per output
/// (the chunks then cut rows mid-row): every result within 1e-4 of the float64 twin (the
/// convolution test's bound), and within 2e-6 of one lane's (the same compensated terms
/// grouped otherwise, ~1e-7). A texel wrongly left out of a reach would take the sun or a
/// slice of sky with it: a reach 20% short, one that does not wrap, or one that never takes a
/// whole row at a pole each fails here.
#[test]
fn lanes_and_reaches_change_rounding_only() {
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let map = EnvMap::from_fn(Mapping::LatLong, 256, 128, 1, |d| sky.radiance(d));
        let o = Orientation {
            flip_u: true,
            flip_v: false,
            rotate_y_degrees: 200.0,
        };
        let g = GpuEnvMap::upload(&ctx, &map).unwrap();
        let fine = filter::Prepared::new(&map, o.world_to_file().transpose());
        let target = FilterTarget {
            to: Mapping::LatLong,
            size: 32,
        };
        let mut pass = BruteFilter::new(&ctx).unwrap();
        pass.set_target_invocations(1);
        for kernel in [
            Kernel::Phong { n: 2000.0 },
            Kernel::Phong { n: 3.0 },
            Kernel::Cosine,
        ] {
            let exact = at_centres(Mapping::LatLong, 32, 16, |d| fine.convolve(kernel, d));
            let mut outs = Vec::new();
            for lanes in [1, 2, 8, 32] {
                pass.set_texel_lanes(lanes);
                let Timed { value: out, .. } = pass.run(&g, &o, kernel, target).unwrap();
                let out = out.download(&ctx).unwrap();
                let vs_twin = worst_relative(&out, &exact);
                eprintln!("{kernel:?}, {lanes} lanes: twin {vs_twin:.2e}");
                assert!(vs_twin < 1e-4, "{kernel:?}, {lanes} lanes: {vs_twin:e}");
                outs.push(out);
            }
            let one: Vec<[f64; 3]> = outs[0].texels.iter().map(|t| t.map(f64::from)).collect();
            for (other, lanes) in outs[1..].iter().zip([2, 8, 32]) {
                let apart = worst_relative(other, &one);
                eprintln!("{kernel:?}: {lanes} lanes against one {apart:.2e}");
                assert!(apart < 2e-6, "{kernel:?}, {lanes} lanes: {apart:e}");
            }
        }
    }
    common::finish(ctx);
}

/// Small outputs split the source among parts, each summed by its own invocation, then added
/// per texel: the split may change float rounding only. A sky with a sun 5·10⁴ × the zenith,
/// filtered into a 2² cube (24 texels: the default target of 65 536 invocations makes ~2 700
/// parts) and a 2² dual paraboloid (its two halves' parts must not overlap) without a split,
/// by default, and with 16× the default: the sums agree to 2e-6
/// relative (compensated f32 sums of the same terms grouped otherwise, ~1e-7), and each is
/// within 1e-4 of the float64 twin (the bound of the convolution test above).
#[test]
fn source_split_changes_rounding_only() {
    let ctx = common::ctx();
    {
        let mut pass = BruteFilter::new(&ctx).unwrap();
        let sky = Sky::default();
        let map = EnvMap::from_fn(Mapping::LatLong, 128, 64, 2, |d| sky.radiance(d));
        let fine = filter::Prepared::new(&map, DMat3::IDENTITY);
        for (to, kernel) in [
            (Mapping::Cube, Kernel::Cosine),
            (Mapping::Cube, Kernel::Phong { n: 30.0 }),
            (Mapping::DualParaboloid, Kernel::Phong { n: 30.0 }),
        ] {
            let target = FilterTarget { to, size: 2 };
            let exact = at_centres(to, 2, 2, |d| fine.convolve(kernel, d));
            let mut outs = Vec::new();
            for invocations in [
                1,
                envlight::passes::brute::DEFAULT_TARGET_INVOCATIONS,
                1 << 20,
            ] {
                pass.set_target_invocations(invocations);
                let out = brute_gpu(&ctx, &pass, &map, kernel, target);
                let vs_twin = worst_relative(&out, &exact);
                eprintln!("{to:?} {kernel:?}, {invocations} invocations: twin {vs_twin:.2e}");
                assert!(
                    vs_twin < 1e-4,
                    "{to:?} {kernel:?} {invocations}: {vs_twin:e}"
                );
                outs.push(out);
            }
            for other in &outs[1..] {
                let one: Vec<[f64; 3]> =
                    outs[0].texels.iter().map(|t| t.map(|c| c as f64)).collect();
                let apart = worst_relative(other, &one);
                eprintln!("{to:?} {kernel:?}: split against one sum {apart:.2e}");
                assert!(apart < 2e-6, "{to:?} {kernel:?}: {apart:e}");
            }
        }
    }
    common::finish(ctx);
}

/// `--phong-levels`: each level from the moment pyramid's level that `level_for` picks, on
/// the GPU, against the float64 twin of the same sums (f32 rounding and rule decisions at f32
/// thresholds; measured 1.8e-5, bound 1e-4) and against the float64 convolution of every source texel (what
/// the levels stand for: measured 2.4e-4, bound 1e-3, the issue's). Sources: the sky with a sun 5·10⁴ × the
/// zenith, times texel noise over three decades drawn per channel, so that every coarse
/// texel's light differs per channel and is lumpy (the moments' third-order error shows); a
/// lat-long and a cube.
#[test]
fn phong_levels_match_float64() {
    use envlight::math::moments::{level_for, MomentLevel};
    use envlight::passes::brute::PhongLevels;
    let ctx = common::ctx();
    {
        let pass = BruteFilter::new(&ctx).unwrap();
        let sky = Sky::default();
        let noisy = |mapping: Mapping, w: u32, h: u32| {
            let mut map = EnvMap::from_fn(mapping, w, h, 2, |d| sky.radiance(d));
            let mut state = 0x9e3779b97f4a7c15u64;
            for t in &mut map.texels {
                for v in t.iter_mut() {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    *v *= 10f32.powf(3.0 * (state >> 40) as f32 / (1u64 << 24) as f32 - 1.5);
                }
            }
            map
        };
        let levels = PhongLevels {
            count: 4,
            scale: 6.0,
            bias: 0.0,
        };
        for (name, map) in [
            ("lat-long 256", noisy(Mapping::LatLong, 256, 128)),
            ("cube 64", noisy(Mapping::Cube, 64, 64)),
        ] {
            let g = GpuEnvMap::upload(&ctx, &map).unwrap();
            let target = FilterTarget {
                to: Mapping::Cube,
                size: 8,
            };
            let Timed {
                value: (maps, sources),
                ..
            } = pass
                .run_levels(&g, &Orientation::default(), &levels, target)
                .unwrap();
            let expected: Vec<u32> = (0..4)
                .map(|k| {
                    let kernel = Kernel::Phong {
                        n: levels.exponent(k),
                    };
                    level_for(kernel, map.mapping, map.width, map.height)
                })
                .collect();
            assert_eq!(sources, expected);
            assert!(sources.iter().any(|&s| s >= 2), "{name}: {sources:?}");
            let fine = filter::Prepared::new(&map, DMat3::IDENTITY);
            for (k, (out, &s)) in maps.iter().zip(&sources).enumerate() {
                let gpu = out.download(&ctx).unwrap();
                let kernel = Kernel::Phong {
                    n: levels.exponent(k as u32),
                };
                let exact = at_centres(Mapping::Cube, out.width, out.height, |d| {
                    fine.convolve(kernel, d)
                });
                // At level 0 the twin is the sum over every texel.
                let twin = if s > 0 {
                    let level = MomentLevel::new(&fine, s);
                    at_centres(Mapping::Cube, out.width, out.height, |d| {
                        level.convolve(&fine, kernel, d)
                    })
                } else {
                    exact.clone()
                };
                let vs_twin = worst_relative(&gpu, &twin);
                let vs_exact = worst_relative(&gpu, &exact);
                eprintln!(
                    "{name} level {k} (n = {:.0}, source level {s}): twin {vs_twin:.2e}, all texels {vs_exact:.2e}",
                    kernel.exponent()
                );
                assert!(vs_twin < 1e-4, "{name} level {k}: {vs_twin:e}");
                assert!(vs_exact < 1e-3, "{name} level {k}: {vs_exact:e}");
            }
        }
    }
    common::finish(ctx);
}

/// The visit floor (`BruteFilter::set_visit_floor`, what `cargo xtask lab peers` times as the floor of
/// the exact sum) visits what the sum visits, read once each: per output texel Σ L·Ω over
/// the walk's texels. It must hold every texel whose centre lies inside the lobe's cap above
/// the cut-off (those the rule keeps) and nothing past the walk's stated reach: the rows'
/// haversine reach d plus their one column each side (lanes, a lat-long source), or the
/// cap plus a tile's diagonal (tiles). A sun map (5·10⁴ × the zenith), turned and mirrored,
/// into a lat-long (poles, seam), Phong 2000 and 3. Bounds: the float64 sums over those two
/// sets of centres, 1e-5 relative and 1e-4 rad of slack for f32 sums and angles.
#[test]
fn the_visit_floor_visits_the_lobes_reach() {
    use common::abi::filter_rule::{CONE_MARGIN, LOG_CUTOFF, REACH_MARGIN_ABS, REACH_MARGIN_REL};
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let (w, h) = (256u32, 128u32);
        let map = EnvMap::from_fn(Mapping::LatLong, w, h, 1, |d| sky.radiance(d));
        let o = Orientation {
            flip_u: true,
            flip_v: false,
            rotate_y_degrees: 200.0,
        };
        let file_to_world = o.world_to_file().transpose();
        let mut texels = Vec::new();
        map.for_each_texel(|layer, i, j, t, omega| {
            let dir = file_to_world * map.texel_dir(layer, i, j);
            texels.push((dir, t.map(|c| c as f64 * omega)));
        });
        let sum_within = |axis: DVec3, angle: f64| -> [f64; 3] {
            let mut s = [0.0; 3];
            for (dir, lw) in &texels {
                if axis.dot(*dir).clamp(-1.0, 1.0).acos() <= angle {
                    (0..3).for_each(|c| s[c] += lw[c]);
                }
            }
            s
        };
        let g = GpuEnvMap::upload(&ctx, &map).unwrap();
        let target = FilterTarget {
            to: Mapping::LatLong,
            size: 32,
        };
        let step = (2.0 * PI / w as f64, PI / h as f64);
        let mut pass = BruteFilter::new(&ctx).unwrap();
        envlight::passes::testing::set_visit_floor(&mut pass, true);
        for n in [2000.0, 3.0] {
            // The cap where the lobe is above its cut-off, and the rows' reach (brute.comp).
            let cap = 2.0 * (0.5 * (1.0 - (LOG_CUTOFF / n).exp())).sqrt().asin();
            let d = cap
                + (1.0 + REACH_MARGIN_REL) * CONE_MARGIN * 0.5 * step.0.hypot(step.1)
                + REACH_MARGIN_ABS;
            let tile = common::abi::BRUTE_TILE as f64 * std::f64::consts::SQRT_2 * step.0;
            for (lanes, past) in [(8, d + 2.0 * step.0), (1, cap + tile)] {
                pass.set_texel_lanes(lanes);
                let Timed { value: out, .. } =
                    pass.run(&g, &o, Kernel::Phong { n }, target).unwrap();
                let out = out.download(&ctx).unwrap();
                let inner = at_centres(Mapping::LatLong, 32, 16, |a| sum_within(a, cap - 1e-4));
                let outer = at_centres(Mapping::LatLong, 32, 16, |a| sum_within(a, past + 1e-4));
                let mut ratios = Vec::new();
                for ((got, lo), hi) in out.texels.iter().zip(&inner).zip(&outer) {
                    for c in 0..3 {
                        let g = got[c] as f64;
                        assert!(
                            g >= lo[c] * (1.0 - 1e-5) && g <= hi[c] * (1.0 + 1e-5),
                            "n {n}, {lanes} lanes: {g} outside [{}, {}]",
                            lo[c],
                            hi[c]
                        );
                        ratios.push(g / lo[c]);
                    }
                }
                let (low, high) = (min_of(ratios.iter().copied()), max_of(ratios));
                eprintln!("n {n}, {lanes} lanes: floor / cap's sum from {low:.4} to {high:.4}");
            }
        }
    }
    common::finish(ctx);
}
