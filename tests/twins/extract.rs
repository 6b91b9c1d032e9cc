//! The GPU light extraction against its float64 twin (`math::lights::extract`, no fill).
//! `tests/extract.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::Errors;
use envlight::gpu::Context;
use envlight::math::envmap::luminance;
use envlight::math::lights::{extract, light_sum_local, ExtractOptions, LightKernel};
use envlight::math::split_sum::chain_norm;
use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::math::Orientation;
use envlight::passes::extract::Extracted;
use envlight::passes::Extractor;
use envlight::passes::{GpuEnvMap, GpuExtraction, ShProjector, SplitSum, Subgroups};
use envlight::EnvMap;
use std::collections::HashMap;

/// Invocations a workgroup of the records' indirect arguments counts.
const GROUP: u32 = crate::common::abi::lights::EXTRACT_LIGHT_GROUP;

/// The bound [`check`] holds the threshold, every light's excess (relative to its luminance)
/// and every residual texel (relative to the threshold) to: the GPU's mean is the SH
/// projection's float32 L00 (within ~1e-6 of the float64 sum) and its luminances are float32.
pub const BOUND: f64 = 1e-5;

/// Texels whose luminance lies this close (relative) to the threshold may fall on either side
/// of it in float32 and float64; they are left out of the set comparison and counted.
pub const NEAR: f64 = 1e-5;

/// The sun sky at `size` in `mapping`, its sun 3° across (at least a sample of every map
/// here falls in it) at 5·10⁴ times the zenith.
pub fn sky(mapping: Mapping, size: u32) -> EnvMap {
    sky_with(mapping, size, 3.0, 5e4)
}

/// A sky whose sun is `radius_deg` in radius and `ratio` times the zenith.
pub fn sky_with(mapping: Mapping, size: u32, radius_deg: f64, ratio: f64) -> EnvMap {
    let sky = Sky {
        sun_radius: radius_deg.to_radians(),
        sun_ratio: ratio,
        ..Sky::default()
    };
    let (w, h) = mapping.extent_for_size(size);
    EnvMap::from_fn(mapping, w, h, 2, move |d| sky.radiance(d))
}

/// [`sky`] with a broad glow (peak 200, about 13° wide) low in the west: dozens of texels
/// above twice the mean luminance, graded (no plateau for the cap to fall in).
pub fn glow_sky(mapping: Mapping, size: u32) -> EnvMap {
    let sky = Sky {
        sun_radius: 3f64.to_radians(),
        ..Sky::default()
    };
    let glow = glam::DVec3::new(-0.8, 0.2, 0.3).normalize();
    let (w, h) = mapping.extent_for_size(size);
    EnvMap::from_fn(mapping, w, h, 2, move |d| {
        let g = 200.0 * (20.0 * (d.dot(glow) - 1.0)).exp();
        sky.radiance(d).map(|c| c + g)
    })
}

/// Power of a map: Σ Y·ω over the texels that hold the sphere.
pub fn power(map: &EnvMap) -> f64 {
    luminance(map.power())
}

/// The GPU extraction of `map` by `opts` against the host's: the threshold, the set of light
/// texels (but for those within [`NEAR`] of the threshold), each light's excess, direction and
/// solid angle, every residual texel, and power conserved. Returns the worst error.
pub fn compare(ex: &Extractor, map: &EnvMap, opts: &ExtractOptions) -> (Extracted, f64) {
    let (got, t) = ex.run(map, opts).unwrap();
    assert!(t.iter().any(|t| t.label == "extract lights"));
    let want = extract(map, opts);
    let thr = want.threshold;
    assert!(
        thr.is_finite() && !want.lights.is_empty(),
        "a map with lights: {:?} threshold {thr}, max luminance {}, power {}",
        map.mapping,
        crate::common::compare::max_of(map.texels.iter().map(|t| luminance(t.map(f64::from)))),
        power(map)
    );
    let mut errors = Errors::new();
    errors.rel(got.stats.threshold, thr, 0.0, ("threshold", 0, 0, 0));
    assert_eq!(got.stats.kept as usize, got.lights.len(), "kept = records");
    let groups = [got.stats.kept.div_ceil(GROUP), 1, 1];
    assert_eq!(
        got.stats.light_groups, groups,
        "the records' indirect arguments"
    );
    let host: HashMap<[u32; 3], _> = want
        .lights
        .iter()
        .map(|l| ([l.layer, l.i, l.j], l))
        .collect();
    let near = |y: f64| ((y - thr) / thr).abs() < NEAR;
    let mut matched = 0;
    for g in &got.lights {
        let [layer, i, j] = g.texel;
        let Some(h) = host.get(&g.texel) else {
            assert!(
                near(g.luminance as f64),
                "GPU light {:?} (Y {}) not the host's",
                g.texel,
                g.luminance
            );
            continue;
        };
        matched += 1;
        let y = luminance(map.texel(layer, i, j).map(f64::from)).max(g.luminance as f64);
        for c in 0..3 {
            errors.add(
                ((g.excess[c] - h.radiance[c]) as f64).abs() / y,
                ("excess", layer, i, j),
            );
            errors.abs(g.dir[c], h.dir[c], ("dir", layer, i, j));
        }
        errors.rel(g.omega, h.omega, 0.0, ("omega", layer, i, j));
    }
    let gpu_set: std::collections::HashSet<_> = got.lights.iter().map(|g| g.texel).collect();
    for h in &want.lights {
        let y = luminance(map.texel(h.layer, h.i, h.j).map(f64::from));
        assert!(
            gpu_set.contains(&[h.layer, h.i, h.j]) || near(y),
            "host light {:?} missing on the GPU",
            (h.layer, h.i, h.j)
        );
    }
    assert!(matched > 0 && matched + 4 >= want.lights.len());
    for (k, (g, w)) in got
        .residual
        .texels
        .iter()
        .zip(&want.residual.texels)
        .enumerate()
    {
        let y = luminance(map.texels[k].map(f64::from));
        if near(y) {
            continue;
        }
        for c in 0..3 {
            errors.add(
                ((g[c] - w[c]) as f64).abs() / thr,
                ("residual", k as u32, c as u32, 0),
            );
        }
    }
    let (p, q) = (power(map), got.power());
    errors.rel(q, p, 0.0, ("power", 0, 0, 0));
    eprintln!(
        "extract {:?} {}x{} ratio {} cap {}: {} lights ({} above τ), worst {:.2e} at {:?}",
        map.mapping,
        map.width,
        map.height,
        opts.ratio,
        opts.max_texels,
        got.lights.len(),
        got.stats.candidates,
        errors.worst(),
        errors.at()
    );
    errors.assert_within(BOUND, "GPU light extraction");
    let worst = errors.worst();
    (got, worst)
}

/// The extraction's lights of `map` added to a 16² cube (the cosine into level 0, GGX α
/// `alpha` into level 1), the map turned 30° and mirrored, against the float64 sums of the
/// host's extraction (`light_sum_local`, each texel's nodes as fine as the kernel's scale
/// there asks); returns the worst texel error relative to the
/// level's largest.
pub fn compare_add(
    ctx: &Context,
    ex: &Extractor,
    map: &EnvMap,
    opts: &ExtractOptions,
    alpha: f64,
) -> f64 {
    let o = Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 30.0,
    };
    let f2w = o.world_to_file().transpose();
    let gpu = GpuEnvMap::upload(ctx, map).unwrap();
    let out = GpuExtraction::new(
        ctx,
        map.mapping,
        map.width,
        map.height,
        opts.max_texels as u32,
    )
    .unwrap();
    let proj = ShProjector::new(ctx, Subgroups::Auto).unwrap();
    let sh = envlight::gpu::Buffer::new(
        ctx,
        "L00",
        ShProjector::output_bytes(0),
        ash::vk::BufferUsageFlags::STORAGE_BUFFER | ash::vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuOnly,
    )
    .unwrap();
    let cube = SplitSum::cube_chain(ctx, 16, 2).unwrap();
    let norm = chain_norm(alpha);
    let (levels, t) = ctx
        .run("adding extracted lights", |rec| {
            proj.record_into(rec, &gpu, 0, &Orientation::default(), &sh)?;
            ex.record(rec, &gpu, &sh, opts.ratio, &out)?;
            rec.clear(&cube.image, [0.0; 4]);
            ex.record_add(rec, &out, f2w, LightKernel::Cosine, 1.0, &cube, 0)?;
            ex.record_add(rec, &out, f2w, LightKernel::Ggx { alpha }, norm, &cube, 1)?;
            Ok([cube.record_download(rec, 0)?, cube.record_download(rec, 1)?])
        })
        .unwrap();
    assert!(t.iter().any(|t| t.label == "add lights"));
    let host = extract(map, opts);
    let mut worst = 0.0f64;
    for (level, (kernel, inv)) in [
        (LightKernel::Cosine, 1.0),
        (LightKernel::Ggx { alpha }, 1.0 / norm),
    ]
    .into_iter()
    .enumerate()
    {
        let side = 16u32 >> level;
        let got = levels[level].read();
        let want: Vec<[f64; 3]> = (0..6 * side * side)
            .map(|k| {
                let c = envlight::math::Coord {
                    layer: k / (side * side),
                    u: ((k % side) as f64 + 0.5) / side as f64,
                    v: ((k / side % side) as f64 + 0.5) / side as f64,
                };
                let r = Mapping::Cube.coord_to_dir(c);
                light_sum_local(map, &host, f2w, r, kernel).map(|v| v * inv)
            })
            .collect();
        let top = crate::common::compare::max_of(want.iter().map(|w| w[1]));
        let mut errors = Errors::new();
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                errors.abs(g[c], w[c], (level, k, c));
            }
        }
        let e = errors.worst() / top;
        eprintln!(
            "add lights {:?} {kernel:?}: {} lights, worst {e:.2e} of the largest at {:?}",
            map.mapping,
            host.lights.len(),
            errors.at()
        );
        assert!(e <= BOUND, "adding lights {kernel:?}: {e:e} > {BOUND:e}");
        worst = crate::common::compare::max_of([worst, e]);
    }
    drop((proj, out, gpu, sh, cube));
    worst
}

/// Each mapping's sun sky extracted as bakes do (32× the mean, at most 256: the sun alone),
/// and the sun sky with a broad glow as renders extract for diffuse techniques (2× the mean)
/// capped at 16, so that the cap binds and the threshold is the 17th brightest luminance:
/// within [`BOUND`].
pub fn check(ctx: &Context) {
    let ex = Extractor::new(ctx).unwrap();
    for (mapping, size) in [
        (Mapping::LatLong, 64),
        (Mapping::Cube, 16),
        (Mapping::Angular, 48),
        (Mapping::DualParaboloid, 24),
    ] {
        for (map, ratio, max_texels) in [
            (sky(mapping, size), 32.0, 256),
            (glow_sky(mapping, size), 2.0, 16),
        ] {
            let opts = ExtractOptions {
                ratio,
                max_texels,
                fill: None,
            };
            let (got, _) = compare(&ex, &map, &opts);
            assert!(ratio > 2.0 || got.stats.candidates > 16, "the cap binds");
            if mapping == Mapping::Cube || mapping == Mapping::Angular {
                compare_add(ctx, &ex, &map, &opts, 0.1);
            }
        }
    }
}
