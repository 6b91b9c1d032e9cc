//! Importance sampling of a lat-long environment by luminance (float64; the GPU reads the
//! same tables in float32, `glsl/mc.comp`).
//!
//! Texel t is chosen with probability p_t ∝ Y(L_t)·Ω_t (Y: Rec. 709 luminance, Ω_t: its exact
//! solid angle), by a marginal CDF over rows and a conditional CDF within the row; the
//! direction is then uniform in solid angle inside the texel (φ uniform, cos θ uniform between
//! the row's bounds), so its density is exactly p_t/Ω_t and, read texel by texel, the
//! estimator L/pdf of a constant-BRDF integrand has no variance at all.

use super::mapping::{Mapping, Orientation};
use crate::error::{Error, Result};
use crate::math::envmap::{luminance, EnvMap};
use glam::{DMat3, DVec3};
use std::f64::consts::{PI, TAU};

/// The sampling tables of one lat-long map.
#[derive(Clone, Debug)]
pub struct EnvSampler {
    width: u32,
    height: u32,
    texels: Vec<[f64; 3]>,
    world_to_file: DMat3,
    /// Marginal CDF over rows (H entries, the last 1).
    marginal: Vec<f64>,
    /// Conditional CDF of each row (W entries per row, the last 1).
    conditional: Vec<f64>,
    /// Solid-angle density of each texel, p_t/Ω_t.
    pdf: Vec<f64>,
}

/// First k whose entry exceeds u (the last one when none does).
fn search(cdf: &[f64], u: f64) -> usize {
    let (mut lo, mut hi) = (0, cdf.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if cdf[mid] > u {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

impl EnvSampler {
    /// Builds the tables of a lat-long `map` whose file is oriented by `orientation`. Fails
    /// for another mapping; a map without light is sampled uniformly.
    pub fn new(map: &EnvMap, orientation: &Orientation) -> Result<EnvSampler> {
        if map.mapping != Mapping::LatLong {
            return Err(Error::Invalid(format!(
                "environment sampling needs a lat-long map, not {}",
                map.mapping.name()
            )));
        }
        let (w, h) = (map.width, map.height);
        let texels: Vec<[f64; 3]> = map
            .texels
            .iter()
            .map(|t| [t[0] as f64, t[1] as f64, t[2] as f64])
            .collect();
        // A map without light (zero luminance everywhere) is sampled
        // uniformly over the sphere: every sample then reads zero radiance, and the estimate
        // is an exact 0 rather than a refused render.
        let dark = texels.iter().all(|&t| luminance(t) <= 0.0);
        let weight = |t: [f64; 3]| if dark { 1.0 } else { luminance(t) };
        let mut conditional = vec![0.0; (w * h) as usize];
        let mut rows = vec![0.0; h as usize];
        for j in 0..h {
            let omega = Mapping::LatLong.texel_solid_angle(w, h, 0, j);
            let mut acc = 0.0;
            for i in 0..w {
                let k = (j * w + i) as usize;
                acc += weight(texels[k]) * omega;
                conditional[k] = acc;
            }
            rows[j as usize] = acc;
            for i in 0..w {
                let k = (j * w + i) as usize;
                // A dark row is never chosen; keep its CDF well formed anyway.
                conditional[k] = if acc > 0.0 {
                    conditional[k] / acc
                } else {
                    (i + 1) as f64 / w as f64
                };
            }
        }
        let total: f64 = rows.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return Err(Error::Invalid(
                "the environment has no light to sample".into(),
            ));
        }
        let mut marginal = Vec::with_capacity(h as usize);
        let mut acc = 0.0;
        for r in &rows {
            acc += r;
            marginal.push(acc / total);
        }
        // p_t/Ω_t = (Y·Ω_t/total)/Ω_t.
        let pdf = texels.iter().map(|&t| weight(t) / total).collect();
        Ok(EnvSampler {
            width: w,
            height: h,
            texels,
            world_to_file: orientation.checked_world_to_file()?,
            marginal,
            conditional,
            pdf,
        })
    }

    /// (width, height) of the map.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The tables as the GPU reads them: marginal, conditional, pdf, in float32.
    pub fn tables_f32(&self) -> Vec<f32> {
        self.marginal
            .iter()
            .chain(&self.conditional)
            .chain(&self.pdf)
            .map(|&v| v as f32)
            .collect()
    }

    fn texel_of(&self, d: DVec3) -> usize {
        let c = Mapping::LatLong.dir_to_coord(self.world_to_file * d);
        let i = ((c.u * self.width as f64) as u32).min(self.width - 1);
        let j = ((c.v * self.height as f64) as u32).min(self.height - 1);
        (j * self.width + i) as usize
    }

    /// Radiance along world direction d (the texel it falls in).
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        self.texels[self.texel_of(d)]
    }

    /// The solid-angle density of [`EnvSampler::sample`] at world direction d.
    pub fn pdf(&self, d: DVec3) -> f64 {
        self.pdf[self.texel_of(d)]
    }

    /// A world direction for uniforms u, with its density and the texel's radiance.
    pub fn sample(&self, u: [f64; 4]) -> (DVec3, f64, [f64; 3]) {
        let (w, h) = (self.width as usize, self.height as usize);
        let j = search(&self.marginal, u[0]);
        let i = search(&self.conditional[j * w..(j + 1) * w], u[1]);
        let phi = TAU * (i as f64 + u[2]) / w as f64;
        let (c0, c1) = (
            (PI * j as f64 / h as f64).cos(),
            (PI * (j + 1) as f64 / h as f64).cos(),
        );
        let ct = c0 - u[3] * (c0 - c1);
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        let f = DVec3::new(st * phi.sin(), ct, -st * phi.cos());
        let k = j * w + i;
        (
            (self.world_to_file.transpose() * f).normalize(),
            self.pdf[k],
            self.texels[k],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sequence::Rng;

    #[test]
    fn pdf_integrates_to_one_and_matches_sampling() {
        let sky = crate::math::synth::Sky::default();
        let map = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
        let s = EnvSampler::new(
            &map,
            &Orientation {
                rotate_y_degrees: 30.0,
                ..Default::default()
            },
        )
        .unwrap();
        let mut total = 0.0;
        map.for_each_texel(|_, i, j, _, omega| total += s.pdf[(j * 64 + i) as usize] * omega);
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        // E[L/pdf] over samples is the power ∫Y dω, with no variance for the luminance.
        let power: f64 = {
            let mut p = 0.0;
            map.for_each_texel(|_, _, _, t, omega| {
                p += luminance([t[0] as f64, t[1] as f64, t[2] as f64]) * omega
            });
            p
        };
        let mut rng = Rng::new(1, 2, 3, 4);
        for _ in 0..2000 {
            let u = [rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform()];
            let (d, pdf, l) = s.sample(u);
            assert!((d.length() - 1.0).abs() < 1e-12);
            // The sampled direction lies in the texel whose density it reports.
            assert_eq!(s.pdf(d), pdf);
            assert_eq!(s.radiance(d), l);
            assert!((luminance(l) / pdf / power - 1.0).abs() < 1e-9);
        }
    }
}
