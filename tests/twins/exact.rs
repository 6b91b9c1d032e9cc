//! The exact reference pass against its float64 twin (`ExactFilter::shade`).
//! `tests/exact.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::Errors;
use envlight::gpu::Context;
use envlight::math::brdf::{Brdf, Frame};
use envlight::math::exact::ExactFilter;
use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::passes::{ExactShader, GpuEnvMap};
use envlight::EnvMap;
use glam::{DMat3, DVec3};

/// The relative bound [`check`] holds each query to.
pub const BOUND: f64 = 1e-4;

/// The BRDFs the check takes: diffuse, Phong 64, GGX sharp to rough, anisotropic Ward.
pub fn brdfs() -> Vec<Brdf> {
    let ggx = |alpha| Brdf::Ggx {
        alpha,
        correlated: true,
    };
    vec![
        Brdf::Lambert,
        Brdf::Phong { n: 64.0 },
        ggx(0.05),
        ggx(0.3),
        ggx(0.6),
        Brdf::Ward { ax: 0.1, ay: 0.4 },
    ]
}

/// Queries (normal, towards the eye): normals all round the sphere, each seen head-on, at
/// n·v = 0.5 and grazing (0.05), one facing the sun with its reflection on it.
pub fn queries(sun: DVec3) -> Vec<(DVec3, DVec3)> {
    let mut q = Vec::new();
    for (k, n) in envlight::math::synth::fibonacci_sphere(6)
        .into_iter()
        .enumerate()
    {
        let frame = Frame::new(n);
        for (mu, phi) in [(1.0, 0.0), (0.5, 1.0 + k as f64), (0.05, 2.5 + k as f64)] {
            let s = (1.0f64 - mu * mu).sqrt();
            q.push((
                n,
                frame.to_world(DVec3::new(s * phi.cos(), s * phi.sin(), mu)),
            ));
        }
    }
    // The sun's mirror reflection: n halfway between the sun and the eye.
    let v = DVec3::new(0.3, 0.2, 0.93).normalize();
    q.push(((sun + v).normalize(), v));
    q
}

/// The GPU's sums against the twin's at [`queries`] for each of [`brdfs`], on a sun sky
/// (the sun 5e4 times the zenith, a disc 3° across) as a 64 × 32 lat-long, a 16² cube and a
/// 32² angular map, turned by a rotation from the world: every value within 1e-4 of the
/// twin's (relative; the float32 sums and the rule's cell count, which float32 may round the
/// other way at a threshold, where the rule's own error is about 1e-4 of that texel's term).
pub fn check(ctx: &Context) {
    let sky = Sky::default();
    let world_to_file = DMat3::from_rotation_y(0.7) * DMat3::from_rotation_x(-0.3);
    let file_to_world = world_to_file.transpose();
    let mut errors = Errors::new();
    let pass = ExactShader::new(ctx).unwrap();
    for (mapping, w, h) in [
        (Mapping::LatLong, 64, 32),
        (Mapping::Cube, 16, 16),
        (Mapping::Angular, 32, 32),
    ] {
        let map = EnvMap::from_fn(mapping, w, h, 3, |d| sky.radiance(file_to_world * d));
        let gpu = GpuEnvMap::upload(ctx, &map).unwrap();
        let twin = ExactFilter::new(&map, file_to_world);
        let qs = queries(sky.sun_dir);
        for brdf in brdfs() {
            let got = pass.run(&gpu, world_to_file, brdf, &qs).unwrap();
            assert!(got.timings.iter().any(|t| t.label == "exact reference"));
            for (k, (&(n, v), g)) in qs.iter().zip(&got.value).enumerate() {
                let want = twin.shade(&brdf, n, v);
                for c in 0..3 {
                    errors.rel(g[c], want[c], 1e-3, (mapping.name(), brdf, k, c));
                }
            }
        }
    }
    let worst = errors.worst();
    eprintln!(
        "exact pass: {} values, worst {worst:.2e} at {:?}",
        errors.count(),
        errors.at()
    );
    assert!(worst < BOUND, "{worst:e} at {:?}", errors.at());
}
