//! Filtered importance sampling (Colbert & Křivánek 2007) in float64: the twin of
//! `glsl/shade.frag`'s `fis()`. N Hammersley points (optionally rotated per pixel) sample the
//! BRDF; each sample reads the premultiplied dual-paraboloid chain ([`super::mip`]) at
//! lod = clamp(½·log2(Ωs/Ωp) + bias, 0, last), Ωs = 1/(N·pdf), Ωp the level-0 texel's solid
//! angle at the sample's direction; samples below the horizon count as zero light.

use super::brdf::{local_view, Brdf, Frame};
use super::mapping::Mapping;
use super::mip::{texel_solid_angle, Level};
use super::sequence::{hammersley, rotate};
use glam::DVec3;

/// A bilinear read of a premultiplied level at direction `d`, clamped to the edge as the
/// sampler is: (Σ w·rgb, Σ w).
fn bilinear(level: &Level, d: DVec3) -> [f64; 4] {
    let c = Mapping::DualParaboloid.dir_to_coord(d);
    let size = level.size as i64;
    let (x, y) = (c.u * size as f64 - 0.5, c.v * size as f64 - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let mut acc = [0.0; 4];
    for k in 0..4 {
        let (dx, dy) = (k & 1, k >> 1);
        let i = (x0 as i64 + dx).clamp(0, size - 1);
        let j = (y0 as i64 + dy).clamp(0, size - 1);
        let w = if dx == 1 { fx } else { 1.0 - fx } * if dy == 1 { fy } else { 1.0 - fy };
        let t = level.texels[((c.layer as i64 * size + j) * size + i) as usize];
        for ch in 0..4 {
            acc[ch] += w * t[ch];
        }
    }
    acc
}

/// Radiance read from `chain` along `d` at `lod`: trilinear in the premultiplied levels, then
/// rgb divided by the weight (0 where there is none), as `dp_lookup` does.
pub fn lookup(chain: &[Level], d: DVec3, lod: f64) -> [f64; 3] {
    let lod = lod.clamp(0.0, (chain.len() - 1) as f64);
    let l0 = lod.floor() as usize;
    let f = lod - l0 as f64;
    let mut v = bilinear(&chain[l0], d);
    if f > 0.0 && l0 + 1 < chain.len() {
        let b = bilinear(&chain[l0 + 1], d);
        for ch in 0..4 {
            v[ch] += f * (b[ch] - v[ch]);
        }
    }
    if v[3] > 0.0 {
        [v[0] / v[3], v[1] / v[3], v[2] / v[3]]
    } else {
        [0.0; 3]
    }
}

/// The FIS estimate of ∫ f·cos·L dω at a surface of normal `n` seen along `v` (unit, towards
/// the eye), with `samples` points, lod `bias`, and the per-pixel rotation `offset` ([0, 0]
/// when off). Shadows are not traced here.
pub fn estimate(
    chain: &[Level],
    brdf: &Brdf,
    n: DVec3,
    v: DVec3,
    samples: u32,
    bias: f64,
    offset: [f64; 2],
) -> [f64; 3] {
    let frame = Frame::new(n);
    let wo = local_view(&frame, v);
    let size = chain[0].size;
    let max_lod = (chain.len() - 1) as f64;
    let mut sum = [0.0; 3];
    for i in 0..samples {
        let wi = brdf.sample(wo, rotate(hammersley(i, samples), offset));
        if wi.z <= 0.0 {
            continue;
        }
        let w = brdf.weight(wo, wi);
        let pdf = brdf.pdf(wo, wi);
        let d = frame.to_world(wi).normalize();
        let lod = if pdf > 0.0 {
            let omega_s = 1.0 / (samples as f64 * pdf);
            (0.5 * (omega_s / texel_solid_angle(d, size)).log2() + bias).clamp(0.0, max_lod)
        } else {
            max_lod
        };
        let l = lookup(chain, d, lod);
        for c in 0..3 {
            sum[c] += w * l[c];
        }
    }
    sum.map(|s| s / samples as f64)
}

/// Views up to this angle from the normal (degrees) get level-0 texels no coarser than their
/// densest FIS sample calls for, in [`dp_size_for`]; more grazing views (the outer 1.5% of a
/// sphere's radius) may read level 0 where they would want finer.
pub const DP_SIZE_VIEW_LIMIT_DEG: f64 = 80.0;

/// The largest sampling density of `brdf` over views up to [`DP_SIZE_VIEW_LIMIT_DEG`]: its
/// pdf at the mirror direction (the peak of every lobe here) and at the normal (Lambert's).
pub fn pdf_peak(brdf: &Brdf) -> f64 {
    let mut peak = 0.0f64;
    for k in 0..=32 {
        let t = (k as f64 / 32.0 * DP_SIZE_VIEW_LIMIT_DEG).to_radians();
        // Along x and along y, for Ward's two axes.
        for wo in [
            DVec3::new(t.sin(), 0.0, t.cos()),
            DVec3::new(0.0, t.sin(), t.cos()),
        ] {
            let mirror = DVec3::new(-wo.x, -wo.y, wo.z);
            peak = peak.max(brdf.pdf(wo, mirror)).max(brdf.pdf(wo, DVec3::Z));
        }
    }
    peak
}

/// The dual-paraboloid side a FIS material needs: the smallest power of two from 16 to 4096
/// at which its densest sample (Ωs = 1/(N·[`pdf_peak`])) reads lod ≥ 0 even where level-0
/// texels are largest (16/size² sr, at a half's centre): ½·log2(Ωs·size²/16) + bias ≥ 0.
/// A larger map's finer levels would never be read. 4096 for a delta BRDF.
pub fn dp_size_for(brdf: &Brdf, samples: u32, bias: f64) -> u32 {
    let peak = pdf_peak(brdf);
    if !(peak.is_finite() && peak > 0.0) {
        return 4096;
    }
    let side = 4.0 * (f64::from(samples.max(1)) * peak).sqrt() / bias.exp2();
    (side.ceil().min(4096.0) as u32)
        .next_power_of_two()
        .clamp(16, 4096)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chosen side is the smallest power of two at which the densest sample reads lod ≥ 0,
    /// for lobes from broad to sharp.
    #[test]
    fn dp_size_is_the_smallest_that_keeps_lod_nonnegative() {
        let lod = |brdf: &Brdf, n: u32, bias: f64, size: u32| {
            let omega_s = 1.0 / (f64::from(n) * pdf_peak(brdf));
            0.5 * (omega_s / (16.0 / f64::from(size * size))).log2() + bias
        };
        let mut sizes = Vec::new();
        for (brdf, n) in [
            (Brdf::Lambert, 16),
            (
                Brdf::Ggx {
                    alpha: 0.6,
                    correlated: false,
                },
                64,
            ),
            (
                Brdf::Ggx {
                    alpha: 0.3,
                    correlated: false,
                },
                64,
            ),
            (
                Brdf::Ggx {
                    alpha: 0.05,
                    correlated: true,
                },
                64,
            ),
            (Brdf::Phong { n: 1000.0 }, 64),
            (Brdf::Blinn { n: 200.0 }, 32),
            (Brdf::Ward { ax: 0.05, ay: 0.3 }, 64),
        ] {
            for bias in [0.0, 0.25, 1.0] {
                let s = dp_size_for(&brdf, n, bias);
                sizes.push(s);
                assert!(s.is_power_of_two() && (16..=4096).contains(&s));
                assert!(lod(&brdf, n, bias, s) >= 0.0, "{brdf:?} {n} {bias}: {s}");
                if s > 16 {
                    assert!(lod(&brdf, n, bias, s / 2) < 0.0, "{brdf:?} {n} {bias}: {s}");
                }
            }
        }
        // Sharper lobes and more samples need finer maps.
        let g = |a: f64, n: u32| {
            dp_size_for(
                &Brdf::Ggx {
                    alpha: a,
                    correlated: false,
                },
                n,
                0.25,
            )
        };
        assert!(g(0.05, 64) > g(0.3, 64) && g(0.3, 64) > g(0.6, 64) && g(0.3, 256) > g(0.3, 16));
        assert_eq!(dp_size_for(&Brdf::Mirror, 64, 0.25), 4096);
        eprintln!("{sizes:?}");
    }
}
