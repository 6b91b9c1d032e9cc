//! The brute-force filter against the float64 convolution with the same per-texel rules.
//! `tests/brute.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{max_of, min_of, rel_err, Errors};
use envlight::gpu::{Context, Timed};
use envlight::math::filter::{self, at_centres, Kernel};
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::{Mapping, Orientation};
use envlight::passes::{BruteFilter, FilterTarget};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// The relative bound [`check`] holds the pass to.
pub const BOUND: f64 = 1e-4;

pub fn brute_gpu(
    ctx: &Context,
    pass: &BruteFilter,
    map: &EnvMap,
    kernel: Kernel,
    target: FilterTarget,
) -> EnvMap {
    let g = GpuEnvMap::upload(ctx, map).unwrap();
    let Timed {
        value: out,
        timings: t,
    } = pass
        .run(&g, &Orientation::default(), kernel, target)
        .unwrap();
    let spans: Vec<&str> = t.iter().map(|t| t.label.as_str()).collect();
    assert_eq!(spans[..2], ["brute prepare", "brute tiles"]);
    assert_eq!(spans.len(), 3);
    out.download(ctx).unwrap()
}

/// Worst per-texel relative difference over the texels the target mapping reads.
pub fn worst_relative(gpu: &EnvMap, cpu: &[[f64; 3]]) -> f64 {
    let (w, h) = (gpu.width, gpu.height);
    let mut errors = Errors::new();
    for (k, (g, c)) in gpu.texels.iter().zip(cpu).enumerate() {
        let (i, j) = ((k as u32 % (w * h)) % w, (k as u32 % (w * h)) / w);
        if !gpu.mapping.texel_in_domain(w, h, i, j) {
            continue;
        }
        for ch in 0..3 {
            errors.rel(g[ch], c[ch], 1e-30, (k, ch));
        }
    }
    assert!(errors.count() > 0, "no texel compared");
    errors.worst()
}

/// Brute-force irradiance and Phong prefilters of a 64×32 map against the float64
/// convolution with the same per-texel rules. Both sum the same ~2k texels; the GPU's error
/// is f32 rounding of node directions and kernel values (~1e-6 each, compensated sums), so
/// 1e-4 relative leaves two orders of margin while catching any rule that differs.
pub fn check(ctx: &Context) {
    let pass = BruteFilter::new(ctx).unwrap();
    let sky = Sky::default();
    let sources = [
        (
            "sky",
            EnvMap::from_fn(Mapping::LatLong, 64, 32, 4, |d| sky.radiance(d)),
        ),
        (
            "smooth",
            EnvMap::from_fn(Mapping::LatLong, 64, 32, 4, smooth_env),
        ),
        (
            "smooth cube",
            EnvMap::from_fn(Mapping::Cube, 12, 12, 4, smooth_env),
        ),
        (
            "smooth angular",
            EnvMap::from_fn(Mapping::Angular, 40, 40, 4, smooth_env),
        ),
        (
            "smooth dp",
            EnvMap::from_fn(Mapping::DualParaboloid, 20, 20, 4, smooth_env),
        ),
    ];
    for (name, map) in &sources {
        let kernels: &[Kernel] = if *name == "sky" || *name == "smooth" {
            &[
                Kernel::Cosine,
                Kernel::Phong { n: 1.0 },
                Kernel::Phong { n: 100.0 },
                Kernel::Phong { n: 1e3 },
                Kernel::Phong { n: 1e4 },
            ]
        } else {
            &[Kernel::Cosine, Kernel::Phong { n: 30.0 }]
        };
        for &kernel in kernels {
            for target in [
                FilterTarget {
                    to: Mapping::Cube,
                    size: 6,
                },
                FilterTarget {
                    to: Mapping::LatLong,
                    size: 16,
                },
            ] {
                let gpu = brute_gpu(ctx, &pass, map, kernel, target);
                let (w, h) = target.extent();
                let cpu = filter::filter_map(map, DMat3::IDENTITY, kernel, target.to, w, h);
                let worst = worst_relative(&gpu, &cpu);
                eprintln!("{name} {kernel:?} -> {:?}: worst {worst:.2e}", target.to);
                assert!(
                    worst < BOUND,
                    "{name} {kernel:?} {:?}: {worst:e}",
                    target.to
                );
            }
        }
    }
}
