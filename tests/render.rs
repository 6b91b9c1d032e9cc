//! The G-buffer and SH diffuse shading against the float64 path: f64 rays and intersections,
//! f64 SH projection and evaluation.

mod common;

use common::compare::Errors;
use envlight::math::camera::{trace, Camera, Projection, Shape};
use envlight::math::sh;
use envlight::math::synth::smooth_env;
use envlight::math::{Mapping, Orientation};
use envlight::passes::gbuffer::{GBufferPass, Object};
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::passes::shade::{Shade, ShadeInputs};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use std::f64::consts::PI;

fn scene() -> Vec<Object> {
    vec![
        Object {
            shape: Shape::Sphere {
                center: [0.0, 0.0, 0.0],
                radius: 1.0,
            },
            albedo: [0.8, 0.6, 0.4],
        },
        Object {
            shape: Shape::Sphere {
                center: [-2.2, -0.4, -0.5],
                radius: 0.6,
            },
            albedo: [0.2, 0.9, 0.3],
        },
        Object {
            shape: Shape::Sphere {
                center: [1.9, -0.5, 0.8],
                radius: 0.5,
            },
            albedo: [0.95, 0.95, 0.95],
        },
        Object {
            shape: Shape::Plane {
                normal: [0.0, 1.0, 0.0],
                offset: -1.0,
                extent: 6.0,
            },
            albedo: [0.5, 0.5, 0.5],
        },
    ]
}

/// Every pixel that hits an object equals albedo·E(n)/π computed in float64 (rays,
/// intersection, the f64 projection of the same map, the f64 basis) within 1e-4 relative,
/// for a perspective and an orthographic camera and SH orders 2 and 8. The GPU's f32 error
/// budget: coefficients within 1e-5·|L00| of f64 (tests/sh_project.rs), normals from f32
/// intersections (~1e-6), the basis in f32. Pixels whose hit float32 cannot decide (margin
/// under 1e-3: silhouettes, the plane's rim, near-ties) are left out and counted; the rest
/// must be most of the objects' pixels.
#[test]
fn diffuse_spheres_match_float64_irradiance() {
    let ctx = common::ctx();
    {
        let map = EnvMap::from_fn(Mapping::LatLong, 128, 64, 4, smooth_env);
        let g = GpuEnvMap::upload(&ctx, &map).unwrap();
        let projector = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let gpass = GBufferPass::new(&ctx).unwrap();
        let shade = Shade::new(&ctx).unwrap();
        let objects = scene();
        let shapes: Vec<Shape> = objects.iter().map(|o| o.shape).collect();
        let cameras = [
            Camera {
                projection: Projection::Perspective { fov_y: 45.0 },
                eye: [0.5, 1.5, 6.0],
                target: [0.0, -0.2, 0.0],
                up: [0.0, 1.0, 0.0],
                width: 64,
                height: 40,
            },
            Camera {
                projection: Projection::Orthographic { height: 4.0 },
                eye: [3.0, 4.0, 5.0],
                target: [0.0, 0.0, 0.0],
                up: [0.0, 1.0, 0.0],
                width: 40,
                height: 40,
            },
        ];
        for lmax in [2u32, 8] {
            let (c, _) = projector.run(&g, lmax).unwrap();
            let irr_gpu = sh::irradiance_coeffs(&c.coeffs);
            let irr_cpu = sh::irradiance_coeffs(&sh::project(&map, lmax));
            for cam in &cameras {
                let records: Vec<_> = objects.iter().map(|o| o.gpu(lmax)).collect();
                let (gbuf, t) = gpass.run(cam, &records).unwrap();
                assert_eq!(t[0].label, "gbuffer");
                let (frame, t) = shade
                    .run(
                        &gbuf,
                        &ShadeInputs {
                            env: &g,
                            orientation: Orientation::default(),
                            sh: Some(&irr_gpu),
                            dp: None,
                            prefiltered: None,
                            mc: None,
                            brdf_sh: None,
                            sh_rotation: envlight::passes::shade::Rotation::Zxzxz,
                            split: None,
                            shadows: false,
                            lights: None,
                            footprint: Default::default(),
                        },
                    )
                    .unwrap();
                assert_eq!(t[0].label, "shade");
                let img = frame.download(&ctx).unwrap();
                let (mut compared, mut skipped, mut misses) = (0, 0, 0);
                let mut seen = vec![0usize; objects.len()];
                let mut worst = Errors::new();
                for j in 0..cam.height {
                    for i in 0..cam.width {
                        let px = img.texels[(j * cam.width + i) as usize];
                        assert!(px.iter().all(|v| v.is_finite() && *v >= 0.0));
                        let (o, d) = cam.ray(i, j);
                        let Some(hit) = trace(&shapes, o, d) else {
                            misses += 1;
                            continue;
                        };
                        if hit.margin < 1e-3 {
                            skipped += 1;
                            continue;
                        }
                        seen[hit.index] += 1;
                        let e = sh::eval(&irr_cpu, hit.normal);
                        let a = objects[hit.index].albedo;
                        for ch in 0..3 {
                            let want = a[ch] * e[ch].max(0.0) / PI;
                            let rel = worst.rel(px[ch], want, 0.0, (i, j, ch));
                            assert!(
                                rel < 1e-4,
                                "L={lmax} {:?} pixel ({i}, {j}) ch {ch}: {} vs {want}",
                                cam.projection,
                                px[ch]
                            );
                        }
                        compared += 1;
                    }
                }
                eprintln!(
                    "L={lmax} {:?}: {compared} pixels within {:.1e}, {skipped} edge pixels left out, {misses} background",
                    cam.projection,
                    worst.worst()
                );
                assert!(compared > 10 * skipped && compared > 300);
                assert!(
                    seen.iter().all(|&n| n > 10),
                    "every object in view: {seen:?}"
                );
            }
        }
    }
    common::finish(ctx);
}

/// SH irradiance with lights extracted, through the shading pass: every object pixel equals
/// albedo·(max(0, E_res(n)) + Σ_c max(0, n·V_c))/π in float64 — the diffuse residual's f64
/// projection and basis, and `math::lights::cluster_irradiance` over the light clusters of
/// the diffuse extraction — within 1e-4 relative, where the GPU's residual coefficients are,
/// as the renderer makes them, the whole map's GPU projection less `light_sh`, on the sky whose sun is 5·10⁴ × the zenith
/// (64 × 32), turned 30° and mirrored. Without the clusters (lights not bound) the same
/// pixels lose the sun's direct light: the pass adds them. The clusters in turn sum their
/// texels exactly away from the horizon (math::lights' unit tests).
#[test]
fn diffuse_with_lights_matches_float64() {
    use envlight::math::lights::{
        cluster_irradiance, clusters, diffuse_options, extract, light_sh, CLUSTER_GRID,
        DIFFUSE_RATIO,
    };
    use envlight::math::synth::Sky;
    use envlight::passes::GpuLights;
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let map = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, move |d| sky.radiance(d));
        let o = Orientation {
            flip_u: true,
            flip_v: false,
            rotate_y_degrees: 30.0,
        };
        let f2w = o.world_to_file().transpose();
        let ex = extract(&map, &diffuse_options(DIFFUSE_RATIO));
        let cl = clusters(&ex, f2w, CLUSTER_GRID);
        assert!(!cl.is_empty());
        let gpu_lights = GpuLights::upload_with_clusters(&ctx, &[], &cl).unwrap();
        let env = GpuEnvMap::upload(&ctx, &map).unwrap();
        let projector = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let gpass = GBufferPass::new(&ctx).unwrap();
        let shade = Shade::new(&ctx).unwrap();
        let lmax = 2;
        // As the renderer does: the whole map's GPU coefficients less the light texels'.
        let (c, _) = projector.run_oriented(&env, lmax, &o).unwrap();
        let minus = light_sh(&map, &ex, f2w, lmax);
        let res: Vec<[f64; 3]> = c
            .coeffs
            .iter()
            .zip(&minus)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
            .collect();
        let irr_gpu = sh::irradiance_coeffs(&res);
        let irr_cpu = sh::irradiance_coeffs(&sh::project_oriented(&ex.residual, lmax, f2w));
        let objects = scene();
        let shapes: Vec<Shape> = objects.iter().map(|o| o.shape).collect();
        let cam = Camera {
            projection: Projection::Orthographic { height: 4.0 },
            eye: [3.0, 4.0, 5.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            width: 40,
            height: 40,
        };
        let mut records: Vec<_> = objects.iter().map(|o| o.gpu(lmax)).collect();
        for r in &mut records {
            r.extra[3] = 1.0;
        }
        let (gbuf, _) = gpass.run(&cam, &records).unwrap();
        let mut frames = Vec::new();
        for lights in [Some(&gpu_lights), None] {
            let (frame, _) = shade
                .run(
                    &gbuf,
                    &ShadeInputs {
                        env: &env,
                        orientation: o,
                        sh: Some(&irr_gpu),
                        dp: None,
                        prefiltered: None,
                        mc: None,
                        brdf_sh: None,
                        sh_rotation: envlight::passes::shade::Rotation::Zxzxz,
                        split: None,
                        shadows: false,
                        lights,
                        footprint: Default::default(),
                    },
                )
                .unwrap();
            frames.push(frame.download(&ctx).unwrap());
        }
        let (mut compared, mut worst, mut sunlit) = (0, Errors::new(), 0);
        for j in 0..cam.height {
            for i in 0..cam.width {
                let (o_ray, d) = cam.ray(i, j);
                let Some(hit) = trace(&shapes, o_ray, d) else {
                    continue;
                };
                if hit.margin < 1e-3 {
                    continue;
                }
                let e = sh::eval(&irr_cpu, hit.normal);
                let l = cluster_irradiance(&cl, hit.normal);
                let a = objects[hit.index].albedo;
                let k = (j * cam.width + i) as usize;
                for ch in 0..3 {
                    let want = a[ch] * (e[ch].max(0.0) + l[ch]) / PI;
                    let got = frames[0].texels[k][ch] as f64;
                    let rel = worst.rel(got, want, 0.0, (i, j, ch));
                    assert!(rel < 1e-4, "pixel ({i}, {j}) ch {ch}: {got} vs {want}");
                }
                if l[1] > 0.1 * e[1] {
                    sunlit += 1;
                    assert!(frames[1].texels[k][1] < 0.95 * frames[0].texels[k][1]);
                }
                compared += 1;
            }
        }
        eprintln!(
            "{compared} pixels within {:.1e}, {sunlit} sunlit",
            worst.worst()
        );
        assert!(compared > 300 && sunlit > 100, "{compared} {sunlit}");
        drop(gpu_lights);
    }
    common::finish(ctx);
}
