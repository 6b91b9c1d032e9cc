//! The shading pass (filtered importance sampling) against its float64 twin.
//! `tests/shade.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::Errors;
use crate::common::scenes::{fis, object, scene, sphere_camera, unit_sphere};
use envlight::gpu::Context;
use envlight::math::brdf::Brdf;
use envlight::math::brdf::{local_view, Frame};
use envlight::math::camera::{trace, Shape};
use envlight::math::synth::smooth_env;
use envlight::math::{mip, Mapping};
use envlight::render::render;
use envlight::scene::Technique;
use envlight::EnvMap;

/// The relative bound [`check`] holds each pixel to.
pub const BOUND: f64 = 1e-4;

/// The FIS pass against its float64 twin (`math::fis::estimate` over the float64 conversion
/// and MIP chain): GGX, Phong and Ward on a smooth map, 16 samples, default bias, with and
/// without per-pixel rotation. Tolerance 1e-4 relative (measured worst 1.6e-5, Ward): the GPU
/// samples, converts and filters in float32, and its lod values round differently near a
/// level; pixels within 1e-3 of the silhouette are skipped, where float32 and float64 can
/// disagree on which samples fall below the horizon.
pub fn check(ctx: &Context) {
    use envlight::math::{fis as fis64, sequence};
    {
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, smooth_env);
        let size = 32;
        let dp = crate::common::dp_f64(&env, size);
        let chain = mip::chain(&dp);
        let cam = sphere_camera(20);
        for (kind, rotate) in [
            (
                Brdf::Ggx {
                    alpha: 0.3,
                    correlated: false,
                },
                false,
            ),
            (Brdf::Phong { n: 50.0 }, true),
            (Brdf::Ward { ax: 0.4, ay: 0.1 }, false),
        ] {
            let technique = Technique::Fis {
                samples: 16,
                bias: None,
                rotate,
            };
            let mut sc = scene(
                cam,
                vec![object(unit_sphere(), kind, [1.0; 3], technique)],
                false,
                size,
            );
            // The pass alone: the chain holds the whole map (a smooth map still has texels
            // above the default extraction's 2 × the mean).
            sc.environment.lights = envlight::scene::LightsMode::None;
            let r = render(ctx, &sc, &env).unwrap();
            let (mut errors, mut n) = (Errors::new(), 0);
            for j in 0..cam.height {
                for i in 0..cam.width {
                    let (o, d) = cam.ray(i, j);
                    let Some(hit) = trace(&[unit_sphere()], o, d) else {
                        continue;
                    };
                    if hit.margin < 1e-3 {
                        continue;
                    }
                    let offset = if rotate {
                        sequence::pixel_offset(i, j)
                    } else {
                        [0.0; 2]
                    };
                    let bias = envlight::scene::defaults::FIS_BIAS;
                    let want = fis64::estimate(&chain, &kind, hit.normal, -d, 16, bias, offset);
                    let px = r.frame.texels[(j * cam.width + i) as usize];
                    for c in 0..3 {
                        errors.rel(px[c], want[c], 1e-3, (i, j, c));
                    }
                    n += 1;
                }
            }
            let worst = errors.worst();
            eprintln!("{kind:?} rotate {rotate}: {n} pixels, worst {worst:.2e}");
            assert!(n > 150);
            assert!(worst < BOUND, "{kind:?}: worst {worst:e}");
        }
    }
}
