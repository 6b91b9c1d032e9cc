//! The GPU light extraction against its float64 twin (`math::lights::extract`), its residual
//! clamped and filled.
//! `tests/extract.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::Errors;
use envlight::gpu::{Context, Timed};
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

/// The bound on each light's solid angle, relative (to at least 1% of the map's mean
/// texel's): float32 texel rules, the clipped one at an angular rim measured at 1.0e-5.
pub const OMEGA_BOUND: f64 = 3e-5;

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
    let Timed {
        value: got,
        timings: t,
    } = ex.run(map, opts).unwrap();
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
    let texels = map.width as f64 * map.height as f64 * map.mapping.layers() as f64;
    let mean_omega = 4.0 * std::f64::consts::PI / texels;
    // Solid angles apart: a texel at an angular map's rim takes the clipped rule, whose
    // float32 sum errs by up to ~1e-5 of it (a sliver's, of 1% of the mean texel's).
    let mut omegas = Errors::new();
    // With a fill, a grown texel whose filled residual all but equals its own value holds an
    // excess of float32 rounding that either side may keep or not.
    let slight = |excess: [f32; 3], y: f64| {
        opts.fill.is_some() && luminance(excess.map(f64::from)).abs() < NEAR * y
    };
    let mut matched = 0;
    for g in &got.lights {
        let [layer, i, j] = g.texel;
        let Some(h) = host.get(&g.texel) else {
            assert!(
                near(g.luminance as f64) || slight(g.excess, g.luminance as f64),
                "GPU light {:?} (Y {}, excess {:?}) not the host's",
                g.texel,
                g.luminance,
                g.excess
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
        omegas.rel(g.omega, h.omega, 0.01 * mean_omega, ("omega", layer, i, j));
    }
    let gpu_set: std::collections::HashSet<_> = got.lights.iter().map(|g| g.texel).collect();
    for h in &want.lights {
        let y = luminance(map.texel(h.layer, h.i, h.j).map(f64::from));
        assert!(
            gpu_set.contains(&[h.layer, h.i, h.j]) || near(y) || slight(h.radiance, y),
            "host light {:?} (Y {y}, excess {:?}) missing on the GPU",
            (h.layer, h.i, h.j),
            h.radiance
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
        "extract {:?} {}x{} ratio {} cap {} fill {:?}: {} lights ({} above τ; grown {}, \
         {} members, {} rounds), worst {:.2e} at {:?}",
        map.mapping,
        map.width,
        map.height,
        opts.ratio,
        opts.max_texels,
        opts.fill,
        got.lights.len(),
        got.stats.candidates,
        got.stats.grown,
        got.stats.members,
        got.stats.rounds,
        errors.worst(),
        errors.at()
    );
    errors.assert_within(BOUND, "GPU light extraction");
    omegas.assert_within(OMEGA_BOUND, "GPU light extraction's solid angles");
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
    let Timed {
        value: levels,
        timings: t,
    } = ctx
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

/// A lat-long map whose light straddles the seam (u = 0): a glow 10° wide centred 1.3 of a
/// 64-wide map's texels past it (off the seam, so that the fill's rounds reach the texels on
/// its two sides in different rounds), on a graded sky.
pub fn seam_sky(w: u32, h: u32) -> EnvMap {
    let seam = Mapping::LatLong.coord_to_dir(envlight::math::Coord {
        layer: 0,
        u: 1.3 / 64.0,
        v: 0.45,
    });
    EnvMap::from_fn(Mapping::LatLong, w, h, 2, move |d| {
        let g = 300.0 * (30.0 * (d.dot(seam) - 1.0)).exp();
        [0.5 + 0.3 * d.y + g, 0.6 + 0.2 * d.x + g, 0.7 + g]
    })
}

/// An angular map (`side` a side) with a broad glow (peak 200, about 18° wide) straight
/// behind, the direction the disc's rim stands for, on a graded sky.
pub fn rim_glow(side: u32) -> EnvMap {
    let behind = Mapping::Angular.coord_to_dir(envlight::math::Coord {
        layer: 0,
        u: 0.5,
        v: 0.999,
    });
    EnvMap::from_fn(Mapping::Angular, side, side, 2, move |d| {
        let g = 200.0 * (12.0 * (d.dot(behind) - 1.0)).exp();
        [0.5 + 0.3 * d.y + g, 0.6 + 0.2 * d.x + g, 0.7 + g]
    })
}

/// A cube whose face 2 is bright throughout (graded, 40–60× the others): its light set fills
/// the face, so no fill round reaches it and its residual is the threshold.
pub fn bright_face(side: u32) -> EnvMap {
    let mut map = EnvMap::from_fn(Mapping::Cube, side, side, 2, |d| {
        [1.0 + 0.2 * d.x, 1.1 + 0.1 * d.y, 0.9 + 0.1 * d.z]
    });
    let per = (side * side) as usize;
    for (k, t) in map.texels[2 * per..3 * per].iter_mut().enumerate() {
        let v = 40.0 + 20.0 * k as f32 / per as f32;
        *t = [v, v * 0.9, v * 1.1];
    }
    map
}

/// The filled extraction (the renderer's chain default, `ExtractOptions::fill`) against the
/// host's on every mapping's glow sky: two rings where the cap has room for them, one where it
/// has room for the first only, none where it has room for ring 0 alone or binds on the
/// candidates; on a light across a lat-long's seam; and on a cube face wholly in the light
/// set. Within [`BOUND`].
pub fn check_fill(ctx: &Context) {
    let ex = Extractor::new(ctx).unwrap();
    let opts = |max_texels, fill| ExtractOptions {
        ratio: 2.0,
        max_texels,
        fill: Some(fill),
    };
    let mut grown = Vec::new();
    for (mapping, size) in [
        (Mapping::LatLong, 64),
        (Mapping::Cube, 16),
        (Mapping::Angular, 48),
        (Mapping::DualParaboloid, 24),
    ] {
        let map = glow_sky(mapping, size);
        let (two, _) = compare(&ex, &map, &opts(8192, 2));
        assert!(two.stats.members > two.stats.candidates, "the set grew");
        // Room for ring 0 and ring 1's members: where every texel is its own source, ring 2
        // does not fit.
        let Timed { value: one, .. } = ex.run(&map, &opts(8192, 1)).unwrap();
        let (first, _) = compare(&ex, &map, &opts(one.stats.members as usize, 2));
        let (none, _) = compare(&ex, &map, &opts(two.stats.candidates as usize, 2));
        grown.push((
            mapping,
            [two.stats.grown, first.stats.grown, none.stats.grown],
        ));
        // Where the cap binds on the candidates themselves, ring 0 is found from every texel
        // (the candidates' list is incomplete).
        let (capped, _) = compare(&ex, &map, &opts(16, 2));
        assert!(capped.stats.candidates > 16 && capped.stats.members == 16);
    }
    eprintln!("rings grown (room for two, one, none): {grown:?}");
    for (mapping, g) in &grown {
        match mapping {
            Mapping::LatLong | Mapping::Cube => assert_eq!(g, &[2, 1, 0], "{mapping:?}"),
            _ => assert!(g[0] == 2 && g[2] == 0, "{mapping:?}: {g:?}"),
        }
    }
    let (seam, _) = compare(&ex, &seam_sky(64, 32), &opts(8192, 2));
    let w = 64;
    assert!(
        seam.lights.iter().any(|l| l.texel[1] == 0)
            && seam.lights.iter().any(|l| l.texel[1] == w - 1),
        "the light spans the seam"
    );
    // An angular map's light at its rim: positions outside the disc read texels inside it,
    // so the rings' records outnumber their members and the cap counts the records.
    let rim = rim_glow(48);
    let (rims, _) = compare(&ex, &rim, &opts(8192, 2));
    let reads_another = |t: &[u32; 3]| {
        Mapping::Angular.integration_source(48, 48, t[1], t[2]) != Some((t[1], t[2]))
    };
    let readers = rims
        .lights
        .iter()
        .filter(|l| reads_another(&l.texel))
        .count();
    assert!(readers > 0, "rim positions among the lights");
    // Room for the members of ring 1 but not for their rim records: the host's rule grows
    // by fewer rings than the members alone would allow.
    let Timed { value: one, .. } = ex.run(&rim, &opts(8192, 1)).unwrap();
    let (tight, _) = compare(&ex, &rim, &opts(one.stats.members as usize, 2));
    eprintln!(
        "angular rim: {readers} of {} lights read another texel; room for ring 1's members: \
         grown {}",
        rims.lights.len(),
        tight.stats.grown
    );
    assert_eq!(tight.stats.grown, 0, "ring 1's rim records do not fit");
    let (face, _) = compare(&ex, &bright_face(8), &opts(8192, 2));
    let thr = face.stats.threshold;
    let y = luminance(face.residual.texel(2, 3, 4).map(f64::from));
    assert!(
        (y - thr as f64).abs() < BOUND * thr as f64,
        "an unreached texel's residual is the threshold: {y} vs {thr}"
    );
}
