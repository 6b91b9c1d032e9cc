//! Scenes built in code for the rendering tests.
#![allow(dead_code)]

use envlight::math::camera::{Camera, Projection, Shape};
use envlight::scene::{
    Environment, FisSettings, Material, MaterialKind, McSettings, Scene, SceneObject, Technique,
};

/// An orthographic camera whose n × n image a unit sphere at the origin fills, so that the
/// view angle runs from normal incidence to grazing.
pub fn sphere_camera(n: u32) -> Camera {
    Camera {
        projection: Projection::Orthographic { height: 2.1 },
        eye: [0.0, 0.3, 5.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        width: n,
        height: n,
    }
}

pub fn unit_sphere() -> Shape {
    Shape::Sphere {
        center: [0.0, 0.0, 0.0],
        radius: 1.0,
    }
}

pub fn object(
    shape: Shape,
    kind: MaterialKind,
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
    Scene {
        environment: Environment {
            file: "(in memory)".into(),
            mapping: None,
            flip_u: false,
            flip_v: false,
            rotate_y: 0.0,
            intensity: 1.0,
        },
        camera,
        shadows,
        fis: FisSettings {
            size: Some(dp_size),
        },
        mc: McSettings::default(),
        objects,
    }
}

pub fn fis(samples: u32) -> Technique {
    Technique::Fis {
        samples,
        bias: None,
        rotate: false,
    }
}
