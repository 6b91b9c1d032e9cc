//! The float64 twin of the conversion pass (`glsl/convert.comp`): the same reconstruction
//! (masked bilinear, lat-long rows between their solid-angle centroids, seamless cube
//! filtering) and the same footprint means, as the oracle the GPU is tested against; and of
//! the reduction (`glsl/reduce.comp`) that strong minification reads instead of the source.

use super::mapping::{Coord, Mapping};
use crate::envmap::EnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// Polar angle of the solid-angle centroid of lat-long row `j` of height `h` (rows −1 and H are
/// rows 0 and H−1 seen across the pole).
pub fn row_centroid(j: i64, h: f64) -> f64 {
    let tm = (j as f64 + 0.5) * h;
    let x = 0.5 * h;
    // cot θm · (1 − x cot x)
    tm + tm.cos() / tm.sin() * (1.0 - x / x.tan())
}

/// Texels that cover the sphere (those inside the disc for angular and paraboloid maps).
fn texels_on_sphere(m: Mapping, w: u32, h: u32) -> f64 {
    let n = w as f64 * h as f64;
    match m {
        Mapping::LatLong => n,
        Mapping::Angular => n * std::f64::consts::FRAC_PI_4,
        Mapping::Cube => 6.0 * n,
        Mapping::DualParaboloid => 2.0 * n * std::f64::consts::FRAC_PI_4,
    }
}

/// How a conversion samples its source: from which reduction level, at how many samples per
/// axis per output texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampling {
    /// The source is first reduced by 2^level per axis ([`reduce`]); 0 reads it as it is.
    pub level: u32,
    /// Samples per axis per output texel.
    pub ss: u32,
}

/// Most reduction levels a conversion uses (a factor of 1024 per axis).
pub const MAX_REDUCTION: u32 = 10;

impl Sampling {
    /// Level 0 at `ss` samples per axis (a forced rate).
    pub fn at(ss: u32) -> Sampling {
        Sampling {
            level: 0,
            ss: ss.max(1),
        }
    }

    /// The sampling for a `src` → `dst` conversion, each (mapping, width, height).
    ///
    /// About four samples per axis per source texel the output texel covers, so that the
    /// footprint mean sees every source texel (1 when magnifying). Past a ratio of 4 source
    /// texels per output texel per axis that rate costs ss² ∝ ratio² per output texel, so a
    /// lat-long or cube source is first reduced by 2^level (solid-angle-weighted block means,
    /// which keep its power) to leave 2 to 4 texels per output texel: the reduced texel, and
    /// so the extra blur of its bilinear tent, is at most half an output texel wide.
    pub fn for_conversion(src: (Mapping, u32, u32), dst: (Mapping, u32, u32)) -> Sampling {
        let ratio =
            (texels_on_sphere(src.0, src.1, src.2) / texels_on_sphere(dst.0, dst.1, dst.2)).sqrt();
        let mut level = 0;
        if matches!(src.0, Mapping::LatLong | Mapping::Cube) && ratio >= 4.0 {
            let divides = src.1.trailing_zeros().min(src.2.trailing_zeros());
            level = ((ratio / 2.0).log2().floor() as u32)
                .min(divides)
                .min(MAX_REDUCTION);
        }
        let rest = ratio / f64::from(1u32 << level);
        Sampling {
            level,
            ss: ((4.0 * rest).ceil() as u32).clamp(1, 64),
        }
    }
}

/// `map` reduced by `factor` per axis (which must divide its sides): each texel the mean of
/// its factor × factor source texels weighted by their solid angles, so that ∑ L·Ω is kept
/// (exactly for a lat-long map, whose weights are closed forms; for a cube, the weights are
/// the solid-angle density at the texel centre, exact to O(h²) within a block).
pub fn reduce(map: &EnvMap, factor: u32) -> EnvMap {
    assert!(factor >= 1 && map.width % factor == 0 && map.height % factor == 0);
    let (w, h) = (map.width / factor, map.height / factor);
    let mut texels = Vec::with_capacity((w * h * map.layers()) as usize);
    for layer in 0..map.layers() {
        for j in 0..h {
            for i in 0..w {
                let (mut acc, mut wsum) = ([0.0f64; 3], 0.0);
                for y in j * factor..(j + 1) * factor {
                    for x in i * factor..(i + 1) * factor {
                        let wt = reduce_weight(map.mapping, map.width, map.height, x, y);
                        let l = map.texel(layer, x, y);
                        for c in 0..3 {
                            acc[c] += wt * f64::from(l[c]);
                        }
                        wsum += wt;
                    }
                }
                texels.push(acc.map(|a| (a / wsum) as f32));
            }
        }
    }
    EnvMap::new(map.mapping, w, h, texels)
}

/// The weight of texel (i, j) of a `w × h` layer in [`reduce`] (as `glsl/reduce.comp`).
pub fn reduce_weight(m: Mapping, w: u32, h: u32, i: u32, j: u32) -> f64 {
    match m {
        Mapping::Cube => {
            let s = 2.0 * (i as f64 + 0.5) / w as f64 - 1.0;
            let t = 2.0 * (j as f64 + 0.5) / h as f64 - 1.0;
            (1.0 + s * s + t * t).powf(-1.5)
        }
        _ => m.texel_solid_angle(w, h, i, j),
    }
}

fn fetch(map: &EnvMap, layer: u32, i: i64, j: i64) -> [f64; 3] {
    map.texel(layer, i as u32, j as u32).map(f64::from)
}

/// Radiance of a map towards `d`, reconstructed as the GPU does.
pub fn sample(map: &EnvMap, d: DVec3) -> [f64; 3] {
    let (w, h) = (map.width as i64, map.height as i64);
    let c = map.mapping.dir_to_coord(d);
    let px = c.u * w as f64 - 0.5;
    let py = c.v * h as f64 - 0.5;
    let (i0, mut j0) = (px.floor() as i64, py.floor() as i64);
    let tx = px - i0 as f64;
    let mut ty = py - j0 as f64;
    if map.mapping == Mapping::LatLong {
        let hh = PI / h as f64;
        let theta = PI * c.v;
        let (mut c0, mut c1) = (row_centroid(j0, hh), row_centroid(j0 + 1, hh));
        if theta < c0 {
            j0 -= 1;
            c1 = c0;
            c0 = row_centroid(j0, hh);
        } else if theta >= c1 {
            j0 += 1;
            c0 = c1;
            c1 = row_centroid(j0 + 1, hh);
        }
        ty = ((theta - c0) / (c1 - c0)).clamp(0.0, 1.0);
    }
    let mut acc = [0.0; 3];
    let mut wsum = 0.0;
    let mut nearest = [0.0; 3];
    for k in 0..4 {
        let (mut qi, mut qj) = (i0 + (k & 1), j0 + (k >> 1));
        let wt =
            (if k & 1 == 1 { tx } else { 1.0 - tx }) * (if k >> 1 == 1 { ty } else { 1.0 - ty });
        let mut layer = c.layer;
        match map.mapping {
            Mapping::LatLong => {
                if qj < 0 {
                    (qi, qj) = (qi + w / 2, -1 - qj);
                } else if qj >= h {
                    (qi, qj) = (qi + w / 2, 2 * h - 1 - qj);
                }
                qi = qi.rem_euclid(w);
            }
            Mapping::Cube if qi < 0 || qi >= w || qj < 0 || qj >= h => {
                // Seamless filtering: the texel past the edge is the adjacent face's texel in
                // that direction.
                let virt = Coord {
                    layer,
                    u: (qi as f64 + 0.5) / w as f64,
                    v: (qj as f64 + 0.5) / h as f64,
                };
                let e = Mapping::Cube.dir_to_coord(Mapping::Cube.coord_to_dir(virt));
                layer = e.layer;
                qi = ((e.u * w as f64).floor() as i64).clamp(0, w - 1);
                qj = ((e.v * h as f64).floor() as i64).clamp(0, h - 1);
            }
            _ => {}
        }
        qi = qi.clamp(0, w - 1);
        qj = qj.clamp(0, h - 1);
        let v = fetch(map, layer, qi, qj);
        if k == 0 || wt > 0.25 {
            nearest = v;
        }
        if !map
            .mapping
            .texel_in_domain(map.width, map.height, qi as u32, qj as u32)
        {
            continue;
        }
        for ch in 0..3 {
            acc[ch] += wt * v[ch];
        }
        wsum += wt;
    }
    if wsum > 0.0 {
        acc.map(|x| x / wsum)
    } else {
        nearest
    }
}

/// Converts `map` to `to` at `size` as `sampling` says (its reduction level, then `ss × ss`
/// samples per output texel), `world_to_file` orienting the source (see
/// [`super::Orientation::world_to_file`]).
pub fn convert(
    map: &EnvMap,
    to: Mapping,
    size: u32,
    world_to_file: DMat3,
    sampling: Sampling,
) -> EnvMap {
    if sampling.level > 0 {
        let reduced = reduce(map, 1 << sampling.level);
        return convert(&reduced, to, size, world_to_file, Sampling::at(sampling.ss));
    }
    let ss = sampling.ss.max(1);
    let (w, h) = to.extent_for_size(size);
    let mut texels = Vec::with_capacity((w * h * to.layers()) as usize);
    for layer in 0..to.layers() {
        for j in 0..h {
            for i in 0..w {
                if to == Mapping::Angular && !to.texel_in_domain(w, h, i, j) {
                    texels.push([0.0; 3]);
                    continue;
                }
                let (mut acc, mut wsum) = ([0.0f64; 3], 0.0);
                for b in 0..ss {
                    for a in 0..ss {
                        let c = Coord {
                            layer,
                            u: (i as f64 + (a as f64 + 0.5) / ss as f64) / w as f64,
                            v: (j as f64 + (b as f64 + 0.5) / ss as f64) / h as f64,
                        };
                        let wt = to.footprint_weight(c);
                        let l = sample(map, world_to_file * to.coord_to_dir(c));
                        for k in 0..3 {
                            acc[k] += wt * l[k];
                        }
                        wsum += wt;
                    }
                }
                if wsum > 0.0 {
                    texels.push(acc.map(|x| (x / wsum) as f32));
                } else {
                    // A paraboloid texel whose samples all miss its disc holds its own half's
                    // rim nearest its centre (as glsl/convert.comp).
                    let mut c = Mapping::texel_center(w, h, layer, i, j);
                    if to == Mapping::DualParaboloid {
                        let (s, t) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
                        let r = 1.0 - crate::abi::constants::RIM_PULL_IN;
                        let k = r / (s * s + t * t).sqrt().max(r);
                        c.u = 0.5 * (s * k + 1.0);
                        c.v = 0.5 * (t * k + 1.0);
                    }
                    texels.push(sample(map, world_to_file * to.coord_to_dir(c)).map(|x| x as f32));
                }
            }
        }
    }
    EnvMap::new(to, w, h, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_centroids_match_quadrature() {
        let h = PI / 7.0;
        for j in 0..7 {
            let t0 = j as f64 * h;
            let n = 20000;
            let (mut num, mut den) = (0.0, 0.0);
            for k in 0..n {
                let t = t0 + (k as f64 + 0.5) / n as f64 * h;
                num += t * t.sin();
                den += t.sin();
            }
            assert!((num / den - row_centroid(j, h)).abs() < 1e-8, "row {j}");
        }
        // Across the pole the virtual rows mirror the real ones.
        assert!((row_centroid(-1, h) + row_centroid(0, h)).abs() < 1e-12);
        assert!((row_centroid(7, h) - (2.0 * PI - row_centroid(6, h))).abs() < 1e-12);
    }

    /// Below 4 source texels per output texel per axis the source is read as it is; above,
    /// a lat-long or cube source is reduced to leave 2 to 4, within what its sides allow;
    /// angular and paraboloid sources never are.
    #[test]
    fn sampling_reduces_only_strong_minification() {
        let s = |src: (Mapping, u32, u32), to: Mapping, size: u32| {
            let (w, h) = to.extent_for_size(size);
            Sampling::for_conversion(src, (to, w, h))
        };
        let ll = (Mapping::LatLong, 1024, 512);
        assert_eq!(s(ll, Mapping::Cube, 256), Sampling { level: 0, ss: 5 });
        for (to, size) in [
            (Mapping::Cube, 64),
            (Mapping::Cube, 8),
            (Mapping::DualParaboloid, 16),
            (Mapping::LatLong, 64),
            (Mapping::Angular, 40),
        ] {
            let x = s(ll, to, size);
            assert!(
                x.level > 0 && (8..=16).contains(&x.ss),
                "{to:?} {size}: {x:?}"
            );
        }
        // An odd side allows no reduction; a disc mapping is never reduced.
        assert_eq!(s((Mapping::LatLong, 1022, 511), Mapping::Cube, 8).level, 0);
        assert_eq!(s((Mapping::Angular, 1024, 1024), Mapping::Cube, 8).level, 0);
        assert_eq!(s((Mapping::Cube, 256, 256), Mapping::Cube, 16).level, 3);
    }

    /// Reducing keeps ∑ L·Ω: exactly for lat-long maps (to float32 storage), to O(h²) of the
    /// density weights for cubes; and a constant stays constant.
    #[test]
    fn reduction_keeps_power() {
        for (m, size, factor, tol) in [
            (Mapping::LatLong, 64, 4, 1e-6),
            (Mapping::LatLong, 64, 16, 1e-6),
            (Mapping::Cube, 32, 4, 2e-4),
        ] {
            let (w, h) = m.extent_for_size(size);
            // A sun 10⁴ × the sky, off every block centre.
            let sun = DVec3::new(0.3, 0.5, -0.8).normalize();
            let map = EnvMap::from_fn(m, w, h, 3, |d| {
                let s = 1e4 * (4000.0 * (d.dot(sun) - 1.0)).exp();
                [1.0 + d.y + s, 0.5 + s, 2.0 - d.x]
            });
            let r = reduce(&map, factor);
            assert_eq!((r.width, r.height), (w / factor, h / factor));
            let (p0, p1) = (map.power(), r.power());
            for c in 0..3 {
                assert!(
                    (p1[c] / p0[c] - 1.0).abs() < tol,
                    "{m:?} /{factor} channel {c}: {p0:?} {p1:?}"
                );
            }
            let flat = EnvMap::new(
                m,
                w,
                h,
                vec![[2.0, 3.0, 4.0]; (w * h * m.layers()) as usize],
            );
            assert!(reduce(&flat, factor)
                .texels
                .iter()
                .all(|t| (t[1] - 3.0).abs() < 1e-6));
        }
    }

    #[test]
    fn sampling_a_constant_map_is_exact_everywhere() {
        for m in Mapping::ALL {
            let (w, h) = m.extent_for_size(5);
            let map = EnvMap::new(
                m,
                w,
                h,
                vec![[2.0, 3.0, 4.0]; (w * h * m.layers()) as usize],
            );
            for d in super::super::synth::stress_directions().iter().step_by(37) {
                let s = sample(&map, *d);
                assert!(
                    (s[0] - 2.0).abs() < 1e-12 && (s[2] - 4.0).abs() < 1e-12,
                    "{m:?} {d}: {s:?}"
                );
            }
        }
    }
}
