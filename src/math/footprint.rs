//! Footprint-filtered lookups, the float64 twin of `glsl/shade.frag`'s
//! `footprint_lookup` and `footprint_lights`.
//!
//! A pixel of a mirror (or of the background) sees not one direction but the set its area
//! maps to. Its footprint is the parallelogram spanned by the directional differentials
//! `a` = ∂r/∂x and `b` = ∂r/∂y about the looked-up direction r, taken from the G-buffer's
//! neighbours ([`spread`]: central differences where both neighbours see the same object,
//! one-sided at its edge). The pixel's mean radiance is then read from the dual-paraboloid
//! MIP chain by a grid of taps over the pixel ([`lookup`]), each a sub-pixel camera ray
//! reflected off the object exactly ([`camera_tap`], so a pixel on a silhouette mixes the
//! mirror and the background as its area does):
//! `crate::abi::footprint::MIN_TAPS` across the minor axis and as many at that
//! spacing along the major one, up to `crate::abi::footprint::MAX_TAPS`, each
//! trilinear at the lod whose texel is the taps' spacing.
//!
//! With light texels extracted the chain holds the residual, and each light texel adds its
//! excess radiance times the share of the pixel it covers ([`light_overlap`]): the texel,
//! a square of side ρ = √Ω in the tangent plane, mapped to pixel coordinates by the inverse
//! of the footprint's Jacobian and intersected with the pixel's square.

use super::brdf::Frame;
use super::camera::{trace, Camera, Shape};
use super::fis;
use super::lights::PreparedLight;
use super::mip::{texel_solid_angle, Level};
use crate::abi::footprint::{LOD_BIAS, MAX_TAPS, MIN_SPREAD, MIN_TAPS, TAP_SLACK};
use glam::DVec3;

/// The differential of the looked-up direction along one image axis at a pixel looking up
/// `c`: half the difference of its two neighbours' directions where both see what the pixel
/// sees, else the one-sided difference, else zero; its component along `c` removed.
pub fn spread(c: DVec3, minus: Option<DVec3>, plus: Option<DVec3>) -> DVec3 {
    let d = match (minus, plus) {
        (Some(m), Some(p)) => 0.5 * (p - m),
        (Some(m), None) => c - m,
        (None, Some(p)) => p - c,
        (None, None) => DVec3::ZERO,
    };
    d - c * c.dot(d)
}

/// What pixel (i, j) of `cam` looks up: the shape its centre ray hits (`None`: the
/// background) and the direction, reflected about the normal or the ray's own; `None` outside
/// the image.
pub fn looked_up(cam: &Camera, shapes: &[Shape], i: i64, j: i64) -> Option<(Option<usize>, DVec3)> {
    if i < 0 || j < 0 || i >= cam.width as i64 || j >= cam.height as i64 {
        return None;
    }
    let (o, d) = cam.ray(i as u32, j as u32);
    Some(match trace(shapes, o, d) {
        Some(h) => (Some(h.index), d - 2.0 * h.normal.dot(d) * h.normal),
        None => (None, d),
    })
}

/// Pixel (i, j)'s footprint as `shade.frag` takes it from the G-buffer: what it hits, the
/// direction r it looks up, and [`spread`] along x and y from the neighbours that hit the same.
pub fn pixel_footprint(
    cam: &Camera,
    shapes: &[Shape],
    i: u32,
    j: u32,
) -> (Option<usize>, DVec3, DVec3, DVec3) {
    let (i, j) = (i as i64, j as i64);
    let (what, r) = looked_up(cam, shapes, i, j).unwrap_or((None, DVec3::Z));
    let same = |i, j| {
        looked_up(cam, shapes, i, j)
            .filter(|(w, _)| *w == what)
            .map(|(_, d)| d)
    };
    let a = spread(r, same(i - 1, j), same(i + 1, j));
    let b = spread(r, same(i, j - 1), same(i, j + 1));
    (what, r, a, b)
}

/// Taps along `a` and `b`: the tap spacing is the footprint's minor axis over `MIN_TAPS`,
/// or its major axis over `MAX_TAPS` where that is longer.
pub fn taps(la: f64, lb: f64) -> (u32, u32) {
    let s = (la.max(lb) / MAX_TAPS as f64).max(la.min(lb) / MIN_TAPS as f64);
    let n = |l: f64| {
        if s > 0.0 {
            ((l / s - TAP_SLACK).ceil() as u32).clamp(1, MAX_TAPS)
        } else {
            1
        }
    };
    (n(la), n(lb))
}

/// The mean radiance over the footprint of `r` (unit) spanned by `a` and `b`, read from the
/// premultiplied dual-paraboloid `chain` (level 0 `chain[0].size` a side): a grid of taps,
/// `tap(fa, fb)` giving the direction at pixel offset (fa, fb) ∈ [−½, ½]² or `None` where the
/// tap is not the pixel's to filter; each read at the lod whose texel is the taps' spacing.
/// With no tap left, `r` alone.
pub fn lookup(
    chain: &[Level],
    r: DVec3,
    a: DVec3,
    b: DVec3,
    tap: impl Fn(f64, f64) -> Option<DVec3>,
) -> [f64; 3] {
    let size = chain[0].size;
    let max_lod = (chain.len() - 1) as f64;
    let (la, lb) = (a.length(), b.length());
    let (na, nb) = taps(la, lb);
    let spacing = (la / na as f64).max(lb / nb as f64).max(MIN_SPREAD);
    let read = |d: DVec3| {
        let lod = 0.5 * (spacing * spacing / texel_solid_angle(d, size)).log2() + LOD_BIAS;
        fis::lookup(chain, d, lod.clamp(0.0, max_lod))
    };
    let mut acc = [0.0; 3];
    let mut n = 0;
    for j in 0..nb {
        for i in 0..na {
            let fa = (i as f64 + 0.5) / na as f64 - 0.5;
            let fb = (j as f64 + 0.5) / nb as f64 - 0.5;
            let Some(d) = tap(fa, fb) else {
                continue;
            };
            for (s, x) in acc.iter_mut().zip(read(d)) {
                *s += x;
            }
            n += 1;
        }
    }
    if n == 0 {
        return read(r);
    }
    acc.map(|s| s / n as f64)
}

/// The tap of pixel (i, j) at offset (fa, fb) as `shade.frag` casts it: the ray through that
/// image point, reflected off the shape `what` where it meets that shape first, itself where
/// it meets nothing or `what` is the background (`None`), and no tap where it meets another.
pub fn camera_tap(
    cam: &Camera,
    shapes: &[Shape],
    what: Option<usize>,
    i: u32,
    j: u32,
    fa: f64,
    fb: f64,
) -> Option<DVec3> {
    camera_tap_seen(cam, shapes, what, i, j, fa, fb).map(|t| t.0)
}

/// [`camera_tap`], with whether the tap saw the background though the pixel sees a shape (a
/// silhouette's tap past the shape's edge).
pub fn camera_tap_seen(
    cam: &Camera,
    shapes: &[Shape],
    what: Option<usize>,
    i: u32,
    j: u32,
    fa: f64,
    fb: f64,
) -> Option<(DVec3, bool)> {
    let (o, d) = cam.ray_at(i as f64 + 0.5 + fa, j as f64 + 0.5 + fb);
    if what.is_none() {
        return Some((d, false));
    }
    match trace(shapes, o, d) {
        None => Some((d, true)),
        Some(h) if Some(h.index) == what => Some((d - 2.0 * h.normal.dot(d) * h.normal, false)),
        Some(_) => None,
    }
}

/// The light texels' excess over pixel (i, j) of a shape's silhouette (some of its taps see
/// the background, or a neighbour sees something else): per tap of [`lookup`]'s grid, [`light_overlap`] over a square about the
/// tap's direction as wide as the taps' spacing — the box each tap's read of the chain
/// filters — averaged over the taps. One overlap over the whole pixel would spread the
/// reflection's linearised footprint over the part of the pixel that sees the background,
/// and a grazing reflection's footprint bends within the pixel.
pub fn silhouette_lights(
    cam: &Camera,
    shapes: &[Shape],
    lights: &[PreparedLight],
    (i, j): (u32, u32),
    what: Option<usize>,
    a: DVec3,
    b: DVec3,
) -> [f64; 3] {
    let (la, lb) = (a.length(), b.length());
    let (na, nb) = taps(la, lb);
    let spacing = (la / na as f64).max(lb / nb as f64).max(MIN_SPREAD);
    let (mut acc, mut n) = ([0.0; 3], 0);
    for jj in 0..nb {
        for ii in 0..na {
            let fa = (ii as f64 + 0.5) / na as f64 - 0.5;
            let fb = (jj as f64 + 0.5) / nb as f64 - 0.5;
            let Some(d) = camera_tap(cam, shapes, what, i, j, fa, fb) else {
                continue;
            };
            let f = Frame::new(d);
            let e = light_overlap(lights, d, spacing * f.t, spacing * f.b);
            for (x, y) in acc.iter_mut().zip(e) {
                *x += y;
            }
            n += 1;
        }
    }
    acc.map(|x| x / n.max(1) as f64)
}

/// Whether one of pixel (i, j)'s four neighbours sees something other than `what` (or lies
/// outside the image): its footprint's differentials are one-sided there.
pub fn beside_other(cam: &Camera, shapes: &[Shape], what: Option<usize>, i: u32, j: u32) -> bool {
    let (i, j) = (i as i64, j as i64);
    [(i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)]
        .into_iter()
        .any(|(x, y)| looked_up(cam, shapes, x, y).is_none_or(|(w, _)| w != what))
}

/// Pixel (i, j)'s footprint-filtered radiance, as `shade.frag` computes it for a mirror (of
/// albedo 1) or the background: [`lookup`] with [`camera_tap`]s, plus [`light_overlap`] of
/// `lights` where the chain holds the residual ([`silhouette_lights`] where a tap sees past
/// the shape's edge or a neighbour sees something else).
pub fn pixel(
    chain: &[Level],
    cam: &Camera,
    shapes: &[Shape],
    lights: &[PreparedLight],
    i: u32,
    j: u32,
) -> [f64; 3] {
    let (what, r, a, b) = pixel_footprint(cam, shapes, i, j);
    let past = std::cell::Cell::new(false);
    let mut l = lookup(chain, r, a, b, |fa, fb| {
        let t = camera_tap_seen(cam, shapes, what, i, j, fa, fb)?;
        past.set(past.get() || t.1);
        Some(t.0)
    });
    let e = match past.get() || beside_other(cam, shapes, what, i, j) {
        true => silhouette_lights(cam, shapes, lights, (i, j), what, a, b),
        false => light_overlap(lights, r, a, b),
    };
    for (x, y) in l.iter_mut().zip(e) {
        *x += y;
    }
    l
}

/// Length of [s − h, s + h] ∩ [−½, ½].
fn overlap(s: f64, h: f64) -> f64 {
    ((s + h).min(0.5) - (s - h).max(-0.5)).max(0.0)
}

/// Σ over `lights` of the excess radiance times the share of the pixel (footprint `a`, `b`
/// about `r`) the texel covers. A footprint of area below `MIN_SPREAD`² is a point, which
/// a texel covers wholly or not at all.
pub fn light_overlap(lights: &[PreparedLight], r: DVec3, a: DVec3, b: DVec3) -> [f64; 3] {
    OverlapShape::new(r, a, b).sum(lights)
}

/// A pixel's footprint (`a`, `b` about `r`) as [`light_overlap`] measures texels against it:
/// the tangent frame at r and the inverse of the footprint's Jacobian there.
pub struct OverlapShape {
    r: DVec3,
    f: Frame,
    point: bool,
    inv: [f64; 4],
    n: [f64; 2],
    k: f64,
    /// The Jacobian's Frobenius norm.
    jn: f64,
}

impl OverlapShape {
    /// The shape of footprint `a`, `b` about `r`.
    pub fn new(r: DVec3, a: DVec3, b: DVec3) -> OverlapShape {
        let f = Frame::new(r);
        let (j00, j01, j10, j11) = (a.dot(f.t), b.dot(f.t), a.dot(f.b), b.dot(f.b));
        let det = j00 * j11 - j01 * j10;
        let point = det.abs() < MIN_SPREAD * MIN_SPREAD;
        // Rows of J⁻¹ and their lengths; k scales half sides so a texel's area is Ω/|det J|.
        let inv = if point { 0.0 } else { 1.0 / det };
        let (i00, i01, i10, i11) = (j11 * inv, -j01 * inv, -j10 * inv, j00 * inv);
        let (n0, n1) = (i00.hypot(i01), i10.hypot(i11));
        let k = if point {
            0.0
        } else {
            0.5 / (n0 * n1 * det.abs()).sqrt()
        };
        OverlapShape {
            r,
            f,
            point,
            inv: [i00, i01, i10, i11],
            n: [n0, n1],
            k,
            jn: (j00 * j00 + j01 * j01 + j10 * j10 + j11 * j11).sqrt(),
        }
    }

    /// Σ over `lights` of the excess radiance times the share of the pixel each covers,
    /// divided by the shares' total where it exceeds 1: the texels' squares do not tile the
    /// pixel, and where they overlap (texels large next to the pixel) they would cover it
    /// more than once (a 7 × 7 angular map's background came out 28% above its brightest
    /// texel once the residual under the lights was filled).
    pub fn sum(&self, lights: &[PreparedLight]) -> [f64; 3] {
        let (mut sum, mut total) = ([0.0; 3], 0.0);
        for t in lights {
            let share = self.share(t);
            for (x, l) in sum.iter_mut().zip(t.radiance) {
                *x += share * l;
            }
            total += share;
        }
        Self::normalised(sum, total)
    }

    /// A sum of shares' radiance divided by the shares' `total` where it exceeds 1.
    pub fn normalised(sum: [f64; 3], total: f64) -> [f64; 3] {
        if total > 1.0 {
            sum.map(|x| x / total)
        } else {
            sum
        }
    }

    /// The share of the pixel light texel `t` covers (its square in pixel coordinates).
    pub fn share(&self, t: &PreparedLight) -> f64 {
        let [i00, i01, i10, i11] = self.inv;
        let [n0, n1] = self.n;
        let c = t.dir.dot(self.r);
        if c <= 0.0 {
            return 0.0;
        }
        // Gnomonic projection of the texel's centre onto the tangent plane at r.
        let e = t.dir / c - self.r;
        let (ex, ey) = (e.dot(self.f.t), e.dot(self.f.b));
        if self.point {
            let h = 0.5 * t.rho;
            if ex.abs() <= h && ey.abs() <= h {
                1.0
            } else {
                0.0
            }
        } else {
            let (s, q) = (i00 * ex + i01 * ey, i10 * ex + i11 * ey);
            let h = self.k * t.rho;
            overlap(s, h * n0) * overlap(q, h * n1)
        }
    }

    /// Whether no texel of a light-tree node (texel centres within chord `reach` of its unit
    /// `centre`, texels `rho` wide) can cover any of the pixel: every texel centre lies within
    /// chord `reach` of the node's centre, so on the arc between them the dot with r is at
    /// least c − reach, the gnomonic map stretches by at most 1/(c − reach)², and the arc is
    /// at most π/2 times the chord: the texel's gnomonic point lies within G = π/2·reach/(c −
    /// reach)² of the centre's. The texel's box reaches
    /// k·ρ·n from its point in pixel units (½ρ in the plane for a point footprint).
    /// Also, a texel it covers has its gnomonic point e within the pixel's box grown by the
    /// texel's, so |e| = tan θ ≤ E (½ρ·√2 for a point footprint, else |J|·|(½ + k·ρ·n0, ½ +
    /// k·ρ·n1)|), and its centre lies within chord 2·sin(θ/2) ≤ tan θ ≤ E of r: a node whose
    /// centre lies further than reach + E from r misses (a bound in chords, since one in
    /// cosines is √(2·reach) wide and lets far more nodes through).
    pub fn misses(&self, centre: DVec3, rho: f64, reach: f64) -> bool {
        let c = centre.dot(self.r);
        let e_max = if self.point {
            std::f64::consts::FRAC_1_SQRT_2 * rho
        } else {
            let h = self.k * rho;
            self.jn * (0.5 + h * self.n[0]).hypot(0.5 + h * self.n[1])
        };
        if (centre - self.r).length() > reach + e_max {
            return true;
        }
        let low = c - reach;
        if low <= 0.0 {
            return false;
        }
        let g = std::f64::consts::FRAC_PI_2 * reach / (low * low);
        let e = centre / c - self.r;
        let (ex, ey) = (e.dot(self.f.t), e.dot(self.f.b));
        if self.point {
            let h = 0.5 * rho;
            return ex.abs() - g > h || ey.abs() - g > h;
        }
        let [i00, i01, i10, i11] = self.inv;
        let [n0, n1] = self.n;
        let h = self.k * rho;
        let (s, q) = (i00 * ex + i01 * ey, i10 * ex + i11 * ey);
        s.abs() - n0 * g >= 0.5 + h * n0 || q.abs() - n1 * g >= 0.5 + h * n1
    }
}

/// The pixel-area mean a footprint-filtered render estimates, by brute force: each pixel of
/// `cam`'s image the mean of `n`×`n` sub-pixel camera rays, each reflected off the first of
/// `shapes` it meets (a mirror) or seeing the background, and read from `env` at the texel
/// its direction falls in (no filtering: [`super::convert::sample_nearest`]). `env` in its
/// file's frame (no orientation). The reference of the footprint filter's accuracy.
pub fn supersampled(env: &crate::EnvMap, cam: &Camera, shapes: &[Shape], n: u32) -> crate::EnvMap {
    let row = |j: u32| -> Vec<[f32; 3]> {
        (0..cam.width)
            .map(|i| {
                let mut acc = [0.0; 3];
                for s in 0..n * n {
                    let x = i as f64 + ((s % n) as f64 + 0.5) / n as f64;
                    let y = j as f64 + ((s / n) as f64 + 0.5) / n as f64;
                    let (o, d) = cam.ray_at(x, y);
                    let dir = match trace(shapes, o, d) {
                        Some(h) => d - 2.0 * h.normal.dot(d) * h.normal,
                        None => d,
                    };
                    let l = super::convert::sample_nearest(env, dir);
                    for c in 0..3 {
                        acc[c] += l[c];
                    }
                }
                let k = (n * n) as f64;
                acc.map(|a| (a / k) as f32)
            })
            .collect()
    };
    let rows = super::rows_on_every_core(cam.height, row);
    crate::EnvMap::new(
        super::Mapping::LatLong,
        cam.width,
        cam.height,
        rows.concat(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_follow_the_major_axis() {
        let (lo, hi) = (MIN_TAPS, MAX_TAPS);
        assert_eq!(taps(0.0, 0.0), (1, 1));
        assert_eq!(taps(1.0, 1.0), (lo, lo));
        assert_eq!(taps(2.0, 1.0), ((2 * lo).min(hi), lo.min(hi / 2)));
        assert_eq!(taps(1e3, 1.0), (hi, 1));
        assert_eq!(taps(16.0, 0.0), (hi, 1));
    }

    /// A light texel well inside a large footprint gives Ω/|a×b| of its excess (its share
    /// of the pixel's solid angle); a texel around a point footprint gives all of it; one
    /// beyond the footprint nothing; a texel straddling the footprint's edge about half; and
    /// two texels that each cover the whole pixel give their mean, not their sum.
    #[test]
    fn light_overlap_is_the_covered_share() {
        let r = DVec3::Z;
        let f = Frame::new(r);
        let (a, b) = (0.1 * f.t, 0.05 * f.b);
        let light = |dir: DVec3, rho: f64| PreparedLight {
            dir: dir.normalize(),
            omega: rho * rho,
            radiance: [1.0, 2.0, 3.0],
            rho,
            nodes: Vec::new(),
            coarse: Vec::new(),
        };
        let inside = light(r + 0.01 * f.t, 0.01);
        let s = light_overlap(std::slice::from_ref(&inside), r, a, b);
        let want = 1e-4 / (0.1 * 0.05);
        assert!((s[0] - want).abs() < 1e-3 * want, "{s:?} {want}");
        assert!((s[2] - 3.0 * want).abs() < 3e-3 * want);
        let z = DVec3::ZERO;
        assert_eq!(light_overlap(&[light(r, 0.01)], r, z, z), [1.0, 2.0, 3.0]);
        assert_eq!(
            light_overlap(&[light(r + 0.02 * f.t, 0.01)], r, z, z),
            [0.0; 3]
        );
        assert_eq!(
            light_overlap(&[light(r + 0.2 * f.t, 0.01)], r, a, b),
            [0.0; 3]
        );
        let edge = light_overlap(&[light(r + 0.05 * f.t, 0.01)], r, a, b);
        assert!((edge[0] - 0.5 * want).abs() < 0.02 * want, "{edge:?}");
        assert_eq!(light_overlap(&[light(-r, 0.01)], r, a, b), [0.0; 3]);
        // Two texels whose squares both cover the whole pixel cover it once: their mean.
        let (small_a, small_b) = (1e-3 * f.t, 1e-3 * f.b);
        let both = [light(r + 1e-3 * f.t, 0.1), light(r - 1e-3 * f.t, 0.1)];
        let s = light_overlap(&both, r, small_a, small_b);
        assert!(
            (s[0] - 1.0).abs() < 1e-9 && (s[2] - 3.0).abs() < 1e-9,
            "{s:?}"
        );
    }

    /// `spread` takes central differences inside, one-sided at an edge, and keeps only the
    /// part tangent to the looked-up direction.
    #[test]
    fn spread_is_tangent() {
        let c = DVec3::Z;
        let m = DVec3::new(-0.1, 0.0, 1.0).normalize();
        let p = DVec3::new(0.1, 0.0, 1.0).normalize();
        let s = spread(c, Some(m), Some(p));
        assert!((s.x - p.x).abs() < 1e-12 && s.z.abs() < 1e-12);
        let s = spread(c, None, Some(p));
        assert!((s.x - p.x).abs() < 1e-12 && s.z.abs() < 1e-12);
        assert_eq!(spread(c, None, None), DVec3::ZERO);
    }
}
