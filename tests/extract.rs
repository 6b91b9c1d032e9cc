//! Light extraction on the GPU (`passes::extract`): against the float64 twin on every mapping,
//! the cap's exact threshold with ties, power conserved, non-finite texels, resources reused
//! from frame to frame, and refused inputs.

mod common;
#[path = "twins/extract.rs"]
mod twin;

use envlight::gpu::{Buffer, Image, ImageDesc, Timed};
use envlight::math::envmap::luminance;
use envlight::math::lights::{extract, ExtractOptions};
use envlight::math::Mapping;
use envlight::passes::map::{map_desc, FORMAT};
use envlight::passes::{Extractor, GpuEnvMap, GpuExtraction};
use envlight::EnvMap;

/// Every mapping's sun sky, uncapped and capped, within 1e-5 of the host's rule (see the twin).
#[test]
fn extraction_matches_the_float64_twin_on_every_mapping() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// The residual filled under grown lights, as renders extract for FIS, split-sum and footprint
/// lookups: every mapping, rings that fit and rings that do not, the lat-long seam, a layer
/// no fill round reaches (see the twin).
#[test]
fn filled_extraction_matches_the_float64_twin_on_every_mapping() {
    let ctx = common::ctx();
    twin::check_fill(&ctx);
    common::finish(ctx);
}

/// A lat-long map with 900 distinct bright texels and a plateau of 41 equal ones where the cap
/// falls: the GPU keeps exactly the host's texels (all brighter than the plateau, none of it,
/// as the host's strict rule does), its threshold is the plateau's luminance, the texels the
/// cap leaves out stay whole in the residual and are counted, and power is conserved.
#[test]
fn the_cap_keeps_the_host_texels_and_counts_the_rest() {
    let ctx = common::ctx();
    let (w, h) = (64u32, 32u32);
    let mut texels = vec![[0.2f32, 0.3, 0.4]; (w * h) as usize];
    // 900 bright texels, luminance rising in steps of 0.37 from 50 (all distinct); the
    // plateau: 40 more at the luminance of the 250th brightest, so the 256th falls in it.
    for k in 0..900usize {
        let v = 50.0 + k as f32 * 0.37;
        texels[(k * 2 + 100) % (w * h) as usize] = [v, v * 0.9, v * 0.8];
    }
    let plateau = texels[(650 * 2 + 100) % (w * h) as usize];
    for k in 0..40usize {
        texels[k * 13 + 1] = plateau;
    }
    let map = EnvMap::new(Mapping::LatLong, w, h, texels);
    let opts = ExtractOptions {
        ratio: 2.0,
        max_texels: 256,
        fill: None,
    };
    let ex = Extractor::new(&ctx).unwrap();
    let Timed { value: got, .. } = ex.run(&map, &opts).unwrap();
    let want = extract(&map, &opts);
    let y_plateau = luminance(plateau.map(f64::from));
    assert!(
        (want.threshold - y_plateau).abs() < 1e-9 * y_plateau,
        "the plateau sets the host's threshold"
    );
    assert!(want.lights.len() < 256, "ties at the cap are all left out");
    let mut g: Vec<_> = got.lights.iter().map(|l| l.texel).collect();
    let mut w_: Vec<_> = want.lights.iter().map(|l| [l.layer, l.i, l.j]).collect();
    g.sort_unstable();
    w_.sort_unstable();
    assert_eq!(g, w_, "the GPU keeps the host's light texels");
    let rel = (got.stats.threshold as f64 - y_plateau).abs() / y_plateau;
    assert!(
        rel < 1e-6,
        "threshold {} vs {y_plateau}",
        got.stats.threshold
    );
    let above_tau = map
        .texels
        .iter()
        .filter(|t| luminance(t.map(f64::from)) > got.stats.tau as f64)
        .count();
    assert_eq!(
        got.stats.candidates as usize, above_tau,
        "every texel above τ counted"
    );
    assert_eq!(got.stats.kept as usize, want.lights.len());
    let groups = got
        .stats
        .kept
        .div_ceil(common::abi::lights::EXTRACT_LIGHT_GROUP);
    assert_eq!(
        got.stats.light_groups,
        [groups, 1, 1],
        "the records' indirect arguments"
    );
    eprintln!(
        "cap 256: {} texels above τ {}, {} kept, threshold {}",
        got.stats.candidates, got.stats.tau, got.stats.kept, got.stats.threshold
    );
    assert!(
        got.stats.candidates > 256 && got.stats.candidates - got.stats.kept >= 41,
        "the cap binds and what it leaves out is counted"
    );
    // Left out by the cap: whole in the residual.
    for (k, (r, t)) in got.residual.texels.iter().zip(&map.texels).enumerate() {
        let y = luminance(t.map(f64::from));
        if y <= y_plateau {
            assert_eq!(r, t, "texel {k} at or below the threshold is kept whole");
        }
    }
    let (p, q) = (twin::power(&map), got.power());
    assert!((q - p).abs() < 1e-5 * p, "power {q} vs {p}");
    drop(ex);
    common::finish(ctx);
}

/// One frame's map holds a NaN and an infinite texel: they count as zero everywhere — in the
/// residual, in the SH projection's L00 and so in the mean — and are counted; the frame's
/// lights are the host's of the map with those texels zeroed, every record finite. The next
/// frame, written into the same image, extracts the clean map as the host does.
#[test]
fn nonfinite_texels_are_zero_and_counted_and_the_next_frame_recovers() {
    let ctx = common::ctx();
    let clean = twin::sky(Mapping::LatLong, 64);
    let mut texels: Vec<[f32; 4]> = clean
        .texels
        .iter()
        .map(|t| [t[0], t[1], t[2], 1.0])
        .collect();
    texels[70][1] = f32::NAN;
    texels[900][0] = f32::INFINITY;
    let map = GpuEnvMap::new(&ctx, "frame map", Mapping::LatLong, 64, 32).unwrap();
    let mut staging = Buffer::new(
        &ctx,
        "frame texels",
        (texels.len() * 16) as u64,
        ash::vk::BufferUsageFlags::TRANSFER_SRC,
        gpu_allocator::MemoryLocation::CpuToGpu,
    )
    .unwrap();
    staging.write(&texels);
    let ex = Extractor::new(&ctx).unwrap();
    let opts = ExtractOptions {
        ratio: 32.0,
        max_texels: 256,
        fill: None,
    };
    ctx.run("a broken frame's map", |rec| {
        rec.copy_buffer_to_image(&staging, &map.image, 0, true);
        Ok(())
    })
    .unwrap();
    let Timed { value: broken, .. } = ex.run_on(&map, &opts).unwrap();
    assert_eq!(broken.stats.nonfinite, 2, "both texels counted");
    assert!(broken
        .residual
        .texels
        .iter()
        .flatten()
        .all(|c| c.is_finite()));
    assert_eq!(broken.residual.texels[70], [0.0; 3]);
    assert_eq!(broken.residual.texels[900], [0.0; 3]);
    assert_eq!(
        broken.residual.texels[71], clean.texels[71],
        "the rest untouched"
    );
    let mut zeroed = clean.clone();
    zeroed.texels[70] = [0.0; 3];
    zeroed.texels[900] = [0.0; 3];
    let want = extract(&zeroed, &opts);
    assert!(!want.lights.is_empty());
    assert_eq!(broken.lights.len(), want.lights.len(), "the frame's lights");
    let rel = (broken.stats.threshold as f64 / want.threshold - 1.0).abs();
    assert!(rel < 1e-5, "threshold {rel:e} from the host's");
    for l in &broken.lights {
        assert!(l.excess.iter().chain(&l.dir).all(|c| c.is_finite()));
    }
    // The next frame: the clean map through the same resources.
    let up = ctx.run("the next frame's map", |rec| map.record_upload(rec, &clean));
    up.unwrap();
    let Timed { value: next, .. } = ex.run_on(&map, &opts).unwrap();
    let want = extract(&clean, &opts);
    assert_eq!(next.stats.nonfinite, 0);
    assert_eq!(next.lights.len(), want.lights.len(), "the sun is back");
    drop((ex, map, staging));
    common::finish(ctx);
}

/// An image without SAMPLED usage, and resources made for another size, are refused when the
/// pass records, naming the image; nothing reaches the device (validation stays silent).
#[test]
fn unusable_images_are_refused_naming_them() {
    let ctx = common::ctx();
    let ex = Extractor::new(&ctx).unwrap();
    let sh = Buffer::storage(&ctx, "sh", &[1.0f32; 3]).unwrap();
    let out = GpuExtraction::new(&ctx, Mapping::LatLong, 64, 32, 16).unwrap();
    let desc = ImageDesc {
        usage: ash::vk::ImageUsageFlags::STORAGE | ash::vk::ImageUsageFlags::TRANSFER_DST,
        ..map_desc(Mapping::LatLong, 64, 32, 1)
    };
    assert_eq!(desc.format, FORMAT);
    let unsampled = GpuEnvMap::from_image(
        Image::new(&ctx, "engine sky (storage only)", desc).unwrap(),
        Mapping::LatLong,
    );
    let err = ctx
        .run("refused", |rec| ex.record(rec, &unsampled, &sh, 32.0, &out))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("engine sky (storage only)") && err.contains("SAMPLED"),
        "{err}"
    );
    let other = GpuEnvMap::new(&ctx, "engine sky 128", Mapping::LatLong, 128, 64).unwrap();
    let err = ctx
        .run("refused", |rec| ex.record(rec, &other, &sh, 32.0, &out))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("engine sky 128") && err.contains("64 x 32"),
        "{err}"
    );
    assert!(GpuExtraction::new(&ctx, Mapping::Cube, 8, 8, 0).is_err());
    drop((ex, sh, out, unsampled, other));
    common::finish(ctx);
}

/// The GPU records gathered into clusters (`Extractor::record_clusters`) against the host's
/// `clusters` of the host's extraction (ratio 2, uncapped: a glow of dozens of texels across
/// several cells and the sun), on every mapping: the count of non-empty cells, and the
/// clusters' irradiance at 400 normals (what the shade pass adds) within 1e-5 of the largest
/// (float32 sums of float64 ones).
#[test]
fn gpu_clusters_match_the_host_clusters_on_every_mapping() {
    use envlight::math::lights::{
        cluster_irradiance, clusters, diffuse_options, Cluster, CLUSTER_GRID,
    };
    let ctx = common::ctx();
    {
        let extractor = Extractor::new(&ctx).unwrap();
        for mapping in Mapping::ALL {
            let map = twin::glow_sky(mapping, 32);
            let host_ex = extract(&map, &diffuse_options(2.0));
            let host = clusters(&host_ex, glam::DMat3::IDENTITY, CLUSTER_GRID);
            let opts = ExtractOptions {
                max_texels: map.texels.len(),
                ..diffuse_options(2.0)
            };
            let got = extractor.run_clusters(&map, &opts, CLUSTER_GRID).unwrap();
            let gpu: Vec<Cluster> = got
                .iter()
                .filter(|c| c.iter().flatten().any(|&x| x != 0.0))
                .map(|c| Cluster {
                    v: c.map(|v| glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)),
                })
                .collect();
            assert!(host.len() > 3, "{mapping:?}: {} clusters", host.len());
            assert_eq!(gpu.len(), host.len(), "{mapping:?}: non-empty cells");
            let mut errors = common::compare::Errors::new();
            let normals: Vec<glam::DVec3> = (0..400)
                .map(|k| {
                    let z = 1.0 - (2 * k + 1) as f64 / 400.0;
                    let phi = k as f64 * 2.399963;
                    let s = (1.0 - z * z).sqrt();
                    glam::DVec3::new(s * phi.cos(), z, s * phi.sin())
                })
                .collect();
            let want: Vec<[f64; 3]> = normals
                .iter()
                .map(|&n| cluster_irradiance(&host, n))
                .collect();
            let largest = common::compare::max_of(want.iter().map(|e| luminance(*e)));
            for (n, w) in normals.iter().zip(&want) {
                let g = cluster_irradiance(&gpu, *n);
                for ch in 0..3 {
                    errors.abs(g[ch] / largest, w[ch] / largest, (mapping, *n, ch));
                }
            }
            errors.assert_within(1e-5, "GPU light clusters");
        }
    }
    common::finish(ctx);
}

/// The GPU's preparation of its light records for the shade pass's walk
/// (`Extractor::record_prepare`) against the float64 twin on every mapping (a sun and a glow,
/// ratio 2 with the cap of 40 binding on a 64-texel map, directions turned by a rotation and
/// a mirror, 2 cells a side: 16 quadrature nodes a texel): the GPU's order of the texels is
/// the kept records' (each once) sorted by the spatial key, up to the few pairs float32
/// rounding may swap where keys are within a cell of the Morton grid (≤ 2 of 39 adjacent
/// pairs out of order by the float64 key); over that order the host prepares the same
/// records (`prepare_local`) and builds `LightTree::implicit`; every float of the texels, of
/// their coarser quadratures (`GpuLights::on_gpu_local`: 1 cell, 4 nodes, after the tree) and
/// of the tree's nodes, the end node included, agrees within 5e-6 relative to its own size,
/// floor 1 (measured 3.9e-7: float32 against float64), the nodes' sigma axes compared as the
/// covariance they stand for (their signs and, for a round node, their directions are a
/// basis's choice) within 5e-4 of 1e-4 rad² (measured 5.6e-5: differences of nearby
/// directions in float32).
#[test]
fn gpu_prepared_lights_match_the_float64_twin_on_every_mapping() {
    use envlight::math::light_tree::{LightTree, TREE_VEC4S};
    use envlight::math::lights::{gpu_list, prepare_local, LightTexel};
    use envlight::passes::GpuLights;
    let ctx = common::ctx();
    {
        let extractor = Extractor::new(&ctx).unwrap();
        let (room, cells) = (40u32, 2u32);
        let nodes = 4 * cells * cells;
        let f2w = glam::DMat3::from_rotation_y(0.7)
            * glam::DMat3::from_diagonal(glam::DVec3::new(-1.0, 1.0, 1.0));
        for mapping in Mapping::ALL {
            let map = twin::glow_sky(mapping, 64);
            let opts = ExtractOptions {
                ratio: 2.0,
                max_texels: room as usize,
                fill: None,
            };
            let lights = GpuLights::on_gpu_local(&ctx, room, nodes, 0).unwrap();
            let (ex, got) = extractor.run_prepared(&map, &opts, f2w, &lights).unwrap();
            let kept = ex.stats.kept;
            assert!(
                ex.stats.candidates > room && kept == room,
                "{mapping:?}: {:?}",
                ex.stats
            );
            let texel_of = |l: &envlight::passes::extract::GpuLightTexel| LightTexel {
                layer: l.texel[0],
                i: l.texel[1],
                j: l.texel[2],
                dir: glam::DVec3::new(l.dir[0] as f64, l.dir[1] as f64, l.dir[2] as f64),
                omega: l.omega as f64,
                radiance: l.excess,
            };
            // The GPU's order: each prepared texel's world direction names its record.
            let stride = lights.stride() as usize;
            let world = |l: &envlight::passes::extract::GpuLightTexel| {
                f2w * glam::DVec3::new(l.dir[0] as f64, l.dir[1] as f64, l.dir[2] as f64)
            };
            let mut order = Vec::new();
            for k in 0..kept as usize {
                let d = got[k * stride];
                let at = glam::DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
                let r = (0..ex.lights.len())
                    .min_by(|&a, &b| {
                        (world(&ex.lights[a]) - at)
                            .length()
                            .total_cmp(&(world(&ex.lights[b]) - at).length())
                    })
                    .unwrap();
                assert!(
                    (world(&ex.lights[r]) - at).length() < 1e-5,
                    "{mapping:?} texel {k}"
                );
                order.push(r);
            }
            let mut seen = order.clone();
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), kept as usize, "{mapping:?}: a record twice");
            let keys: Vec<u32> = order
                .iter()
                .map(|&r| spatial_key(world(&ex.lights[r])))
                .collect();
            let swapped = keys.windows(2).filter(|w| w[0] > w[1]).count();
            assert!(
                swapped <= 2,
                "{mapping:?}: {swapped} pairs out of order: {keys:?}"
            );
            let texels: Vec<LightTexel> = order.iter().map(|&r| texel_of(&ex.lights[r])).collect();
            let tree = LightTree::implicit(
                prepare_local(&map, &texels, f2w, cells),
                lights.tree_nodes(),
            );
            let want_texels = gpu_list(&tree.lights);
            let want_nodes = tree.gpu_nodes();
            assert_eq!(want_texels.len() as u32, kept * lights.stride());
            assert_eq!(
                want_nodes.len() as u32,
                20 * TREE_VEC4S,
                "2·10 − 1 nodes, the end"
            );
            let at = lights.tree_at() as usize;
            let mut errors = common::compare::Errors::new();
            let mut spread = common::compare::Errors::new();
            for (k, (g, w)) in got.iter().zip(&want_texels).enumerate() {
                for c in 0..4 {
                    errors.rel(g[c], w[c], 1.0, (mapping, "texel", k, c));
                }
            }
            let got_nodes = &got[at..at + want_nodes.len()];
            for (n, (g, w)) in got_nodes
                .chunks_exact(TREE_VEC4S as usize)
                .zip(want_nodes.chunks_exact(TREE_VEC4S as usize))
                .enumerate()
            {
                for v in [0, 1, 4] {
                    for c in 0..4 {
                        errors.rel(g[v][c], w[v][c], 1.0, (mapping, "node", n, 4 * v + c));
                    }
                }
                errors.rel(g[2][3], w[2][3], 1.0, (mapping, "node", n, 11));
                let cov = |a: &[[f32; 4]]| {
                    let (x, y) = (a[2], a[3]);
                    [0, 1, 2].map(|r| [0, 1, 2].map(|c| (x[r] * x[c] + y[r] * y[c]) as f64))
                };
                let (cg, cw) = (cov(g), cov(w));
                for r in 0..3 {
                    for c in 0..3 {
                        // The covariance is of order ρ² (1e-3 here): relative to 1e-4.
                        spread.rel(
                            1e4 * cg[r][c],
                            1e4 * cw[r][c],
                            1.0,
                            (mapping, "axes", n, 3 * r + c),
                        );
                    }
                }
            }
            // Each texel's coarser quadrature (1 cell: 4 nodes), in the texels' order after
            // everything else.
            let want_coarse: Vec<[f32; 4]> = tree
                .lights
                .iter()
                .flat_map(|t| t.coarse.iter())
                .map(|&(d, w)| [d.x as f32, d.y as f32, d.z as f32, w as f32])
                .collect();
            let coarse_at = lights.coarse_at() as usize;
            assert_eq!(want_coarse.len(), 4 * kept as usize);
            assert_eq!(coarse_at + want_coarse.len(), got.len(), "{mapping:?}");
            assert!(
                coarse_at >= at + want_nodes.len(),
                "{mapping:?}: {coarse_at}"
            );
            for (k, (g, w)) in got[coarse_at..].iter().zip(&want_coarse).enumerate() {
                for c in 0..4 {
                    errors.rel(g[c], w[c], 1.0, (mapping, "coarse", k, c));
                }
            }
            errors.assert_within(
                5e-6,
                "GPU-prepared light texels, coarser quadratures and tree",
            );
            spread.assert_within(5e-4, "GPU light tree's spread");
        }
    }
    common::finish(ctx);
}

/// Room for 16384 texels of 8 cells (256 nodes, 560 coarser ones) takes 215 MB with the
/// coarser quadratures, 67 MB without: `GpuLights::on_gpu_local` keeps them only where that
/// fits the device's storage range, and the buffer never passes it.
#[test]
fn coarser_quadratures_are_kept_only_within_the_storage_range() {
    use envlight::passes::GpuLights;
    let ctx = common::ctx();
    {
        let big = GpuLights::on_gpu_local(&ctx, 16384, 256, 0).unwrap();
        let range = ctx.info().max_storage_buffer_range;
        assert_eq!(big.coarse_at() == 0, 215_089_184 > range, "range {range}");
        assert!(big.buffer().size() <= range, "{}", big.buffer().size());
        let small = GpuLights::on_gpu_local(&ctx, 40, 16, 0).unwrap();
        assert!(small.coarse_at() > 0);
        assert_eq!(GpuLights::on_gpu(&ctx, 40, 16, 0).unwrap().coarse_at(), 0);
    }
    common::finish(ctx);
}

/// The GPU's own light texels summed into a cube level through the tree it builds over them
/// (`Extractor::record_prepare` into `GpuLights::on_gpu_local`, each texel's coarser
/// quadratures kept, then `LightsPass::record`, what `bench dynamic` adds to its irradiance
/// cube and GGX chain), against the same records one by one
/// (`Extractor::record_add`, held to the float64 twin in tests/lights.rs): a lat-long sun and
/// glow sky (ratio 2, room for 4096 texels of which the extraction keeps far fewer, so the
/// tree's room runs past its records), its directions turned, the level first cleared to a
/// grey (each tree node's allowed error is 1% of it) on a 32² cube's level 1; cosine and GGX
/// α 0.03 and 0.3. The tree's own error (nodes taken whole by their sigma points,
/// `TREE_BELOW`): worst texel within 5e-3 of the level's largest and relative RMS within 4e-3
/// (measured 1.6e-4–3.0e-3 and 1.4e-4–2.6e-3, the most at α 0.03, a lobe far narrower than these
/// 64-wide texels), and apart somewhere (the tree takes nodes whole). Faces 2–4 alone
/// (`record_faces`, a time slice): those faces equal the whole level's bit for bit, the
/// others keep the grey; faces past the sixth, or none, are refused by name.
#[test]
fn lights_summed_through_the_gpu_tree_match_the_texels_one_by_one() {
    use envlight::math::lights::LightKernel;
    use envlight::math::split_sum::chain_norm;
    use envlight::passes::{GpuLights, LightsPass, ShProjector, SplitSum, Subgroups};
    use gpu_allocator::MemoryLocation;
    let ctx = common::ctx();
    {
        let extractor = Extractor::new(&ctx).unwrap();
        let pass = LightsPass::new(&ctx).unwrap();
        let proj = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let map = twin::glow_sky(Mapping::LatLong, 64);
        let gpu = GpuEnvMap::upload(&ctx, &map).unwrap();
        let room = 4096;
        let ex = GpuExtraction::new(&ctx, map.mapping, map.width, map.height, room).unwrap();
        let lights = GpuLights::on_gpu_local(&ctx, room, 16, 0).unwrap();
        let l00 = Buffer::new(
            &ctx,
            "L00",
            ShProjector::output_bytes(0),
            ash::vk::BufferUsageFlags::STORAGE_BUFFER | ash::vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )
        .unwrap();
        let f2w = glam::DMat3::from_rotation_y(0.7);
        let opts = ExtractOptions {
            ratio: 2.0,
            max_texels: room as usize,
            fill: None,
        };
        let kept = extract(&map, &opts).lights.len();
        assert!(kept > 20 && kept < room as usize / 4, "{kept} light texels");
        let grey = 0.5f32;
        for kernel in [
            LightKernel::Cosine,
            LightKernel::Ggx { alpha: 0.03 },
            LightKernel::Ggx { alpha: 0.3 },
        ] {
            let norm = match kernel {
                LightKernel::Cosine => 1.0,
                LightKernel::Ggx { alpha } => chain_norm(alpha),
            };
            let cubes: Vec<GpuEnvMap> = (0..3)
                .map(|_| SplitSum::cube_chain(&ctx, 32, 2).unwrap())
                .collect();
            let Timed { value: levels, .. } = ctx
                .run("lights through the gpu tree", |rec| {
                    let o = envlight::math::Orientation::default();
                    proj.record_into(rec, &gpu, 0, &o, &l00)?;
                    extractor.record(rec, &gpu, &l00, 2.0, &ex)?;
                    extractor.record_prepare(rec, &ex, f2w, &lights)?;
                    for c in &cubes {
                        rec.clear(&c.image, [grey, grey, grey, 0.0]);
                    }
                    pass.record(rec, &lights, kernel, &cubes[0], 1)?;
                    extractor.record_add(rec, &ex, f2w, kernel, norm, &cubes[1], 1)?;
                    pass.record_faces(rec, &lights, kernel, &cubes[2], 1, 2..5)?;
                    cubes
                        .iter()
                        .map(|c| c.record_download(rec, 1))
                        .collect::<Result<Vec<_>, _>>()
                })
                .unwrap();
            let [tree, brute, slice] = [0, 1, 2].map(|k| levels[k].read());
            let top = common::compare::max_of(brute.iter().flat_map(|b| b[..3].to_vec()));
            let mut errors = common::compare::Errors::new();
            let mut s2 = 0.0;
            for (t, (a, b)) in tree.iter().zip(&brute).enumerate() {
                for c in 0..3 {
                    errors.abs(a[c], b[c], (t, c));
                    s2 += (b[c] as f64).powi(2);
                }
            }
            let apart = errors.worst() / top;
            let se = errors.rms().powi(2) * errors.count() as f64;
            let rms = (se / s2).sqrt();
            eprintln!(
                "{kernel:?}: tree against the texels one by one: worst {apart:.2e} of the \
                 largest ({top:.3e}), relative RMS {rms:.2e}"
            );
            assert!(apart < 5e-3 && rms < 4e-3, "{kernel:?}: {apart:e}, {rms:e}");
            assert!(apart > 0.0, "{kernel:?}: the tree took no node whole");
            let face = tree.len() / 6;
            for (t, (s, w)) in slice.iter().zip(&tree).enumerate() {
                let want = match (2..5).contains(&(t / face)) {
                    true => [w[0], w[1], w[2]],
                    false => [grey; 3],
                };
                assert_eq!(
                    s[..3],
                    want[..],
                    "{kernel:?}: texel {t} of face {}",
                    t / face
                );
            }
        }
        // A frame with no light texels (a flat map: none above twice the mean) through the
        // same buffers: its tree is the end node alone, which the preparation writes though
        // it starts no workgroup over records, so the last frame's sun adds nothing.
        let flat = EnvMap::from_fn(map.mapping, map.width, map.height, 1, |_| [0.3; 3]);
        assert!(extract(&flat, &opts).lights.is_empty());
        let flat_gpu = GpuEnvMap::upload(&ctx, &flat).unwrap();
        let cube = SplitSum::cube_chain(&ctx, 32, 2).unwrap();
        let Timed { value: level, .. } = ctx
            .run("no light texels through the gpu tree", |rec| {
                let o = envlight::math::Orientation::default();
                proj.record_into(rec, &flat_gpu, 0, &o, &l00)?;
                extractor.record(rec, &flat_gpu, &l00, 2.0, &ex)?;
                extractor.record_prepare(rec, &ex, f2w, &lights)?;
                rec.clear(&cube.image, [grey, grey, grey, 0.0]);
                pass.record(rec, &lights, LightKernel::Cosine, &cube, 1)?;
                cube.record_download(rec, 1)
            })
            .unwrap();
        let moved = level.read().iter().filter(|t| t[..3] != [grey; 3]).count();
        assert_eq!(moved, 0, "no light texels, yet {moved} texels moved");
        // Faces a cube has not, or none, are refused before anything is recorded.
        for faces in [4..7, 3..3] {
            let e = ctx
                .run("faces refused", |rec| {
                    pass.record_faces(rec, &lights, LightKernel::Cosine, &cube, 1, faces.clone())
                })
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.contains("faces") && e.contains("six"), "{faces:?}: {e:?}");
        }
    }
    common::finish(ctx);
}

/// The spatial key of `glsl/extract_prepare.comp` in float64: a Morton code over the
/// octahedral map of `d` (z folded), `TREE_KEY_AXIS_BITS` bits a side.
fn spatial_key(d: glam::DVec3) -> u32 {
    let n = d.x.abs() + d.y.abs() + d.z.abs();
    let (mut px, mut py) = (d.x / n, d.y / n);
    if d.z < 0.0 {
        let (sx, sy) = (
            if px >= 0.0 { 1.0 } else { -1.0 },
            if py >= 0.0 { 1.0 } else { -1.0 },
        );
        (px, py) = ((1.0 - py.abs()) * sx, (1.0 - px.abs()) * sy);
    }
    use envlight::math::light_tree::TREE_KEY_AXIS_BITS as BITS;
    let side = (1u32 << BITS) as f64;
    let q = |p: f64| ((p * 0.5 + 0.5) * side).clamp(0.0, side - 1.0) as u32;
    let spread = |v: u32| (0..BITS).map(|b| ((v >> b) & 1) << (2 * b)).sum::<u32>();
    spread(q(px)) | (spread(q(py)) << 1)
}
