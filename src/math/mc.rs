//! The Monte Carlo reference estimator in float64, the oracle of `glsl/mc.comp`: the same
//! samples drawn in the same order, BRDF sampling combined with environment sampling by the
//! balance heuristic, and visibility against the scene's shapes when shadows are asked for.

use super::brdf::{local_view, Brdf, Frame};
use super::camera::Shape;
use super::envsample::EnvSampler;
use super::sequence::Rng;
use crate::math::envmap::luminance;
use glam::DVec3;

/// What every pixel's estimate shares.
#[derive(Clone, Copy)]
pub struct McSetup<'a> {
    /// The environment and its sampling tables.
    pub env: &'a EnvSampler,
    /// The scene's shapes, for shadow rays.
    pub shapes: &'a [Shape],
    /// Test visibility (V_em).
    pub shadows: bool,
    /// Combine BRDF and environment sampling (otherwise BRDF sampling alone).
    pub mis: bool,
    /// The random seed.
    pub seed: u32,
}

/// A surface point to estimate.
#[derive(Clone, Copy, Debug)]
pub struct McPoint {
    /// Pixel (x, y): it selects the random streams.
    pub pixel: (u32, u32),
    /// Hit position.
    pub position: DVec3,
    /// Unit normal.
    pub normal: DVec3,
    /// Unit direction to the eye.
    pub view: DVec3,
    /// The BRDF.
    pub brdf: Brdf,
    /// Albedo (specular colour) multiplying the result.
    pub albedo: [f64; 3],
}

/// The mean of some samples and the variance of that mean's luminance.
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    /// Mean radiance.
    pub mean: [f64; 3],
    /// Variance of the mean's luminance (sample variance / n).
    pub lum_var: f64,
}

/// Where a shadow ray starts (as `shadow_origin` in `glsl/include/scene.glsl`).
pub fn shadow_origin(p: DVec3, n: DVec3) -> DVec3 {
    p + n * (crate::abi::constants::SHADOW_OFFSET * (1.0 + p.length()))
}

fn occluded(shapes: &[Shape], o: DVec3, d: DVec3) -> bool {
    shapes.iter().any(|s| s.intersect(o, d).is_some())
}

/// Samples `first .. first + samples` of point `p`.
pub fn estimate(setup: &McSetup<'_>, p: &McPoint, first: u32, samples: u32) -> Estimate {
    let frame = Frame::new(p.normal);
    let wo = local_view(&frame, p.view);
    let origin = shadow_origin(p.position, p.normal);
    let incoming = |d: DVec3, l: [f64; 3]| {
        if setup.shadows && occluded(setup.shapes, origin, d) {
            [0.0; 3]
        } else {
            l
        }
    };
    let delta = p.brdf.is_delta();
    let (mut sum, mut sum2) = ([0.0; 3], 0.0);
    for s in 0..samples {
        let mut rng = Rng::new(p.pixel.0, p.pixel.1, first + s, setup.seed);
        let u = [rng.uniform(), rng.uniform()];
        let mut x = [0.0; 3];
        let wi = p.brdf.sample(wo, u);
        if wi.z > 0.0 {
            let d = frame.to_world(wi).normalize();
            let mut wt = if delta { 1.0 } else { p.brdf.weight(wo, wi) };
            if setup.mis && !delta {
                let pb = p.brdf.pdf(wo, wi);
                wt *= pb / (pb + setup.env.pdf(d));
            }
            if wt > 0.0 {
                let l = incoming(d, setup.env.radiance(d));
                for c in 0..3 {
                    x[c] += wt * l[c];
                }
            }
        }
        let ue = [rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform()];
        if setup.mis && !delta {
            let (d, pe, l) = setup.env.sample(ue);
            let wl = frame.to_local(d);
            if wl.z > 0.0 && pe > 0.0 {
                let f = p.brdf.eval_cos(wo, wl);
                if f > 0.0 {
                    let k = f / (p.brdf.pdf(wo, wl) + pe);
                    let l = incoming(d, l);
                    for c in 0..3 {
                        x[c] += k * l[c];
                    }
                }
            }
        }
        for c in 0..3 {
            x[c] *= p.albedo[c];
            sum[c] += x[c];
        }
        sum2 += luminance(x).powi(2);
    }
    let n = samples as f64;
    let mean = sum.map(|v| v / n);
    let ml = luminance(mean);
    let var = if samples > 1 {
        ((sum2 / n - ml * ml) * n / (n - 1.0)).max(0.0) / n
    } else {
        f64::INFINITY
    };
    Estimate { mean, lum_var: var }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::mapping::{Mapping, Orientation};
    use crate::EnvMap;

    #[test]
    fn furnace_converges_to_the_albedo() {
        // A white environment: every estimate is the BRDF's albedo, with and without MIS.
        let map = EnvMap::new(Mapping::LatLong, 16, 8, vec![[1.0; 3]; 128]);
        let env = EnvSampler::new(&map, &Orientation::default()).unwrap();
        for mis in [false, true] {
            let setup = McSetup {
                env: &env,
                shapes: &[],
                shadows: false,
                mis,
                seed: 9,
            };
            for brdf in [
                Brdf::Lambert,
                Brdf::Ggx {
                    alpha: 0.3,
                    correlated: true,
                },
                Brdf::Ward { ax: 0.3, ay: 0.1 },
            ] {
                let n = DVec3::new(0.2, 0.9, 0.1).normalize();
                let v = DVec3::new(0.9, 0.4, -0.2).normalize();
                let p = McPoint {
                    pixel: (3, 4),
                    position: DVec3::ZERO,
                    normal: n,
                    view: v,
                    brdf,
                    albedo: [1.0; 3],
                };
                let e = estimate(&setup, &p, 0, 20_000);
                let f = Frame::new(n);
                let want = brdf.albedo(local_view(&f, v));
                let err = (e.mean[1] - want).abs();
                assert!(
                    err < 5.0 * e.lum_var.sqrt() + 1e-12,
                    "{brdf:?} mis {mis}: {} vs {want} ± {}",
                    e.mean[1],
                    e.lum_var.sqrt()
                );
            }
        }
    }
}
