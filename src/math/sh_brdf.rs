//! SH shading of arbitrary BRDFs (Kautz, Sloan & Snyder 2002), in float64: the twins of
//! `glsl/sh_brdf.comp` (the projection) and of the `TECH_SH_BRDF` branch of `glsl/shade.frag`.
//!
//! For each view direction ωₒ on a grid over the local hemisphere, the slice
//! f(ωₒ, ωᵢ)·cos θᵢ is projected onto the SH basis in the local frame (normal +z, tangent +x
//! as [`Frame::new`] builds it): c(ωₒ) = ∫ f·cos θᵢ·y(ωᵢ) dωᵢ. Anisotropic BRDFs (Ward) keep
//! every coefficient; nothing assumes zonal symmetry. Shading a pixel then takes
//! Lₒ = Σ_k [M(F)·c(ωₒ)]_k·L_k, F the local → world rotation and L_k the environment's
//! radiance coefficients in world space: rotating the one BRDF vector to world costs a third
//! of rotating the three colour channels of the light into the local frame, and is the same
//! number (M is orthogonal).
//!
//! - **View grid**: `size`² views at the texel centres of the upper paraboloid
//!   (s, t) = (x, y)/(1 + z) over [−1, 1]²; centres outside the unit disc take the direction on
//!   the rim, lifted to the horizon as [`local_view`] lifts views. Shading interpolates the
//!   four nearest centres bilinearly (clamped at the grid's edge).
//! - **Projection**: the integral is taken over the BRDF sampler's unit square, where the
//!   integrand weight(ωₒ, ωᵢ)·y(ωᵢ) is bounded however narrow the lobe. The first uniform
//!   (the lobe's polar coordinate) takes the 2·[`GRADED_LEVELS`] panels of [`graded_panels`],
//!   the second (azimuth) [`PANELS`] uniform ones, each panel 4 × 4 Gauss–Legendre nodes:
//!   4096 nodes a view. Measured against 48 azimuth panels at l = 8 (worst coefficient over
//!   c₀₀): ≤ 7e-5 for GGX α 0.05–1, Blinn and Ward from normal to grazing views (uniform
//!   panels erred by up to 7e-3 on GGX α 0.05, whose tail the sampler squeezes into
//!   u₁ > 1 − α²); Phong's horizon cut is a kink across the square, 6e-4 at n = 50 and
//!   1.2e-2 at n = 2 for a view 86° from the normal, under 1e-13 at normal incidence.

use super::brdf::{local_view, Brdf, Frame};
use super::sh::{basis_into, count};
use super::sh_rotate::{ivanic, ShRotation};
use crate::abi::constants::RIM_PULL_IN;
pub use crate::abi::sh_brdf::{gauss4, DEFAULT_GRID, GRADED_LEVELS, MAX_GRID, PANELS};
use glam::{DMat3, DVec3};

/// The paraboloid-mapped grid of view directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewGrid {
    /// Views per side.
    pub size: u32,
}

impl ViewGrid {
    /// The view at grid texel (i, j) (row j, column i).
    pub fn view(&self, i: u32, j: u32) -> DVec3 {
        let g = self.size as f64;
        let mut s = (i as f64 + 0.5) / g * 2.0 - 1.0;
        let mut t = (j as f64 + 0.5) / g * 2.0 - 1.0;
        let r2 = s * s + t * t;
        if r2 > 1.0 {
            let k = (1.0 - RIM_PULL_IN) / r2.sqrt();
            s *= k;
            t *= k;
        }
        let q = s * s + t * t;
        let d = DVec3::new(2.0 * s, 2.0 * t, 1.0 - q) / (1.0 + q);
        local_view(&Frame::new(DVec3::Z), d)
    }

    /// The four grid views around local view `wo` and their bilinear weights: (view index, weight).
    pub fn lookup(&self, wo: DVec3) -> [(usize, f64); 4] {
        let g = self.size as f64;
        let k = 1.0 / (1.0 + wo.z);
        let p = [
            ((wo.x * k + 1.0) * 0.5 * g - 0.5).clamp(0.0, g - 1.0),
            ((wo.y * k + 1.0) * 0.5 * g - 0.5).clamp(0.0, g - 1.0),
        ];
        let i0 = p.map(|x| (x.floor() as u32).min(self.size.saturating_sub(2)));
        let f = [p[0] - i0[0] as f64, p[1] - i0[1] as f64];
        let i1 = i0.map(|x| (x + 1).min(self.size - 1));
        let at = |i: u32, j: u32| (j * self.size + i) as usize;
        [
            (at(i0[0], i0[1]), (1.0 - f[0]) * (1.0 - f[1])),
            (at(i1[0], i0[1]), f[0] * (1.0 - f[1])),
            (at(i0[0], i1[1]), (1.0 - f[0]) * f[1]),
            (at(i1[0], i1[1]), f[0] * f[1]),
        ]
    }
}

/// c(ωₒ) = ∫ f(ωₒ, ωᵢ)·cos θᵢ·y(ωᵢ) dωᵢ to band `lmax`, by the rule in the module docs
/// with `panels` azimuth panels (the GPU uses [`PANELS`]). The mirror's is y(r).
pub fn project(brdf: &Brdf, lmax: u32, wo: DVec3, panels: u32) -> Vec<f64> {
    let n = count(lmax);
    let mut c = vec![0.0; n];
    let mut y = vec![0.0; n];
    if brdf.is_delta() {
        basis_into(lmax, DVec3::new(-wo.x, -wo.y, wo.z), &mut c);
        return c;
    }
    for_each_node(brdf, wo, panels, |wi, k| {
        basis_into(lmax, wi, &mut y);
        for (ci, yi) in c.iter_mut().zip(&y) {
            *ci += k * yi;
        }
    });
    c
}

/// Calls `f(ωᵢ, k)` for every node of the rule in the module docs (`panels` azimuth panels)
/// whose weight is not zero, k = node weight × f·cos/pdf: Σ k·g(ωᵢ) ≈ ∫ f·cos·g dωᵢ.
pub fn for_each_node(brdf: &Brdf, wo: DVec3, panels: u32, mut f: impl FnMut(DVec3, f64)) {
    let (x, w) = gauss4();
    let h = 1.0 / panels as f64;
    for (a0, a1) in graded_panels(GRADED_LEVELS) {
        for pb in 0..panels {
            for (xa, wa) in x.iter().zip(&w) {
                for (xb, wb) in x.iter().zip(&w) {
                    let u = [
                        a0 + (a1 - a0) * 0.5 * (xa + 1.0),
                        (pb as f64 + 0.5 * (xb + 1.0)) * h,
                    ];
                    let wi = brdf.sample(wo, u);
                    let weight = brdf.weight(wo, wi);
                    if weight != 0.0 {
                        f(wi, 0.25 * wa * wb * (a1 - a0) * h * weight);
                    }
                }
            }
        }
    }
}

/// Panels of the first uniform, graded geometrically toward both ends: [0, 2⁻ᴶ], [2⁻ᴶ, 2¹⁻ᴶ],
/// …, [¼, ½], [½, ¾], …, [1 − 2⁻ᴶ, 1]. The samplers put a lobe's tail there (GGX's visible
/// normals near u₁ → 1, power lobes and Ward near u₁ → 0), squeezed into a width of about α²
/// or the like, where uniform panels would see it as a jump.
pub fn graded_panels(levels: u32) -> Vec<(f64, f64)> {
    let mut v = vec![(0.0, 0.5f64.powi(levels as i32))];
    for j in (1..levels).rev() {
        v.push((0.5f64.powi(j as i32 + 1), 0.5f64.powi(j as i32)));
    }
    let lower: Vec<(f64, f64)> = v.iter().rev().map(|&(a, b)| (1.0 - b, 1.0 - a)).collect();
    v.extend(lower);
    v
}

/// The table the GPU builds: every view of `grid` (row-major), [`count`]`(lmax)` values each.
pub fn table(brdf: &Brdf, lmax: u32, grid: ViewGrid) -> Vec<f64> {
    let mut out = Vec::with_capacity((grid.size * grid.size) as usize * count(lmax));
    for j in 0..grid.size {
        for i in 0..grid.size {
            out.extend(project(brdf, lmax, grid.view(i, j), PANELS));
        }
    }
    out
}

/// The BRDF vector interpolated at world view `v` over normal `n`, rotated to world space.
pub fn world_vector(table: &[f64], grid: ViewGrid, lmax: u32, n: DVec3, v: DVec3) -> Vec<f64> {
    let frame = Frame::new(n);
    let wo = local_view(&frame, v);
    let nc = count(lmax);
    let mut c = vec![0.0; nc];
    for (view, w) in grid.lookup(wo) {
        for (ci, ti) in c.iter_mut().zip(&table[view * nc..(view + 1) * nc]) {
            *ci += w * ti;
        }
    }
    let f = DMat3::from_cols(frame.t, frame.b, frame.n);
    let m: ShRotation = ivanic(lmax, &f);
    m.apply(&c)
}

/// Outgoing radiance at a pixel with normal `n` and view `v` (towards the eye, world space)
/// from the environment's radiance coefficients `env` (world, at least [`count`]`(lmax)`),
/// clamped at 0 as the shader clamps (ringing).
pub fn shade(
    table: &[f64],
    grid: ViewGrid,
    lmax: u32,
    env: &[[f64; 3]],
    n: DVec3,
    v: DVec3,
) -> [f64; 3] {
    let c = world_vector(table, grid, lmax, n, v);
    let mut out = [0.0; 3];
    for (ck, lk) in c.iter().zip(env) {
        for ch in 0..3 {
            out[ch] += ck * lk[ch];
        }
    }
    out.map(|x| x.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sh::{cosine_lobe, index, k_lm};

    #[test]
    fn gauss4_is_the_four_point_rule() {
        let (x, w) = gauss4();
        let (x2, w2) = crate::math::quadrature::gauss_legendre(4);
        for k in 0..4 {
            assert!((x[k] - x2[k]).abs() < 1e-14 && (w[k] - w2[k]).abs() < 1e-14);
        }
    }

    #[test]
    fn lambert_projects_to_the_clamped_cosine_of_funk_hecke() {
        // ∫ cos⁺θ/π · y_lm = Â_l/π · y_lm(ẑ): zonal, K_l0·Â_l/π at m = 0, whatever the view.
        for wo in [DVec3::Z, DVec3::new(0.6, 0.3, 0.2).normalize()] {
            let c = project(&Brdf::Lambert, 8, wo, PANELS);
            for l in 0..=8u32 {
                for m in -(l as i32)..=l as i32 {
                    let want = if m == 0 {
                        k_lm(l, 0) * cosine_lobe(l) / std::f64::consts::PI
                    } else {
                        0.0
                    };
                    let got = c[index(l, m)];
                    assert!((got - want).abs() < 2e-4, "l {l} m {m}: {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn the_projection_converges_and_its_dc_term_is_the_albedo() {
        // c₀₀ = albedo·Y₀₀; the GPU's rule against three times the azimuth panels (bounds from
        // the measurement in the module docs, with margin).
        let brdfs = [
            (Brdf::Phong { n: 50.0 }, 2e-3),
            (Brdf::Blinn { n: 200.0 }, 2e-4),
            (
                Brdf::Ggx {
                    alpha: 0.3,
                    correlated: true,
                },
                2e-4,
            ),
            (
                Brdf::Ggx {
                    alpha: 0.05,
                    correlated: false,
                },
                2e-4,
            ),
            (
                Brdf::Ggx {
                    alpha: 1.0,
                    correlated: false,
                },
                2e-4,
            ),
            (Brdf::Ward { ax: 0.1, ay: 0.4 }, 2e-4),
        ];
        for (b, bound) in brdfs {
            for wo in [
                DVec3::Z,
                DVec3::new(0.7, 0.1, 0.2).normalize(),
                DVec3::new(0.9, 0.1, 0.05).normalize(),
            ] {
                let c = project(&b, 8, wo, PANELS);
                let fine = project(&b, 8, wo, 3 * PANELS);
                let albedo = b.albedo(wo);
                let y00 = k_lm(0, 0);
                assert!(
                    (c[0] / y00 - albedo).abs() < 2e-3 * albedo.max(0.1),
                    "{b:?} {wo}: {} vs {albedo}",
                    c[0] / y00
                );
                let worst = c
                    .iter()
                    .zip(&fine)
                    .map(|(a, f)| (a - f).abs())
                    .fold(0.0, f64::max);
                assert!(worst < bound * fine[0], "{b:?} {wo}: {worst:e}");
            }
        }
    }

    #[test]
    fn grid_lookup_reproduces_the_views_at_their_centres() {
        let g = ViewGrid { size: 8 };
        for (i, j) in [(3u32, 4u32), (4, 4), (2, 5)] {
            let w = g.lookup(g.view(i, j));
            let at = (j * 8 + i) as usize;
            let hit: f64 = w.iter().filter(|x| x.0 == at).map(|x| x.1).sum();
            assert!((hit - 1.0).abs() < 1e-9, "{i} {j}: {w:?}");
        }
    }
}
