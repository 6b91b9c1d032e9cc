//! Light records gathered into blocks of texels, so that a large map and the same content at
//! a smaller size extract the same lights: [`record_block`] picks the block for a map,
//! [`extract_blocks`] extracts by the clamp rule texel by texel and gathers each block's
//! excess into one record.

use super::{clamp_residual, ExtractOptions, Extraction, LightSet, LightTexel};
#[cfg(doc)]
use crate::abi::lights::RECORD_WIDTH;
use crate::math::envmap::luminance;
use crate::math::mapping::Mapping;
use crate::EnvMap;

/// The side, in texels, of the blocks whose light one record gathers on `map`, for records
/// no finer than a lat-long map `width` columns wide (`RECORD_WIDTH` in bakes): the
/// largest k dividing both sides of `map` that leaves the grid of blocks at least `width`
/// columns wide (lat-long) or a quarter of that a face (cube); 1 on smaller maps, on sizes
/// with no such divisor, and on the mappings whose rims read other texels (angular,
/// paraboloid).
pub fn record_block(map: &EnvMap, width: u32) -> u32 {
    let least = match map.mapping {
        Mapping::LatLong => width,
        Mapping::Cube => width / 4,
        Mapping::Angular | Mapping::DualParaboloid => return 1,
    };
    let most = (map.width / least.max(1)).max(1);
    (1..=most)
        .rev()
        .find(|k| map.width.is_multiple_of(*k) && map.height.is_multiple_of(*k))
        .unwrap_or(1)
}

/// An extraction whose records gather blocks of texels.
#[derive(Clone, Debug)]
pub struct BlockExtraction {
    /// The map the records index: a texel per block, holding the block's mean radiance
    /// (Σ L·Ω / Ω of the block), whose geometry (directions, solid angles, quadrature nodes)
    /// is the records'. `None`: the records are the map's own texels.
    pub grid: Option<EnvMap>,
    /// The records (each a block's excess over the residual, spread over the block: its
    /// power Σ (L − residual)·Ω over the block's texels, divided by the block's Ω), and the
    /// residual at the map's own resolution.
    pub extraction: Extraction,
}

/// [`super::extract`] of `map` with its light records gathered into `block` × `block` blocks
/// of texels. The rule is the clamp's, texel by texel: a texel whose luminance Y exceeds τ
/// = `ratio` × the mean keeps L·τ/Y in the residual, and its excess goes to its block's
/// record; the cap counts records, τ rising (as [`super::extract`]'s) until at most
/// `max_texels` blocks hold a light texel. A map repeating each texel of a smaller one
/// `block` × `block` times thus extracts that map's records and its residual, repeated.
/// Lights plus residual equal the map to float32 rounding of the records. Falls back to
/// [`super::extract`] (`grid` `None`) for a block of 1, a block not dividing both sides, a
/// mapping other than lat-long or cube, and a filled residual (`fill`).
pub fn extract_blocks(map: &EnvMap, opts: &ExtractOptions, block: u32) -> BlockExtraction {
    if !blocks_apply(map, opts, block) {
        return BlockExtraction {
            grid: None,
            extraction: super::extract(map, opts),
        };
    }
    let (grid, _, set) = block_lights(map, opts, block);
    BlockExtraction {
        grid: Some(grid),
        extraction: Extraction {
            residual: clamp_residual(map, set.threshold),
            threshold: set.threshold,
            lights: set.lights,
        },
    }
}

/// [`extract_block_lights`]' result: the records and the grids they go with.
#[derive(Clone, Debug)]
pub struct BlockLights {
    /// The grid of block means the records index ([`BlockExtraction::grid`]); `None`: the
    /// records are the map's own texels.
    pub grid: Option<EnvMap>,
    /// The residual's block means (Σ residual·Ω / Ω of each block: the grid less the
    /// records), beside `grid`.
    pub residual_grid: Option<EnvMap>,
    /// The threshold and the records.
    pub set: LightSet,
}

/// [`extract_blocks`]' grid and records without building its residual at the map's
/// resolution, which is [`clamp_residual`] of `map` at the threshold (every fallback's too,
/// as the bake's options have no `fill`; with one, [`super::extract_lights`]' rule holds),
/// and the residual's block means, which a bake converts instead of the residual.
pub fn extract_block_lights(map: &EnvMap, opts: &ExtractOptions, block: u32) -> BlockLights {
    if !blocks_apply(map, opts, block) {
        return BlockLights {
            grid: None,
            residual_grid: None,
            set: super::extract_lights(map, opts),
        };
    }
    let (grid, residual, set) = block_lights(map, opts, block);
    BlockLights {
        grid: Some(grid),
        residual_grid: Some(residual),
        set,
    }
}

/// The means of `map` over `block` × `block` blocks of texels (Σ L·Ω / Ω of each block, the
/// grid's texel's Ω being the block's exactly): the map at a lower resolution with the same
/// power in every block; and, for a finite `threshold`, the same of the map clamped at that
/// luminance ([`clamp_residual`], not built). `None` where [`extract_blocks`] would not
/// gather blocks (a block of 1, one not dividing both sides, a mapping other than lat-long
/// or cube).
pub fn block_means(map: &EnvMap, block: u32, threshold: f64) -> Option<(EnvMap, Option<EnvMap>)> {
    if !blocks_apply(map, &ExtractOptions::default(), block) {
        return None;
    }
    let (_, sums) = block_sums(map, block);
    let whole = grid_of(map, block, &sums);
    if !threshold.is_finite() {
        return Some((whole, None));
    }
    let (gw, gh) = (map.width / block, map.height / block);
    let mut kept = vec![[0.0f64; 3]; sums.len()];
    map.for_each_texel(|layer, i, j, t, omega| {
        let y = luminance(t.map(f64::from));
        let r = match y > threshold {
            true => t.map(|c| c * (threshold / y) as f32),
            false => t,
        };
        let s = &mut kept[((layer * gh + j / block) * gw + i / block) as usize];
        for c in 0..3 {
            s[c] += r[c] as f64 * omega;
        }
    });
    Some((whole, Some(grid_of(map, block, &kept))))
}

/// The map's luminance power and each block's Σ L·Ω, blocks in grid order.
fn block_sums(map: &EnvMap, block: u32) -> (f64, Vec<[f64; 3]>) {
    let (gw, gh) = (map.width / block, map.height / block);
    let block_of =
        |layer: u32, i: u32, j: u32| ((layer * gh + j / block) * gw + i / block) as usize;
    let mut power = 0.0;
    let mut sums = vec![[0.0f64; 3]; (gw * gh * map.layers()) as usize];
    map.for_each_texel(|layer, i, j, t, omega| {
        power += luminance(t.map(f64::from)) * omega;
        let s = &mut sums[block_of(layer, i, j)];
        for c in 0..3 {
            s[c] += t[c] as f64 * omega;
        }
    });
    (power, sums)
}

/// The grid map of block sums `sums`: each divided by its block's solid angle.
fn grid_of(map: &EnvMap, block: u32, sums: &[[f64; 3]]) -> EnvMap {
    let (gw, gh) = (map.width / block, map.height / block);
    let texels = sums
        .iter()
        .enumerate()
        .map(|(b, s)| {
            let (bi, bj) = (
                (b % gw as usize) as u32,
                (b / gw as usize % gh as usize) as u32,
            );
            let o = map.mapping.texel_solid_angle(gw, gh, bi, bj);
            s.map(|v| (v / o) as f32)
        })
        .collect();
    EnvMap::new(map.mapping, gw, gh, texels)
}

/// Whether [`extract_blocks`] gathers blocks (else it falls back to [`super::extract`]).
fn blocks_apply(map: &EnvMap, opts: &ExtractOptions, block: u32) -> bool {
    let fits = block > 1 && map.width.is_multiple_of(block) && map.height.is_multiple_of(block);
    fits && opts.fill.is_none() && matches!(map.mapping, Mapping::LatLong | Mapping::Cube)
}

/// The grid of blocks, the residual's block means and the records of [`extract_blocks`].
fn block_lights(map: &EnvMap, opts: &ExtractOptions, block: u32) -> (EnvMap, EnvMap, LightSet) {
    let (w, h) = (map.width, map.height);
    let (gw, gh) = (w / block, h / block);
    let block_of =
        |layer: u32, i: u32, j: u32| ((layer * gh + j / block) * gw + i / block) as usize;
    let (power, sums) = block_sums(map, block);
    let mean = power / (4.0 * std::f64::consts::PI);
    // A block's (i, j) in its layer, and its solid angle (the grid's texel's).
    let cell = |b: usize| {
        (
            (b % gw as usize) as u32,
            (b / gw as usize % gh as usize) as u32,
        )
    };
    let grid_omega = |b: usize| {
        let (bi, bj) = cell(b);
        map.mapping.texel_solid_angle(gw, gh, bi, bj)
    };
    let grid = grid_of(map, block, &sums);
    let Some(threshold) = block_threshold(map, mean, opts, &block_of) else {
        let none = LightSet {
            threshold: f64::INFINITY,
            lights: Vec::new(),
        };
        return (grid.clone(), grid, none);
    };
    // The clamp, texel by texel; each block's excess power.
    let mut excess = vec![[0.0f64; 3]; sums.len()];
    let mut lit = vec![false; sums.len()];
    for layer in 0..map.layers() {
        for j in 0..h {
            for i in 0..w {
                let k = map.index(layer, i, j);
                let l = map.texels[k];
                let y = luminance(l.map(f64::from));
                if y > threshold {
                    let keep = (threshold / y) as f32;
                    let r = l.map(|c| c * keep);
                    let omega = map.mapping.texel_solid_angle(w, h, i, j);
                    let b = block_of(layer, i, j);
                    lit[b] = true;
                    for c in 0..3 {
                        excess[b][c] += (l[c] - r[c]) as f64 * omega;
                    }
                }
            }
        }
    }
    let mut lights: Vec<(f64, LightTexel)> = (0..sums.len())
        .filter(|&b| lit[b])
        .map(|b| {
            let (gl, (bi, bj)) = ((b / (gw * gh) as usize) as u32, cell(b));
            let omega = grid_omega(b);
            let radiance = excess[b].map(|e| (e / omega) as f32);
            let t = LightTexel {
                layer: gl,
                i: bi,
                j: bj,
                dir: grid.texel_dir(gl, bi, bj),
                omega,
                radiance,
            };
            (luminance(radiance.map(f64::from)), t)
        })
        .collect();
    // Brightest first, ties by position (layer, row, column), as extract's.
    lights.sort_by(|a, b| {
        b.0.total_cmp(&a.0)
            .then((a.1.layer, a.1.j, a.1.i).cmp(&(b.1.layer, b.1.j, b.1.i)))
    });
    let lights = lights.into_iter().map(|(_, t)| t).collect();
    let kept: Vec<[f64; 3]> = sums
        .iter()
        .zip(&excess)
        .map(|(s, e)| [s[0] - e[0], s[1] - e[1], s[2] - e[2]])
        .collect();
    let residual = grid_of(map, block, &kept);
    (grid, residual, LightSet { threshold, lights })
}

/// τ for [`extract_blocks`]: `ratio` × `mean`, raised to the luminance of the brightest
/// texel whose block would be the (`max_texels` + 1)-th to hold a light texel (every texel
/// at or below it then stays in the residual). `None` where nothing is extracted.
fn block_threshold(
    map: &EnvMap,
    mean: f64,
    opts: &ExtractOptions,
    block_of: &impl Fn(u32, u32, u32) -> usize,
) -> Option<f64> {
    if mean.is_nan() || mean <= 0.0 {
        return None;
    }
    let threshold = opts.ratio * mean;
    let (w, h) = (map.width, map.height);
    let mut candidates: Vec<(f64, usize)> = Vec::new();
    for layer in 0..map.layers() {
        for j in 0..h {
            for i in 0..w {
                let y = luminance(map.texel(layer, i, j).map(f64::from));
                if y > threshold {
                    candidates.push((y, block_of(layer, i, j)));
                }
            }
        }
    }
    if candidates.is_empty() {
        return None;
    }
    candidates.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut seen = std::collections::HashSet::new();
    for &(y, b) in &candidates {
        if seen.insert(b) && seen.len() > opts.max_texels {
            // Every texel as bright as this one stays too; a cap of 0 extracts nothing.
            return (candidates[0].0 > y).then_some(y);
        }
    }
    Some(threshold)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::synth::Sky;
    use glam::DVec3;

    /// Each texel of `map` repeated `k` × `k` times.
    fn upsample(map: &EnvMap, k: u32) -> EnvMap {
        let (w, h) = (map.width * k, map.height * k);
        let mut texels = Vec::with_capacity((w * h * map.layers()) as usize);
        for layer in 0..map.layers() {
            for j in 0..h {
                for i in 0..w {
                    texels.push(map.texel(layer, i / k, j / k));
                }
            }
        }
        EnvMap::new(map.mapping, w, h, texels)
    }

    /// A sky whose sun (12° across, 10⁴ × the zenith) covers tens of texels at these sizes.
    fn sun_sky(mapping: Mapping, size: u32) -> EnvMap {
        let sky = Sky {
            sun_dir: DVec3::new(0.3, 0.6, -0.74).normalize(),
            sun_radius: 6f64.to_radians(),
            sun_ratio: 1e4,
        };
        let (w, h) = match mapping {
            Mapping::LatLong => (2 * size, size),
            _ => (size, size),
        };
        EnvMap::from_fn(mapping, w, h, 2, move |d| sky.radiance(d))
    }

    /// `sum` += `t`·`w`, per channel.
    fn add(sum: &mut [f64; 3], t: [f32; 3], w: f64) {
        for (s, c) in sum.iter_mut().zip(t) {
            *s += c as f64 * w;
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    /// The same content at k times the resolution extracts the same records and the same
    /// residual, repeated, though its light texels are k² times as many as the cap: the
    /// base map's cap just holds its own (so a per-texel extraction of the larger map would
    /// raise τ and leave most of the sun in the residual).
    #[test]
    fn upsampled_maps_extract_the_records_of_the_original() {
        for mapping in [Mapping::LatLong, Mapping::Cube] {
            let base = sun_sky(mapping, 64);
            let plain = ExtractOptions::default();
            let count = super::super::extract(&base, &plain).lights.len();
            assert!(count >= 8, "{mapping:?}: the sun covers {count} texels");
            let opts = ExtractOptions {
                max_texels: count,
                ..plain
            };
            let want = super::super::extract(&base, &opts);
            assert_eq!(want.lights.len(), count);
            for k in [2, 4] {
                let big = upsample(&base, k);
                let per_texel = super::super::extract(&big, &opts);
                assert!(per_texel.threshold > 2.0 * want.threshold, "the cap binds");
                let got = extract_blocks(&big, &opts, k);
                let grid = got.grid.as_ref().expect("a grid");
                assert_eq!((grid.width, grid.height), (base.width, base.height));
                let ex = &got.extraction;
                assert!(rel(ex.threshold, want.threshold) < 1e-9, "{mapping:?} ×{k}");
                assert_eq!(ex.lights.len(), want.lights.len(), "{mapping:?} ×{k}");
                for (a, b) in ex.lights.iter().zip(&want.lights) {
                    assert_eq!((a.layer, a.i, a.j), (b.layer, b.i, b.j), "{mapping:?} ×{k}");
                    assert!((a.dir - b.dir).length() < 1e-12);
                    assert!(rel(a.omega, b.omega) < 1e-9);
                    for c in 0..3 {
                        let e = rel(a.radiance[c] as f64, b.radiance[c] as f64);
                        assert!(e < 1e-6, "{mapping:?} ×{k}: {a:?} {b:?}");
                    }
                }
                assert_eq!(ex.residual.texels, upsample(&want.residual, k).texels);
            }
        }
    }

    /// On a map that is no upsampling (the sun's edge cuts blocks), with the cap binding:
    /// at most `max_texels` records, each block holding a texel above τ among them, no
    /// residual texel above τ, and records plus residual keep the map's power per channel.
    #[test]
    fn blocks_keep_power_and_the_cap() {
        for (mapping, size) in [(Mapping::LatLong, 240), (Mapping::Cube, 120)] {
            let map = sun_sky(mapping, size);
            for block in [2, 3, 4] {
                let all = extract_blocks(&map, &ExtractOptions::default(), block);
                let n0 = all.extraction.lights.len();
                assert!(
                    (8..256).contains(&n0),
                    "{mapping:?} block {block}: {n0} records"
                );
                // Uncapped, then capped two records short (the cut falls on the sun's rim,
                // where texels differ; inside it they tie, and a tie is kept whole or not).
                for cap in [256, n0 - 2] {
                    let opts = ExtractOptions {
                        max_texels: cap,
                        ..ExtractOptions::default()
                    };
                    let got = extract_blocks(&map, &opts, block);
                    let ex = &got.extraction;
                    let n = ex.lights.len();
                    assert!(
                        n > 0 && n <= cap,
                        "{mapping:?} block {block} cap {cap}: {n}"
                    );
                    let mut power = [0.0f64; 3];
                    ex.residual.for_each_texel(|_, _, _, t, o| {
                        assert!(luminance(t.map(f64::from)) <= ex.threshold * (1.0 + 1e-6));
                        add(&mut power, t, o);
                    });
                    for t in &ex.lights {
                        add(&mut power, t.radiance, t.omega);
                    }
                    let mut want = [0.0f64; 3];
                    map.for_each_texel(|_, _, _, t, o| add(&mut want, t, o));
                    for c in 0..3 {
                        let e = rel(power[c], want[c]);
                        assert!(e < 1e-6, "{mapping:?} block {block}: power {e:e}");
                    }
                    // Brightest first.
                    let y: Vec<f64> = ex
                        .lights
                        .iter()
                        .map(|t| luminance(t.radiance.map(f64::from)))
                        .collect();
                    assert!(y.windows(2).all(|p| p[0] >= p[1]));
                }
            }
        }
    }

    /// Block 1, a block that does not divide the sides, another mapping or a filled residual
    /// extract texel by texel.
    #[test]
    fn falls_back_to_texels() {
        let map = sun_sky(Mapping::LatLong, 30);
        let opts = ExtractOptions::default();
        let want = super::super::extract(&map, &opts);
        for block in [1, 7] {
            let got = extract_blocks(&map, &opts, block);
            assert!(got.grid.is_none());
            assert_eq!(got.extraction.lights, want.lights);
        }
        let filled = ExtractOptions {
            fill: Some(2),
            ..opts
        };
        assert!(extract_blocks(&map, &filled, 2).grid.is_none());
        let angular = sun_sky(Mapping::Angular, 32);
        assert!(extract_blocks(&angular, &opts, 2).grid.is_none());
    }

    #[test]
    fn record_blocks_follow_the_width() {
        let ll =
            |w: u32, h: u32| EnvMap::new(Mapping::LatLong, w, h, vec![[0.0; 3]; (w * h) as usize]);
        assert_eq!(record_block(&ll(1024, 512), 1024), 1);
        assert_eq!(record_block(&ll(8192, 4096), 1024), 8);
        assert_eq!(record_block(&ll(16384, 8192), 1024), 16);
        assert_eq!(record_block(&ll(3000, 1500), 1024), 2);
        assert_eq!(record_block(&ll(1000, 500), 128), 5);
        assert_eq!(record_block(&ll(2054, 1027), 1024), 1);
        let cube = EnvMap::new(Mapping::Cube, 1024, 1024, vec![[0.0; 3]; 6 << 20]);
        assert_eq!(record_block(&cube, 1024), 4);
        let angular = EnvMap::new(Mapping::Angular, 64, 64, vec![[0.0; 3]; 4096]);
        assert_eq!(record_block(&angular, 16), 1);
    }

    /// Block means keep each block's power (Σ L·Ω over its texels against the grid texel's
    /// L·Ω, every channel, to 1e-6: the grid's texels are float32); the residual's are the
    /// block means of [`clamp_residual`] at the threshold, and [`extract_block_lights`]'
    /// residual grid (the grid less the records) the same to 1e-6; a map upsampled ×4 has
    /// the original map as its ×4 block means; a block that does not divide gives none.
    #[test]
    fn block_means_keep_every_blocks_power() {
        for mapping in [Mapping::LatLong, Mapping::Cube] {
            let map = sun_sky(mapping, 64);
            let block = 4;
            let ex = extract_block_lights(&map, &ExtractOptions::default(), block);
            let tau = ex.set.threshold;
            assert!(tau.is_finite(), "{mapping:?}: no lights");
            let (whole, residual) = block_means(&map, block, tau).unwrap();
            let (gw, gh) = (map.width / block, map.height / block);
            let mut sums = vec![[0.0f64; 3]; whole.texels.len()];
            map.for_each_texel(|layer, i, j, t, o| {
                add(
                    &mut sums[((layer * gh + j / block) * gw + i / block) as usize],
                    t,
                    o,
                )
            });
            whole.for_each_texel(|layer, i, j, t, o| {
                let s = sums[whole.index(layer, i, j)];
                for c in 0..3 {
                    let e = rel(t[c] as f64 * o, s[c]);
                    assert!(
                        e < 1e-6,
                        "{mapping:?}: block ({layer}, {i}, {j}) errs {e:e}"
                    );
                }
            });
            let residual = residual.unwrap();
            let (want, _) = block_means(&clamp_residual(&map, tau), block, f64::INFINITY).unwrap();
            let from_lights = ex.residual_grid.unwrap();
            for ((r, w), l) in residual
                .texels
                .iter()
                .zip(&want.texels)
                .zip(&from_lights.texels)
            {
                for c in 0..3 {
                    assert!(
                        rel(r[c] as f64, w[c] as f64) < 1e-6,
                        "{mapping:?}: {r:?} {w:?}"
                    );
                    assert!(
                        rel(l[c] as f64, w[c] as f64) < 1e-6,
                        "{mapping:?}: {l:?} {w:?}"
                    );
                }
            }
            let differs = residual
                .texels
                .iter()
                .zip(&whole.texels)
                .filter(|(a, b)| a != b);
            assert!(
                differs.count() > 0,
                "{mapping:?}: the residual's means are the map's"
            );
            let (back, _) = block_means(&upsample(&map, 4), 4, f64::INFINITY).unwrap();
            for (b, t) in back.texels.iter().zip(&map.texels) {
                for c in 0..3 {
                    assert!(
                        rel(b[c] as f64, t[c] as f64) < 1e-6,
                        "{mapping:?}: {b:?} {t:?}"
                    );
                }
            }
            assert!(block_means(&map, 3, tau).is_none());
        }
    }
}
