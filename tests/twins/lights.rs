//! The lights pass against its float64 twin (`math::lights::light_sum`).
//! `tests/lights.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{max_of, Errors};
use envlight::gpu::Context;
use envlight::math::exact::ExactFilter;
use envlight::math::lights::{
    cluster_irradiance, clusters, diffuse_options, extract, light_sum, prepare, ExtractOptions,
    LightKernel, CLUSTER_GRID, DIFFUSE_RATIO,
};
use envlight::math::split_sum::chain_norm;
use envlight::math::synth::Sky;
use envlight::math::{Coord, Mapping, Orientation};
use envlight::passes::{GpuLights, LightsPass, SplitSum};
use envlight::EnvMap;
use glam::DVec3;

/// The bound [`check`] holds each texel to, relative to the level's largest.
pub const BOUND: f64 = 1e-5;

pub fn sky(mapping: Mapping, size: u32) -> EnvMap {
    let sky = Sky::default();
    let (w, h) = mapping.extent_for_size(size);
    EnvMap::from_fn(mapping, w, h, 2, move |d| sky.radiance(d))
}

/// Every texel of a 16² cube level (and an 8² one) against the twin, for the cosine and GGX
/// α 0.02 (a lobe far narrower than the 64-wide maps' texels: every node counts) and 0.3, the
/// map turned 30° and mirrored. Bound 1e-5 of the level's largest texel: float32 sums of a few
/// hundred terms (measured: printed).
pub fn check(ctx: &Context) {
    let pass = LightsPass::new(ctx).unwrap();
    let o = Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 30.0,
    };
    let f2w = o.world_to_file().transpose();
    for mapping in [Mapping::LatLong, Mapping::Angular] {
        let map = sky(mapping, 64);
        let ex = extract(&map, &ExtractOptions::default());
        assert!(!ex.lights.is_empty());
        let prepared = prepare(&map, &ex, f2w, 0.02);
        let gpu = GpuLights::upload(ctx, &prepared).unwrap();
        for kernel in [
            LightKernel::Cosine,
            LightKernel::Ggx { alpha: 0.02 },
            LightKernel::Ggx { alpha: 0.3 },
        ] {
            let cube = SplitSum::cube_chain(ctx, 16, 2).unwrap();
            let (levels, _) = ctx
                .run("lights test", |rec| {
                    rec.clear(&cube.image, [0.0; 4]);
                    pass.record(rec, &gpu, kernel, &cube, 0)?;
                    pass.record(rec, &gpu, kernel, &cube, 1)?;
                    Ok([cube.record_download(rec, 0)?, cube.record_download(rec, 1)?])
                })
                .unwrap();
            let norm = match kernel {
                LightKernel::Cosine => 1.0,
                LightKernel::Ggx { alpha } => chain_norm(alpha),
            };
            for (k, level) in levels.iter().enumerate() {
                let got = level.read();
                let s = 16u32 >> k;
                let want: Vec<[f64; 3]> = (0..6 * s * s)
                    .map(|t| {
                        let d = Mapping::Cube.coord_to_dir(Coord {
                            layer: t / (s * s),
                            u: ((t % s) as f64 + 0.5) / s as f64,
                            v: ((t / s % s) as f64 + 0.5) / s as f64,
                        });
                        light_sum(&prepared, d, kernel).map(|v| v / norm)
                    })
                    .collect();
                let top = max_of(want.iter().map(|w| w[1]));
                assert!(top > 0.0);
                let mut errors = Errors::new();
                for (t, (g, w)) in got.iter().zip(&want).enumerate() {
                    for c in 0..3 {
                        errors.abs(g[c], w[c], (t, c));
                    }
                }
                let worst = errors.worst();
                eprintln!("{mapping:?} {kernel:?} level {k}: {:.2e}", worst / top);
                assert!(
                    errors.count() == want.len() * 3 && worst < BOUND * top,
                    "{mapping:?} {kernel:?}: {worst:e} of {top:e} at {:?}",
                    errors.at()
                );
            }
        }
        drop(gpu);
    }
}
