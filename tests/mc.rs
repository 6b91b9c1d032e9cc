//! The Monte Carlo reference on the GPU against its float64 twin, and filtered importance
//! sampling against the converged reference on real probes.

mod common;

use common::scenes::{fis, object, scene, sphere_camera, unit_sphere};
use envlight::math::brdf::Brdf;
use envlight::math::camera::{trace, Camera, Projection, Shape};
use envlight::math::envmap::luminance;
use envlight::math::mc::{estimate, McPoint, McSetup};
use envlight::math::{Mapping, Orientation};
use envlight::passes::gbuffer::GBufferPass;
use envlight::passes::mc::{pixel_stats, McEnv, McOptions, MonteCarlo};
use envlight::render::{object_record, render};
use envlight::scene::Technique;
use envlight::EnvMap;

/// GPU and CPU estimates of the same pixels with independent seeds agree within their
/// combined statistical error: per pixel, z = (Y_gpu − Y_cpu)/√(σ²_gpu + σ²_cpu) of the mean
/// luminance. With ~100 pixels of 512 samples each, |z| < 5 everywhere and the mean z² near 1
/// (0.4 to 2) if both estimators target the same value and report their variance truthfully.
/// The scene has a sun 5·10⁴ × the sky, shadows, a rotated environment, and four BRDFs.
#[test]
fn gpu_monte_carlo_matches_the_float64_estimator() {
    let ctx = common::ctx();
    {
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
        let records: Vec<_> = objs.iter().map(|o| object_record(o, 0)).collect();
        let (gbuf, _) = GBufferPass::new(&ctx).unwrap().run(&cam, &records).unwrap();
        let mc_env = McEnv::new(&ctx, &env, &orientation).unwrap();
        let (res, t) = MonteCarlo::new(&ctx)
            .unwrap()
            .run(&gbuf, &mc_env, &{
                let mut o = McOptions::new(512);
                (o.shadows, o.seed, o.per_frame) = (true, 11, 128);
                o
            })
            .unwrap();
        assert_eq!(res.samples, 512);
        assert!(t.iter().all(|t| t.label.starts_with("mc frame")));
        let accum = res.accum.download_level(&ctx, 0).unwrap();
        let shapes: Vec<Shape> = objs.iter().map(|o| o.shape).collect();
        let setup = McSetup {
            env: &mc_env.sampler,
            shapes: &shapes,
            shadows: true,
            mis: true,
            seed: 12345,
        };
        let (mut n, mut z2, mut zmax) = (0, 0.0, 0.0f64);
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
                zmax = zmax.max(z.abs());
                n += 1;
            }
        }
        let mean_z2 = z2 / n as f64;
        eprintln!("{n} pixels: max |z| {zmax:.2}, mean z² {mean_z2:.2}");
        assert!(n > 60);
        assert!(
            zmax < 5.0 && (0.4..2.0).contains(&mean_z2),
            "max |z| {zmax}, mean z² {mean_z2}"
        );
    }
    common::finish(ctx);
}

/// FIS at N = 64 against the Monte Carlo reference (MIS, 4096 samples per pixel) on a studio
/// map and on a map whose sun holds half the power in 2·10⁻⁴ sr, for GGX α ∈ {0.05, 0.3} and
/// Phong n ∈ {10, 1000}, on a sphere seen from normal incidence to grazing.
/// With lights extracted (the scenes' default) FIS reads the residual and adds the light
/// texels exactly. Measured relative RMS over the sphere (luminance), GGX α 0.05, 0.3, Phong
/// 10, 1000: studio 3.6%, 4.0%, 5.0%, 1.8%; quarry 2.1%, 2.4%, 1.4%, 2.2% (before extraction:
/// 5–8% and 18–33%, whose 15% and 40% bounds hid regressions). Each case is bounded at 1.3×
/// its measured error, MC's own noise (about 0.5–1% at 4096 samples) included; and no pixel
/// may exceed the reference by more than 2.1× plus 1% of the image's mean (measured 1.58×: a
/// firefly bound), nor be NaN or Inf.
#[test]
fn fis_converges_towards_monte_carlo_on_real_probes() {
    let Some(probes) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    {
        let cam = sphere_camera(24);
        // Bounds per BRDF below, in this order.
        for (file, tols) in [
            ("photo_studio_01_1k.hdr", [0.047, 0.052, 0.065, 0.024]),
            ("quarry_01_1k.hdr", [0.028, 0.031, 0.019, 0.029]),
        ] {
            let env = envlight::io::load(probes.join(file), &Default::default()).unwrap();
            for (kind, tol) in [
                Brdf::Ggx {
                    alpha: 0.05,
                    correlated: false,
                },
                Brdf::Ggx {
                    alpha: 0.3,
                    correlated: false,
                },
                Brdf::Phong { n: 10.0 },
                Brdf::Phong { n: 1000.0 },
            ]
            .into_iter()
            .zip(tols)
            {
                let f = render(
                    &ctx,
                    &scene(
                        cam,
                        vec![object(unit_sphere(), kind, [1.0; 3], fis(64))],
                        false,
                        256,
                    ),
                    &env,
                )
                .unwrap();
                let m = render(
                    &ctx,
                    &scene(
                        cam,
                        vec![object(
                            unit_sphere(),
                            kind,
                            [1.0; 3],
                            Technique::Mc {
                                samples: 4096,
                                error: None,
                            },
                        )],
                        false,
                        256,
                    ),
                    &env,
                )
                .unwrap();
                let (mut se, mut sr, mut n, mut worst_ratio) = (0.0, 0.0, 0, 0.0f64);
                let mean_ref: f64 = m
                    .frame
                    .texels
                    .iter()
                    .map(|t| luminance(t.map(f64::from)))
                    .sum::<f64>()
                    / m.frame.texels.len() as f64;
                for (k, (a, b)) in f.frame.texels.iter().zip(&m.frame.texels).enumerate() {
                    assert!(
                        a.iter().all(|v| v.is_finite()),
                        "{file} {kind:?}: pixel {k} {a:?}"
                    );
                    let (o, d) = cam.ray(k as u32 % cam.width, k as u32 / cam.width);
                    if trace(&[unit_sphere()], o, d).is_none_or(|h| h.margin < 1e-3) {
                        continue;
                    }
                    let (la, lb) = (luminance(a.map(f64::from)), luminance(b.map(f64::from)));
                    se += (la - lb).powi(2);
                    sr += lb * lb;
                    n += 1;
                    worst_ratio = worst_ratio.max(la / (lb + 0.01 * mean_ref));
                }
                let rel = (se / sr).sqrt();
                eprintln!("{file} {kind:?}: FIS-64 relative RMS {rel:.3} over {n} pixels, worst ratio to reference {worst_ratio:.2}");
                assert!(rel < tol, "{file} {kind:?}: {rel}");
                assert!(worst_ratio < 2.1, "{file} {kind:?}: firefly {worst_ratio}");
            }
        }
    }
    common::finish(ctx);
}
