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

/// The lod a FIS sample of density `pdf` (one of `samples`) along `d` reads from a chain whose
/// level 0 is `size` a side: ½·log2(Ωs/Ωp) + `bias`, Ωs = 1/(N·pdf), clamped to [0,
/// `max_lod`]; the last level where the pdf is 0.
pub fn sample_lod(pdf: f64, samples: u32, d: DVec3, size: u32, bias: f64, max_lod: f64) -> f64 {
    if pdf > 0.0 {
        let omega_s = 1.0 / (samples as f64 * pdf);
        (0.5 * (omega_s / texel_solid_angle(d, size)).log2() + bias).clamp(0.0, max_lod)
    } else {
        max_lod
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
        let d = frame.to_world(wi).normalize();
        let lod = sample_lod(brdf.pdf(wo, wi), samples, d, size, bias, max_lod);
        let l = lookup(chain, d, lod);
        for c in 0..3 {
            sum[c] += w * l[c];
        }
    }
    sum.map(|s| s / samples as f64)
}
