//! Light texels grouped into lights for reports (`envlight lights`, a bake's lights).

use super::Extraction;
use crate::math::envmap::luminance;
use crate::EnvMap;
use glam::DVec3;

/// A group of light texels reported as one light.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Light {
    /// Power-weighted mean direction (file frame, unit).
    pub direction: [f64; 3],
    /// Solid angle of its texels.
    pub solid_angle: f64,
    /// Its power ∑ L·Ω per channel (of the excess).
    pub power: [f64; 3],
    /// Its share of the map's luminance power.
    pub share: f64,
    /// Texels in it.
    pub texels: usize,
}

/// Light texels grouped into lights for reports: each texel, brightest first, joins the
/// first light whose direction is within `radius` radians, else starts one.
pub fn group(map: &EnvMap, ex: &Extraction, radius: f64) -> Vec<Light> {
    let total = luminance(map.stats().power);
    let mut lights: Vec<(DVec3, Light)> = Vec::new();
    for t in &ex.lights {
        let p = t.radiance.map(|c| c as f64 * t.omega);
        let y = luminance(p);
        let found = lights
            .iter_mut()
            .find(|(d, _)| d.normalize_or_zero().dot(t.dir) > radius.cos());
        let (d, l) = match found {
            Some(e) => (&mut e.0, &mut e.1),
            None => {
                lights.push((
                    DVec3::ZERO,
                    Light {
                        direction: [0.0; 3],
                        solid_angle: 0.0,
                        power: [0.0; 3],
                        share: 0.0,
                        texels: 0,
                    },
                ));
                let e = lights.last_mut().unwrap_or_else(|| unreachable!());
                (&mut e.0, &mut e.1)
            }
        };
        *d += t.dir * y.max(1e-300);
        l.solid_angle += t.omega;
        for (a, b) in l.power.iter_mut().zip(p) {
            *a += b;
        }
        l.share += if total > 0.0 { y / total } else { 0.0 };
        l.texels += 1;
    }
    lights
        .into_iter()
        .map(|(d, mut l)| {
            let d = d.normalize_or_zero();
            l.direction = [d.x, d.y, d.z];
            l
        })
        .collect()
}
