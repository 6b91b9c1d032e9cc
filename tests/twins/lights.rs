//! The lights pass against its float64 twin (`math::lights::light_sum`).
//! `tests/lights.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{max_of, Errors};
use envlight::gpu::{Context, Timed};
use envlight::math::envmap::luminance;
use envlight::math::exact::ExactFilter;
use envlight::math::light_tree::LightTree;
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

/// Every texel of a 16² cube level (and an 8² one) against the twin, the light tree's sum
/// (`LightTree::sum`, what the pass walks), for the cosine and GGX α 0.02 (a lobe far
/// narrower than the 64-wide maps' texels: every node counts) and 0.3, the map (a sun, three
/// lamps, a row of seven and a column of five of different powers: light texels whose
/// quadratures the pass must tell apart, in groups the tree takes whole) turned 30° and
/// mirrored; on a cleared level (the tree's geometric rule alone) and on a level already
/// holding a residual (whose luminance sets each node's allowed error); the texels prepared
/// with one quadrature for all kernels and with the coarser ones kept (`prepare_local`, a
/// bake's: cells from the kernel's scale at each texel, which must pick some coarser set
/// here); the list read through its texel view and, once, as a storage buffer
/// (`read_as_storage`: the path for lists beyond maxTexelBufferElements). Bound 1e-5 of the
/// level's largest texel: float32 sums of a few hundred terms (measured: printed). The tree's
/// sums must differ from the texels one by one somewhere by more than that bound, so that a
/// pass summing every texel fails.
pub fn check(ctx: &Context) {
    let pass = LightsPass::new(ctx).unwrap();
    let o = Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 30.0,
    };
    let f2w = o.world_to_file().transpose();
    for mapping in [Mapping::LatLong, Mapping::Angular] {
        // Besides the sun, lamps of different power apart from it and from each other.
        let mut map = sky(mapping, 64);
        let row = (30..37).map(|i| (i, 20, 300.0 * (i - 28) as f32));
        let column = (10..15).map(|j| (50, j, 800.0 * (j - 8) as f32));
        let lamps = [(20, 30, 2e4), (21, 30, 1e4), (44, 24, 5e3)];
        for (i, j, v) in lamps.into_iter().chain(row).chain(column) {
            assert!(mapping.texel_in_domain(map.width, map.height, i, j));
            map.texels[(j * map.width + i) as usize] = [v, 0.8 * v, 0.6 * v];
        }
        let ex = extract(&map, &ExtractOptions::default());
        assert!(ex.lights.len() >= 12, "{} light texels", ex.lights.len());
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
    let tree = LightTree::new(prepared.to_vec());
    let (mut coarser, mut apart) = (0, Vec::new());
    for kernel in [
        LightKernel::Cosine,
        LightKernel::Ggx { alpha: 0.02 },
        LightKernel::Ggx { alpha: 0.3 },
    ] {
        // Nothing, then a residual's colour: 0.3 of the level's largest light sum.
        for background in [0.0, 0.3] {
            apart.push(check_level(
                ctx,
                pass,
                &gpu,
                (&tree, prepared),
                kernel,
                background,
            ));
            eprintln!("{mapping:?} {rule} {kernel:?} background {background}");
        }
        coarser += coarser_taken(prepared, 16, kernel) + coarser_taken(prepared, 8, kernel);
    }
    let apart = max_of(apart);
    assert!(
        apart > BOUND,
        "{mapping:?} {rule}: the tree's sums equal the texels one by one ({apart:e})"
    );
    assert!(
        rule == "fixed" || coarser > 0,
        "{mapping:?}: the local rule took no coarser quadrature"
    );
    drop(gpu);
}

/// Levels 0 and 1 of a 16² cube, cleared to `background` × the largest light sum's
/// luminance (grey), with `gpu` (`prepared` in `tree`'s order) added by `kernel`, against
/// `tree`'s float64 sums (see [`check`]). Returns how far the tree's sums are from the
/// texels one by one, relative to each level's largest.
fn check_level(
    ctx: &Context,
    pass: &LightsPass,
    gpu: &GpuLights,
    (tree, prepared): (&LightTree, &[envlight::math::lights::PreparedLight]),
    kernel: LightKernel,
    background: f64,
) -> f64 {
    let norm = match kernel {
        LightKernel::Cosine => 1.0,
        LightKernel::Ggx { alpha } => chain_norm(alpha),
    };
    let dir = |s: u32, t: u32| {
        Mapping::Cube.coord_to_dir(Coord {
            layer: t / (s * s),
            u: ((t % s) as f64 + 0.5) / s as f64,
            v: ((t / s % s) as f64 + 0.5) / s as f64,
        })
    };
    // The residual's grey, from the largest brute sum over the finer level.
    let brute_top =
        max_of((0..6 * 256).map(|t| luminance(light_sum(prepared, dir(16, t), kernel))));
    let grey = (background * brute_top / norm) as f32;
    let cube = SplitSum::cube_chain(ctx, 16, 2).unwrap();
    let Timed { value: levels, .. } = ctx
        .run("lights test", |rec| {
            rec.clear(&cube.image, [grey, grey, grey, 0.0]);
            pass.record(rec, gpu, kernel, &cube, 0)?;
            pass.record(rec, gpu, kernel, &cube, 1)?;
            Ok([cube.record_download(rec, 0)?, cube.record_download(rec, 1)?])
        })
        .unwrap();
    let g = grey as f64;
    let mut apart = Vec::new();
    for (k, level) in levels.iter().enumerate() {
        let got = level.read();
        let s = 16u32 >> k;
        let estimate = luminance([g; 3]) * norm;
        let want: Vec<[f64; 3]> = (0..6 * s * s)
            .map(|t| tree.sum(dir(s, t), kernel, estimate).map(|v| g + v / norm))
            .collect();
        let brute: Vec<[f64; 3]> = (0..6 * s * s)
            .map(|t| light_sum(prepared, dir(s, t), kernel).map(|v| g + v / norm))
            .collect();
        let top = max_of(want.iter().map(|w| w[1]));
        assert!(top > g);
        let mut errors = Errors::new();
        let mut gap = Errors::new();
        for (t, ((x, w), b)) in got.iter().zip(&want).zip(&brute).enumerate() {
            for c in 0..3 {
                errors.abs(x[c], w[c], (t, c));
                gap.abs(b[c], w[c], (t, c));
            }
        }
        let worst = errors.worst();
        apart.push(gap.worst() / top);
        eprintln!(
            "{kernel:?} background {background} level {k}: {:.2e} (tree to texels {:.2e})",
            worst / top,
            gap.worst() / top
        );
        assert!(
            errors.count() == want.len() * 3 && worst < BOUND * top,
            "{kernel:?} background {background} level {k}: {worst:e} of {top:e} at {:?}",
            errors.at()
        );
    }
    max_of(apart)
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
