//! Cameras and analytic scene geometry (spheres and planes) in float64: the oracle of the
//! G-buffer pass (`glsl/gbuffer.frag`), which casts the same rays in float32.
//!
//! Pixel (i, j) of a W×H image, row 0 at the top, is the ray through its centre: with
//! x = 2(i+½)/W − 1 and y = 1 − 2(j+½)/H, a perspective camera of vertical field of view φ
//! shoots from the eye towards forward + x·tan(φ/2)·(W/H)·right + y·tan(φ/2)·up; an
//! orthographic camera of height h shoots along forward from eye + x·(h/2)(W/H)·right +
//! y·(h/2)·up. right = forward × up (normalised), up re-orthogonalised.

use glam::DVec3;

/// How a camera projects.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Projection {
    /// Perspective with a vertical field of view in degrees.
    Perspective {
        /// Vertical field of view, degrees.
        fov_y: f64,
    },
    /// Orthographic with an explicit height of the view volume (world units).
    Orthographic {
        /// Height of the view, world units; the width follows the aspect ratio.
        height: f64,
    },
}

/// A camera and the size of the image it makes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// Projection.
    pub projection: Projection,
    /// Eye position.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up hint.
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// The camera's orthonormal frame.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Unit forward.
    pub forward: DVec3,
    /// Unit right.
    pub right: DVec3,
    /// Unit up.
    pub up: DVec3,
}

/// Smallest sine of the angle between the view and the up hint (below it the frame's right
/// vector is lost to rounding).
pub const MIN_UP_SINE: f64 = 1e-6;

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

impl Camera {
    /// Checks everything [`Camera::frame`] and [`Camera::ray`] need: finite positions, an
    /// eye apart from its target, an up hint not along the view, a field of view in (0°, 180°)
    /// or a positive orthographic height, and an image of 1 to 16384 pixels a side.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 || self.width > 16384 || self.height > 16384 {
            return Err(format!(
                "camera resolution {} x {} is outside 1 to 16384",
                self.width, self.height
            ));
        }
        for (name, v) in [("eye", self.eye), ("target", self.target), ("up", self.up)] {
            if !finite3(v) {
                return Err(format!("camera {name} {v:?} is not finite"));
            }
        }
        let (eye, target) = (DVec3::from(self.eye), DVec3::from(self.target));
        let view = target - eye;
        let scale = eye.length().max(target.length()).max(1.0);
        if view.length() <= 1e-9 * scale {
            return Err(format!(
                "camera eye {:?} and target {:?} coincide: there is no view direction",
                self.eye, self.target
            ));
        }
        let up = DVec3::from(self.up);
        if up.length() == 0.0 || view.normalize().cross(up.normalize()).length() < MIN_UP_SINE {
            return Err(format!(
                "camera up {:?} is zero or along the view direction {:?}; give an up vector \
                 across the view",
                self.up,
                view.normalize().to_array()
            ));
        }
        match self.projection {
            Projection::Perspective { fov_y } if !(fov_y > 0.0 && fov_y < 180.0) => Err(format!(
                "perspective fov_y = {fov_y} must be between 0 and 180 degrees (exclusive)"
            )),
            Projection::Orthographic { height } if !(height > 0.0 && height.is_finite()) => Err(
                format!("orthographic height = {height} must be positive and finite"),
            ),
            _ => Ok(()),
        }
    }

    /// The camera's frame.
    pub fn frame(&self) -> Frame {
        let forward = (DVec3::from(self.target) - DVec3::from(self.eye)).normalize();
        let right = forward.cross(DVec3::from(self.up)).normalize();
        Frame {
            forward,
            right,
            up: right.cross(forward),
        }
    }

    /// Half extents of the image plane: at distance 1 for perspective, in world units for
    /// orthographic.
    pub fn half_extent(&self) -> (f64, f64) {
        let aspect = self.width as f64 / self.height as f64;
        let hy = match self.projection {
            Projection::Perspective { fov_y } => (0.5 * fov_y.to_radians()).tan(),
            Projection::Orthographic { height } => 0.5 * height,
        };
        (hy * aspect, hy)
    }

    /// The ray through the centre of pixel (i, j): origin and unit direction.
    pub fn ray(&self, i: u32, j: u32) -> (DVec3, DVec3) {
        self.ray_at(i as f64 + 0.5, j as f64 + 0.5)
    }

    /// The ray through image point (x, y) in pixels from the top-left corner (supersampling).
    pub fn ray_at(&self, px: f64, py: f64) -> (DVec3, DVec3) {
        let f = self.frame();
        let (hx, hy) = self.half_extent();
        let x = 2.0 * px / self.width as f64 - 1.0;
        let y = 1.0 - 2.0 * py / self.height as f64;
        let eye = DVec3::from(self.eye);
        match self.projection {
            Projection::Perspective { .. } => (
                eye,
                (f.forward + x * hx * f.right + y * hy * f.up).normalize(),
            ),
            Projection::Orthographic { .. } => (eye + x * hx * f.right + y * hy * f.up, f.forward),
        }
    }
}

/// A shape of the scene.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "shape", rename_all = "lowercase", deny_unknown_fields)]
pub enum Shape {
    /// A sphere.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
    },
    /// A plane n·x = offset, seen from the side n points to, cut to a disc of `extent` around
    /// the point of the plane nearest the origin (0: unbounded).
    Plane {
        /// Unit normal.
        normal: [f64; 3],
        /// Offset along the normal.
        offset: f64,
        /// Radius of the disc the plane is cut to, 0 for none.
        #[serde(default)]
        extent: f64,
    },
}

impl Shape {
    /// Checks that the shape is well defined: finite numbers, a positive sphere radius, a
    /// non-zero plane normal and a non-negative extent.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Shape::Sphere { center, radius } => {
                if !finite3(center) {
                    return Err(format!("sphere center {center:?} is not finite"));
                }
                if !(radius > 0.0 && radius.is_finite()) {
                    return Err(format!(
                        "sphere radius {radius} must be positive and finite"
                    ));
                }
            }
            Shape::Plane {
                normal,
                offset,
                extent,
            } => {
                if !finite3(normal) || DVec3::from(normal).length() < 1e-12 {
                    return Err(format!(
                        "plane normal {normal:?} must be finite and non-zero"
                    ));
                }
                if !offset.is_finite() {
                    return Err(format!("plane offset {offset} is not finite"));
                }
                if !(extent >= 0.0 && extent.is_finite()) {
                    return Err(format!("plane extent {extent} must be finite and ≥ 0"));
                }
            }
        }
        Ok(())
    }
}

/// Where a ray meets the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f64,
    /// Unit normal facing the ray's origin side.
    pub normal: DVec3,
    /// Index of the shape.
    pub index: usize,
    /// How far the hit is from changing (a silhouette or an edge): for a sphere
    /// 1 − |distance of the ray to the centre|²/r², for a plane the cosine of incidence, for
    /// the nearer of two shapes the relative gap to the next. Tests skip pixels whose margin
    /// float32 cannot resolve.
    pub margin: f64,
}

impl Shape {
    /// The nearest intersection in front of `o` along unit `d`, with its normal and margin.
    pub fn intersect(&self, o: DVec3, d: DVec3) -> Option<(f64, DVec3, f64)> {
        match *self {
            Shape::Sphere { center, radius } => {
                let c = DVec3::from(center);
                let oc = o - c;
                let b = oc.dot(d);
                // Distance² of the line to the centre, without the cancellation of b² − c.
                let h = oc - b * d;
                let disc = radius * radius - h.length_squared();
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                let t = if -b - s > 0.0 { -b - s } else { -b + s };
                if t <= 0.0 {
                    return None;
                }
                let n = (o + t * d - c) / radius;
                Some((t, n, disc / (radius * radius)))
            }
            Shape::Plane {
                normal,
                offset,
                extent,
            } => {
                let n = DVec3::from(normal).normalize();
                let dn = d.dot(n);
                if dn >= 0.0 {
                    return None;
                }
                let t = (offset - o.dot(n)) / dn;
                if t <= 0.0 {
                    return None;
                }
                if extent > 0.0 {
                    let p = o + t * d - offset * n;
                    let r2 = p.length_squared() / (extent * extent);
                    if r2 > 1.0 {
                        return None;
                    }
                    return Some((t, n, (-dn).min(1.0 - r2)));
                }
                Some((t, n, -dn))
            }
        }
    }
}

/// The nearest hit of a ray among `shapes`.
pub fn trace(shapes: &[Shape], o: DVec3, d: DVec3) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut second = f64::INFINITY;
    for (index, s) in shapes.iter().enumerate() {
        if let Some((t, normal, margin)) = s.intersect(o, d) {
            match best {
                Some(b) if b.t <= t => second = second.min(t),
                _ => {
                    if let Some(b) = best {
                        second = second.min(b.t);
                    }
                    best = Some(Hit {
                        t,
                        normal,
                        index,
                        margin,
                    });
                }
            }
        }
    }
    best.map(|mut b| {
        if second.is_finite() {
            b.margin = b.margin.min((second - b.t) / second);
        }
        b
    })
}

/// An orthographic camera whose `size`² image a unit sphere at the origin fills, so that the
/// view angle runs from normal incidence to grazing.
pub fn sphere_camera(size: u32) -> Camera {
    Camera {
        projection: Projection::Orthographic { height: 2.1 },
        eye: [0.0, 0.3, 5.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        width: size,
        height: size,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_the_target_and_hits_the_sphere_front() {
        let cam = Camera {
            projection: Projection::Perspective { fov_y: 40.0 },
            eye: [0.0, 0.0, 5.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            width: 3,
            height: 3,
        };
        let (o, d) = cam.ray(1, 1);
        assert!((d - DVec3::NEG_Z).length() < 1e-15);
        let s = [Shape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        }];
        let h = trace(&s, o, d).unwrap();
        assert!((h.t - 4.0).abs() < 1e-12 && (h.normal - DVec3::Z).length() < 1e-12);
        // Row 0 is the top: its ray points up.
        assert!(cam.ray(1, 0).1.y > 0.0 && cam.ray(2, 1).1.x > 0.0);
        let ortho = Camera {
            projection: Projection::Orthographic { height: 2.0 },
            ..cam
        };
        let (o, d) = ortho.ray(0, 1);
        assert!((d - DVec3::NEG_Z).length() < 1e-15 && (o.x + 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn planes_are_seen_from_the_normal_side_only() {
        let p = Shape::Plane {
            normal: [0.0, 1.0, 0.0],
            offset: -1.0,
            extent: 0.0,
        };
        assert!(p.intersect(DVec3::ZERO, DVec3::NEG_Y).is_some());
        assert!(p.intersect(DVec3::new(0.0, -2.0, 0.0), DVec3::Y).is_none());
    }
}
