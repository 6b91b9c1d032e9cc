//! Scenes built in code for the rendering tests.
#![allow(dead_code)]

use envlight::math::camera::{Camera, Shape};
use envlight::scene::{FisSettings, Material, Scene, SceneObject, Technique};

#[allow(unused_imports)]
pub use envlight::math::camera::sphere_camera;

pub fn unit_sphere() -> Shape {
    Shape::Sphere {
        center: [0.0, 0.0, 0.0],
        radius: 1.0,
    }
}

pub fn object(
    shape: Shape,
    kind: envlight::math::brdf::Brdf,
    albedo: [f64; 3],
    technique: Technique,
) -> SceneObject {
    SceneObject {
        shape,
        material: Material {
            kind,
            albedo,
            technique: Some(technique),
        },
    }
}

pub fn scene(camera: Camera, objects: Vec<SceneObject>, shadows: bool, dp_size: u32) -> Scene {
    let mut sc = Scene::new(camera, objects);
    sc.shadows = shadows;
    sc.fis = FisSettings {
        size: Some(dp_size),
    };
    sc
}

pub fn fis(samples: u32) -> Technique {
    Technique::Fis {
        samples,
        bias: None,
        rotate: false,
    }
}

/// The pixels of `cam` that see the unit sphere away from its silhouette (where float32 and
/// float64 may disagree on the hit: margin < 1e-3), as (pixel index, normal, ray direction).
pub fn sphere_pixels(cam: &Camera) -> Vec<(usize, glam::DVec3, glam::DVec3)> {
    let mut v = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            if let Some(hit) = envlight::math::camera::trace(&[unit_sphere()], o, d) {
                if hit.margin >= 1e-3 {
                    v.push(((j * cam.width + i) as usize, hit.normal, d));
                }
            }
        }
    }
    v
}

/// Relative RMS of `a` against `b` over `pixels` ([`sphere_pixels`]), all channels.
pub fn rel_rms(
    a: &envlight::EnvMap,
    b: &envlight::EnvMap,
    pixels: &[(usize, glam::DVec3, glam::DVec3)],
) -> f64 {
    let (mut se, mut sw) = (0.0, 0.0);
    for &(k, _, _) in pixels {
        for ch in 0..3 {
            let (x, m) = (a.texels[k][ch] as f64, b.texels[k][ch] as f64);
            se += (x - m).powi(2);
            sw += m * m;
        }
    }
    (se / sw).sqrt()
}

/// `envlight render` of `scene` into `out` (validation on, lavapipe): the frame it wrote.
pub fn cli_render(scene: &std::path::Path, out: &std::path::Path) -> envlight::EnvMap {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["--validation", "--device", "cpu", "render"])
        .arg(scene)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    envlight::io::load(out, &Default::default()).unwrap()
}
