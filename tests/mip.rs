//! The MIP chain pass (`passes::mip`): levels against the float64 box filter, and no step at the
//! dual paraboloid's rim.

mod common;

use envlight::math::synth::smooth_env;
use envlight::math::{mip, Mapping};
use envlight::passes::mip::MipChain;
use envlight::EnvMap;
use envlight::GpuEnvMap;

/// Every level of a smooth map's chain equals the float64 solid-angle-weighted box filter of
/// level 0 (power of two: straight from level 0; odd sizes: the float64 twin's fractional
/// footprints), within 2e-6 relative: float32 sums of at most 9 terms per level.
#[test]
fn mip_levels_match_the_float64_box_filter() {
    let ctx = common::ctx();
    {
        let chain_pass = MipChain::new(&ctx).unwrap();
        for size in [64u32, 45] {
            let map = EnvMap::from_fn(Mapping::DualParaboloid, size, size, 1, smooth_env);
            let dp = GpuEnvMap::upload_mipped(&ctx, &map).unwrap();
            let level0 = dp.download(&ctx).unwrap();
            let t = chain_pass.run(&dp).unwrap();
            assert_eq!(t.len() as u32, dp.mips());
            let reference = mip::chain(&level0);
            assert_eq!(reference.len() as u32, dp.mips());
            let mut worst: f64 = 0.0;
            for (k, l) in reference.iter().enumerate() {
                let got = dp.download_level(&ctx, k as u32).unwrap();
                for layer in 0..2 {
                    for j in 0..l.size {
                        for i in 0..l.size {
                            let g = got[((layer * l.size + j) * l.size + i) as usize];
                            assert!(g.iter().all(|v| v.is_finite()));
                            if g[3] <= 0.0 {
                                assert!(
                                    l.texels[((layer * l.size + j) * l.size + i) as usize][3]
                                        == 0.0
                                );
                                continue;
                            }
                            let want = if size.is_power_of_two() {
                                mip::box_reference(&level0, k as u32, layer, i, j)
                            } else {
                                l.radiance(layer, i, j)
                            };
                            for c in 0..3 {
                                let rel = ((g[c] / g[3]) as f64 - want[c]).abs() / want[c];
                                worst = worst.max(rel);
                                assert!(
                                    rel < 2e-6,
                                    "size {size} level {k} ({layer}, {i}, {j}) ch {c}: {} vs {}",
                                    g[c] / g[3],
                                    want[c]
                                );
                            }
                        }
                    }
                }
            }
            eprintln!("size {size}: {} levels within {worst:.1e}", dp.mips());
        }
    }
    common::finish(ctx);
}

/// A map constant on each half (1 above, 10⁵ below, and 10⁵ again in the upper half's texels
/// outside its disc) shows no step at the rim at any level: every texel with weight reads its
/// own half's constant within 1e-6 relative, so the gradient across the rim is bounded by
/// that.
#[test]
fn mip_chain_has_no_step_at_the_rim() {
    let ctx = common::ctx();
    {
        let size = 32u32;
        let mut map = EnvMap::new(
            Mapping::DualParaboloid,
            size,
            size,
            vec![[1.0; 3]; (2 * size * size) as usize],
        );
        for j in 0..size {
            for i in 0..size {
                let k = map.index(1, i, j);
                map.texels[k] = [1e5; 3];
                if !Mapping::DualParaboloid.texel_in_domain(size, size, i, j) {
                    let k = map.index(0, i, j);
                    map.texels[k] = [1e5; 3];
                }
            }
        }
        let dp = GpuEnvMap::upload_mipped(&ctx, &map).unwrap();
        MipChain::new(&ctx).unwrap().run(&dp).unwrap();
        for k in 0..dp.mips() {
            let (s, _) = dp.level_size(k);
            let got = dp.download_level(&ctx, k).unwrap();
            for layer in 0..2u32 {
                let c = if layer == 0 { 1.0 } else { 1e5 };
                for idx in 0..(s * s) {
                    let g = got[(layer * s * s + idx) as usize];
                    if g[3] > 0.0 {
                        let v = g[1] / g[3];
                        assert!(
                            ((v - c) / c).abs() < 1e-6,
                            "level {k} layer {layer} texel {idx}: {v}"
                        );
                    }
                }
            }
        }
    }
    common::finish(ctx);
}
