//! Real spherical harmonics in the convention of docs/design.md §2, and what Ramamoorthi &
//! Hanrahan (2001) build on them: projection, the clamped-cosine convolution, and the 4×4
//! irradiance matrix.
//!
//! Orthonormal on the sphere, flat index k = l(l+1)+m, θ from +Z and φ = atan2(y, x), no
//! Condon–Shortley phase: for l ≤ 2 these are R&H's eq. 3 on world (x, y, z).

use super::mapping::Mapping;
use crate::math::envmap::EnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// Number of coefficients up to and including band `lmax`.
pub fn count(lmax: u32) -> usize {
    ((lmax + 1) * (lmax + 1)) as usize
}

/// Flat index of (l, m).
pub fn index(l: u32, m: i32) -> usize {
    (l as i32 * (l as i32 + 1) + m) as usize
}

fn factorial(n: u32) -> f64 {
    (1..=n).map(|k| k as f64).product()
}

/// K_lm = √((2l+1)/4π · (l−|m|)!/(l+|m|)!).
pub fn k_lm(l: u32, m: u32) -> f64 {
    ((2 * l + 1) as f64 / (4.0 * PI) * factorial(l - m) / factorial(l + m)).sqrt()
}

/// All basis functions up to `lmax` at unit direction `d`.
///
/// Uses the associated Legendre functions divided by sinᵐθ (polynomials in z, so nothing is
/// singular at the poles) times Re/Im((x + iy)ᵐ) = sinᵐθ·cos/sin(mφ).
pub fn basis(lmax: u32, d: DVec3) -> Vec<f64> {
    let mut y = vec![0.0; count(lmax)];
    basis_into(lmax, d, &mut y);
    y
}

/// [`basis`] into a caller's buffer of at least (lmax+1)² values.
pub fn basis_into(lmax: u32, d: DVec3, y: &mut [f64]) {
    let z = d.z;
    // (x + iy)^m, built up as m grows.
    let (mut re, mut im) = (1.0, 0.0);
    let mut pmm = 1.0; // P̃_m^m = (2m−1)!!
    for m in 0..=lmax {
        if m > 0 {
            let (r, i) = (re * d.x - im * d.y, re * d.y + im * d.x);
            re = r;
            im = i;
            pmm *= (2 * m - 1) as f64;
        }
        // P̃_l^m for l = m, m+1, … by the three-term recurrence.
        let mut p_prev = 0.0;
        let mut p = pmm;
        for l in m..=lmax {
            if l == m + 1 {
                p_prev = p;
                p = z * (2 * m + 1) as f64 * pmm;
            } else if l > m + 1 {
                let next =
                    ((2 * l - 1) as f64 * z * p - (l + m - 1) as f64 * p_prev) / (l - m) as f64;
                p_prev = p;
                p = next;
            }
            let k = k_lm(l, m);
            if m == 0 {
                y[index(l, 0)] = k * p;
            } else {
                let s = std::f64::consts::SQRT_2 * k * p;
                y[index(l, m as i32)] = s * re;
                y[index(l, -(m as i32))] = s * im;
            }
        }
    }
}

/// Largest error of the per-texel quadrature [`project`] (and the GPU pass) accepts: a
/// spurious coefficient of 0.1 % of L00 on a constant map.
pub const RULE_TOLERANCE: f64 = 1e-3;

/// The error of the per-texel rule of [`project`] on a `w` × `h` grid of `mapping` up to band
/// `lmax`: the largest coefficient beyond L00 that a constant map projects to (exactly 0 for
/// the true integral), relative to L00. A 2×2 Gauss rule per texel cannot integrate high
/// bands over a texel that spans a large part of the sphere (a 1×1 lat-long gives 100 % at
/// order 2); grids of 4096 texels or more per layer are fine to l = 8 (under 1e-5, measured)
/// and are not evaluated.
pub fn rule_error(mapping: Mapping, w: u32, h: u32, lmax: u32) -> f64 {
    if (w as u64) * (h as u64) >= 4096 || lmax == 0 {
        return 0.0;
    }
    let n = (w * h * mapping.layers()) as usize;
    let c = project(&EnvMap::new(mapping, w, h, vec![[1.0; 3]; n]), lmax);
    c.iter().skip(1).map(|x| x[0].abs()).fold(0.0, f64::max) / c[0][0]
}

/// Projects a map onto the basis up to `lmax`: ∑ L_i·∫_texel Y_k dω over the texels that hold
/// the sphere ([`EnvMap::for_each_texel`]). Each texel's integral uses 2×2 Gauss points
/// weighted by the density (fourth order); texels the rim of an angular or paraboloid disc
/// cuts use a clipped Gauss–Legendre rule. The weights are scaled to the texel's exact solid
/// angle, so a constant map gives exactly L·∑Ω for L00. The GPU pass
/// (`glsl/sh_project.comp`) does the same.
pub fn project(map: &EnvMap, lmax: u32) -> Vec<[f64; 3]> {
    project_oriented(map, lmax, DMat3::IDENTITY)
}

/// [`project`] of a map whose file directions map to world directions by `file_to_world`
/// (orthogonal: the transpose of [`super::Orientation::world_to_file`]).
pub fn project_oriented(map: &EnvMap, lmax: u32, file_to_world: DMat3) -> Vec<[f64; 3]> {
    let n = count(lmax);
    let mut c = vec![[0.0; 3]; n];
    let mut y = vec![0.0; n];
    let mut acc = vec![0.0; n];
    let g = crate::abi::constants::GAUSS2_OFFSET;
    let (w, h) = (map.width as f64, map.height as f64);
    let disc = matches!(map.mapping, Mapping::Angular | Mapping::DualParaboloid);
    map.for_each_texel(|layer, i, j, t, omega| {
        acc.iter_mut().for_each(|a| *a = 0.0);
        let lo = [2.0 * i as f64 / w - 1.0, 2.0 * j as f64 / h - 1.0];
        let hi = [
            2.0 * (i + 1) as f64 / w - 1.0,
            2.0 * (j + 1) as f64 / h - 1.0,
        ];
        let far = [lo[0].abs().max(hi[0].abs()), lo[1].abs().max(hi[1].abs())];
        let mut wsum = 0.0;
        if disc && far[0] * far[0] + far[1] * far[1] > 1.0 {
            // The clipped rule of the GPU's `clipped_square` (filter::for_each_node).
            super::filter::for_each_node(
                map.mapping,
                (map.width, map.height),
                (layer, i, j),
                1,
                |q, wq| {
                    basis_into(lmax, file_to_world * map.mapping.coord_to_dir(q), &mut y);
                    for (a, yk) in acc.iter_mut().zip(&y) {
                        *a += wq * yk;
                    }
                    wsum += wq;
                },
            );
        } else {
            for (du, dv) in [(-g, -g), (g, -g), (-g, g), (g, g)] {
                let q = super::Coord {
                    layer,
                    u: (i as f64 + 0.5 + du) / w,
                    v: (j as f64 + 0.5 + dv) / h,
                };
                let wq = map.mapping.density(q);
                basis_into(lmax, file_to_world * map.mapping.coord_to_dir(q), &mut y);
                for (a, yk) in acc.iter_mut().zip(&y) {
                    *a += wq * yk;
                }
                wsum += wq;
            }
        }
        if wsum <= 0.0 {
            basis_into(lmax, file_to_world * map.texel_dir(layer, i, j), &mut acc);
            wsum = 1.0;
        }
        let scale = omega / wsum;
        for (ck, ak) in c.iter_mut().zip(&acc) {
            for ch in 0..3 {
                ck[ch] += t[ch] as f64 * ak * scale;
            }
        }
    });
    c
}

/// One coefficient of a packed set, as `passes::sh_pack` writes it for the shade pass:
/// `scale` × (radiance coefficient `source`, less coefficient `minus` of a second set where
/// there is one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackEntry {
    /// The radiance coefficient (flat index).
    pub source: u32,
    /// What the difference is multiplied by (Â_l for irradiance, a window's w_l).
    pub scale: f64,
    /// The coefficient of the second set subtracted first, if any.
    pub minus: Option<u32>,
}

/// The entries of an irradiance set to band `order` (Â_l folded in, as
/// `irradiance_coeffs`), of the radiance less the second set where `residual` (an
/// extraction's light texels: the residual's irradiance).
pub fn irradiance_entries(order: u32, residual: bool) -> Vec<PackEntry> {
    (0..=order)
        .flat_map(|l| {
            (-(l as i32)..=(l as i32)).map(move |m| {
                let k = index(l, m) as u32;
                PackEntry {
                    source: k,
                    scale: cosine_lobe(l),
                    minus: residual.then_some(k),
                }
            })
        })
        .collect()
}

/// The entries of the radiance to band `order` windowed by `window` (as [`Window::apply`]).
pub fn windowed_entries(order: u32, window: Window) -> Vec<PackEntry> {
    let w = window.weights(order);
    (0..=order)
        .flat_map(|l| {
            let wl = w[l as usize];
            (-(l as i32)..=(l as i32)).map(move |m| PackEntry {
                source: index(l, m) as u32,
                scale: wl,
                minus: None,
            })
        })
        .collect()
}

/// The packed set `entries` describe, from `radiance` and the second set `minus`: the float64
/// twin of `passes::sh_pack`.
pub fn pack(radiance: &[[f64; 3]], minus: &[[f64; 3]], entries: &[PackEntry]) -> Vec<[f64; 3]> {
    entries
        .iter()
        .map(|e| {
            let c = radiance[e.source as usize];
            let m = e.minus.map_or([0.0; 3], |j| minus[j as usize]);
            [0, 1, 2].map(|ch| (c[ch] - m[ch]) * e.scale)
        })
        .collect()
}

/// Evaluates an SH expansion at `d`.
pub fn eval(coeffs: &[[f64; 3]], d: DVec3) -> [f64; 3] {
    let lmax = (coeffs.len() as f64).sqrt() as u32 - 1;
    let y = basis(lmax, d);
    let mut out = [0.0; 3];
    for (c, yk) in coeffs.iter().zip(&y) {
        for ch in 0..3 {
            out[ch] += c[ch] * yk;
        }
    }
    out
}

/// Â_l of the clamped cosine (R&H 2001 eq. 8): π, 2π/3, then for even l
/// 2π·(−1)^(l/2−1)/((l+2)(l−1)) · l!/(2^l·((l/2)!)²); zero for odd l > 1.
pub fn cosine_lobe(l: u32) -> f64 {
    match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            let h = l / 2;
            let sign = if (h - 1).is_multiple_of(2) { 1.0 } else { -1.0 };
            // l!/(2^l·((l/2)!)²) = Π_{k=1}^{l/2} (2k−1)/(2k): no overflow at any l.
            let central: f64 = (1..=h)
                .map(|k| (2 * k - 1) as f64 / (2 * k) as f64)
                .product();
            2.0 * PI * sign / ((l + 2) as f64 * (l - 1) as f64) * central
        }
    }
}

/// Irradiance coefficients E_lm = Â_l·L_lm.
pub fn irradiance_coeffs(radiance: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let lmax = (radiance.len() as f64).sqrt() as u32 - 1;
    let mut out = radiance.to_vec();
    for l in 0..=lmax {
        for m in -(l as i32)..=(l as i32) {
            out[index(l, m)] = radiance[index(l, m)].map(|c| c * cosine_lobe(l));
        }
    }
    out
}

/// R&H 2001 eq. 12: the symmetric 4×4 matrix M of one channel such that E(n) = nᵀMn with
/// n = (x, y, z, 1), from the first nine radiance coefficients of that channel. The constants
/// are computed from Â_l and the basis constants rather than taken from the paper's six
/// printed digits (c1 = π·√(15/4π)/8 = 0.429043…, c2 = π·√(3/4π)/3 = 0.511664…,
/// c3 = 3π·√(5/16π)/4 = 0.743125…, c4 = π/(2√π) = 0.886227…, c5 = π·√(5/16π)/4 = 0.247708…).
pub fn irradiance_matrix(l: &[f64]) -> [[f64; 4]; 4] {
    assert!(
        l.len() >= 9,
        "the matrix needs the nine coefficients up to l = 2"
    );
    let k20 = (5.0 / (16.0 * PI)).sqrt();
    let c1 = PI * (15.0 / (4.0 * PI)).sqrt() / 8.0;
    let c2 = PI * (3.0 / (4.0 * PI)).sqrt() / 3.0;
    let c3 = 3.0 * PI * k20 / 4.0;
    let c4 = PI / (2.0 * PI.sqrt());
    let c5 = PI * k20 / 4.0;
    let (l00, l1m1, l10, l11, l2m2, l2m1, l20, l21, l22) =
        (l[0], l[1], l[2], l[3], l[4], l[5], l[6], l[7], l[8]);
    [
        [c1 * l22, c1 * l2m2, c1 * l21, c2 * l11],
        [c1 * l2m2, -c1 * l22, c1 * l2m1, c2 * l1m1],
        [c1 * l21, c1 * l2m1, c3 * l20, c2 * l10],
        [c2 * l11, c2 * l1m1, c2 * l10, c4 * l00 - c5 * l20],
    ]
}

/// nᵀMn for n = (d, 1).
pub fn eval_matrix(m: &[[f64; 4]; 4], d: DVec3) -> f64 {
    let n = [d.x, d.y, d.z, 1.0];
    let mut e = 0.0;
    for i in 0..4 {
        for j in 0..4 {
            e += n[i] * m[i][j] * n[j];
        }
    }
    e
}

/// A window on SH bands, against ringing: coefficient band l is scaled by w_l.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    /// w_l = 1.
    None,
    /// Hanning of a given width w: w_l = (1 + cos(π·l/w))/2 for l < w, else 0 (Sloan 2008,
    /// "Stupid SH tricks"). A width of lmax+1 damps band lmax hard; 2·(lmax+1) is gentler.
    Hanning {
        /// Width w in bands.
        width: f64,
    },
    /// Sloan's w_l = 1/(1 + λ·l²(l+1)²), which damps band l like a Laplacian-squared penalty.
    Sloan {
        /// Strength.
        lambda: f64,
    },
}

impl Window {
    /// w_l for l = 0..=lmax.
    pub fn weights(self, lmax: u32) -> Vec<f64> {
        (0..=lmax)
            .map(|l| {
                let lf = l as f64;
                match self {
                    Window::None => 1.0,
                    Window::Hanning { width } if lf < width => {
                        0.5 * (1.0 + (PI * lf / width).cos())
                    }
                    Window::Hanning { .. } => 0.0,
                    Window::Sloan { lambda } => 1.0 / (1.0 + lambda * lf * lf * (lf + 1.0).powi(2)),
                }
            })
            .collect()
    }

    /// `coeffs` with band l scaled by w_l.
    pub fn apply(self, coeffs: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let lmax = (coeffs.len() as f64).sqrt() as u32 - 1;
        let w = self.weights(lmax);
        let mut out = coeffs.to_vec();
        for l in 0..=lmax {
            for m in -(l as i32)..=(l as i32) {
                out[index(l, m)] = coeffs[index(l, m)].map(|c| c * w[l as usize]);
            }
        }
        out
    }
}

/// Where an SH reconstruction goes negative, over a set of directions.
#[derive(Clone, Debug, PartialEq)]
pub struct Negativity {
    /// The most negative value over all channels relative to the mean of that channel's
    /// values (0 when nothing is negative).
    pub worst: f64,
    /// The direction of the worst value.
    pub at: DVec3,
    /// The fraction of directions with any channel negative.
    pub fraction: f64,
}

/// Evaluates `coeffs` at `dirs` and reports where and by how much it is negative.
pub fn negativity(coeffs: &[[f64; 3]], dirs: &[DVec3]) -> Negativity {
    let lmax = (coeffs.len() as f64).sqrt() as u32 - 1;
    let mut y = vec![0.0; count(lmax)];
    let values: Vec<[f64; 3]> = dirs
        .iter()
        .map(|&d| {
            basis_into(lmax, d, &mut y);
            let mut v = [0.0; 3];
            for (c, yk) in coeffs.iter().zip(&y) {
                for ch in 0..3 {
                    v[ch] += c[ch] * yk;
                }
            }
            v
        })
        .collect();
    let mean = [0, 1, 2].map(|ch| values.iter().map(|v| v[ch]).sum::<f64>() / dirs.len() as f64);
    let mut out = Negativity {
        worst: 0.0,
        at: DVec3::Y,
        fraction: 0.0,
    };
    let mut negative = 0usize;
    for (v, &d) in values.iter().zip(dirs) {
        if v.iter().any(|&c| c < 0.0) {
            negative += 1;
        }
        for ch in 0..3 {
            let rel = v[ch] / mean[ch].abs().max(f64::MIN_POSITIVE);
            if rel < out.worst {
                out.worst = rel;
                out.at = d;
            }
        }
    }
    out.fraction = negative as f64 / dirs.len() as f64;
    out
}

/// The smallest λ of [`Window::Sloan`] for which the windowed irradiance of `radiance` is
/// non-negative at every one of `dirs` (bisection to 1% of λ; 0 when it already is). The
/// irradiance of l = 0 alone is non-negative whenever L00 is, so a λ always exists.
pub fn smallest_nonnegative_window(radiance: &[[f64; 3]], dirs: &[DVec3]) -> f64 {
    let ok = |lambda: f64| {
        let e = irradiance_coeffs(&Window::Sloan { lambda }.apply(radiance));
        negativity(&e, dirs).fraction == 0.0
    };
    if ok(0.0) {
        return 0.0;
    }
    let mut hi = 1e-4;
    while !ok(hi) {
        hi *= 4.0;
        if hi > 1e12 {
            return hi;
        }
    }
    let mut lo = hi / 4.0;
    while hi - lo > 0.01 * hi {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// Exposes the mapping used for quadrature tests.
#[doc(hidden)]
pub fn gram_matrix(lmax: u32, mapping: Mapping, size: u32) -> Vec<Vec<f64>> {
    let n = count(lmax);
    let mut g = vec![vec![0.0; n]; n];
    let (w, h) = mapping.extent_for_size(size);
    for layer in 0..mapping.layers() {
        for j in 0..h {
            for i in 0..w {
                // 3×3 Gauss points per texel keep the quadrature exact enough for l ≤ 8.
                for (a, wa) in [
                    (-0.7745966692414834, 5.0 / 9.0),
                    (0.0, 8.0 / 9.0),
                    (0.7745966692414834, 5.0 / 9.0),
                ] {
                    for (b, wb) in [
                        (-0.7745966692414834, 5.0 / 9.0),
                        (0.0, 8.0 / 9.0),
                        (0.7745966692414834, 5.0 / 9.0),
                    ] {
                        let c = super::Coord {
                            layer,
                            u: (i as f64 + 0.5 + 0.5 * a) / w as f64,
                            v: (j as f64 + 0.5 + 0.5 * b) / h as f64,
                        };
                        let wt = wa * wb / 4.0 * mapping.density(c) / (w * h) as f64;
                        let y = basis(lmax, mapping.coord_to_dir(c));
                        for p in 0..n {
                            for q in 0..n {
                                g[p][q] += wt * y[p] * y[q];
                            }
                        }
                    }
                }
            }
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_bands_equal_ramamoorthi_hanrahan_eq3() {
        for d in super::super::synth::fibonacci_sphere(500) {
            let (x, y, z) = (d.x, d.y, d.z);
            let rh = [
                0.282095,
                0.488603 * y,
                0.488603 * z,
                0.488603 * x,
                1.092548 * x * y,
                1.092548 * y * z,
                0.315392 * (3.0 * z * z - 1.0),
                1.092548 * x * z,
                0.546274 * (x * x - y * y),
            ];
            let b = basis(2, d);
            for k in 0..9 {
                // R&H print six digits.
                assert!(
                    (b[k] - rh[k]).abs() < 2e-6,
                    "k={k} at {d}: {} vs {}",
                    b[k],
                    rh[k]
                );
            }
        }
    }

    #[test]
    fn bands_up_to_8_are_orthonormal() {
        let g = gram_matrix(8, Mapping::Cube, 48);
        for (p, row) in g.iter().enumerate() {
            for (q, v) in row.iter().enumerate() {
                let want = if p == q { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-6, "G[{p}][{q}] = {v}");
            }
        }
    }

    #[test]
    fn cosine_lobe_matches_quadrature() {
        // Â_l = 2π ∫₀^{π/2} P_l(cos θ) cos θ sin θ dθ (Y_l0 normalisation cancels).
        for l in 0..=8u32 {
            let n = 20000;
            let mut s = 0.0;
            for k in 0..n {
                let t = (k as f64 + 0.5) / n as f64 * PI / 2.0;
                let y = basis(l, DVec3::new(t.sin(), 0.0, t.cos()))[index(l, 0)];
                s += y / k_lm(l, 0) * t.cos() * t.sin();
            }
            let a = 2.0 * PI * s * (PI / 2.0) / n as f64;
            assert!(
                (a - cosine_lobe(l)).abs() < 1e-7,
                "l={l}: {a} vs {}",
                cosine_lobe(l)
            );
        }
    }

    #[test]
    fn matrix_constants_round_to_the_papers() {
        let m = irradiance_matrix(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        // The paper's digits are its rounding of products of rounded basis constants.
        let near = |x: f64, paper: f64| assert!((x - paper).abs() < 1.5e-6, "{x} vs {paper}");
        near(m[0][1], 0.429043);
        near(m[0][3], 0.511664);
        near(m[2][2], 0.743125);
        near(m[3][3] + 0.247708, 0.886227);
    }

    #[test]
    fn matrix_form_equals_polynomial_form() {
        let coeffs: Vec<f64> = (0..9)
            .map(|k| 0.3 + 0.17 * k as f64 - 0.05 * (k * k) as f64)
            .collect();
        let rgb: Vec<[f64; 3]> = coeffs.iter().map(|&c| [c, 0.0, 0.0]).collect();
        let e = irradiance_coeffs(&rgb);
        let m = irradiance_matrix(&coeffs);
        for d in super::super::synth::fibonacci_sphere(300) {
            let poly = eval(&e, d)[0];
            let mat = eval_matrix(&m, d);
            assert!(
                (poly - mat).abs() <= 1e-12 * poly.abs().max(1.0),
                "{d}: {poly} vs {mat}"
            );
        }
    }
}
