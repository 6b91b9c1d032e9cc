//! Analytic environments: the bundled sky and the smooth functions conversion is tested on.

use glam::DVec3;
use std::f64::consts::PI;

use super::mapping::Mapping;

/// `n` nearly uniform unit directions on a Fibonacci spiral.
pub fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let (s, c) = (golden * k as f64).sin_cos();
            DVec3::new(r * c, y, r * s)
        })
        .collect()
}

/// Directions that stress every mapping: the six axes, points within 1e-7 and 1e-12 of them,
/// cube edges, the paraboloid seam (y = 0), the lat-long seam (x = 0, z < 0), plus 100 000
/// Fibonacci directions.
pub fn stress_directions() -> Vec<DVec3> {
    let mut v = Vec::new();
    let axes = [
        DVec3::X,
        DVec3::NEG_X,
        DVec3::Y,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ];
    for a in axes {
        v.push(a);
        for b in axes {
            for eps in [1e-7, -1e-7, 1e-12, 1e-3] {
                v.push((a + b * eps).normalize());
            }
            v.push((a + b).try_normalize().unwrap_or(a));
        }
    }
    for k in 0..2000 {
        let t = k as f64 / 2000.0 * std::f64::consts::TAU;
        v.push(DVec3::new(t.cos(), 0.0, t.sin()));
        v.push(DVec3::new(t.cos(), 1e-7, t.sin()).normalize());
        v.push(DVec3::new(1e-9 * t.cos(), t.sin(), -t.cos().abs()).normalize());
        v.push(DVec3::new(1.0, t.cos(), t.sin()).normalize());
    }
    v.extend(fibonacci_sphere(100_000));
    v
}

/// A smooth, strictly positive test environment: a few low SH bands plus a soft lobe, different
/// in each channel. Its second derivatives are bounded (|∇²L| ≲ 3), which is what the conversion
/// tolerances are derived from.
pub fn smooth_env(d: DVec3) -> [f64; 3] {
    let lobe_dir = DVec3::new(0.3, 0.5, -0.8).normalize();
    let lobe = (4.0 * (d.dot(lobe_dir) - 1.0)).exp();
    let base = 1.0 + 0.4 * d.y + 0.25 * d.x * d.z + 0.2 * (3.0 * d.z * d.z - 1.0) / 2.0;
    [
        base + 0.8 * lobe,
        base * 0.7 + 0.3 * d.x + 1.2 * lobe,
        base * 0.5 - 0.2 * d.z + 0.4 * lobe + 0.3,
    ]
}

/// Parameters of the analytic sky used for the bundled probe.
#[derive(Clone, Copy, Debug)]
pub struct Sky {
    /// Unit direction towards the sun.
    pub sun_dir: DVec3,
    /// Angular radius of the sun's disc, radians.
    pub sun_radius: f64,
    /// Ratio of the sun's radiance to the zenith sky's.
    pub sun_ratio: f64,
}

impl Default for Sky {
    fn default() -> Self {
        let (el, az) = (30f64.to_radians(), 40f64.to_radians());
        Sky {
            sun_dir: DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos()),
            sun_radius: 1.5f64.to_radians(),
            sun_ratio: 5e4,
        }
    }
}

impl Sky {
    /// Radiance towards `d`: a blue gradient sky brightening to the horizon, a sun disc with
    /// `sun_ratio` times the zenith radiance, and a darker, warmer ground below the horizon.
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        let zenith = [0.25, 0.45, 0.9];
        if d.y < 0.0 {
            // Ground, with a soft transition so the horizon is a few texels wide.
            let g = 0.35 + 0.15 * (-8.0 * -d.y).exp();
            return [0.30 * g, 0.24 * g, 0.18 * g];
        }
        let h = (1.0 - d.y).powi(4);
        let mut c = [
            zenith[0] * (1.0 + 2.5 * h),
            zenith[1] * (1.0 + 1.8 * h),
            zenith[2] * (1.0 + 0.6 * h),
        ];
        // Aureole around the sun, then the disc itself.
        let cos_sun = d.dot(self.sun_dir);
        let aureole = 2.0 * (60.0 * (cos_sun - 1.0)).exp();
        for ch in &mut c {
            *ch += aureole;
        }
        if cos_sun >= self.sun_radius.cos() {
            let s = self.sun_ratio * zenith[2];
            c = [s, s * 0.92, s * 0.8];
        }
        c
    }
}

/// Bakes `f` into a map: each texel is the solid-angle-weighted mean of `f` over `ss × ss`
/// points of the texel, the same footprint mean the conversion pass computes (weights from
/// [`Mapping::footprint_weight`]); angular texels centred outside the disc are black and
/// paraboloid texels wholly outside hold the continuation at their centre.
/// Returns RGB texels, layer-major then row-major.
pub fn bake(
    mapping: Mapping,
    w: u32,
    h: u32,
    ss: u32,
    f: impl Fn(DVec3) -> [f64; 3] + Sync,
) -> Vec<[f32; 3]> {
    let mut out = Vec::with_capacity((w * h * mapping.layers()) as usize);
    for layer in 0..mapping.layers() {
        for j in 0..h {
            for i in 0..w {
                if mapping == Mapping::Angular && !mapping.texel_in_domain(w, h, i, j) {
                    out.push([0.0; 3]);
                    continue;
                }
                let mut acc = [0.0f64; 3];
                let mut wsum = 0.0;
                for b in 0..ss {
                    for a in 0..ss {
                        let c = super::Coord {
                            layer,
                            u: (i as f64 + (a as f64 + 0.5) / ss as f64) / w as f64,
                            v: (j as f64 + (b as f64 + 0.5) / ss as f64) / h as f64,
                        };
                        let wt = mapping.footprint_weight(c);
                        let l = f(mapping.coord_to_dir(c));
                        for k in 0..3 {
                            acc[k] += wt * l[k];
                        }
                        wsum += wt;
                    }
                }
                if wsum > 0.0 {
                    out.push(acc.map(|x| (x / wsum) as f32));
                } else {
                    let c = Mapping::texel_center(w, h, layer, i, j);
                    out.push(f(mapping.coord_to_dir(c)).map(|x| x as f32));
                }
            }
        }
    }
    out
}
