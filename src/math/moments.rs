//! A power-moment pyramid of an environment map, and the convolution of one of its levels: the
//! float64 twin of `glsl/moments.comp` and of the brute force's moment variant.
//!
//! Level s groups the 2^s × 2^s texels of the source (lat-long or cube) into one coarse texel
//! and keeps, per channel, the power P = ∑ L·Ω, its first moment ∑ L·∫ω dω and its second
//! moment ∑ L·∫ωωᵀ dω (the sums are exact: moments add). Averaging radiance alone would move a
//! sun to the coarse texel's centre, an error of first order in the lobe's slope; with the
//! moments, each channel's light in a coarse texel is a uniform parallelogram with the same
//! power, centroid and covariance, which the tilted rule ([`filter::tilted_mean`]) integrates.
//! What is left is the third and higher cumulants of the light inside a coarse texel, which
//! [`level_for`] keeps small by choosing the level from the lobe's width.

use super::filter::{self, rule, tilted_mean, Kernel, Prepared, Rule, TexelShape, TILT_LIMIT};
use super::mapping::Mapping;
use glam::DVec3;

/// One channel's light in a coarse texel, reduced to what the tilted rule needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Power ∑ L·Ω.
    pub power: f64,
    /// The uniform parallelogram with the light's centroid and covariance (`regular` true).
    pub shape: TexelShape,
}

pub use crate::abi::filter_rule::MAX_SOURCE_LEVEL as MAX_LEVEL;

/// Whether a map of `mapping` and `w` × `h` has a level `s` (lat-long or cube, sides divisible
/// by 2^s, s ≤ [`MAX_LEVEL`]).
pub fn has_level(mapping: Mapping, w: u32, h: u32, s: u32) -> bool {
    matches!(mapping, Mapping::LatLong | Mapping::Cube)
        && s <= MAX_LEVEL
        && w.is_multiple_of(1 << s)
        && h.is_multiple_of(1 << s)
}

/// The source level a lobe of `kernel` is filtered from: the coarsest level whose every texel
/// the tilted rule takes at the lobe's peak (n·ρ² ≤ `TILT_LIMIT`, ρ the texel's angular radius
/// with its margin), 0 when there is none or the mapping has no levels. Where the rule cannot
/// take a coarse texel whole (the horizon cuts it, or the lobe curves too much across it off
/// the peak), the sum descends to its fine texels, so the level decides the cost, and the
/// light's third moments inside a coarse texel the error.
pub fn level_for(kernel: Kernel, mapping: Mapping, w: u32, h: u32) -> u32 {
    let n = kernel.exponent();
    let mut best = 0;
    for s in 1..=MAX_LEVEL {
        if !has_level(mapping, w, h, s) || n * max_rho2(mapping, w >> s, h >> s) > TILT_LIMIT {
            break;
        }
        best = s;
    }
    best
}

/// The largest 2(1 − cos ρ) over the texels of a `w` × `h` map (one quadrant of one layer:
/// the rest are congruent).
fn max_rho2(mapping: Mapping, w: u32, h: u32) -> f64 {
    let mut worst: f64 = 0.0;
    for j in 0..h.div_ceil(2) {
        for i in 0..w.div_ceil(2) {
            let c = filter::texel_cos_radius(mapping, w, h, 0, i, j);
            worst = worst.max(2.0 * (1.0 - c));
        }
    }
    worst
}

/// One level of the pyramid: per coarse texel (layer-major, row-major) and channel, its light.
pub struct MomentLevel {
    /// Mapping (that of the source).
    pub mapping: Mapping,
    /// Level index s.
    pub level: u32,
    /// Width of a layer at this level.
    pub width: u32,
    /// Height of a layer at this level.
    pub height: u32,
    /// Per texel, per channel (`None` without power).
    pub light: Vec<[Option<Light>; 3]>,
    /// Per texel, its centre direction (world) and the cosine and sine of its angular radius,
    /// which the rule decides from.
    cones: Vec<(DVec3, f64, f64)>,
}

impl MomentLevel {
    /// Level `s` of the map `fine` was prepared from (see [`has_level`]). Each fine texel is
    /// the uniform parallelogram of its [`TexelShape`] (centroid c, covariance (hu huᵀ +
    /// hv hvᵀ)/3); a channel's centroid is ∑ P·c normalised, and its covariance, in the tangent
    /// plane e₁, e₂ there, ∑ P·((e·c)(e′·c) + eᵀ Σ e′) / ∑ P, taken directly so that nothing
    /// cancels (the GLSL does the same in f32).
    pub fn new(fine: &Prepared, s: u32) -> MomentLevel {
        let map = fine.map();
        let (w, h) = (map.width, map.height);
        assert!(has_level(map.mapping, w, h, s), "no level {s} for {w}x{h}");
        let side = 1u32 << s;
        let (cw, ch) = (w >> s, h >> s);
        let mut light = Vec::with_capacity((cw * ch * map.layers()) as usize);
        let mut cones = Vec::with_capacity(light.capacity());
        for layer in 0..map.layers() {
            for cj in 0..ch {
                for ci in 0..cw {
                    let m = map.mapping;
                    let cos_rho = filter::texel_cos_radius(m, cw, ch, layer, ci, cj);
                    cones.push((
                        fine.file_to_world()
                            * m.coord_to_dir(Mapping::texel_center(cw, ch, layer, ci, cj)),
                        cos_rho,
                        (1.0 - cos_rho * cos_rho).max(0.0).sqrt(),
                    ));
                    let children = || {
                        (0..side * side).map(move |k| {
                            let (i, j) = (ci * side + k % side, cj * side + k / side);
                            fine.texel(((layer * h + j) * w + i) as usize)
                        })
                    };
                    let mut out = [None; 3];
                    for (c, o) in out.iter_mut().enumerate() {
                        let (mut p, mut m1) = (0.0, DVec3::ZERO);
                        for (shape, l, omega) in children() {
                            p += l[c] * omega;
                            m1 += l[c] * omega * shape.centroid;
                        }
                        if p <= 0.0 || p.is_nan() || m1.length_squared() == 0.0 {
                            continue;
                        }
                        let cen = m1.normalize();
                        let e1 = cen.any_orthonormal_vector();
                        let e2 = cen.cross(e1);
                        let mut cov = [0.0; 3];
                        for (shape, l, omega) in children() {
                            let pw = l[c] * omega;
                            let (a1, a2) = (e1.dot(shape.centroid), e2.dot(shape.centroid));
                            let (u1, u2) = (e1.dot(shape.hu), e2.dot(shape.hu));
                            let (v1, v2) = (e1.dot(shape.hv), e2.dot(shape.hv));
                            cov[0] += pw * (a1 * a1 + (u1 * u1 + v1 * v1) / 3.0);
                            cov[1] += pw * (a1 * a2 + (u1 * u2 + v1 * v2) / 3.0);
                            cov[2] += pw * (a2 * a2 + (u2 * u2 + v2 * v2) / 3.0);
                        }
                        let sq = filter::sqrt2(cov.map(|v| v / p)).unwrap_or([0.0; 3]);
                        let r3 = 3f64.sqrt();
                        *o = Some(Light {
                            power: p,
                            shape: TexelShape {
                                centroid: cen,
                                hu: (e1 * sq[0] + e2 * sq[1]) * r3,
                                hv: (e1 * sq[1] + e2 * sq[2]) * r3,
                                regular: true,
                            },
                        });
                    }
                    light.push(out);
                }
            }
        }
        MomentLevel {
            mapping: map.mapping,
            level: s,
            width: cw,
            height: ch,
            light,
            cones,
        }
    }

    /// ∑ over coarse texels and channels of the kernel integrated over each channel's
    /// parallelogram, where the rule for a texel of a `width` × `height` map takes the coarse
    /// texel whole (centre or tilted); elsewhere (cells: the horizon cuts it, or the lobe curves
    /// too much across it) the sum descends to its fine texels in `fine`, the level-0
    /// preparation of the same map.
    pub fn convolve(&self, fine: &Prepared, kernel: Kernel, axis: DVec3) -> [f64; 3] {
        let m = self.mapping;
        let (w, h) = (self.width, self.height);
        let side = 1u32 << self.level;
        let (fw, fh) = (w * side, h * side);
        let mut out = [0.0; 3];
        for layer in 0..m.layers() {
            for j in 0..h {
                for i in 0..w {
                    let at = ((layer * h + j) * w + i) as usize;
                    let light = &self.light[at];
                    let (dir, cos_rho, sin_rho) = self.cones[at];
                    match rule(kernel, axis.dot(dir), cos_rho, sin_rho, true) {
                        Rule::Skip => {}
                        Rule::Centre | Rule::Tilted => {
                            for (o, l) in out.iter_mut().zip(light) {
                                if let Some(l) = l {
                                    *o += l.power * tilted_mean(kernel, axis, &l.shape);
                                }
                            }
                        }
                        Rule::Cells(_) => {
                            for b in 0..side {
                                for a in 0..side {
                                    let (fi, fj) = (i * side + a, j * side + b);
                                    let t = ((layer * fh + fj) * fw + fi) as usize;
                                    for (o, v) in
                                        out.iter_mut().zip(fine.texel_term(kernel, axis, t))
                                    {
                                        *o += v;
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::envmap::EnvMap;
    use crate::math::synth::Sky;
    use glam::DMat3;

    /// Moments add: every level holds the map's power per channel (to f64 rounding), and a
    /// coarse texel whose light is one fine texel has that texel's centroid and covariance.
    #[test]
    fn levels_keep_power_and_a_lone_texel_shape() {
        let sky = Sky::default();
        let map = EnvMap::from_fn(Mapping::Cube, 16, 16, 2, |d| sky.radiance(d));
        let fine = Prepared::new(&map, DMat3::IDENTITY);
        let power = map.power();
        for s in 1..=4 {
            let level = MomentLevel::new(&fine, s);
            let mut sum = [0.0; 3];
            for t in &level.light {
                for (c, l) in t.iter().enumerate() {
                    sum[c] += l.map_or(0.0, |l| l.power);
                }
            }
            for c in 0..3 {
                assert!((sum[c] / power[c] - 1.0).abs() < 1e-12, "level {s}");
            }
        }
        let mut lone = EnvMap::from_fn(Mapping::LatLong, 32, 16, 1, |_| [0.0; 3]);
        let (i, j) = (13, 5);
        let at = lone.index(0, i, j);
        lone.texels[at] = [1.0, 2.0, 0.0];
        let fine = Prepared::new(&lone, DMat3::IDENTITY);
        let (shape, _, omega) = fine.texel(at);
        let level = MomentLevel::new(&fine, 2);
        let light = level.light[((j >> 2) * 8 + (i >> 2)) as usize];
        assert!(light[2].is_none());
        let cov = |hu: DVec3, hv: DVec3, a: DVec3, b: DVec3| {
            (a.dot(hu) * b.dot(hu) + a.dot(hv) * b.dot(hv)) / 3.0
        };
        let e1 = shape.centroid.any_orthonormal_vector();
        let e2 = shape.centroid.cross(e1);
        for (c, l) in light[..2].iter().enumerate() {
            let l = l.expect("power");
            assert!((l.power - (c + 1) as f64 * omega).abs() < 1e-15);
            assert!((l.shape.centroid - shape.centroid).length() < 1e-12);
            for (a, b) in [(e1, e1), (e1, e2), (e2, e2)] {
                let want = cov(shape.hu, shape.hv, a, b);
                let got = cov(l.shape.hu, l.shape.hv, a, b);
                assert!(
                    (got - want).abs() < 1e-9 * shape.hu.length_squared(),
                    "{got} vs {want}"
                );
            }
        }
    }

    /// The level falls as the lobe sharpens, and disc mappings and odd sizes have none.
    #[test]
    fn level_follows_the_lobe() {
        let levels: Vec<u32> = [1.0, 3.0, 17.0, 65.0, 257.0, 2049.0]
            .map(|n| level_for(Kernel::Phong { n }, Mapping::LatLong, 1024, 512))
            .to_vec();
        assert!(levels.windows(2).all(|w| w[0] >= w[1]), "{levels:?}");
        assert_eq!(levels[5], 0);
        assert!(levels[1] >= 4, "{levels:?}");
        assert_eq!(
            level_for(Kernel::Phong { n: 3.0 }, Mapping::Angular, 512, 512),
            0
        );
        assert_eq!(
            level_for(Kernel::Phong { n: 3.0 }, Mapping::LatLong, 1022, 511),
            0
        );
    }
}
