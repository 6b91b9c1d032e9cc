//! The float64 twin of the conversion pass (`glsl/convert.comp`): the same reconstruction
//! (masked bilinear, lat-long rows between their solid-angle centroids, seamless cube
//! filtering) and the same footprint means, as the oracle the GPU is tested against.

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

/// The texel of `map` that `d` falls in (the conversion's `nearest` reconstruction).
pub fn sample_nearest(map: &EnvMap, d: DVec3) -> [f64; 3] {
    let c = map.mapping.dir_to_coord(d);
    let i = ((c.u * map.width as f64).floor() as i64).clamp(0, map.width as i64 - 1);
    let j = ((c.v * map.height as f64).floor() as i64).clamp(0, map.height as i64 - 1);
    fetch(map, c.layer, i, j)
}

/// Converts `map` to `to` at `size` with `ss × ss` samples per output texel, `world_to_file`
/// orienting the source (see [`super::Orientation::world_to_file`]).
pub fn convert(map: &EnvMap, to: Mapping, size: u32, world_to_file: DMat3, ss: u32) -> EnvMap {
    convert_with(map, to, size, world_to_file, ss, false)
}

/// [`convert`], each sample reading the source's nearest texel where `nearest` is set.
pub fn convert_with(
    map: &EnvMap,
    to: Mapping,
    size: u32,
    world_to_file: DMat3,
    ss: u32,
    nearest: bool,
) -> EnvMap {
    let read = |d: DVec3| {
        if nearest {
            sample_nearest(map, d)
        } else {
            sample(map, d)
        }
    };
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
                        let l = read(world_to_file * to.coord_to_dir(c));
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
                    texels.push(read(world_to_file * to.coord_to_dir(c)).map(|x| x as f32));
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
