//! Rotation of real SH coefficient vectors (the basis of [`super::sh`]), in float64: the twins
//! of `glsl/include/sh_rotate.glsl`.
//!
//! Convention: for a rotation R, the block-diagonal matrix M(R) satisfies y(R·d) = M(R)·y(d)
//! for the basis vector y, so the coefficients of the rotated function f(R⁻¹·d) are M(R)·c,
//! and M(R₁R₂) = M(R₁)·M(R₂). Two constructions, as Kautz, Sloan & Snyder (2002) and
//! Ivanic & Ruedenberg (1996, with their 1998 corrections) give them:
//! - [`ivanic`]: band l from band l−1 and the 3×3 rotation by a recurrence;
//! - [`zxzxz`]: R = Rz(α)·Ry(β)·Rz(γ) with Ry(β) = Rx(−90°)·Rz(β)·Rx(90°), so M(R) is three
//!   rotations about z (each (m, −m) pair turns by mφ) and two fixed matrices M(Rx(±90°)).
//!
//! [`by_quadrature`] builds M(R) = ∫ y(R·d)·y(d)ᵀ dd with a product rule exact for the
//! degree, independent of both: the tests' oracle.

use super::sh::{basis_into, count};
use glam::{DMat3, DVec3};

/// M(R) as one dense (2l+1)² block per band, row-major: `bands[l][(m+l)·(2l+1) + (n+l)]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ShRotation {
    /// The blocks, band 0 first.
    pub bands: Vec<Vec<f64>>,
}

impl ShRotation {
    /// Highest band.
    pub fn lmax(&self) -> u32 {
        self.bands.len() as u32 - 1
    }

    /// Entry (l, m, n).
    pub fn get(&self, l: u32, m: i32, n: i32) -> f64 {
        let w = 2 * l as i32 + 1;
        self.bands[l as usize][((m + l as i32) * w + n + l as i32) as usize]
    }

    /// M·c for a coefficient vector of (lmax+1)² entries.
    pub fn apply(&self, c: &[f64]) -> Vec<f64> {
        assert_eq!(c.len(), count(self.lmax()));
        let mut out = vec![0.0; c.len()];
        for (l, b) in self.bands.iter().enumerate() {
            let w = 2 * l + 1;
            let o = l * l;
            for i in 0..w {
                out[o + i] = (0..w).map(|j| b[i * w + j] * c[o + j]).sum();
            }
        }
        out
    }

    /// Largest |MᵀM − I| entry over every band.
    pub fn orthogonality_error(&self) -> f64 {
        let mut worst = 0.0f64;
        for (l, b) in self.bands.iter().enumerate() {
            let w = 2 * l + 1;
            for i in 0..w {
                for j in 0..w {
                    let dot: f64 = (0..w).map(|k| b[k * w + i] * b[k * w + j]).sum();
                    worst = worst.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
                }
            }
        }
        worst
    }

    /// Largest entry of |self − other|.
    pub fn max_difference(&self, other: &ShRotation) -> f64 {
        self.bands
            .iter()
            .zip(&other.bands)
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max)
    }
}

/// Band 1 of M(R): y₁ = (y, z, x)·√(3/4π), so M₁[m][n] = R[p(m)][p(n)] with p = (1, 2, 0).
fn band1(r: &DMat3) -> [[f64; 3]; 3] {
    const P: [usize; 3] = [1, 2, 0];
    let mut b = [[0.0; 3]; 3];
    for (i, row) in b.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            // glam is column-major: col(c)[r] is R[r][c].
            *v = r.col(P[j])[P[i]];
        }
    }
    b
}

/// M(R) to band `lmax` by the Ivanic–Ruedenberg recurrence.
pub fn ivanic(lmax: u32, r: &DMat3) -> ShRotation {
    let r1 = band1(r);
    let mut bands = vec![vec![1.0]];
    if lmax >= 1 {
        bands.push(r1.iter().flatten().copied().collect());
    }
    for l in 2..=lmax as i32 {
        let prev = &bands[l as usize - 1];
        let wp = 2 * l - 1;
        let pv = |a: i32, b: i32| prev[((a + l - 1) * wp + b + l - 1) as usize];
        let ri = |i: i32, c: i32| r1[(i + 1) as usize][(c + 1) as usize];
        let p = |i: i32, a: i32, b: i32| {
            if b == l {
                ri(i, 1) * pv(a, l - 1) - ri(i, -1) * pv(a, -l + 1)
            } else if b == -l {
                ri(i, 1) * pv(a, -l + 1) + ri(i, -1) * pv(a, l - 1)
            } else {
                ri(i, 0) * pv(a, b)
            }
        };
        let w = 2 * l + 1;
        let mut band = vec![0.0; (w * w) as usize];
        for m in -l..=l {
            for n in -l..=l {
                let d = (m == 0) as i32 as f64;
                let denom = if n.abs() < l {
                    ((l + n) * (l - n)) as f64
                } else {
                    (2 * l * (2 * l - 1)) as f64
                };
                let am = m.abs();
                let u = (((l + m) * (l - m)) as f64 / denom).sqrt();
                let v = 0.5
                    * ((1.0 + d) * ((l + am - 1) * (l + am)) as f64 / denom).sqrt()
                    * (1.0 - 2.0 * d);
                let wc = -0.5 * (((l - am - 1) * (l - am)) as f64 / denom).sqrt() * (1.0 - d);
                let mut x = 0.0;
                if u != 0.0 {
                    x += u * p(0, m, n);
                }
                if v != 0.0 {
                    x += v * if m == 0 {
                        p(1, 1, n) + p(-1, -1, n)
                    } else if m > 0 {
                        let d1 = (m == 1) as i32 as f64;
                        p(1, m - 1, n) * (1.0 + d1).sqrt() - p(-1, -m + 1, n) * (1.0 - d1)
                    } else {
                        let d1 = (m == -1) as i32 as f64;
                        p(1, m + 1, n) * (1.0 - d1) + p(-1, -m - 1, n) * (1.0 + d1).sqrt()
                    };
                }
                if wc != 0.0 {
                    x += wc
                        * if m > 0 {
                            p(1, m + 1, n) + p(-1, -m - 1, n)
                        } else {
                            p(1, m - 1, n) - p(-1, -m + 1, n)
                        };
                }
                band[((m + l) * w + n + l) as usize] = x;
            }
        }
        bands.push(band);
    }
    ShRotation { bands }
}

/// (cos, sin) of the ZYZ Euler angles (α, β, γ) of R = Rz(α)·Ry(β)·Rz(γ), without
/// trigonometry (the GPU's sin, cos and atan are too loose for 1e-5): α from the third column
/// (α = 0 where it is ±ẑ), then β and γ from Q = Rz(α)ᵀ·R = Ry(β)·Rz(γ), whose entries
/// `Q[0][2]` = sin β, `Q[2][2]` = cos β, `Q[1][0]` = sin γ, `Q[1][1]` = cos γ need no
/// division by sin β. Stable at β = 0 and π: any α there is compensated exactly by γ.
pub fn zyz_cos_sin(r: &DMat3) -> [(f64, f64); 3] {
    let at = |i: usize, j: usize| r.col(j)[i];
    let h = at(0, 2).hypot(at(1, 2));
    let (c, s) = if h > 0.0 {
        (at(0, 2) / h, at(1, 2) / h)
    } else {
        (1.0, 0.0)
    };
    let q02 = c * at(0, 2) + s * at(1, 2);
    let q10 = -s * at(0, 0) + c * at(1, 0);
    let q11 = -s * at(0, 1) + c * at(1, 1);
    let unit = |x: f64, y: f64| {
        let n = x.hypot(y);
        (x / n, y / n)
    };
    [(c, s), unit(at(2, 2), q02), unit(q11, q10)]
}

/// Applies M(Rz(φ)) to `c` in place, given (cos φ, sin φ): each (m, −m) pair turns by mφ,
/// with cos mφ and sin mφ by the angle-addition recurrence.
pub fn rotate_z(lmax: u32, (c1, s1): (f64, f64), c: &mut [f64]) {
    let (mut cm, mut sm) = (1.0, 0.0);
    for m in 1..=lmax as i32 {
        (cm, sm) = (cm * c1 - sm * s1, sm * c1 + cm * s1);
        for l in m..=lmax as i32 {
            let kp = (l * (l + 1) + m) as usize;
            let km = (l * (l + 1) - m) as usize;
            let (a, b) = (c[kp], c[km]);
            c[kp] = cm * a - sm * b;
            c[km] = sm * a + cm * b;
        }
    }
}

/// The fixed matrix M(Rx(90°)) (its transpose is M(Rx(−90°))), from [`ivanic`].
pub fn x90(lmax: u32) -> ShRotation {
    ivanic(lmax, &DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2))
}

/// M(R)·c by the zxzxz decomposition (Kautz et al. 2002), given the fixed `x90` matrices.
pub fn apply_zxzxz(x90: &ShRotation, r: &DMat3, c: &[f64]) -> Vec<f64> {
    let lmax = x90.lmax();
    let [alpha, beta, gamma] = zyz_cos_sin(r);
    let mut v = c.to_vec();
    rotate_z(lmax, gamma, &mut v);
    v = x90.apply(&v);
    rotate_z(lmax, beta, &mut v);
    v = transpose(x90).apply(&v);
    rotate_z(lmax, alpha, &mut v);
    v
}

/// M(R) built column by column with [`apply_zxzxz`].
pub fn zxzxz(lmax: u32, r: &DMat3) -> ShRotation {
    let x = x90(lmax);
    let n = count(lmax);
    let mut bands: Vec<Vec<f64>> = (0..=lmax)
        .map(|l| vec![0.0; ((2 * l + 1) * (2 * l + 1)) as usize])
        .collect();
    for j in 0..n {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        let col = apply_zxzxz(&x, r, &e);
        let l = (j as f64).sqrt() as usize;
        let w = 2 * l + 1;
        for i in 0..w {
            bands[l][i * w + (j - l * l)] = col[l * l + i];
        }
    }
    ShRotation { bands }
}

/// The transpose (inverse) of a rotation.
pub fn transpose(m: &ShRotation) -> ShRotation {
    ShRotation {
        bands: m
            .bands
            .iter()
            .enumerate()
            .map(|(l, b)| {
                let w = 2 * l + 1;
                (0..w * w).map(|k| b[(k % w) * w + k / w]).collect()
            })
            .collect(),
    }
}

/// M(R) = ∫ y(R·d)·y(d)ᵀ dd by a product rule exact for degree 2·lmax (Gauss–Legendre in
/// cos θ, uniform in φ): the oracle the two constructions are tested against.
pub fn by_quadrature(lmax: u32, r: &DMat3) -> ShRotation {
    let nz = lmax as usize + 2;
    let nphi = 2 * lmax as usize + 3;
    let (zs, ws) = super::quadrature::gauss_legendre(nz);
    let n = count(lmax);
    let mut full = vec![0.0; n * n];
    let (mut y, mut yr) = (vec![0.0; n], vec![0.0; n]);
    for (z, wz) in zs.iter().zip(&ws) {
        let s = (1.0 - z * z).max(0.0).sqrt();
        for k in 0..nphi {
            let phi = std::f64::consts::TAU * k as f64 / nphi as f64;
            let d = DVec3::new(s * phi.cos(), s * phi.sin(), *z);
            let w = wz * std::f64::consts::TAU / nphi as f64;
            basis_into(lmax, d, &mut y);
            basis_into(lmax, *r * d, &mut yr);
            for i in 0..n {
                for j in 0..n {
                    full[i * n + j] += w * yr[i] * y[j];
                }
            }
        }
    }
    ShRotation {
        bands: (0..=lmax as usize)
            .map(|l| {
                let w = 2 * l + 1;
                let o = l * l;
                (0..w * w)
                    .map(|k| full[(o + k / w) * n + o + k % w])
                    .collect()
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    fn rotations() -> Vec<DMat3> {
        let mut v = vec![
            DMat3::IDENTITY,
            DMat3::from_rotation_x(std::f64::consts::PI),
            DMat3::from_rotation_y(std::f64::consts::PI),
            DMat3::from_rotation_z(0.3),
            DMat3::from_rotation_y(1e-9),
            DMat3::from_rotation_y(std::f64::consts::PI - 1e-9),
            DMat3::from_rotation_x(1e-5) * DMat3::from_rotation_z(2.0),
        ];
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20 {
            let q =
                DQuat::from_xyzw(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
            v.push(DMat3::from_quat(q));
        }
        v
    }

    #[test]
    fn both_constructions_equal_the_quadrature_oracle() {
        for r in rotations() {
            let q = by_quadrature(8, &r);
            let a = ivanic(8, &r);
            let b = zxzxz(8, &r);
            assert!(
                q.max_difference(&a) < 1e-12,
                "ivanic {}",
                q.max_difference(&a)
            );
            assert!(
                q.max_difference(&b) < 1e-12,
                "zxzxz {}",
                q.max_difference(&b)
            );
            assert!(a.orthogonality_error() < 1e-12);
        }
    }

    #[test]
    fn the_basis_rotates_as_the_convention_says() {
        let r = rotations()[9];
        let m = ivanic(8, &r);
        for d in [
            DVec3::new(0.2, -0.5, 0.8).normalize(),
            DVec3::Z,
            DVec3::NEG_X,
        ] {
            let y = crate::math::sh::basis(8, d);
            let yr = crate::math::sh::basis(8, r * d);
            let my = m.apply(&y);
            for (a, b) in yr.iter().zip(&my) {
                assert!((a - b).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn rotation_composes_and_inverts() {
        let rs = rotations();
        let (a, b) = (rs[10], rs[11]);
        let ab = ivanic(6, &(a * b));
        let c: Vec<f64> = (0..count(6)).map(|k| (k as f64 * 0.37).sin()).collect();
        let two = ivanic(6, &a).apply(&ivanic(6, &b).apply(&c));
        let one = ab.apply(&c);
        for (x, y) in one.iter().zip(&two) {
            assert!((x - y).abs() < 1e-12);
        }
        let back = transpose(&ivanic(6, &a)).apply(&ivanic(6, &a).apply(&c));
        for (x, y) in back.iter().zip(&c) {
            assert!((x - y).abs() < 1e-12);
        }
    }
}
