//! The MIP chain pass (`passes::mip`): levels against the float64 box filter, and no step at the
//! dual paraboloid's rim.

mod common;
#[path = "twins/mip.rs"]
mod twin;

use envlight::math::Mapping;
use envlight::passes::mip::MipChain;
use envlight::EnvMap;
use envlight::GpuEnvMap;

/// Every level of a smooth map's chain equals the float64 solid-angle-weighted box filter of
/// level 0 (power of two: straight from level 0; odd sizes: the float64 twin's fractional
/// footprints), within 2e-6 relative: float32 sums of at most 9 terms per level.
#[test]
fn mip_levels_match_the_float64_box_filter() {
    let ctx = common::ctx();
    twin::check(&ctx);
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
