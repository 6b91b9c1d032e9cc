//! BRDFs in float64: evaluation, importance sampling, pdf and directional albedo, in a local
//! frame whose +z is the normal. Twin of `glsl/include/brdf.glsl`; the GPU must make the same
//! choices, so every formula here is written in the form the shader uses.
//!
//! What each material means (all with the Fresnel factor 1: a white conductor):
//! - `Lambert`: f = 1/π.
//! - `Mirror`: a delta in the reflected direction r.
//! - `Phong { n }`: the seed's normalised Phong lobe about r, f·cos θᵢ = (n+1)/2π · cosⁿα
//!   with α the angle between ωᵢ and r (the lobe #3's Phong maps integrate; its integral over
//!   the sphere is 1, so the surface never reflects more than it receives).
//! - `Blinn { n }`: f = (n+8)/8π · cosⁿθₕ (Akenine-Möller's normalisation).
//! - `Ggx { alpha, correlated }`: Walter et al. 2007, D·G/(4 cos θᵢ cos θₒ), α = roughness²,
//!   Smith masking G₁(ωᵢ)·G₁(ωₒ) or, when `correlated`, the height-correlated
//!   1/(1 + Λ(ωᵢ) + Λ(ωₒ)) (Heitz 2014). Sampled from the visible normals (Heitz 2018).
//!   α below [`GGX_ALPHA_MIN`] is taken as that value, whose lobe is already far narrower
//!   than any texel, so α = 0 is the mirror limit with finite numbers.
//! - `Ward { ax, ay }`: Ward 1992 anisotropic, sampled as in Walter's 2005 notes; αx runs along
//!   the tangent of [`Frame::new`].

use glam::DVec3;
use std::f64::consts::PI;

pub use crate::abi::brdf::{ids, GGX_ALPHA_MIN, WARD_ALPHA_MIN};
use crate::abi::constants::{PHONG_EXPONENT_RANGE, VIEW_LIFT};

/// A BRDF and its parameters. In scene files it is tagged by `type`: `mirror`, `diffuse`,
/// `phong {n}`, `blinn {n}`, `ggx {alpha, correlated}`, `ward {alpha_x, alpha_y}`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum Brdf {
    /// Lambertian diffuse.
    #[serde(rename = "diffuse")]
    Lambert,
    /// Perfect mirror.
    Mirror,
    /// Normalised Phong lobe about the reflected direction, exponent n.
    Phong {
        /// Exponent.
        n: f64,
    },
    /// Blinn-Phong, exponent n.
    Blinn {
        /// Exponent.
        n: f64,
    },
    /// GGX microfacets.
    Ggx {
        /// Roughness α.
        alpha: f64,
        /// Height-correlated Smith masking instead of the uncorrelated product.
        #[serde(default)]
        correlated: bool,
    },
    /// Ward anisotropic.
    Ward {
        /// Roughness along the tangent.
        #[serde(rename = "alpha_x")]
        ax: f64,
        /// Roughness along the bitangent.
        #[serde(rename = "alpha_y")]
        ay: f64,
    },
}

/// The shading frame: tangent `t`, bitangent `b`, normal `n`. The tangent is ŷ × n normalised
/// (along a sphere's parallels), or x̂ × n within 0.001 of the poles (|n.y| > 0.999).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Tangent (local x).
    pub t: DVec3,
    /// Bitangent (local y).
    pub b: DVec3,
    /// Normal (local z).
    pub n: DVec3,
}

impl Frame {
    /// The frame of unit normal `n`.
    pub fn new(n: DVec3) -> Frame {
        let a = if n.y.abs() < crate::abi::constants::POLE_THRESHOLD {
            DVec3::Y
        } else {
            DVec3::X
        };
        let t = a.cross(n).normalize();
        Frame {
            t,
            b: n.cross(t),
            n,
        }
    }

    /// World → local.
    pub fn to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Local → world.
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// The view direction `v` (towards the eye) in `frame`, lifted to 1e-4 above the surface where
/// float32 silhouettes put it at or below (the GPU applies the same rule).
pub fn local_view(frame: &Frame, v: DVec3) -> DVec3 {
    let mut wo = frame.to_local(v);
    if wo.z < VIEW_LIFT {
        wo.z = VIEW_LIFT;
        wo = wo.normalize();
    }
    wo
}

/// An orthonormal basis (e1, e2) completing unit `a` (Duff et al. 2017, branchless).
pub fn basis(a: DVec3) -> (DVec3, DVec3) {
    let s = if a.z >= 0.0 { 1.0 } else { -1.0 };
    let p = -1.0 / (s + a.z);
    let q = a.x * a.y * p;
    (
        DVec3::new(1.0 + s * a.x * a.x * p, s * q, -s * a.x),
        DVec3::new(q, s + a.y * a.y * p, -a.y),
    )
}

/// cosᵏ of the angle whose 1 − cos is `gap`, without the cancellation of forming cos first.
fn pow_from_gap(k: f64, gap: f64) -> f64 {
    if gap >= 1.0 {
        return 0.0;
    }
    (k * (-gap).ln_1p()).exp()
}

/// 1 − cos of the angle between unit vectors a and b, accurate when they nearly coincide.
pub fn gap(a: DVec3, b: DVec3) -> f64 {
    0.5 * (a - b).length_squared()
}

/// A direction at angle α from unit `axis` with cos α = u₁^(1/(k+1)), azimuth 2πu₂: a sample
/// of the density (k+1)/2π·cosᵏα. Returns it and 1 − cos α.
fn sample_power_lobe(axis: DVec3, k: f64, u: [f64; 2]) -> (DVec3, f64) {
    let one_minus = -((u[0].ln() / (k + 1.0)).exp_m1());
    let sin = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
    let (e1, e2) = basis(axis);
    let (sp, cp) = (2.0 * PI * u[1]).sin_cos();
    (
        axis * (1.0 - one_minus) + (e1 * cp + e2 * sp) * sin,
        one_minus,
    )
}

/// The Phong lobe (n+1)/2π·cosⁿα about the reflection of wo: both its f·cos θᵢ and its pdf.
fn phong_lobe(n: f64, wo: DVec3, wi: DVec3) -> f64 {
    let r = DVec3::new(-wo.x, -wo.y, wo.z);
    (n + 1.0) / (2.0 * PI) * pow_from_gap(n, gap(r, wi))
}

fn reflect(wo: DVec3, h: DVec3) -> DVec3 {
    h * (2.0 * wo.dot(h)) - wo
}

fn ggx_alpha(alpha: f64) -> f64 {
    alpha.max(GGX_ALPHA_MIN)
}

fn ggx_d(a: f64, h: DVec3) -> f64 {
    let a2 = a * a;
    let s = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
    a2 / (PI * s * s)
}

/// √(α² + (1−α²)c²): the Smith term's square root for a direction of cosine c.
fn ggx_root(a: f64, c: f64) -> f64 {
    let a2 = a * a;
    (a2 + (1.0 - a2) * c * c).sqrt()
}

fn ggx_g1(a: f64, c: f64) -> f64 {
    2.0 * c / (c + ggx_root(a, c))
}

fn ward_exponent(ax: f64, ay: f64, h: DVec3) -> f64 {
    -((h.x / ax).powi(2) + (h.y / ay).powi(2)) / (h.z * h.z)
}

impl Brdf {
    /// The id the shaders know it by.
    pub fn id(&self) -> u32 {
        match self {
            Brdf::Lambert => ids::LAMBERT,
            Brdf::Mirror => ids::MIRROR,
            Brdf::Phong { .. } => ids::PHONG,
            Brdf::Blinn { .. } => ids::BLINN,
            Brdf::Ggx { .. } => ids::GGX,
            Brdf::Ward { .. } => ids::WARD,
        }
    }

    /// How its f·cos fades towards the horizon (`crate::abi::brdf::HORIZON_FADE`).
    pub fn horizon_fade(&self) -> f64 {
        crate::abi::brdf::HORIZON_FADE[self.id() as usize]
    }

    /// The two parameters the shaders read: (n, 0), (α, correlated) or (αx, αy).
    pub fn params(&self) -> [f64; 2] {
        match *self {
            Brdf::Lambert | Brdf::Mirror => [0.0, 0.0],
            Brdf::Phong { n } | Brdf::Blinn { n } => [n, 0.0],
            Brdf::Ggx { alpha, correlated } => [alpha, correlated as u32 as f64],
            Brdf::Ward { ax, ay } => [ax, ay],
        }
    }

    /// Checks the parameters' ranges; the message names the bad one.
    pub fn validate(&self) -> Result<(), String> {
        let check = |name: &str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!("{name} = {v} is outside [{lo}, {hi}]"))
            }
        };
        let (lo, hi) = PHONG_EXPONENT_RANGE;
        match *self {
            Brdf::Lambert | Brdf::Mirror => Ok(()),
            Brdf::Phong { n } => check("Phong exponent n", n, lo, hi),
            Brdf::Blinn { n } => check("Blinn exponent n", n, lo, hi),
            Brdf::Ggx { alpha, .. } => check("GGX alpha", alpha, 0.0, 1.0),
            Brdf::Ward { ax, ay } => {
                check("Ward alpha_x", ax, WARD_ALPHA_MIN, 1.0)?;
                check("Ward alpha_y", ay, WARD_ALPHA_MIN, 1.0)
            }
        }
    }

    /// Whether it is a delta (sampling is exact; [`Brdf::eval_cos`] is 0 everywhere).
    pub fn is_delta(&self) -> bool {
        matches!(self, Brdf::Mirror)
    }

    /// f(ωₒ, ωᵢ)·cos θᵢ, local directions; 0 unless both are above the surface.
    pub fn eval_cos(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        match *self {
            Brdf::Lambert => wi.z / PI,
            Brdf::Mirror => 0.0,
            Brdf::Phong { n } => phong_lobe(n, wo, wi),
            Brdf::Blinn { n } => {
                let h = (wo + wi).normalize();
                (n + 8.0) / (8.0 * PI) * pow_from_gap(n, gap(h, DVec3::Z)) * wi.z
            }
            Brdf::Ggx { alpha, correlated } => {
                let a = ggx_alpha(alpha);
                // D of the half vector unnormalised: D(h/|h|) = α²|h|⁴ / (π·(hx² + hy² +
                // α²hz²)²), no root or division for the normalisation.
                let h = wo + wi;
                let s = h.x * h.x + h.y * h.y + a * a * h.z * h.z;
                let h2 = h.length_squared();
                let d = a * a * h2 * h2 / (PI * s * s);
                let g = if correlated {
                    2.0 * wo.z * wi.z / (ggx_root(a, wo.z) * wi.z + ggx_root(a, wi.z) * wo.z)
                } else {
                    ggx_g1(a, wo.z) * ggx_g1(a, wi.z)
                };
                d * g / (4.0 * wo.z)
            }
            Brdf::Ward { ax, ay } => {
                let h = (wo + wi).normalize();
                ward_exponent(ax, ay, h).exp() / (4.0 * PI * ax * ay * (wi.z * wo.z).sqrt()) * wi.z
            }
        }
    }

    /// The direction [`Brdf::sample`] draws for uniforms `u` (it may lie below the surface;
    /// such samples carry weight 0).
    pub fn sample(&self, wo: DVec3, u: [f64; 2]) -> DVec3 {
        match *self {
            Brdf::Lambert => {
                let r = u[0].sqrt();
                let (s, c) = (2.0 * PI * u[1]).sin_cos();
                DVec3::new(r * c, r * s, (1.0 - u[0]).max(0.0).sqrt())
            }
            Brdf::Mirror => DVec3::new(-wo.x, -wo.y, wo.z),
            Brdf::Phong { n } => sample_power_lobe(DVec3::new(-wo.x, -wo.y, wo.z), n, u).0,
            Brdf::Blinn { n } => reflect(wo, sample_power_lobe(DVec3::Z, n, u).0),
            Brdf::Ggx { alpha, .. } => {
                let a = ggx_alpha(alpha);
                let vh = DVec3::new(a * wo.x, a * wo.y, wo.z).normalize();
                let lensq = vh.x * vh.x + vh.y * vh.y;
                let t1 = if lensq > 0.0 {
                    DVec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
                } else {
                    DVec3::X
                };
                let t2 = vh.cross(t1);
                let r = u[0].sqrt();
                let (sp, cp) = (2.0 * PI * u[1]).sin_cos();
                let p1 = r * cp;
                let s = 0.5 * (1.0 + vh.z);
                let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sp;
                let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                let h = DVec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize();
                reflect(wo, h)
            }
            Brdf::Ward { ax, ay } => {
                let (s, c) = (2.0 * PI * u[1]).sin_cos();
                let (ps, pc) = (ay * s, ax * c);
                let len = (ps * ps + pc * pc).sqrt();
                let (sp, cp) = (ps / len, pc / len);
                let tan2 = -u[0].ln() / (cp * cp / (ax * ax) + sp * sp / (ay * ay));
                let t = tan2.sqrt();
                let h = DVec3::new(t * cp, t * sp, 1.0).normalize();
                reflect(wo, h)
            }
        }
    }

    /// The solid-angle density of [`Brdf::sample`] at ωᵢ (0 for the mirror's delta).
    pub fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        match *self {
            Brdf::Lambert => wi.z.max(0.0) / PI,
            Brdf::Mirror => 0.0,
            Brdf::Phong { n } => phong_lobe(n, wo, wi),
            Brdf::Blinn { n } => {
                let h = (wo + wi).normalize();
                let oh = wo.dot(h);
                if oh <= 0.0 || h.z <= 0.0 {
                    return 0.0;
                }
                (n + 1.0) / (2.0 * PI) * pow_from_gap(n, gap(h, DVec3::Z)) / (4.0 * oh)
            }
            Brdf::Ggx { alpha, .. } => {
                if wo.z <= 0.0 {
                    return 0.0;
                }
                let a = ggx_alpha(alpha);
                let h = (wo + wi).normalize();
                if h.z <= 0.0 {
                    return 0.0;
                }
                ggx_g1(a, wo.z) * ggx_d(a, h) / (4.0 * wo.z)
            }
            Brdf::Ward { ax, ay } => {
                let h = (wo + wi).normalize();
                let oh = wo.dot(h);
                if oh <= 0.0 || h.z <= 0.0 {
                    return 0.0;
                }
                ward_exponent(ax, ay, h).exp() / (4.0 * PI * ax * ay * h.z.powi(3) * oh)
            }
        }
    }

    /// f·cos θᵢ / pdf for a sampled ωᵢ, in closed form (bounded where the ratio is): 0 below
    /// the surface. The mirror's is 1.
    pub fn weight(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        match *self {
            Brdf::Lambert | Brdf::Mirror | Brdf::Phong { .. } => 1.0,
            Brdf::Blinn { n } => {
                let h = (wo + wi).normalize();
                ((n + 8.0) / (n + 1.0) * wi.z * wo.dot(h)).max(0.0)
            }
            Brdf::Ggx { alpha, correlated } => {
                let a = ggx_alpha(alpha);
                if correlated {
                    let (ro, ri) = (ggx_root(a, wo.z), ggx_root(a, wi.z));
                    wi.z * (wo.z + ro) / (ro * wi.z + ri * wo.z)
                } else {
                    ggx_g1(a, wi.z)
                }
            }
            Brdf::Ward { .. } => {
                let h = (wo + wi).normalize();
                (h.z.powi(3) * wo.dot(h) * (wi.z / wo.z).sqrt()).max(0.0)
            }
        }
    }

    /// Directional albedo ∫ f·cos θᵢ dωᵢ for local ωₒ, by quadrature over the sampling map's
    /// unit square (the weight is bounded and smooth there, however narrow the lobe): 24 × 24
    /// panels of 8 × 8 Gauss–Legendre nodes. Phong's weight is an indicator, so its azimuth is
    /// integrated in closed form and the rest in 1D.
    pub fn albedo(&self, wo: DVec3) -> f64 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        match *self {
            Brdf::Lambert | Brdf::Mirror => 1.0,
            Brdf::Phong { n } => phong_albedo(n, wo.z),
            _ => self.albedo_rule(wo, 24, 8),
        }
    }

    /// [`Brdf::albedo`]'s quadrature over the sampling map's unit square with `panels` ×
    /// `panels` panels of `nodes` × `nodes` Gauss–Legendre nodes (any BRDF but Phong's
    /// indicator; a coarser rule where its error is allowed).
    pub fn albedo_rule(&self, wo: DVec3, panels: u32, nodes: usize) -> f64 {
        let (x, w) = super::quadrature::gauss_legendre(nodes);
        let h = 1.0 / panels as f64;
        let mut total = 0.0;
        for pa in 0..panels {
            for pb in 0..panels {
                for (xa, wa) in x.iter().zip(&w) {
                    for (xb, wb) in x.iter().zip(&w) {
                        let u = [
                            (pa as f64 + 0.5 * (xa + 1.0)) * h,
                            (pb as f64 + 0.5 * (xb + 1.0)) * h,
                        ];
                        let wi = self.sample(wo, u);
                        total += 0.25 * wa * wb * h * h * self.weight(wo, wi);
                    }
                }
            }
        }
        total
    }
}

/// Phong albedo at cos θₒ = `c`: the lobe's cone of half-angle α about r (polar angle θᵣ = θₒ)
/// is above the horizon for the azimuth fraction acos(clamp(−cot α cot θᵣ))/π, and u₁ = cos^(n+1) α.
fn phong_albedo(n: f64, c: f64) -> f64 {
    let sin_r = (1.0 - c * c).max(0.0).sqrt();
    if sin_r == 0.0 {
        return 1.0;
    }
    let cot_r = c / sin_r;
    // The cone dips below the horizon for α > π/2 − θᵣ, i.e. u₁ < sin θᵣ^(n+1).
    let kink = ((n + 1.0) * sin_r.ln()).exp();
    let fraction = |u: f64| {
        if u <= 0.0 {
            return 0.5;
        }
        let one_minus = -((u.ln() / (n + 1.0)).exp_m1());
        let cos_a = 1.0 - one_minus;
        let sin_a = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
        let k = -cos_a / sin_a * cot_r;
        k.clamp(-1.0, 1.0).acos() / PI
    };
    // [kink, 1] is fully visible; on [0, kink] the integrand has a square-root kink at the
    // right end, so the panels are graded towards it.
    let mut below = 0.0;
    let panels = 200;
    for p in 0..panels {
        let t0 = p as f64 / panels as f64;
        let t1 = (p + 1) as f64 / panels as f64;
        // u = kink·(1 − (1 − t)²): dense near u = kink.
        below += super::quadrature::integrate(t0, t1, |t| {
            let s = 1.0 - t;
            fraction(kink * (1.0 - s * s)) * kink * 2.0 * s
        });
    }
    (1.0 - kink) + below
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cases() -> Vec<Brdf> {
        vec![
            Brdf::Lambert,
            Brdf::Phong { n: 1.0 },
            Brdf::Phong { n: 10.0 },
            Brdf::Blinn { n: 5.0 },
            Brdf::Blinn { n: 60.0 },
            Brdf::Ggx {
                alpha: 0.3,
                correlated: false,
            },
            Brdf::Ggx {
                alpha: 0.7,
                correlated: true,
            },
            Brdf::Ggx {
                alpha: 1.0,
                correlated: false,
            },
            Brdf::Ward { ax: 0.4, ay: 0.15 },
        ]
    }

    fn wo(c: f64, phi: f64) -> DVec3 {
        let s = (1.0 - c * c).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), c)
    }

    /// ∫ f·cos over the hemisphere by a plain product rule in (cos θ, φ), split at the
    /// reflected direction's azimuth: independent of sample() and pdf().
    fn direct_albedo(b: &Brdf, o: DVec3) -> f64 {
        let mut total = 0.0;
        let (np, nt) = (256, 128);
        for i in 0..nt {
            let c0 = i as f64 / nt as f64;
            let c1 = (i + 1) as f64 / nt as f64;
            total += super::super::quadrature::integrate(c0, c1, |c| {
                let s = (1.0 - c * c).max(0.0).sqrt();
                let mut ring = 0.0;
                for j in 0..np {
                    let p0 = 2.0 * PI * j as f64 / np as f64;
                    let p1 = 2.0 * PI * (j + 1) as f64 / np as f64;
                    ring += super::super::quadrature::integrate(p0, p1, |p| {
                        b.eval_cos(o, DVec3::new(s * p.cos(), s * p.sin(), c))
                    });
                }
                ring
            });
        }
        total
    }

    #[test]
    fn sampling_matches_evaluation() {
        // The sampling-map albedo (weights of sample()) equals the direct integral of
        // eval_cos only if pdf() is sample()'s true density and weight() = eval_cos/pdf.
        for b in cases() {
            for c in [1.0, 0.7, 0.3] {
                let o = wo(c, 0.4);
                let a = b.albedo(o);
                let d = direct_albedo(&b, o);
                assert!((a - d).abs() < 2e-4, "{b:?} cos {c}: {a} vs direct {d}");
            }
        }
    }

    #[test]
    fn weight_is_eval_over_pdf() {
        for b in cases() {
            for k in 0..200 {
                let o = wo(0.05 + 0.9 * (k as f64 * 0.37).fract(), k as f64);
                let u = super::super::sequence::hammersley(k, 200);
                let i = b.sample(o, u);
                if i.z <= 0.0 {
                    assert_eq!(b.weight(o, i), 0.0);
                    continue;
                }
                let (f, p, w) = (b.eval_cos(o, i), b.pdf(o, i), b.weight(o, i));
                assert!((i.length() - 1.0).abs() < 1e-12);
                assert!(p > 0.0, "{b:?}");
                assert!(
                    (f / p - w).abs() <= 1e-9 * w.max(1.0),
                    "{b:?}: {f}/{p} vs {w}"
                );
            }
        }
    }

    #[test]
    fn narrow_lobes_stay_finite_and_tend_to_the_mirror() {
        for b in [
            Brdf::Phong { n: 1e6 },
            Brdf::Blinn { n: 1e6 },
            Brdf::Ggx {
                alpha: 0.0,
                correlated: false,
            },
            Brdf::Ward { ax: 1e-3, ay: 1e-3 },
        ] {
            for c in [1.0, 0.5, 0.05] {
                let o = wo(c, 1.0);
                let r = DVec3::new(-o.x, -o.y, o.z);
                for k in 0..64 {
                    let i = b.sample(o, super::super::sequence::hammersley(k, 64));
                    assert!(i.is_finite());
                    assert!(gap(i, r) < 1e-4, "{b:?}: {i} far from {r}");
                    let (p, w) = (b.pdf(o, i), b.weight(o, i));
                    assert!(p.is_finite() && w.is_finite() && p > 0.0, "{b:?}");
                }
            }
        }
        let a = Brdf::Phong { n: 1e6 }.albedo(wo(0.5, 0.0));
        assert!((a - 1.0).abs() < 1e-9, "{a}");
        let a = Brdf::Ggx {
            alpha: 0.0,
            correlated: false,
        }
        .albedo(wo(0.5, 0.0));
        assert!((a - 1.0).abs() < 1e-6, "{a}");
    }

    #[test]
    fn phong_albedo_falls_at_grazing() {
        // At normal incidence the lobe lies wholly above the surface; at grazing about half.
        assert!((phong_albedo(1.0, 1.0) - 1.0).abs() < 1e-12);
        let g = phong_albedo(1.0, 1e-6);
        assert!((g - 0.5).abs() < 1e-3, "{g}");
        let m = phong_albedo(10.0, 0.2);
        assert!(m > 0.5 && m < 1.0);
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in super::super::synth::fibonacci_sphere(500) {
            let f = Frame::new(n);
            assert!((f.t.length() - 1.0).abs() < 1e-12 && f.t.dot(n).abs() < 1e-12);
            assert!(f.b.dot(f.t).abs() < 1e-12 && (f.b.length() - 1.0).abs() < 1e-12);
            let v = DVec3::new(0.3, -0.5, 0.81).normalize();
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-12);
        }
    }
}
