//! Split-sum: the DFG table and the prefiltered chain against their float64 twins.
//! `tests/split_sum.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{abs_err, max_of, Errors};
use crate::common::scenes::{object, rel_rms, scene, sphere_camera, sphere_pixels, unit_sphere};
use envlight::gpu::{total_ms, Context, Timed};
use envlight::math::brdf::{local_view, Brdf, Frame};
use envlight::math::split_sum::{self, dfg_table, dfg_table_at, prefiltered_chain, DfgAxes};
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::{mip, Mapping};
use envlight::passes::{MipChain, PrefilterOptions, SplitSum};
use envlight::render::Renderer;
use envlight::scene::{Scene, SplitSumSettings, Technique};
use envlight::{EnvMap, GpuEnvMap};
use glam::DVec3;

/// The bound [`check`] holds the DFG table to (A and B, absolute; the chain is held to 1e-5 of its texels).
pub const BOUND: f64 = 2e-6;

/// The DFG table and the prefiltered chain: [`check_dfg`], then [`check_chain`].
pub fn check(ctx: &Context) {
    check_dfg(ctx);
    check_chain(ctx);
}

/// Both Smith forms' tables, at endpoints and at texel centres, against
/// `math::split_sum::dfg_table_at`, entry by entry, absolute (A and B are fractions of 1).
/// Bound 2e-6: float32 sums of 4096 node weights each ≤ 1 (measured 1.5e-6). The two axes
/// differ by far more than that (a centres table read as endpoints fails).
pub fn check_dfg(ctx: &Context) {
    let pass = SplitSum::new(ctx).unwrap();
    let size = 16;
    for (correlated, axes) in [
        (false, DfgAxes::Endpoints),
        (true, DfgAxes::Endpoints),
        (true, DfgAxes::Centres),
    ] {
        let Timed {
            value: got,
            timings: t,
        } = pass.run_dfg_at(size, correlated, axes).unwrap();
        let want = dfg_table_at(size, correlated, axes);
        if axes == DfgAxes::Centres {
            let other = dfg_table(size, correlated);
            let apart = max_of(
                want.iter()
                    .zip(&other)
                    .enumerate()
                    .map(|(k, (a, b))| abs_err(a[0], b[0], k)),
            );
            assert!(apart > 1e-2, "the axes do not differ: {apart:e}");
        }
        let mut errors = Errors::new();
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(g.iter().all(|v| *v >= 0.0), "entry {k}: {g:?}");
            errors.abs(g[0], w[0], (k, 0));
            errors.abs(g[1], w[1], (k, 1));
        }
        assert_eq!(errors.count(), 2 * want.len());
        let worst = errors.worst();
        eprintln!(
            "DFG {size}² correlated {correlated} {axes:?}: worst {worst:.2e}, {:.1} ms",
            total_ms(&t)
        );
        assert!(worst < BOUND, "{worst:e}");
    }
}

/// Every level of the prefiltered chain against `math::split_sum::prefiltered_chain` reading
/// the float64 MIP chain of the same paraboloid: a smooth map, and the sky whose sun is
/// 5·10⁴ × the zenith (the hard case: a sample's lod rounds differently in float32 near a
/// level boundary, and next to the sun that moves the result most). Error relative to the
/// texel's own value, or to the level's mean where the texel is darker. Measured (printed)
/// 3.3e-7 smooth, 1.1e-6 sky; bounds 1e-5 and 2e-5 leave room for other drivers' lod
/// rounding, still far below any error of the technique. The sky again with the rough
/// levels' boost (`PrefilterOptions::rough_boost` 4: level 2, 8² a layer, takes 4 × 16
/// samples), against the twin at the same samples a level.
pub fn check_chain(ctx: &Context) {
    let mips = MipChain::new(ctx).unwrap();
    let pass = SplitSum::new(ctx).unwrap();
    let sky = Sky::default();
    let size = 32;
    let (levels, samples, bias) = (3, 16, 0.25);
    type Radiance = Box<dyn Fn(DVec3) -> [f64; 3] + Sync>;
    // (name, radiance, bound, rough boost, nearest MIP level)
    let cases: [(&str, Radiance, f64, u32, bool); 5] = [
        ("smooth", Box::new(smooth_env), 1e-5, 1, false),
        ("sky", Box::new(move |d| sky.radiance(d)), 2e-5, 1, false),
        (
            "sky, rough levels boosted",
            Box::new(move |d| sky.radiance(d)),
            2e-5,
            4,
            false,
        ),
        (
            "smooth, nearest MIP level",
            Box::new(smooth_env),
            1e-5,
            1,
            true,
        ),
        (
            "sky, nearest MIP level",
            Box::new(move |d| sky.radiance(d)),
            2e-5,
            4,
            true,
        ),
    ];
    for (name, f, bound, rough_boost, nearest_mip) in cases {
        let map = EnvMap::from_fn(Mapping::DualParaboloid, size, size, 2, f);
        let src = GpuEnvMap::upload_mipped(ctx, &map).unwrap();
        let level0 = src.download(ctx).unwrap();
        mips.run(&src).unwrap();
        let chain = SplitSum::chain(ctx, size, levels).unwrap();
        let mut opts = PrefilterOptions::new(levels);
        (opts.samples, opts.bias, opts.rough_boost) = (samples, bias, rough_boost);
        opts.nearest_mip = nearest_mip;
        ctx.run("split-sum test", |rec| {
            pass.record_prefilter(rec, &src, &chain, &opts)
        })
        .unwrap();
        let per_level = opts.level_samples();
        let twin = mip::chain(&level0);
        for k in 0..levels {
            let (s, n) = (split_sum::level_size(size, k), per_level.at(size, k));
            let alpha = split_sum::level_alpha(k, levels);
            // Each texel's twin and whether a sample of it lies at a tie between two levels
            // (float32 may round its lod to the other: left out, and counted).
            let want: Vec<([f64; 3], u32)> = (0..2)
                .flat_map(|layer| (0..s).flat_map(move |j| (0..s).map(move |i| (layer, i, j))))
                .map(|(layer, i, j)| {
                    let d = split_sum::texel_dir(s, layer, i, j);
                    split_sum::prefilter_read(&twin, alpha, d, n, bias, nearest_mip)
                })
                .collect();
            let got = chain.download_level(ctx, k).unwrap();
            let mean = want.iter().map(|t| t.0[1]).sum::<f64>() / want.len() as f64;
            let (mut errors, mut ties) = (Errors::new(), 0);
            for (t, (g, (w, tie))) in got.iter().zip(&want).enumerate() {
                if *tie > 0 {
                    ties += 1;
                    continue;
                }
                for c in 0..3 {
                    errors.rel(g[c], w[c], mean, (t, c));
                }
            }
            assert!(
                ties * 20 <= want.len(),
                "{name} level {k}: {ties} texels at ties"
            );
            assert_eq!(errors.count(), 3 * (want.len() - ties));
            let worst = errors.worst();
            eprintln!("{name} level {k} ({s}², {n} samples): worst {worst:.2e}, {ties} at ties");
            assert!(worst < bound, "{name} level {k}: {worst:e}");
        }
    }
}
