//! The MIP chain pass against the float64 box filter.
//! `tests/mip.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{rel_err, Errors};
use envlight::gpu::Context;
use envlight::math::synth::smooth_env;
use envlight::math::{mip, Mapping};
use envlight::passes::mip::MipChain;
use envlight::EnvMap;
use envlight::GpuEnvMap;

/// The relative bound [`check`] holds each level to.
pub const BOUND: f64 = 2e-6;

/// Every level of a smooth map's chain equals the float64 solid-angle-weighted box filter of
/// level 0 (power of two: straight from level 0; odd sizes: the float64 twin's fractional
/// footprints), within 2e-6 relative: float32 sums of at most 9 terms per level.
pub fn check(ctx: &Context) {
    let chain_pass = MipChain::new(ctx).unwrap();
    for size in [64u32, 45] {
        let map = EnvMap::from_fn(Mapping::DualParaboloid, size, size, 1, smooth_env);
        let dp = GpuEnvMap::upload_mipped(ctx, &map).unwrap();
        let level0 = dp.download(ctx).unwrap();
        let t = chain_pass.run(&dp).unwrap();
        assert_eq!(t.len() as u32, dp.mips());
        let reference = mip::chain(&level0);
        assert_eq!(reference.len() as u32, dp.mips());
        let mut errors = Errors::new();
        for (k, l) in reference.iter().enumerate() {
            let got = dp.download_level(ctx, k as u32).unwrap();
            for layer in 0..2 {
                for j in 0..l.size {
                    for i in 0..l.size {
                        let g = got[((layer * l.size + j) * l.size + i) as usize];
                        assert!(g.iter().all(|v| v.is_finite()));
                        if g[3] <= 0.0 {
                            assert!(
                                l.texels[((layer * l.size + j) * l.size + i) as usize][3] == 0.0
                            );
                            continue;
                        }
                        let want = if size.is_power_of_two() {
                            mip::box_reference(&level0, k as u32, layer, i, j)
                        } else {
                            l.radiance(layer, i, j)
                        };
                        for c in 0..3 {
                            let at = (k, layer, i, j, c);
                            let rel = errors.add(rel_err(g[c] / g[3], want[c], 0.0, at), at);
                            assert!(
                                rel < BOUND,
                                "size {size} level {k} ({layer}, {i}, {j}) ch {c}: {} vs {}",
                                g[c] / g[3],
                                want[c]
                            );
                        }
                    }
                }
            }
        }
        assert!(errors.count() > 0);
        eprintln!(
            "size {size}: {} levels within {:.1e}",
            dp.mips(),
            errors.worst()
        );
    }
}
