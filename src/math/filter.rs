//! Brute-force convolution of a whole map with a kernel of the angle to an axis (Miller &
//! Hoffman 1984): the clamped cosine (irradiance, indexed by the normal) and the normalised
//! Phong lobe (indexed by the reflection direction). This is the float64 twin of
//! `glsl/brute.comp`, using the same per-texel rules, and the reference SH irradiance is
//! measured against.
//!
//! The map is taken as what it stores: constant radiance over each texel. The convolution is
//! then the exact sum over every texel of `L_t · ∫_t K(axis·ω) dω`, and the only
//! approximation is how each texel's integral of the kernel is computed:
//! - texels wholly below the kernel's horizon, or where the lobe is below 1e-10 of its peak,
//!   are skipped;
//! - texels small next to the kernel's width (`n·ρ² < 1e-5`, ρ the texel's angular radius)
//!   and not cut by the horizon take one node at their centre;
//! - regular texels (see [`TexelShape`]) where the kernel's log-curvature across the texel
//!   is small (`n·ρ² ≤ TILT_LIMIT·x_min²`) take the tilted rule, one closed-form term
//!   ([`tilted_mean`]);
//! - the rest are split into s×s cells with 3×3 Gauss points each, s = ⌈ρ·√n·c⌉ (at least
//!   [`EDGE_CELLS`] where the horizon cuts the texel, at most [`MAX_CELLS`]);
//! - texels the rim of an angular or paraboloid disc cuts take the clipped rule of the SH
//!   projection, with pieces split the same way.
//!
//! Each texel's node weights are scaled to its exact solid angle, so a constant map gives
//! `L·∫K` up to the kernel's quadrature error, which the tests bound (1e-4 for the cosine and
//! for Phong lobes up to n = 10⁴).

use super::mapping::{Coord, Mapping};
use crate::math::envmap::EnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

pub use crate::abi::filter_rule::{
    CELLS_PER_WIDTH, CENTRE_LIMIT, CONE_MARGIN, EDGE_CELLS, LOG_CUTOFF, MAX_CELLS,
    TILT_DENSITY_RATIO, TILT_LIMIT, TILT_SERIES_BELOW,
};

/// A convolution kernel of x = axis·ω.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    /// max(0, x): irradiance E(n) = ∫ L(ω) max(0, n·ω) dω.
    Cosine,
    /// (n+1)/(2π)·max(0, x)^n, normalised so that ∫ over the sphere is 1.
    Phong {
        /// The exponent, at least 1.
        n: f64,
    },
}

impl Kernel {
    /// The exponent (1 for the cosine).
    pub fn exponent(self) -> f64 {
        match self {
            Kernel::Cosine => 1.0,
            Kernel::Phong { n } => n,
        }
    }

    /// The normalisation in front of max(0, x)^n.
    pub fn scale(self) -> f64 {
        match self {
            Kernel::Cosine => 1.0,
            Kernel::Phong { n } => (n + 1.0) / (2.0 * PI),
        }
    }

    /// K at a direction ω given `half_chord2` = |axis − ω|²/2 = 1 − axis·ω, which keeps its
    /// digits where ω is close to the axis (x itself rounds to 1 there, and x^10⁴ with it).
    pub fn eval_from_gap(self, half_chord2: f64) -> f64 {
        let x = 1.0 - half_chord2;
        if x <= 0.0 {
            return 0.0;
        }
        match self {
            Kernel::Cosine => x,
            Kernel::Phong { n } => self.scale() * (n * (-half_chord2).ln_1p()).exp(),
        }
    }

    /// K(axis·ω) for unit vectors.
    pub fn eval(self, axis: DVec3, w: DVec3) -> f64 {
        self.eval_from_gap(0.5 * (axis - w).length_squared())
    }
}

/// How one texel's integral of the kernel is taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// The kernel is zero (or below the cut-off) over the whole texel.
    Skip,
    /// One node at the texel's centre.
    Centre,
    /// The tilted rule: the texel as a uniform parallelogram, the log of the kernel linear
    /// across it plus a curvature term ([`tilted_mean`]).
    Tilted,
    /// s×s cells of 3×3 Gauss points.
    Cells(u32),
}

/// The rule for a texel whose centre direction c has x = axis·c and whose directions are
/// within angle ρ of c (`cos_rho`, `sin_rho`); `regular` says whether the tilted rule may
/// take it ([`TexelShape::regular`]). Shared with the GLSL, decision for decision.
pub fn rule(kernel: Kernel, x: f64, cos_rho: f64, sin_rho: f64, regular: bool) -> Rule {
    let sin_c = (1.0 - x * x).max(0.0).sqrt();
    // cos(θc − ρ) and cos(θc + ρ): the largest and smallest x over the texel.
    let x_max = if x >= cos_rho {
        1.0
    } else {
        x * cos_rho + sin_c * sin_rho
    };
    let x_min = x * cos_rho - sin_c * sin_rho;
    if x_max <= 0.0 {
        return Rule::Skip;
    }
    let n = kernel.exponent();
    if n > 1.0 && n * x_max.ln() < LOG_CUTOFF {
        return Rule::Skip;
    }
    let rho2 = 2.0 * (1.0 - cos_rho);
    let straddles = x_min < 0.0;
    if !straddles && n * rho2 < CENTRE_LIMIT {
        return Rule::Centre;
    }
    if regular && !straddles && n * rho2 <= TILT_LIMIT * x_min * x_min {
        return Rule::Tilted;
    }
    let mut s = (CELLS_PER_WIDTH * (n * rho2).sqrt()).ceil().max(1.0);
    if straddles {
        s = s.max(EDGE_CELLS as f64);
    }
    Rule::Cells(s.min(MAX_CELLS as f64) as u32)
}

/// Largest n·ρ² the per-texel rule resolves: its cells (at most `MAX_CELLS` a side, each
/// with 3×3 Gauss points) may be at most two lobe widths (2/√n) wide. The rule asks for
/// cells of 1/`CELLS_PER_WIDTH` lobe width, and is capped at a quarter of that.
pub const RESOLVED_N_RHO2: f64 = {
    let cells = 2.0 * MAX_CELLS as f64 / CELLS_PER_WIDTH;
    cells * cells
};

/// The largest n·ρ² over the texels of a `w` × `h` `mapping` source when it exceeds
/// [`RESOLVED_N_RHO2`]: a lobe that much narrower than a texel falls between the rule's
/// nodes, so the sum would be wrong (a Phong n = 10⁶ lobe on a 32 × 16 map sums to 0).
/// `None` when every texel is resolved.
pub fn unresolved(kernel: Kernel, mapping: Mapping, w: u32, h: u32) -> Option<f64> {
    let n = kernel.exponent();
    // No texel is wider than one covering the whole sphere (ρ ≤ π), so small n are resolved.
    if n * PI * PI <= RESOLVED_N_RHO2 {
        return None;
    }
    // Symmetry keeps this off the pass's critical path: lat-long texels of a row are
    // congruent (one column stands for all); cube faces and paraboloid halves are congruent,
    // and each of them, like the angular disc, is symmetric about both of its axes (one
    // quadrant of layer 0 stands for all).
    let (columns, rows) = if mapping == Mapping::LatLong {
        (1, h)
    } else {
        (w.div_ceil(2), h.div_ceil(2))
    };
    let mut worst: f64 = 0.0;
    for j in 0..rows {
        for i in 0..columns {
            let cos_rho = texel_cos_radius(mapping, w, h, 0, i, j);
            worst = worst.max(n * 2.0 * (1.0 - cos_rho));
        }
    }
    (worst > RESOLVED_N_RHO2).then_some(worst)
}

/// Whether the rim of an angular or paraboloid disc cuts texel (i, j).
pub fn rim_cut(mapping: Mapping, w: u32, h: u32, i: u32, j: u32) -> bool {
    if !matches!(mapping, Mapping::Angular | Mapping::DualParaboloid) {
        return false;
    }
    let (lo, hi) = texel_square(w, h, i, j);
    let fx = lo[0].abs().max(hi[0].abs());
    let fy = lo[1].abs().max(hi[1].abs());
    fx * fx + fy * fy > 1.0
}

fn texel_square(w: u32, h: u32, i: u32, j: u32) -> ([f64; 2], [f64; 2]) {
    let (wf, hf) = (w as f64, h as f64);
    (
        [2.0 * i as f64 / wf - 1.0, 2.0 * j as f64 / hf - 1.0],
        [
            2.0 * (i + 1) as f64 / wf - 1.0,
            2.0 * (j + 1) as f64 / hf - 1.0,
        ],
    )
}

/// The cosine of texel (i, j)'s angular radius about its centre direction: the smallest
/// c·ω over its corners and edge midpoints (pulled into the disc for disc mappings), less a
/// margin for the bulge of the edges between them.
pub fn texel_cos_radius(mapping: Mapping, w: u32, h: u32, layer: u32, i: u32, j: u32) -> f64 {
    let c = mapping.coord_to_dir(Mapping::texel_center(w, h, layer, i, j));
    let disc = matches!(mapping, Mapping::Angular | Mapping::DualParaboloid);
    let mut min_dot: f64 = 1.0;
    for (a, b) in [
        (0.0, 0.0),
        (0.5, 0.0),
        (1.0, 0.0),
        (0.0, 0.5),
        (1.0, 0.5),
        (0.0, 1.0),
        (0.5, 1.0),
        (1.0, 1.0),
    ] {
        let mut u = (i as f64 + a) / w as f64;
        let mut v = (j as f64 + b) / h as f64;
        if disc {
            let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let r = x.hypot(y);
            if r > 1.0 {
                u = 0.5 * (x / r + 1.0);
                v = 0.5 * (y / r + 1.0);
            }
        }
        let d = mapping.coord_to_dir(Coord { layer, u, v });
        min_dot = min_dot.min(c.dot(d));
    }
    // Edges bulge between the sampled points by at most a fraction of the spacing: take the
    // angle 25% wider.
    let rho = min_dot.clamp(-1.0, 1.0).acos() * CONE_MARGIN;
    rho.min(PI).cos()
}

/// What the tilted rule knows of a texel: the centroid of its solid angle and two half-edge
/// vectors in the tangent plane there, the texel being taken as the uniform parallelogram
/// they span. The vectors are the texel's own half-edges (corrected so that the
/// parallelogram's covariance equals the texel's, which takes the trapezoid of a lat-long
/// texel into account), so the skew of cube texels near face corners is kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelShape {
    /// Unit centroid direction.
    pub centroid: DVec3,
    /// Half-edge along u (tangent at the centroid).
    pub hu: DVec3,
    /// Half-edge along v.
    pub hv: DVec3,
    /// Whether the parallelogram model holds: no disc rim cuts the texel and the mapping's
    /// density varies over it by at most [`TILT_DENSITY_RATIO`].
    pub regular: bool,
}

impl TexelShape {
    /// The shape rotated by `m` (file to world).
    pub fn rotated(&self, m: DMat3) -> TexelShape {
        TexelShape {
            centroid: m * self.centroid,
            hu: m * self.hu,
            hv: m * self.hv,
            regular: self.regular,
        }
    }
}

/// The shape of texel (i, j) of `layer` (file frame), from its 3×3 Gauss nodes.
pub fn texel_shape(mapping: Mapping, w: u32, h: u32, layer: u32, i: u32, j: u32) -> TexelShape {
    let at = |a: f64, b: f64| Coord {
        layer,
        u: (i as f64 + a) / w as f64,
        v: (j as f64 + b) / h as f64,
    };
    let mut sum = DVec3::ZERO;
    let mut nodes = [(DVec3::ZERO, 0.0); 9];
    let mut k = 0;
    for_each_node(mapping, (w, h), (layer, i, j), 1, |c, wq| {
        let d = mapping.coord_to_dir(c);
        if k < 9 {
            nodes[k] = (d, wq);
        }
        k += 1;
        sum += d * wq;
    });
    let regular_nodes = k == 9 && !rim_cut(mapping, w, h, i, j);
    let c = if sum.length_squared() > 0.0 {
        sum.normalize()
    } else {
        mapping.coord_to_dir(at(0.5, 0.5))
    };
    let tangent = |v: DVec3| v - c * v.dot(c);
    let hu = tangent(mapping.coord_to_dir(at(1.0, 0.5)) - mapping.coord_to_dir(at(0.0, 0.5))) * 0.5;
    let hv = tangent(mapping.coord_to_dir(at(0.5, 1.0)) - mapping.coord_to_dir(at(0.5, 0.0))) * 0.5;
    let mut shape = TexelShape {
        centroid: c,
        hu,
        hv,
        regular: false,
    };
    if !regular_nodes {
        return shape;
    }
    let (mut dmin, mut dmax) = (f64::MAX, 0.0f64);
    for b in 0..3 {
        for a in 0..3 {
            let d = mapping.density(at(0.5 * a as f64, 0.5 * b as f64));
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
    }
    if !(dmin > 0.0 && dmax <= TILT_DENSITY_RATIO * dmin) {
        return shape;
    }
    // Covariance of the texel (Σ) and of the parallelogram (P = (hu huᵀ + hv hvᵀ)/3) in a
    // tangent frame; the edges are mapped by A = Σ^½ P^-½ so that their covariance is Σ.
    let e1 = c.any_orthonormal_vector();
    let e2 = c.cross(e1);
    let wsum: f64 = nodes.iter().map(|n| n.1).sum();
    let mut cov = [0.0; 3];
    for (d, wq) in nodes {
        let y = tangent(d);
        let (p, q) = (y.dot(e1), y.dot(e2));
        cov[0] += wq * p * p / wsum;
        cov[1] += wq * p * q / wsum;
        cov[2] += wq * q * q / wsum;
    }
    let (a1, a2, b1, b2) = (hu.dot(e1), hu.dot(e2), hv.dot(e1), hv.dot(e2));
    let par = [
        (a1 * a1 + b1 * b1) / 3.0,
        (a1 * a2 + b1 * b2) / 3.0,
        (a2 * a2 + b2 * b2) / 3.0,
    ];
    let (Some(sq), Some(sp)) = (sqrt2(cov), sqrt2(par)) else {
        return shape;
    };
    let det = sp[0] * sp[2] - sp[1] * sp[1];
    if det <= 0.0 {
        return shape;
    }
    let ip = [sp[2] / det, -sp[1] / det, sp[0] / det];
    let m = [
        [sq[0] * ip[0] + sq[1] * ip[1], sq[0] * ip[1] + sq[1] * ip[2]],
        [sq[1] * ip[0] + sq[2] * ip[1], sq[1] * ip[1] + sq[2] * ip[2]],
    ];
    let map = |x: f64, y: f64| e1 * (m[0][0] * x + m[0][1] * y) + e2 * (m[1][0] * x + m[1][1] * y);
    shape.hu = map(a1, a2);
    shape.hv = map(b1, b2);
    shape.regular = true;
    shape
}

/// The square root of a symmetric positive semi-definite 2×2 matrix [a, b; b, c] as
/// [a', b', c'], or `None` when it is zero.
pub(crate) fn sqrt2(m: [f64; 3]) -> Option<[f64; 3]> {
    let d = (m[0] * m[2] - m[1] * m[1]).max(0.0).sqrt();
    let t = (m[0] + m[2] + 2.0 * d).sqrt();
    (t > 0.0).then(|| [(m[0] + d) / t, m[1] / t, (m[2] + d) / t])
}

/// ln(sinh z / z): a series below |z| = `TILT_SERIES_BELOW` (where the closed form cancels in f32), the
/// log-domain closed form above, so that far tails (z in the tens) keep their digits. The
/// GLSL twin takes the same branches.
fn ln_sinhc(z: f64) -> f64 {
    let a = z.abs();
    if a < TILT_SERIES_BELOW {
        let z2 = a * a;
        z2 * (1.0 / 6.0 - z2 * (1.0 / 180.0 - z2 * (1.0 / 2835.0 - z2 / 37800.0)))
    } else {
        a + (-(-2.0 * a).exp()).ln_1p() - (2.0 * a).ln()
    }
}

/// E[s] for s uniform on [−1, 1] tilted by e^{zs}: coth z − 1/z (series below `TILT_SERIES_BELOW`).
fn tilt_m1(z: f64) -> f64 {
    if z.abs() < TILT_SERIES_BELOW {
        let z2 = z * z;
        z * (1.0 / 3.0 - z2 * (1.0 / 45.0 - z2 * (2.0 / 945.0 - z2 / 4725.0)))
    } else {
        1.0 / z.tanh() - 1.0 / z
    }
}

/// E[s²] under the same tilt: 1 − 2(coth z − 1/z)/z (series below `TILT_SERIES_BELOW`).
fn tilt_m2(z: f64) -> f64 {
    if z.abs() < TILT_SERIES_BELOW {
        let z2 = z * z;
        1.0 / 3.0 + z2 * (2.0 / 45.0 - z2 * (4.0 / 945.0 - z2 * 2.0 / 4725.0))
    } else {
        1.0 - 2.0 * tilt_m1(z) / z
    }
}

/// The tilted rule: the mean of K over a texel of shape `s` (world frame), for x = axis·ω
/// above the horizon over it. With g = ln K = ln scale + n·ln x, and ω = centroid + y,
/// y = s_u·hu + s_v·hv, (s_u, s_v) uniform on the square, g is linear in y up to the term
/// −n/2·(|y|² + (axis·y)²/x²). The linear part integrates in closed form (a product of
/// sinh z / z, z = n·axis·h/x); the quadratic part enters through its mean under the tilted
/// distribution. Exact for a linear log-kernel; its error is the curvature's second order.
pub fn tilted_mean(kernel: Kernel, axis: DVec3, s: &TexelShape) -> f64 {
    let e = axis - s.centroid;
    let gap = 0.5 * e.length_squared();
    let x = 1.0 - gap;
    if x <= 0.0 {
        return 0.0;
    }
    let n = kernel.exponent();
    let ln_k = kernel.scale().ln() + n * (-gap).ln_1p();
    // axis·h, as (axis − centroid)·h: h ⊥ centroid, and e keeps its digits near the peak.
    let (bu, bv) = (e.dot(s.hu), e.dot(s.hv));
    let (zu, zv) = (n * bu / x, n * bv / x);
    let x2 = x * x;
    let q = (s.hu.length_squared() + bu * bu / x2) * tilt_m2(zu)
        + (s.hv.length_squared() + bv * bv / x2) * tilt_m2(zv)
        + 2.0 * (s.hu.dot(s.hv) + bu * bv / x2) * tilt_m1(zu) * tilt_m1(zv);
    (ln_k + ln_sinhc(zu) + ln_sinhc(zv) - 0.5 * n * q).exp()
}

/// Calls `f(coord, weight)` for the quadrature nodes of texel (i, j) split into `cells`²
/// cells of 3×3 Gauss points, or for the clipped rule when the rim of a disc cuts it. The
/// weights are proportional to solid angle (they are not yet scaled to the texel's Ω).
pub fn for_each_node(
    mapping: Mapping,
    (w, h): (u32, u32),
    (layer, i, j): (u32, u32, u32),
    cells: u32,
    mut f: impl FnMut(Coord, f64),
) {
    if rim_cut(mapping, w, h, i, j) {
        clipped_nodes(mapping, w, h, layer, i, j, cells.min(4), &mut f);
        return;
    }
    // 3-point Gauss–Legendre on [0, 1] (sixth order): nodes ½ ± ½√(3/5) and ½, weights
    // 5/18, 5/18, 8/18.
    let g = 0.5 * 0.6f64.sqrt();
    let rule = [(-g, 5.0 / 18.0), (0.0, 8.0 / 18.0), (g, 5.0 / 18.0)];
    let s = cells as f64;
    for cy in 0..cells {
        for cx in 0..cells {
            for (dv, wv) in rule {
                for (du, wu) in rule {
                    let c = Coord {
                        layer,
                        u: (i as f64 + (cx as f64 + 0.5 + du) / s) / w as f64,
                        v: (j as f64 + (cy as f64 + 0.5 + dv) / s) / h as f64,
                    };
                    f(c, wu * wv * mapping.density(c));
                }
            }
        }
    }
}

/// The clipped Gauss–Legendre rule (see `clipped_square` in `glsl/include/mappings.glsl`),
/// with every piece cut into `split` more parts in x and every chord into `split` parts.
#[allow(clippy::too_many_arguments)]
fn clipped_nodes(
    mapping: Mapping,
    w: u32,
    h: u32,
    layer: u32,
    i: u32,
    j: u32,
    split: u32,
    f: &mut impl FnMut(Coord, f64),
) {
    let (gx, gw) = super::quadrature::gauss_legendre(8);
    let (lo, hi) = texel_square(w, h, i, j);
    let mut xs = vec![lo[0]];
    for yy in [lo[1], hi[1]] {
        if yy.abs() < 1.0 {
            let e = ((1.0 - yy) * (1.0 + yy)).sqrt();
            for v in [-e, e] {
                if v > lo[0] && v < hi[0] {
                    xs.push(v);
                }
            }
        }
    }
    xs.push(hi[0]);
    xs.sort_by(f64::total_cmp);
    for piece in xs.windows(2) {
        let parts = ((piece[1] - piece[0]) * 4.0).ceil().max(1.0) as u32 * split;
        let hx = 0.5 * (piece[1] - piece[0]) / parts as f64;
        for q in 0..parts {
            let x0 = piece[0] + 2.0 * hx * q as f64;
            for (ta, wa) in gx.iter().zip(&gw) {
                let u = 0.5 + 0.5 * ta;
                let x = x0 + 2.0 * hx * u * u * (3.0 - 2.0 * u);
                let jac = 6.0 * u * (1.0 - u);
                if x.abs() >= 1.0 {
                    continue;
                }
                let e = ((1.0 - x) * (1.0 + x)).sqrt();
                let (ya, yb) = (lo[1].max(-e), hi[1].min(e));
                if yb <= ya {
                    continue;
                }
                let hy = 0.5 * (yb - ya) / split as f64;
                for p in 0..split {
                    let my = ya + hy * (2 * p + 1) as f64;
                    for (tb, wb) in gx.iter().zip(&gw) {
                        let c = Coord {
                            layer,
                            u: 0.5 * (x + 1.0),
                            v: 0.5 * (my + hy * tb + 1.0),
                        };
                        f(c, wa * wb * hx * hy * jac * mapping.density(c));
                    }
                }
            }
        }
    }
}

/// A source map prepared for convolution: per texel that holds part of the sphere, its
/// centre direction (world), the cosine of its angular radius, its radiance and solid angle.
pub struct Prepared<'a> {
    map: &'a EnvMap,
    file_to_world: DMat3,
    texels: Vec<PreparedTexel>,
    tilted: bool,
}

struct PreparedTexel {
    layer: u32,
    i: u32,
    j: u32,
    dir: DVec3,
    cos_rho: f64,
    sin_rho: f64,
    radiance: [f64; 3],
    omega: f64,
    shape: TexelShape,
}

impl<'a> Prepared<'a> {
    /// Prepares `map`, whose file directions reach the world through `file_to_world`.
    pub fn new(map: &'a EnvMap, file_to_world: DMat3) -> Prepared<'a> {
        let (w, h) = (map.width, map.height);
        let mut texels = Vec::new();
        map.for_each_texel(|layer, i, j, t, omega| {
            let cos_rho = texel_cos_radius(map.mapping, w, h, layer, i, j);
            texels.push(PreparedTexel {
                layer,
                i,
                j,
                dir: file_to_world * map.texel_dir(layer, i, j),
                cos_rho,
                sin_rho: (1.0 - cos_rho * cos_rho).max(0.0).sqrt(),
                radiance: t.map(f64::from),
                omega,
                shape: texel_shape(map.mapping, w, h, layer, i, j).rotated(file_to_world),
            });
        });
        Prepared {
            map,
            file_to_world,
            texels,
            tilted: true,
        }
    }

    /// The same sums with the Gauss-cell rule wherever the tilted rule would be taken: the
    /// oracle the tilted rule is measured against.
    pub fn without_tilt(mut self) -> Self {
        self.tilted = false;
        self
    }

    /// ∑ over texels of L_t·∫_t K(axis·ω) dω.
    pub fn convolve(&self, kernel: Kernel, axis: DVec3) -> [f64; 3] {
        let mut out = [0.0; 3];
        for t in 0..self.texels.len() {
            let term = self.texel_term(kernel, axis, t);
            for (o, v) in out.iter_mut().zip(term) {
                *o += v;
            }
        }
        out
    }

    /// The map this was prepared from.
    pub fn map(&self) -> &EnvMap {
        self.map
    }

    /// The file → world rotation.
    pub fn file_to_world(&self) -> DMat3 {
        self.file_to_world
    }

    /// Texel `index`'s shape (world frame), radiance and solid angle (numbered as for
    /// [`Prepared::texel_term`]).
    pub fn texel(&self, index: usize) -> (&TexelShape, [f64; 3], f64) {
        let t = &self.texels[index];
        (&t.shape, t.radiance, t.omega)
    }

    /// Texel `index`'s term L_t·∫_t K(axis·ω) dω (texels are numbered layer-major, then
    /// row-major, over those that hold part of the sphere: every texel of a lat-long or cube).
    pub fn texel_term(&self, kernel: Kernel, axis: DVec3, index: usize) -> [f64; 3] {
        let m = self.map.mapping;
        let (w, h) = (self.map.width, self.map.height);
        let t = &self.texels[index];
        let x = axis.dot(t.dir);
        let regular = self.tilted && t.shape.regular;
        let k = match rule(kernel, x, t.cos_rho, t.sin_rho, regular) {
            Rule::Skip => return [0.0; 3],
            Rule::Centre => kernel.eval(axis, t.dir),
            Rule::Tilted => tilted_mean(kernel, axis, &t.shape),
            Rule::Cells(s) => {
                let (mut acc, mut wsum) = (0.0, 0.0);
                for_each_node(m, (w, h), (t.layer, t.i, t.j), s, |c, wq| {
                    acc += wq * kernel.eval(axis, self.file_to_world * m.coord_to_dir(c));
                    wsum += wq;
                });
                if wsum > 0.0 {
                    acc / wsum
                } else {
                    kernel.eval(axis, t.dir)
                }
            }
        };
        t.radiance.map(|l| l * t.omega * k)
    }
}

/// What the cut-off drops at one axis ([`Prepared::culled`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Culled {
    /// ∑ L·∫K over the texels the rule skips for the cut-off alone (their kernel is not zero),
    /// integrated with the cells rule.
    pub dropped: [f64; 3],
    /// The stated bound on it: scale·e^LOG_CUTOFF·∑ L·ω over those texels, which is at most
    /// scale·e^LOG_CUTOFF times the map's power.
    pub bound: [f64; 3],
    /// Texels skipped for the cut-off.
    pub texels: usize,
}

impl Prepared<'_> {
    /// The part of the convolution at `axis` that the lobe cut-off (`LOG_CUTOFF`) drops, and
    /// its bound. The GPU's tile culling skips only tiles whose texels all fail that same test,
    /// so this is also all that tile culling drops.
    pub fn culled(&self, kernel: Kernel, axis: DVec3) -> Culled {
        let m = self.map.mapping;
        let (w, h) = (self.map.width, self.map.height);
        let bound_k = kernel.scale() * LOG_CUTOFF.exp();
        let mut c = Culled {
            dropped: [0.0; 3],
            bound: [0.0; 3],
            texels: 0,
        };
        for t in &self.texels {
            let x = axis.dot(t.dir);
            if rule(kernel, x, t.cos_rho, t.sin_rho, false) != Rule::Skip {
                continue;
            }
            let sin_c = (1.0 - x * x).max(0.0).sqrt();
            let x_max = if x >= t.cos_rho {
                1.0
            } else {
                x * t.cos_rho + sin_c * t.sin_rho
            };
            if x_max <= 0.0 {
                continue; // wholly below the horizon: the kernel is exactly zero there
            }
            let n = kernel.exponent();
            let rho2 = 2.0 * (1.0 - t.cos_rho);
            let s = ((CELLS_PER_WIDTH * (n * rho2).sqrt()).ceil() as u32).clamp(1, MAX_CELLS);
            let (mut acc, mut wsum) = (0.0, 0.0);
            for_each_node(m, (w, h), (t.layer, t.i, t.j), s, |q, wq| {
                acc += wq * kernel.eval(axis, self.file_to_world * m.coord_to_dir(q));
                wsum += wq;
            });
            let k = if wsum > 0.0 { acc / wsum } else { 0.0 };
            c.texels += 1;
            for ch in 0..3 {
                c.dropped[ch] += t.radiance[ch] * t.omega * k;
                c.bound[ch] += t.radiance[ch] * t.omega * bound_k;
            }
        }
        c
    }
}

/// `f` at the centre direction of every texel of a `to` map of `w × h` per layer, layer-major
/// then row-major (what the GPU's filter passes write); angular texels centred outside the
/// disc are 0. Rows are shared among threads.
pub fn at_centres(
    to: Mapping,
    w: u32,
    h: u32,
    f: impl Fn(DVec3) -> [f64; 3] + Sync,
) -> Vec<[f64; 3]> {
    let rows = (to.layers() * h) as usize;
    let mut out = vec![[0.0; 3]; rows * w as usize];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let per = rows.div_ceil(threads).max(1) * w as usize;
    std::thread::scope(|scope| {
        for (chunk_index, chunk) in out.chunks_mut(per).enumerate() {
            let f = &f;
            scope.spawn(move || {
                for (k, v) in chunk.iter_mut().enumerate() {
                    let idx = chunk_index * per + k;
                    let (row, i) = ((idx / w as usize) as u32, (idx % w as usize) as u32);
                    let (layer, j) = (row / h, row % h);
                    if to == Mapping::Angular && !to.texel_in_domain(w, h, i, j) {
                        continue;
                    }
                    *v = f(to.coord_to_dir(Mapping::texel_center(w, h, layer, i, j)));
                }
            });
        }
    });
    out
}

/// Convolves `map` with `kernel` at the centre of every texel of a `to` map of `w × h` per
/// layer (world frame), as [`at_centres`] lays them out.
pub fn filter_map(
    map: &EnvMap,
    file_to_world: DMat3,
    kernel: Kernel,
    to: Mapping,
    w: u32,
    h: u32,
) -> Vec<[f64; 3]> {
    let prepared = Prepared::new(map, file_to_world);
    at_centres(to, w, h, |d| prepared.convolve(kernel, d))
}

#[cfg(test)]
mod tests;
