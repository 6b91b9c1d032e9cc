//! The four parameterisations of the sphere of directions, in float64.
//!
//! Conventions are those of docs/design.md §1: right-handed world, +Y up, a direction points from
//! the scene to the environment. Texture coordinates `(u, v)` are in [0, 1] with v growing
//! downwards in the image (row 0 is the top row); texel (i, j) has its centre at
//! `((i + ½)/W, (j + ½)/H)`.

use glam::{DMat3, DVec3};
use std::f64::consts::{PI, TAU};

use super::quadrature::integrate_smooth;

/// A parameterisation of the sphere of directions by one or more 2D images (layers).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Mapping {
    /// Equirectangular (Mitsuba 3's convention): one W×H layer.
    LatLong = 0,
    /// Debevec's angular light probe: one square layer; texels with r > 1 are outside.
    Angular = 1,
    /// Cube map: six square layers in Vulkan face order +X, −X, +Y, −Y, +Z, −Z.
    Cube = 2,
    /// Dual paraboloid: two square layers, upper half (y ≥ 0) first.
    DualParaboloid = 3,
}

/// A position in a map: a layer and texture coordinates in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coord {
    /// Layer index (cube face, paraboloid half, 0 otherwise).
    pub layer: u32,
    /// Horizontal texture coordinate, left to right.
    pub u: f64,
    /// Vertical texture coordinate, top to bottom.
    pub v: f64,
}

impl Mapping {
    /// All mappings, in id order.
    pub const ALL: [Mapping; 4] = [
        Mapping::LatLong,
        Mapping::Angular,
        Mapping::Cube,
        Mapping::DualParaboloid,
    ];

    /// The id shared with GLSL (`MAPPING_*` in the generated header).
    pub fn id(self) -> u32 {
        self as u32
    }

    /// The name used on the command line and in file metadata.
    pub fn name(self) -> &'static str {
        match self {
            Mapping::LatLong => "latlong",
            Mapping::Angular => "angular",
            Mapping::Cube => "cube",
            Mapping::DualParaboloid => "dual-paraboloid",
        }
    }

    /// Parses a mapping name (also accepts a few common aliases).
    pub fn parse(s: &str) -> Option<Mapping> {
        match s.to_ascii_lowercase().as_str() {
            "latlong" | "lat-long" | "equirect" | "equirectangular" => Some(Mapping::LatLong),
            "angular" | "probe" | "lightprobe" => Some(Mapping::Angular),
            "cube" | "cubemap" => Some(Mapping::Cube),
            "dual-paraboloid" | "dualparaboloid" | "dp" | "paraboloid" => {
                Some(Mapping::DualParaboloid)
            }
            _ => None,
        }
    }

    /// Number of layers: 6 for a cube, 2 for a dual paraboloid, 1 otherwise.
    pub fn layers(self) -> u32 {
        match self {
            Mapping::Cube => 6,
            Mapping::DualParaboloid => 2,
            _ => 1,
        }
    }

    /// Width and height of one layer for a `--size N`: lat-long is N × N/2, the others N × N
    /// (N is a cube's face size and each paraboloid half's size).
    pub fn extent_for_size(self, size: u32) -> (u32, u32) {
        match self {
            Mapping::LatLong => (size, (size / 2).max(1)),
            _ => (size, size),
        }
    }

    /// Texture coordinate of a unit direction. Accurate everywhere, poles and seams included.
    pub fn dir_to_coord(self, d: DVec3) -> Coord {
        match self {
            Mapping::LatLong => {
                let mut u = d.x.atan2(-d.z) / TAU;
                if u < 0.0 {
                    u += 1.0;
                }
                if u >= 1.0 {
                    u -= 1.0;
                }
                // atan2 rather than acos(d.y): acos loses half the digits at the poles.
                let v = d.x.hypot(d.z).atan2(d.y) / PI;
                Coord { layer: 0, u, v }
            }
            Mapping::Angular => {
                let rho = d.x.hypot(d.y);
                let r = rho.atan2(d.z) / PI;
                let (a, b) = if rho > 0.0 {
                    (r * d.x / rho, r * d.y / rho)
                } else if d.z >= 0.0 {
                    (0.0, 0.0)
                } else {
                    // −Z is the whole rim; any point of it decodes to −Z.
                    (0.0, -1.0)
                };
                Coord {
                    layer: 0,
                    u: 0.5 * (a + 1.0),
                    v: 0.5 * (1.0 - b),
                }
            }
            Mapping::Cube => {
                let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
                // Vulkan specification, cube map face selection table.
                let (layer, sc, tc, ma) = if ax >= ay && ax >= az {
                    if d.x >= 0.0 {
                        (0, -d.z, -d.y, ax)
                    } else {
                        (1, d.z, -d.y, ax)
                    }
                } else if ay >= az {
                    if d.y >= 0.0 {
                        (2, d.x, d.z, ay)
                    } else {
                        (3, d.x, -d.z, ay)
                    }
                } else if d.z >= 0.0 {
                    (4, d.x, -d.y, az)
                } else {
                    (5, -d.x, -d.y, az)
                };
                Coord {
                    layer,
                    u: 0.5 * (sc / ma + 1.0),
                    v: 0.5 * (tc / ma + 1.0),
                }
            }
            Mapping::DualParaboloid => {
                let (layer, k) = if d.y >= 0.0 {
                    (0, 1.0 / (1.0 + d.y))
                } else {
                    (1, 1.0 / (1.0 - d.y))
                };
                Coord {
                    layer,
                    u: 0.5 * (d.x * k + 1.0),
                    v: 0.5 * (d.z * k + 1.0),
                }
            }
        }
    }

    /// Unit direction of a texture coordinate. Outside the disc of an angular map or a
    /// paraboloid half the formulas are continued (they still give unit directions).
    pub fn coord_to_dir(self, c: Coord) -> DVec3 {
        match self {
            Mapping::LatLong => {
                let (sp, cp) = (TAU * c.u).sin_cos();
                let (st, ct) = (PI * c.v).sin_cos();
                DVec3::new(st * sp, ct, -st * cp)
            }
            Mapping::Angular => {
                let (a, b) = (2.0 * c.u - 1.0, 1.0 - 2.0 * c.v);
                let r = a.hypot(b);
                if r == 0.0 {
                    return DVec3::Z;
                }
                let (s, co) = (PI * r).sin_cos();
                DVec3::new(s * a / r, s * b / r, co)
            }
            Mapping::Cube => {
                let (sc, tc) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
                let d = match c.layer {
                    0 => DVec3::new(1.0, -tc, -sc),
                    1 => DVec3::new(-1.0, -tc, sc),
                    2 => DVec3::new(sc, 1.0, tc),
                    3 => DVec3::new(sc, -1.0, -tc),
                    4 => DVec3::new(sc, -tc, 1.0),
                    _ => DVec3::new(-sc, -tc, -1.0),
                };
                d.normalize()
            }
            Mapping::DualParaboloid => {
                let (s, t) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
                let rho2 = s * s + t * t;
                let k = 1.0 / (1.0 + rho2);
                let y = (1.0 - rho2) * k;
                let y = if c.layer == 0 { y } else { -y };
                DVec3::new(2.0 * s * k, y, 2.0 * t * k)
            }
        }
    }

    /// Centre of texel (i, j) of a layer of size `w × h`.
    pub fn texel_center(w: u32, h: u32, layer: u32, i: u32, j: u32) -> Coord {
        Coord {
            layer,
            u: (i as f64 + 0.5) / w as f64,
            v: (j as f64 + 0.5) / h as f64,
        }
    }

    /// Whether a texel is read at all. Angular texels whose centre lies outside the unit disc
    /// are not (Debevec's files print a caption there). Paraboloid texels are read when they
    /// overlap the disc: conversion writes the mean over the part inside into them.
    pub fn texel_in_domain(self, w: u32, h: u32, i: u32, j: u32) -> bool {
        match self {
            Mapping::Angular => {
                let a = 2.0 * (i as f64 + 0.5) / w as f64 - 1.0;
                let b = 2.0 * (j as f64 + 0.5) / h as f64 - 1.0;
                a * a + b * b <= 1.0
            }
            Mapping::DualParaboloid => {
                // Nearest point of the texel's rectangle to the disc's centre, in units of
                // half a texel: integers, so that the GPU (glsl/include/mappings.glsl) decides
                // the same where the rim passes through a corner (0.8² + 0.6² at n = 40).
                let near = |k: u32, n: u32| {
                    0i64.clamp(2 * k as i64 - n as i64, 2 * k as i64 + 2 - n as i64)
                };
                let (a, b, w, h) = (near(i, w), near(j, h), w as i64, h as i64);
                a * a * h * h + b * b * w * w < w * w * h * h
            }
            _ => true,
        }
    }

    /// Which texel's value stands for texel (i, j) in integrals over the sphere (power, SH
    /// projection): the texel itself when it is read; for an angular texel centred outside the
    /// disc but overlapping it, the texel just inside the rim on the same radius, so that the
    /// slivers of the disc such texels hold are counted without reading outside the probe;
    /// `None` for texels wholly outside.
    pub fn integration_source(self, w: u32, h: u32, i: u32, j: u32) -> Option<(u32, u32)> {
        if self.texel_in_domain(w, h, i, j) {
            return Some((i, j));
        }
        if self != Mapping::Angular || self.texel_solid_angle(w, h, i, j) <= 0.0 {
            return None;
        }
        let a = 2.0 * (i as f64 + 0.5) / w as f64 - 1.0;
        let b = 2.0 * (j as f64 + 0.5) / h as f64 - 1.0;
        let r = a.hypot(b);
        for step in 1..4 {
            let k = (1.0 - step as f64 / w.min(h) as f64) / r;
            let (ii, jj) = (
                (((a * k + 1.0) * 0.5 * w as f64).floor() as u32).min(w - 1),
                (((b * k + 1.0) * 0.5 * h as f64).floor() as u32).min(h - 1),
            );
            if self.texel_in_domain(w, h, ii, jj) {
                return Some((ii, jj));
            }
        }
        None
    }

    /// Solid angle per unit area of texture coordinates, dω / (du dv), at `c`; zero outside the
    /// disc of an angular map or paraboloid half.
    pub fn density(self, c: Coord) -> f64 {
        let (a, b) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
        match self {
            Mapping::LatLong => 2.0 * PI * PI * (PI * c.v).sin(),
            Mapping::Angular => {
                let r = a.hypot(b);
                if r > 1.0 {
                    0.0
                } else if r == 0.0 {
                    4.0 * PI * PI
                } else {
                    4.0 * PI * (PI * r).sin() / r
                }
            }
            Mapping::Cube => 4.0 / (1.0 + a * a + b * b).powf(1.5),
            Mapping::DualParaboloid => {
                let rho2 = a * a + b * b;
                if rho2 > 1.0 {
                    0.0
                } else {
                    16.0 / ((1.0 + rho2) * (1.0 + rho2))
                }
            }
        }
    }

    /// Weight of a point of a texel's footprint in the mean a texel holds: |dω/(du dv)| of
    /// the angular mapping continued past its rim (the rim is the single direction −Z, so the
    /// continuation covers its neighbours), and [`Mapping::density`] otherwise, so that each
    /// paraboloid half's rim texels hold the mean over their part of the hemisphere and
    /// ∑ L·Ω over both halves is the power.
    pub fn footprint_weight(self, c: Coord) -> f64 {
        if self == Mapping::Angular {
            let r = (2.0 * c.u - 1.0).hypot(2.0 * c.v - 1.0);
            if r == 0.0 {
                4.0 * PI * PI
            } else {
                (4.0 * PI * (PI * r).sin() / r).abs()
            }
        } else {
            self.density(c)
        }
    }

    /// [`Mapping::texel_solid_angle`] of every texel of a `w × h` layer, row by row. The disc
    /// mappings' texels are found in one quarter and mirrored (their density depends on the
    /// radius alone, and texel w − 1 − i spans texel i's interval negated): a quarter of the
    /// integrals, which a 1k angular map's host passes spend most of their time on.
    pub fn texel_solid_angles(self, w: u32, h: u32) -> Vec<f64> {
        let mut out = vec![0.0; (w as usize) * (h as usize)];
        let (edge, h_at_1): (&dyn Fn(f64, f64, f64) -> f64, f64) = match self {
            Mapping::Angular => (&angular_edge, 2.0),
            Mapping::DualParaboloid => (&paraboloid_edge, 1.0),
            _ => {
                for j in 0..h {
                    for i in 0..w {
                        out[(j * w + i) as usize] = self.texel_solid_angle(w, h, i, j);
                    }
                }
                return out;
            }
        };
        // The quarter's texel edges, each found once and shared by the two texels it bounds
        // (the same sums as texel_solid_angle's, to the bit).
        let (qw, qh) = (w.div_ceil(2) as usize, h.div_ceil(2) as usize);
        let xs: Vec<f64> = (0..=qw).map(|i| 2.0 * i as f64 / w as f64 - 1.0).collect();
        let ys: Vec<f64> = (0..=qh).map(|j| 2.0 * j as f64 / h as f64 - 1.0).collect();
        let vertical: Vec<f64> = (0..qh)
            .flat_map(|j| (0..=qw).map(move |i| (i, j)))
            .map(|(i, j)| clipped_flux(edge, xs[i], ys[j], ys[j + 1]))
            .collect();
        let horizontal: Vec<f64> = (0..=qh)
            .flat_map(|j| (0..qw).map(move |i| (i, j)))
            .map(|(i, j)| clipped_flux(edge, ys[j], xs[i], xs[i + 1]))
            .collect();
        for j in 0..qh {
            for i in 0..qw {
                let v = |i: usize| vertical[j * (qw + 1) + i];
                let hz = |j: usize| horizontal[j * qw + i];
                let edges = v(i + 1) - v(i) + hz(j + 1) - hz(j);
                let o = edges + h_at_1 * arc_inside_rect(xs[i], xs[i + 1], ys[j], ys[j + 1]);
                let (i, j) = (i as u32, j as u32);
                for (ii, jj) in [
                    (i, j),
                    (w - 1 - i, j),
                    (i, h - 1 - j),
                    (w - 1 - i, h - 1 - j),
                ] {
                    out[(jj * w + ii) as usize] = o;
                }
            }
        }
        out
    }

    /// Exact solid angle of texel (i, j) of a `w × h` layer (the same for every layer).
    ///
    /// Lat-long and cube texels have closed forms; for angular and paraboloid texels the part
    /// inside the unit disc is integrated with the divergence theorem, which is exact for the
    /// paraboloid and leaves a smooth 1D integral (Gauss–Legendre,
    /// `math::quadrature::integrate_smooth`) for the angular map.
    pub fn texel_solid_angle(self, w: u32, h: u32, i: u32, j: u32) -> f64 {
        let (wf, hf) = (w as f64, h as f64);
        match self {
            Mapping::LatLong => {
                let (t0, t1) = (PI * j as f64 / hf, PI * (j + 1) as f64 / hf);
                // (2π/W)(cos θ0 − cos θ1) without cancellation.
                (TAU / wf) * 2.0 * (0.5 * (t0 + t1)).sin() * (0.5 * (t1 - t0)).sin()
            }
            Mapping::Cube => {
                let s0 = 2.0 * i as f64 / wf - 1.0;
                let s1 = 2.0 * (i + 1) as f64 / wf - 1.0;
                let t0 = 2.0 * j as f64 / hf - 1.0;
                let t1 = 2.0 * (j + 1) as f64 / hf - 1.0;
                let f = |x: f64, y: f64| (x * y).atan2((x * x + y * y + 1.0).sqrt());
                f(s1, t1) - f(s0, t1) - f(s1, t0) + f(s0, t0)
            }
            Mapping::Angular | Mapping::DualParaboloid => {
                let x0 = 2.0 * i as f64 / wf - 1.0;
                let x1 = 2.0 * (i + 1) as f64 / wf - 1.0;
                let y0 = 2.0 * j as f64 / hf - 1.0;
                let y1 = 2.0 * (j + 1) as f64 / hf - 1.0;
                if self == Mapping::Angular {
                    disc_rect_flux(x0, x1, y0, y1, 2.0, &angular_edge)
                } else {
                    disc_rect_flux(x0, x1, y0, y1, 1.0, &paraboloid_edge)
                }
            }
        }
    }
}

/// Solid angle of the square [x0, x1] × [y0, y1] of a paraboloid half's (s, t) plane under
/// its density 4/(1+s²+t²)² continued past the rim (the divergence theorem on its four
/// edges, unclipped): what the square would cover if the disc did not end.
pub fn paraboloid_square_solid_angle(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    paraboloid_edge(x1, y0, y1) - paraboloid_edge(x0, y0, y1) + paraboloid_edge(y1, x0, x1)
        - paraboloid_edge(y0, x0, x1)
}

/// Flux of V = h(r)·(x, y) through the segment x = c, y ∈ [a, b] for the paraboloid, whose
/// dω/(ds dt) = 4/(1+r²)² = div V with h(r) = 2/(1+r²).
fn paraboloid_edge(c: f64, a: f64, b: f64) -> f64 {
    let k = (1.0 + c * c).sqrt();
    // atan(b/k) − atan(a/k) in one atan to avoid cancellation on short segments.
    2.0 * c / k * ((b - a) * k).atan2(k * k + a * b)
}

/// Same for the angular map: dω/(da db) = π sin(πr)/r = div V with h(r) = 2 sin²(πr/2)/r².
fn angular_edge(c: f64, a: f64, b: f64) -> f64 {
    integrate_smooth(a, b, |y| {
        let r2 = c * c + y * y;
        if r2 == 0.0 {
            return 0.0;
        }
        let s = (0.5 * PI * r2.sqrt()).sin();
        c * 2.0 * s * s / r2
    })
}

/// ∫∫ div(h(r)(x, y)) over the rectangle [x0,x1]×[y0,y1] cut by the unit disc, by the divergence
/// theorem: the flux through the rectangle's edges inside the disc plus h(1) times the length
/// of the unit circle's arcs inside the rectangle.
fn disc_rect_flux(
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    h_at_1: f64,
    edge: &dyn Fn(f64, f64, f64) -> f64,
) -> f64 {
    let clipped = |c: f64, a: f64, b: f64| clipped_flux(edge, c, a, b);
    let edges =
        clipped(x1, y0, y1) - clipped(x0, y0, y1) + clipped(y1, x0, x1) - clipped(y0, x0, x1);
    edges + h_at_1 * arc_inside_rect(x0, x1, y0, y1)
}

/// `edge`'s flux through the part of the segment x = c, y ∈ [a, b] inside the unit disc.
fn clipped_flux(edge: &dyn Fn(f64, f64, f64) -> f64, c: f64, a: f64, b: f64) -> f64 {
    if c.abs() >= 1.0 {
        return 0.0;
    }
    let m = (1.0 - c * c).sqrt();
    let (lo, hi) = (a.max(-m), b.min(m));
    if hi > lo {
        edge(c, lo, hi)
    } else {
        0.0
    }
}

/// Total angle of the unit circle's arcs inside [x0,x1]×[y0,y1].
fn arc_inside_rect(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let inside = |x: f64, y: f64| x >= x0 && x <= x1 && y >= y0 && y <= y1;
    // At most two crossings per side: a fixed array, no allocation per texel.
    let mut angles = [0.0f64; 8];
    let mut count = 0;
    let mut push = |a: f64| {
        angles[count] = a;
        count += 1;
    };
    for c in [x0, x1] {
        if c.abs() < 1.0 {
            let m = (1.0 - c * c).sqrt();
            for y in [m, -m] {
                if y >= y0 && y <= y1 {
                    push(y.atan2(c).rem_euclid(TAU));
                }
            }
        }
    }
    for c in [y0, y1] {
        if c.abs() < 1.0 {
            let m = (1.0 - c * c).sqrt();
            for x in [m, -m] {
                if x >= x0 && x <= x1 {
                    push(c.atan2(x).rem_euclid(TAU));
                }
            }
        }
    }
    if count == 0 {
        return if inside(1.0, 0.0) { TAU } else { 0.0 };
    }
    let angles = &mut angles[..count];
    angles.sort_by(f64::total_cmp);
    let n = count;
    let mut total = 0.0;
    for k in 0..n {
        let a = angles[k];
        let b = if k + 1 < n {
            angles[k + 1]
        } else {
            angles[0] + TAU
        };
        if b - a <= 0.0 {
            continue;
        }
        let (s, c) = (0.5 * (a + b)).sin_cos();
        if inside(c, s) {
            total += b - a;
        }
    }
    total
}

/// How a map's file is oriented relative to the world frame: applied to directions, so it is
/// exact for every mapping (no resampling).
///
/// `flip_u` mirrors the image left–right (x → −x for lat-long and angular maps), `flip_v` turns
/// it upside down (y → −y), and `rotate_y_degrees` turns the environment counter-clockwise about
/// +Y as seen from above. The light stored at file direction f appears in the world at
/// `R_y(θ) · S · f`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Orientation {
    /// Mirror left–right (reflect x).
    pub flip_u: bool,
    /// Turn upside down (reflect y).
    pub flip_v: bool,
    /// Rotation about +Y in degrees.
    pub rotate_y_degrees: f64,
}

impl Orientation {
    /// The matrix taking a world direction to the direction at which the file stores it.
    pub fn world_to_file(&self) -> DMat3 {
        let s = DMat3::from_diagonal(DVec3::new(
            if self.flip_u { -1.0 } else { 1.0 },
            if self.flip_v { -1.0 } else { 1.0 },
            1.0,
        ));
        s * DMat3::from_rotation_y(-self.rotate_y_degrees.to_radians())
    }

    /// Checks that the rotation is a finite number of degrees (a NaN or infinite angle would
    /// turn every direction into NaN).
    pub fn validate(&self) -> Result<(), String> {
        if self.rotate_y_degrees.is_finite() {
            Ok(())
        } else {
            Err(format!(
                "rotation about +Y must be a finite number of degrees (got {})",
                self.rotate_y_degrees
            ))
        }
    }

    /// [`Orientation::world_to_file`] after [`Orientation::validate`].
    pub fn checked_world_to_file(&self) -> crate::error::Result<DMat3> {
        self.validate().map_err(crate::error::Error::Invalid)?;
        Ok(self.world_to_file())
    }

    /// Whether this is the identity.
    pub fn is_identity(&self) -> bool {
        !self.flip_u && !self.flip_v && self.rotate_y_degrees == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn angle(a: DVec3, b: DVec3) -> f64 {
        // Accurate for tiny angles, unlike acos of the dot product.
        a.cross(b).length().atan2(a.dot(b))
    }

    #[test]
    fn round_trip_f64_under_1e12() {
        let dirs = super::super::synth::stress_directions();
        assert!(dirs.len() > 100_000);
        for m in Mapping::ALL {
            let mut worst = 0.0f64;
            for &d in &dirs {
                let c = m.dir_to_coord(d);
                assert!(
                    (0.0..=1.0).contains(&c.u) && (0.0..=1.0).contains(&c.v),
                    "{m:?} {d}"
                );
                assert!(c.layer < m.layers());
                let e = angle(d, m.coord_to_dir(c));
                worst = worst.max(e);
            }
            assert!(worst < 1e-12, "{m:?}: worst round-trip error {worst:e} rad");
        }
    }

    #[test]
    fn axes_land_where_design_md_says() {
        let ll = Mapping::LatLong;
        let c = ll.dir_to_coord(DVec3::Z);
        assert!((c.u - 0.5).abs() < 1e-15 && (c.v - 0.5).abs() < 1e-15);
        assert!((ll.dir_to_coord(DVec3::X).u - 0.25).abs() < 1e-15);
        assert!(ll.dir_to_coord(DVec3::Y).v.abs() < 1e-15);
        // θ = π/2 lies halfway to the rim: +X at the right, +Y above the centre.
        let a = Mapping::Angular.dir_to_coord(DVec3::X);
        assert!((a.u - 0.75).abs() < 1e-15 && (a.v - 0.5).abs() < 1e-15);
        let a = Mapping::Angular.dir_to_coord(DVec3::Y);
        assert!((a.v - 0.25).abs() < 1e-15);
        assert!((Mapping::Angular.dir_to_coord(DVec3::NEG_Z).v - 1.0).abs() < 1e-15);
        assert_eq!(Mapping::Cube.dir_to_coord(DVec3::NEG_Y).layer, 3);
        assert_eq!(Mapping::DualParaboloid.dir_to_coord(DVec3::NEG_Y).layer, 1);
    }

    #[test]
    fn paraboloid_seam_matches_texel_for_texel() {
        for k in 0..360 {
            let t = k as f64 / 360.0 * TAU;
            let d = DVec3::new(t.cos(), 0.0, t.sin());
            let up = Mapping::DualParaboloid.dir_to_coord(d);
            let down = Mapping::DualParaboloid.dir_to_coord(DVec3::new(d.x, -0.0, d.z) * 1.0);
            assert_eq!((up.u, up.v), (down.u, down.v));
            let lower = Mapping::DualParaboloid.coord_to_dir(Coord { layer: 1, ..up });
            assert!(angle(lower, d) < 1e-15);
        }
    }

    fn solid_angle_sum(m: Mapping, w: u32, h: u32) -> f64 {
        let mut s = 0.0;
        for j in 0..h {
            for i in 0..w {
                s += m.texel_solid_angle(w, h, i, j);
            }
        }
        s * m.layers() as f64
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        let fourpi = 4.0 * PI;
        for (m, tol) in [
            (Mapping::LatLong, 1e-9),
            (Mapping::Cube, 1e-9),
            (Mapping::Angular, 1e-6),
            (Mapping::DualParaboloid, 1e-6),
        ] {
            for (w, h) in [(1, 1), (2, 2), (3, 3), (7, 7), (64, 64), (257, 257)] {
                let (w, h) = if m == Mapping::LatLong {
                    (w * 2, h)
                } else {
                    (w, h)
                };
                let s = solid_angle_sum(m, w, h);
                let rel = (s / fourpi - 1.0).abs();
                assert!(rel < tol, "{m:?} {w}x{h}: sum {s} rel err {rel:e}");
            }
        }
    }

    /// The mirrored table is each texel's own solid angle, at even and odd sides, to the
    /// rounding of the divergence-theorem sum: a rim sliver's angle is edge fluxes and arcs of
    /// a whole texel's size less each other, so either orientation rounds it to about 1e-13
    /// of a mean texel's angle (5e-9 of the sliver's own).
    #[test]
    fn the_solid_angle_table_is_every_texels_own() {
        for m in Mapping::ALL {
            for size in [1, 2, 7, 16, 33] {
                let (w, h) = m.extent_for_size(size);
                let table = m.texel_solid_angles(w, h);
                let mean = 4.0 * PI / (m.layers() * w * h) as f64;
                for j in 0..h {
                    for i in 0..w {
                        let own = m.texel_solid_angle(w, h, i, j);
                        let got = table[(j * w + i) as usize];
                        assert!(
                            (got - own).abs() <= 1e-12 * mean,
                            "{m:?} {w}x{h} ({i},{j}): {got} vs {own}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn solid_angles_match_density_quadrature() {
        // Independent check of single texels: 64×64 midpoint quadrature of dω/(du dv).
        for m in Mapping::ALL {
            let (w, h) = m.extent_for_size(9);
            for (i, j) in [(0, 0), (4, 2), (1, 3), (8, 0), (4, 4), (2, 7)] {
                let (i, j) = (i.min(w - 1), j.min(h - 1));
                let n = 256;
                let mut q = 0.0;
                for a in 0..n {
                    for b in 0..n {
                        let c = Coord {
                            layer: 0,
                            u: (i as f64 + (a as f64 + 0.5) / n as f64) / w as f64,
                            v: (j as f64 + (b as f64 + 0.5) / n as f64) / h as f64,
                        };
                        q += m.density(c);
                    }
                }
                q /= (n * n) as f64 * (w * h) as f64;
                let exact = m.texel_solid_angle(w, h, i, j);
                assert!(
                    (q - exact).abs() <= 2e-4 * exact.max(1e-3),
                    "{m:?} texel ({i},{j}): exact {exact} quadrature {q}"
                );
            }
        }
    }

    #[test]
    fn orientation_flips_match_grace_latlong_convention() {
        // SOURCES.md: grace_latlong.exr stores at (θ, φ) the direction
        // (−sinθ sinφ, −cosθ, −sinθ cosφ); ours is (sinθ sinφ, cosθ, −sinθ cosφ).
        let o = Orientation {
            flip_u: true,
            flip_v: true,
            rotate_y_degrees: 0.0,
        };
        let m = o.world_to_file();
        for d in super::super::synth::fibonacci_sphere(100) {
            let f = m * d;
            assert!((f - DVec3::new(-d.x, -d.y, d.z)).length() < 1e-15);
        }
        // uffizi.hdr (SOURCES.md) stores at (θ, φ = 2πu) the direction
        // (sinθ cosφ, cosθ, −sinθ sinφ): docs/formats.md's --flip-u --rotate-y -90 maps onto it.
        let uffizi = Orientation {
            flip_u: true,
            flip_v: false,
            rotate_y_degrees: -90.0,
        };
        for k in 0..50 {
            let c = Coord {
                layer: 0,
                u: (k as f64 + 0.5) / 50.0,
                v: 0.3 + 0.01 * k as f64,
            };
            let world = Mapping::LatLong.coord_to_dir(c);
            let (phi, theta) = (TAU * c.u, PI * c.v);
            let file = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            assert!((uffizi.world_to_file() * world - file).length() < 1e-12);
        }
        let r = Orientation {
            rotate_y_degrees: 90.0,
            ..Default::default()
        };
        // Turning the environment by +90° about +Y brings the file's +X light to world −Z.
        let w = r.world_to_file().inverse() * DVec3::X;
        assert!((w - DVec3::NEG_Z).length() < 1e-15, "{w}");
    }
}
