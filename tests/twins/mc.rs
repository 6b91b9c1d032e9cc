//! The Monte Carlo pass against its float64 estimator.
//! `tests/mc.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{finite, Errors};
use crate::common::scenes::{fis, object, scene, sphere_camera, unit_sphere};
use envlight::gpu::{Context, Timed};
use envlight::math::brdf::Brdf;
use envlight::math::camera::{trace, Camera, Projection, Shape};
use envlight::math::envmap::luminance;
use envlight::math::mc::{estimate, McPoint, McSetup};
use envlight::math::{Mapping, Orientation};
use envlight::passes::gbuffer::GBufferPass;
use envlight::passes::mc::{pixel_stats, McEnv, McOptions, MonteCarlo};
use envlight::render::render;
use envlight::scene::Technique;
use envlight::EnvMap;

/// The relative bias the z test resolves: over ~100 pixels whose combined relative σ is about
/// 2% (a 10% bias gives a mean z² of 20), a mean z² under 2 lets a bias of about 3% through.
pub const BOUND: f64 = 3e-2;

/// GPU and CPU estimates of the same pixels with independent seeds agree within their
/// combined statistical error: per pixel, z = (Y_gpu − Y_cpu)/√(σ²_gpu + σ²_cpu) of the mean
/// luminance. With ~100 pixels of 512 samples each, |z| < 5 everywhere and the mean z² near 1
/// (0.4 to 2) if both estimators target the same value and report their variance truthfully.
/// The scene has a sun 5·10⁴ × the sky, shadows, a rotated environment, and four BRDFs.
pub fn check(ctx: &Context) {
    let sky = envlight::math::synth::Sky::default();
    let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
    let orientation = Orientation {
        rotate_y_degrees: 70.0,
        ..Default::default()
    };
    let mc = |s| Technique::Mc {
        samples: s,
        error: None,
    };
    let objs = [
        object(
            Shape::Sphere {
                center: [-0.6, 0.0, 0.0],
                radius: 0.6,
            },
            Brdf::Ggx {
                alpha: 0.3,
                correlated: false,
            },
            [0.9, 0.8, 0.7],
            mc(512),
        ),
        object(
            Shape::Sphere {
                center: [0.7, -0.1, 0.2],
                radius: 0.5,
            },
            Brdf::Lambert,
            [0.7, 0.7, 0.7],
            mc(512),
        ),
        object(
            Shape::Sphere {
                center: [0.2, 0.6, -0.8],
                radius: 0.35,
            },
            Brdf::Phong { n: 10.0 },
            [1.0; 3],
            mc(512),
        ),
        object(
            Shape::Plane {
                normal: [0.0, 1.0, 0.0],
                offset: -0.6,
                extent: 4.0,
            },
            Brdf::Ward { ax: 0.3, ay: 0.1 },
            [0.6, 0.6, 0.6],
            mc(512),
        ),
    ];
    let cam = Camera {
        projection: Projection::Perspective { fov_y: 45.0 },
        eye: [0.3, 1.2, 3.5],
        target: [0.0, -0.1, 0.0],
        up: [0.0, 1.0, 0.0],
        width: 14,
        height: 10,
    };
    let records: Vec<_> = objs.iter().map(|o| o.record(0)).collect();
    let Timed { value: gbuf, .. } = GBufferPass::new(ctx).unwrap().run(&cam, &records).unwrap();
    let mc_env = McEnv::new(ctx, &env, &orientation).unwrap();
    let Timed {
        value: res,
        timings: t,
    } = MonteCarlo::new(ctx)
        .unwrap()
        .run(&gbuf, &mc_env, &{
            let mut o = McOptions::new(512);
            (o.shadows, o.seed, o.per_frame) = (true, 11, 128);
            o
        })
        .unwrap();
    assert_eq!(res.samples, 512);
    assert!(t.iter().all(|t| t.label.starts_with("mc frame")));
    let accum = res.accum.download_level(ctx, 0).unwrap();
    let shapes: Vec<Shape> = objs.iter().map(|o| o.shape).collect();
    let setup = McSetup {
        env: &mc_env.sampler,
        shapes: &shapes,
        shadows: true,
        mis: true,
        seed: 12345,
    };
    let (mut n, mut z2, mut zs) = (0, 0.0, Errors::new());
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            let Some(hit) = trace(&shapes, o, d) else {
                continue;
            };
            if hit.margin < 1e-3 {
                continue;
            }
            let m = &objs[hit.index].material;
            let p = McPoint {
                pixel: (i, j),
                position: o + hit.t * d,
                normal: hit.normal,
                view: -d,
                brdf: m.kind,
                albedo: m.albedo,
            };
            let cpu = estimate(&setup, &p, 0, 512);
            let (gm, gv) = pixel_stats(accum[(j * cam.width + i) as usize], 512);
            assert!(gm.iter().all(|v| v.is_finite()));
            let z = (luminance(gm) - luminance(cpu.mean)) / (gv + cpu.lum_var).sqrt();
            z2 += z * z;
            zs.add(z.abs(), (i, j));
            n += 1;
        }
    }
    let (mean_z2, zmax) = (z2 / n as f64, zs.worst());
    eprintln!("{n} pixels: max |z| {zmax:.2}, mean z² {mean_z2:.2}");
    assert!(n > 60);
    assert!(
        zmax < 5.0 && (0.4..2.0).contains(&mean_z2),
        "max |z| {zmax}, mean z² {mean_z2}"
    );
}
