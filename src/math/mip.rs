//! The dual-paraboloid MIP chain in float64, the oracle of `glsl/mip.comp`.
//!
//! Levels are stored premultiplied: a texel holds (Σ w·L, Σ w) / area over its footprint,
//! where w is the part of the level-0 texel inside the unit disc (1 inside, the fraction of
//! its solid angle that the disc covers on the rim, 0 outside; [`weight`]). Reading divides
//! rgb by alpha, so texels outside the disc never weigh in (in the down-filter, nor in
//! bilinear or trilinear lookups), and a rim texel counts for what it covers.
//!
//! Coarse texels thus average radiance evenly over the (s, t) plane, not by solid angle. The
//! paraboloid is conformal, but its solid angle per unit area grows fourfold from the rim to
//! the pole, so a solid-angle-weighted box leans towards the pole: a footprint of angular
//! radius σ has its mean displaced by about 2.5·g'·σ² (g the angle per unit of s), against
//! 0.5·g'·σ² for the even average. FIS reads coarse levels for wide lobes, so the leaning
//! biases a map whose bright horizon lies on the rim (venice_sunset, GGX α 0.6, N = 64: −2.7%
//! leaning against −0.8% even, in float64; `fis::tests` bounds the bias on a synthetic band).
//!
//! The solid angle of a level-0 texel at direction d is Ωp = 4/(1+s²+t²)²·(2/W)², and
//! 1+s²+t² = 2/(1+|d.y|) on either half, so Ωp = (1+|d.y|)²·(2/W)²: 16/W² at the poles,
//! 4/W² at the rim ([`texel_solid_angle`]).

use super::mapping::Mapping;
use crate::math::envmap::EnvMap;
use glam::DVec3;

/// One level: `size` × `size` texels per half, layer after layer, row after row, each
/// (premultiplied rgb, weight).
#[derive(Clone, Debug)]
pub struct Level {
    /// Side of a half.
    pub size: u32,
    /// Texels.
    pub texels: Vec<[f64; 4]>,
}

impl Level {
    /// The radiance a lookup reads at texel (layer, i, j): rgb / weight (0 without weight).
    pub fn radiance(&self, layer: u32, i: u32, j: u32) -> [f64; 3] {
        let t = self.texels[((layer * self.size + j) * self.size + i) as usize];
        if t[3] > 0.0 {
            [t[0] / t[3], t[1] / t[3], t[2] / t[3]]
        } else {
            [0.0; 3]
        }
    }
}

/// The weight of level-0 texel (i, j) of a `size`-texel half: 1 wholly inside the disc, 0
/// wholly outside, and on the rim the fraction of its (continued) solid angle that lies
/// inside the disc.
pub fn weight(size: u32, i: u32, j: u32) -> f64 {
    let side = 2.0 / size as f64;
    let (x0, y0) = (i as f64 * side - 1.0, j as f64 * side - 1.0);
    let (x1, y1) = (x0 + side, y0 + side);
    let far = |a: f64, b: f64| a.abs().max(b.abs());
    if far(x0, x1).powi(2) + far(y0, y1).powi(2) <= 1.0 {
        return 1.0;
    }
    let inside = Mapping::DualParaboloid.texel_solid_angle(size, size, i, j);
    if inside <= 0.0 {
        return 0.0;
    }
    (inside / super::mapping::paraboloid_square_solid_angle(x0, x1, y0, y1)).min(1.0)
}

/// The solid angle of a level-0 texel of a `size`-texel half at world direction d.
pub fn texel_solid_angle(d: DVec3, size: u32) -> f64 {
    let k = 2.0 / size as f64;
    let y1 = 1.0 + d.y.abs();
    y1 * y1 * k * k
}

/// Level 0 of a dual-paraboloid map, premultiplied.
pub fn level0(map: &EnvMap) -> Level {
    assert_eq!(map.mapping, Mapping::DualParaboloid);
    let size = map.width;
    let mut texels = Vec::with_capacity(map.texels.len());
    for layer in 0..2 {
        for j in 0..size {
            for i in 0..size {
                let w = weight(size, i, j);
                let t = map.texel(layer, i, j);
                texels.push([t[0] as f64 * w, t[1] as f64 * w, t[2] as f64 * w, w]);
            }
        }
    }
    Level { size, texels }
}

/// The next level: a box filter over each texel's footprint, with fractional overlaps where
/// the size is odd (level k has Vulkan's size max(1, W >> k)).
pub fn down(src: &Level) -> Level {
    let size = (src.size / 2).max(1);
    let scale = src.size as f64 / size as f64;
    let mut texels = Vec::with_capacity((2 * size * size) as usize);
    for layer in 0..2 {
        for j in 0..size {
            for i in 0..size {
                let (lo, hi) = (
                    [i as f64 * scale, j as f64 * scale],
                    [(i + 1) as f64 * scale, (j + 1) as f64 * scale],
                );
                let mut acc = [0.0; 4];
                let mut area = 0.0;
                let y1 = (hi[1].ceil() as u32).min(src.size);
                let x1 = (hi[0].ceil() as u32).min(src.size);
                for y in lo[1].floor() as u32..y1 {
                    let oy = hi[1].min((y + 1) as f64) - lo[1].max(y as f64);
                    for x in lo[0].floor() as u32..x1 {
                        let a = (hi[0].min((x + 1) as f64) - lo[0].max(x as f64)) * oy;
                        let t = src.texels[((layer * src.size + y) * src.size + x) as usize];
                        for c in 0..4 {
                            acc[c] += a * t[c];
                        }
                        area += a;
                    }
                }
                texels.push(acc.map(|v| v / area));
            }
        }
    }
    Level { size, texels }
}

/// Every level from `map` (a dual paraboloid) down to 1 × 1.
pub fn chain(map: &EnvMap) -> Vec<Level> {
    let mut levels = vec![level0(map)];
    while levels.last().is_some_and(|l| l.size > 1) {
        let next = down(levels.last().unwrap_or_else(|| unreachable!()));
        levels.push(next);
    }
    levels
}

/// The box-filtered reference for a power-of-two `map`: texel (layer, i, j) of `level` is the
/// [`weight`]-weighted mean of the 2^level × 2^level level-0 texels it covers, straight from
/// level 0 (no recursion).
pub fn box_reference(map: &EnvMap, level: u32, layer: u32, i: u32, j: u32) -> [f64; 3] {
    assert!(map.width.is_power_of_two());
    let k = 1u32 << level;
    let (mut acc, mut wsum) = ([0.0; 3], 0.0);
    for y in j * k..(j + 1) * k {
        for x in i * k..(i + 1) * k {
            let w = weight(map.width, x, y);
            let t = map.texel(layer, x, y);
            for c in 0..3 {
                acc[c] += w * t[c] as f64;
            }
            wsum += w;
        }
    }
    if wsum > 0.0 {
        acc.map(|v| v / wsum)
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_solid_angle_matches_the_exact_one() {
        // Inside the disc, the closed form at the texel centre against the integrated solid
        // angle: equal to second order in the texel size (the density is smooth there).
        let size = 256;
        let mut worst: f64 = 0.0;
        for j in 0..size {
            for i in 0..size {
                let c = Mapping::texel_center(size, size, 0, i, j);
                let (s, t) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
                let r = (s * s + t * t).sqrt() + 2.0_f64.sqrt() / size as f64;
                if r > 1.0 {
                    continue;
                }
                let d = Mapping::DualParaboloid.coord_to_dir(c);
                let exact = Mapping::DualParaboloid.texel_solid_angle(size, size, i, j);
                let rel = (texel_solid_angle(d, size) / exact - 1.0).abs();
                worst = worst.max(rel);
            }
        }
        assert!(worst < 1e-4, "{worst}");
        // Centre against rim: a factor 4.
        let centre = texel_solid_angle(DVec3::Y, size);
        let rim = texel_solid_angle(DVec3::X, size);
        assert!((centre / rim - 4.0).abs() < 1e-12);
    }

    #[test]
    fn recursion_equals_the_direct_box_filter() {
        let map = EnvMap::from_fn(
            Mapping::DualParaboloid,
            32,
            32,
            1,
            super::super::synth::smooth_env,
        );
        let levels = chain(&map);
        assert_eq!(levels.len(), 6);
        for (k, l) in levels.iter().enumerate() {
            for layer in 0..2 {
                for j in 0..l.size {
                    for i in 0..l.size {
                        let a = l.radiance(layer, i, j);
                        let b = box_reference(&map, k as u32, layer, i, j);
                        for c in 0..3 {
                            assert!((a[c] - b[c]).abs() <= 1e-12 * b[c].abs().max(1.0));
                        }
                    }
                }
            }
        }
        // The top level's weight is the mean weight: the disc's share of the square, π/4, up
        // to the rim texels' solid-angle (not area) fractions.
        let top = &levels[5].texels[0][3];
        assert!((top - std::f64::consts::FRAC_PI_4).abs() < 2e-3, "{top}");
    }

    /// Each weight against a 128 × 128 midpoint count of the density inside the disc over the
    /// density on the whole texel (continued past the rim): 1 inside, 0 outside, the covered
    /// share on the rim, within the count's own error (its cells cut by the rim, ~1e-4).
    #[test]
    fn weight_is_the_share_of_the_texel_inside_the_disc() {
        let size = 12u32;
        let side = 2.0 / size as f64;
        let cells = 128;
        let (mut rim, mut worst) = (0, 0.0f64);
        for j in 0..size {
            for i in 0..size {
                let (mut inside, mut all) = (0.0, 0.0);
                for b in 0..cells {
                    for a in 0..cells {
                        let s = -1.0 + side * (i as f64 + (a as f64 + 0.5) / cells as f64);
                        let t = -1.0 + side * (j as f64 + (b as f64 + 0.5) / cells as f64);
                        let r2 = s * s + t * t;
                        let dens = 4.0 / ((1.0 + r2) * (1.0 + r2));
                        all += dens;
                        if r2 < 1.0 {
                            inside += dens;
                        }
                    }
                }
                let (w, want) = (weight(size, i, j), inside / all);
                if want == 1.0 || want == 0.0 {
                    assert_eq!(w, want, "({i}, {j})");
                } else {
                    rim += 1;
                    worst = worst.max((w - want).abs());
                }
            }
        }
        assert!(
            rim > 20 && worst < 2e-4,
            "{rim} rim texels, worst {worst:e}"
        );
    }
}
