//! The SH projection pass against the float64 projection, with both reductions.
//! `tests/sh_project.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::worst_vs_cpu;
use envlight::gpu::{Context, Timed};
use envlight::math::sh;
use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use std::f64::consts::PI;

/// The bound [`check`] holds every coefficient to, relative to |L00|.
pub const BOUND: f64 = 1e-5;

pub fn gpu_project(ctx: &Context, p: &ShProjector, map: &EnvMap, lmax: u32) -> Vec<[f64; 3]> {
    let g = GpuEnvMap::upload(ctx, map).unwrap();
    let Timed {
        value: c,
        timings: t,
    } = p.run(&g, lmax).unwrap();
    assert_eq!(t.len(), 2);
    c.coeffs
}

/// Both reductions (subgroup arithmetic and the shared-memory tree) on a map that is not
/// constant: a sun ~1e5 times the sky, orders 2 and 8, each against the float64 projection.
/// A reduction that dropped or doubled one workgroup's partial sum would move the
/// coefficients by far more than 1e-5 of L00 (the f32 bound the 4k test measures).
pub fn check(ctx: &Context) {
    let map = EnvMap::from_fn(Mapping::LatLong, 512, 256, 1, |d| {
        Sky::default().radiance(d)
    });
    assert!(map.stats().max_luminance > 1e4);
    if !crate::common::require(ctx.info().subgroup_arithmetic, "subgroup arithmetic") {
        return;
    }
    for sg in [Subgroups::Auto, Subgroups::Off] {
        let p = ShProjector::new(ctx, sg).unwrap();
        assert_eq!(p.uses_subgroups(), sg == Subgroups::Auto);
        for order in [2, 8] {
            let cpu = sh::project(&map, order);
            let gpu = gpu_project(ctx, &p, &map, order);
            let e = worst_vs_cpu(&gpu, &cpu);
            eprintln!("{sg:?} order {order}: worst |GPU - f64| / |L00| = {e:.2e}");
            assert!(e < BOUND, "{sg:?} order {order}: {e:e}");
        }
    }
}
