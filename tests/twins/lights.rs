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
/// map (a sun and three lamps) turned 30° and mirrored; the texels prepared with one
/// quadrature for all kernels and with the coarser ones kept (`prepare_local`, a bake's:
/// cells from the kernel's scale at each texel, which must pick some coarser set here); the
/// list read through its texel view and, once, as a storage buffer (`read_as_storage`: the
/// path for lists beyond maxTexelBufferElements). Bound
/// 1e-5 of the level's largest texel: float32 sums of a few hundred terms (measured: printed).
pub fn check(ctx: &Context) {
    let pass = LightsPass::new(ctx).unwrap();
    let o = Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 30.0,
    };
    let f2w = o.world_to_file().transpose();
    for mapping in [Mapping::LatLong, Mapping::Angular] {
        // Besides the sun, three lamps of different power apart from it and from each
        // other: light texels whose quadratures the pass must tell apart.
        let mut map = sky(mapping, 64);
        for (i, j, v) in [(20, 30, 2e4), (21, 30, 1e4), (44, 24, 5e3)] {
            assert!(mapping.texel_in_domain(map.width, map.height, i, j));
            map.texels[(j * map.width + i) as usize] = [v, 0.8 * v, 0.6 * v];
        }
        let ex = extract(&map, &ExtractOptions::default());
        assert!(ex.lights.len() >= 4, "{} light texels", ex.lights.len());
        let local = envlight::math::lights::prepare_local(
            &map,
            &ex.lights,
            f2w,
            envlight::math::lights::cells_for(&ex, 0.02),
        );
        // The list through its texel view, and (the local one) as a storage buffer too.
        check_prepared(ctx, &pass, mapping, &prepare(&map, &ex, f2w, 0.02), false);
        check_prepared(ctx, &pass, mapping, &local, false);
        check_prepared(ctx, &pass, mapping, &local, true);
    }
}

fn check_prepared(
    ctx: &Context,
    pass: &LightsPass,
    mapping: Mapping,
    prepared: &[envlight::math::lights::PreparedLight],
    storage: bool,
) {
    let rule = match (prepared[0].coarse.is_empty(), storage) {
        (true, _) => "fixed",
        (false, false) => "local",
        (false, true) => "local, as storage",
    };
    let gpu = GpuLights::upload(ctx, prepared).unwrap();
    let gpu = match storage {
        true => gpu.read_as_storage(),
        false => gpu,
    };
    let mut coarser = 0;
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
                    light_sum(prepared, d, kernel).map(|v| v / norm)
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
            eprintln!(
                "{mapping:?} {rule} {kernel:?} level {k}: {:.2e}",
                worst / top
            );
            assert!(
                errors.count() == want.len() * 3 && worst < BOUND * top,
                "{mapping:?} {rule} {kernel:?}: {worst:e} of {top:e} at {:?}",
                errors.at()
            );
            coarser += coarser_taken(prepared, s, kernel);
        }
    }
    assert!(
        rule == "fixed" || coarser > 0,
        "{mapping:?}: the local rule took no coarser quadrature"
    );
    drop(gpu);
}

/// How many (texel, light texel) pairs of a level `s` a side integrate by a quadrature
/// coarser than the light texel's own.
fn coarser_taken(
    prepared: &[envlight::math::lights::PreparedLight],
    s: u32,
    kernel: LightKernel,
) -> usize {
    use envlight::math::lights::{local_nodes, scale_at};
    let scale = match kernel {
        LightKernel::Cosine => 1.0,
        LightKernel::Ggx { alpha } => alpha,
    };
    let mut n = 0;
    for t in 0..6 * s * s {
        let r = Mapping::Cube.coord_to_dir(Coord {
            layer: t / (s * s),
            u: ((t % s) as f64 + 0.5) / s as f64,
            v: ((t / s % s) as f64 + 0.5) / s as f64,
        });
        for l in prepared {
            let w = scale_at(scale, (r - l.dir).length());
            n += (local_nodes(l, w).len() < l.nodes.len()) as usize;
        }
    }
    n
}
