//! The G-buffer and SH diffuse shading against the float64 path: f64 rays and intersections,
//! f64 SH projection and evaluation.

mod common;
#[path = "twins/map.rs"]
mod map_twin;

use common::compare::Errors;
use envlight::gpu::Timed;
use envlight::math::brdf::Brdf;
use envlight::math::camera::{trace, Camera, Projection, Shape};
use envlight::math::sh;
use envlight::math::synth::smooth_env;
use envlight::math::{Mapping, Orientation};
use envlight::passes::gbuffer::{object_record, GBufferPass, Object, Shading};
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::passes::shade::{Shade, ShadeInputs};
use envlight::render::PassKind;
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
            let Timed { value: c, .. } = projector.run(&g, lmax).unwrap();
            let irr_gpu = sh::irradiance_coeffs(&c.coeffs);
            let irr_cpu = sh::irradiance_coeffs(&sh::project(&map, lmax));
            for cam in &cameras {
                let records: Vec<_> = objects.iter().map(|o| o.gpu(lmax)).collect();
                let Timed {
                    value: gbuf,
                    timings: t,
                } = gpass.run(cam, &records).unwrap();
                assert_eq!(t[0].label, "gbuffer");
                let Timed {
                    value: frame,
                    timings: t,
                } = shade
                    .run(
                        &gbuf,
                        &ShadeInputs {
                            env: &g,
                            orientation: Orientation::default(),
                            sh: Some(envlight::passes::shade::ShCoeffs::Host(&irr_gpu)),
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
        let Timed { value: c, .. } = projector.run_oriented(&env, lmax, &o).unwrap();
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
        // SH of the residual, the light clusters added by the shader.
        let residual = Shading::Sh {
            offset: 0,
            order: lmax,
            lights: true,
        };
        let records: Vec<_> = objects
            .iter()
            .map(|o| object_record(&o.shape, o.albedo, &Brdf::Lambert, residual))
            .collect();
        let Timed { value: gbuf, .. } = gpass.run(&cam, &records).unwrap();
        let mut frames = Vec::new();
        for lights in [Some(&gpu_lights), None] {
            let Timed { value: frame, .. } = shade
                .run(
                    &gbuf,
                    &ShadeInputs {
                        env: &env,
                        orientation: o,
                        sh: Some(envlight::passes::shade::ShCoeffs::Host(&irr_gpu)),
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

/// A render without Monte Carlo is one submission: the SH coefficients are packed for each
/// object on the GPU, no host read-back stands between the projection and the shading. The
/// scene has every other technique (SH with lights extracted, whose light texels' coefficients
/// are subtracted on the GPU; SH-BRDF, whose lighting's ringing is noted from a host copy read
/// after the frame; FIS, split-sum, a prefiltered map, a mirror), on the sky whose sun is
/// 5·10⁴ × the zenith. With Monte Carlo, its batches and the shading follow the inputs' in
/// submissions of their own.
#[test]
fn a_render_without_monte_carlo_is_one_submission() {
    use common::scenes::{fis, object, scene as scene_of, sphere_camera};
    use envlight::math::brdf::Brdf;
    use envlight::scene::Technique;
    let ctx = common::ctx();
    {
        let sky = envlight::math::synth::Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
        let at = |x: f64, y: f64| Shape::Sphere {
            center: [x, y, 0.0],
            radius: 0.45,
        };
        let ggx = Brdf::Ggx {
            alpha: 0.3,
            correlated: true,
        };
        let mut objects: Vec<envlight::scene::SceneObject> = vec![
            object(
                at(-1.0, 0.5),
                Brdf::Lambert,
                [1.0; 3],
                Technique::Sh { order: 2 },
            ),
            object(
                at(0.0, 0.5),
                Brdf::Phong { n: 8.0 },
                [1.0; 3],
                Technique::ShBrdf {
                    order: 2,
                    grid: 4,
                    window: None,
                },
            ),
            object(at(1.0, 0.5), ggx, [1.0; 3], fis(16)),
            object(at(-1.0, -0.5), ggx, [1.0; 3], Technique::SplitSum),
            object(
                at(0.0, -0.5),
                Brdf::Lambert,
                [1.0; 3],
                Technique::Prefiltered { size: 8 },
            ),
            object(at(1.0, -0.5), Brdf::Mirror, [1.0; 3], Technique::Lookup),
        ];
        let renderer = envlight::render::Renderer::new(&ctx);
        let submissions = |objects: Vec<envlight::scene::SceneObject>| {
            let mut sc = scene_of(sphere_camera(24), objects, false, 32);
            (sc.split_sum.size, sc.split_sum.levels, sc.split_sum.samples) = (Some(32), 3, 16);
            let before = ctx.submissions();
            let r = renderer.render(&sc, &env).unwrap();
            assert!(r.frame.texels.iter().flatten().all(|v| v.is_finite()));
            assert!(r.lights_ms.is_some(), "no lights were extracted");
            ctx.submissions() - before
        };
        assert_eq!(submissions(objects.clone()), 1);
        objects.truncate(1);
        objects.push(object(
            at(0.0, 0.0),
            ggx,
            [1.0; 3],
            Technique::Mc {
                samples: 16,
                error: None,
            },
        ));
        assert!(submissions(objects) > 2);
    }
    common::finish(ctx);
}

/// The seven techniques the resident path renders (SH irradiance, SH-BRDF, FIS, split-sum, a
/// prefiltered map, a mirror by lookup and one filtered over its footprint), on a lat-long
/// and a cube sky whose sun is 5·10⁴ × the zenith, lights left in the map.
fn resident_scene(footprint: bool) -> envlight::scene::Scene {
    use common::scenes::{fis, object, scene as scene_of, sphere_camera};
    use envlight::math::brdf::Brdf;
    use envlight::scene::{LightsMode, LookupFilter, Technique};
    let at = |x: f64, y: f64| Shape::Sphere {
        center: [x, y, 0.0],
        radius: 0.45,
    };
    let ggx = Brdf::Ggx {
        alpha: 0.3,
        correlated: true,
    };
    let sh_brdf = Technique::ShBrdf {
        order: 2,
        grid: 4,
        window: None,
    };
    let objects = vec![
        object(
            at(-1.0, 0.5),
            Brdf::Lambert,
            [1.0; 3],
            Technique::Sh { order: 2 },
        ),
        object(at(0.0, 0.5), Brdf::Phong { n: 8.0 }, [1.0; 3], sh_brdf),
        object(at(1.0, 0.5), ggx, [1.0; 3], fis(16)),
        object(at(-1.0, -0.5), ggx, [1.0; 3], Technique::SplitSum),
        object(
            at(0.0, -0.5),
            Brdf::Lambert,
            [1.0; 3],
            Technique::Prefiltered { size: 8 },
        ),
        object(at(1.0, -0.5), Brdf::Mirror, [1.0; 3], Technique::Lookup),
    ];
    let mut sc = scene_of(sphere_camera(24), objects, false, 32);
    (sc.split_sum.size, sc.split_sum.levels, sc.split_sum.samples) = (Some(32), 3, 16);
    sc.environment.lights = LightsMode::None;
    sc.environment.filter = match footprint {
        true => LookupFilter::Footprint,
        false => LookupFilter::Point,
    };
    sc
}

/// `Renderer::resident` + `render_resident` (what `envlight render --resident` runs: the map
/// on the GPU, one frame recorded from the image) against `Renderer::render` (the host path):
/// the same passes on the same inputs, only the environment's image is the caller's, so the
/// frames agree to f32 rounding (1e-6 relative, floor 1e-3) on a lat-long and a cube map, with
/// point and footprint-filtered lookups; but for the lat-long's paraboloid, which the resident
/// path converts from a plan (float64 weights; within 3e-6 of the twin) and the host path
/// without (float32 geometry; within 5e-5 of it): 2e-5 there (measured 4.0e-6; 1e-6 with the
/// plan left out). The frames are no constant image: the spheres differ.
/// The tables no environment changes (SH-BRDF, DFG) are made with the prepared scene, so a
/// frame records none of them.
#[test]
fn the_resident_path_renders_what_the_host_path_does() {
    use envlight::render::{MapShape, Renderer};
    let ctx = common::ctx();
    {
        let sky = envlight::math::synth::Sky::default();
        let renderer = Renderer::new(&ctx);
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Cube, 16, 16)] {
            let env = EnvMap::from_fn(mapping, w, h, 2, |d| sky.radiance(d));
            let gpu = GpuEnvMap::upload(&ctx, &env).unwrap();
            for footprint in [false, true] {
                let sc = resident_scene(footprint);
                let host = renderer.render(&sc, &env).unwrap();
                let prepared = renderer.resident(&sc, MapShape::of(&env)).unwrap();
                let planned = prepared.conversion_plan().is_some();
                // (Footprint lookups read the paraboloid's texel means: no areas, no plan.)
                assert_eq!(planned, mapping == Mapping::LatLong && !footprint);
                let before = ctx.submissions();
                let got = renderer.render_resident(&prepared, &gpu).unwrap();
                assert_eq!(ctx.submissions() - before, 1);
                // The SH-BRDF and DFG tables are computed when the scene is prepared: a
                // frame records neither.
                let spans: Vec<&str> = got
                    .records
                    .iter()
                    .flat_map(|r| r.timings.iter().map(|t| t.label.as_str()))
                    .collect();
                assert!(
                    !got.records.iter().any(|r| r.kind == PassKind::ShBrdfTable)
                        && !spans.iter().any(|l| l.contains("dfg")),
                    "a resident frame recomputed its tables: {spans:?}"
                );
                let errors = common::compare::frame_errors(&got.frame, &host.frame);
                let bound = if planned { 2e-5 } else { 1e-6 };
                eprintln!(
                    "{mapping:?} footprint {footprint}: resident differs by {:.1e}",
                    errors.worst()
                );
                assert!(
                    errors.worst() <= bound,
                    "{mapping:?} footprint {footprint}: resident differs by {:e} at {:?}",
                    errors.worst(),
                    errors.at()
                );
                let lum: Vec<f32> = got.frame.texels.iter().map(|t| t[1]).collect();
                let distinct = {
                    let mut v: Vec<u32> = lum.iter().map(|x| x.to_bits()).collect();
                    v.sort_unstable();
                    v.dedup();
                    v.len()
                };
                assert!(distinct > lum.len() / 4, "{distinct} distinct pixels");
            }
        }
    }
    common::finish(ctx);
}

/// What the resident path cannot render is refused when it is prepared, and an image it
/// cannot read when a frame is recorded, each naming what is wrong: Monte Carlo (its
/// sampling tables are built on the host), a map of another shape, an image without SAMPLED
/// usage.
#[test]
fn the_resident_path_refuses_what_it_cannot_render() {
    use envlight::gpu::{Image, ImageDesc};
    use envlight::passes::map::map_desc;
    use envlight::render::{MapShape, Renderer};
    use envlight::scene::Technique;
    let ctx = common::ctx();
    {
        let renderer = Renderer::new(&ctx);
        let shape = MapShape {
            mapping: Mapping::LatLong,
            width: 64,
            height: 32,
        };
        let mut sc = resident_scene(false);
        sc.objects[2].material.technique = Some(Technique::Mc {
            samples: 16,
            error: None,
        });
        let err = renderer.resident(&sc, shape).err().unwrap().to_string();
        assert!(
            err.contains("object 2") && err.contains("Monte Carlo"),
            "{err}"
        );

        let prepared = renderer.resident(&resident_scene(false), shape).unwrap();
        let other = GpuEnvMap::new(&ctx, "engine sky 32", Mapping::LatLong, 32, 16).unwrap();
        let err = ctx
            .run("refused", |rec| {
                renderer.record_resident(rec, &prepared, &other)
            })
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("engine sky 32") && err.contains("64x32"),
            "{err}"
        );
        let desc = ImageDesc {
            usage: ash::vk::ImageUsageFlags::STORAGE | ash::vk::ImageUsageFlags::TRANSFER_DST,
            ..map_desc(Mapping::LatLong, 64, 32, 1)
        };
        let unsampled = GpuEnvMap::from_image(
            Image::new(&ctx, "engine sky (storage only)", desc).unwrap(),
            Mapping::LatLong,
        );
        let err = ctx
            .run("refused", |rec| {
                renderer.record_resident(rec, &prepared, &unsampled)
            })
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("engine sky (storage only)") && err.contains("SAMPLED"),
            "{err}"
        );
        drop((prepared, other, unsampled, renderer));
    }
    common::finish(ctx);
}

/// An engine's frame holding NaN, infinite and negative texels: the resident path reads them
/// as zero and counts them (`Resident::zeroed_texels`), so the frame is finite and equals the
/// host path's render of the map with those texels zeroed (`EnvMap::sanitized`, to 1e-6); the
/// next frame, written into the same image, renders the clean map as the host path does. The
/// same with every technique's lights extracted on the GPU (within the bounds of
/// `the_resident_path_extracts_chain_lights_on_the_gpu`): no NaN reaches the light tree.
#[test]
fn a_broken_frame_shades_finite_pixels_and_the_next_recovers() {
    use envlight::render::{MapShape, Renderer};
    let ctx = common::ctx();
    {
        let sky = envlight::math::synth::Sky::default();
        let renderer = Renderer::new(&ctx);
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Cube, 16, 16)] {
            let clean = EnvMap::from_fn(mapping, w, h, 2, |d| sky.radiance(d));
            let mut broken = clean.clone();
            let n = broken.texels.len();
            broken.texels[n / 3] = [f32::NAN; 3];
            broken.texels[n / 2] = [f32::INFINITY, 1.0, 1.0];
            broken.texels[2 * n / 3] = [1.0, -2.0, f32::NAN];
            let (zeroed_map, zeroed) = broken.sanitized();
            assert_eq!(zeroed, 3);
            for lit in [false, true] {
                let mut sc = resident_scene(true);
                // (worst, mean) bounds: the lights extracted on the GPU agree with the host's
                // within the trees' budgets (the_resident_path_extracts_chain_lights_on_the_gpu).
                let (top, mean) = match lit {
                    false => (1e-6, 1e-6),
                    true => {
                        sc.environment.lights = envlight::scene::LightsMode::Extract;
                        sc.environment.light_texels = Some(24);
                        sc.environment.light_fill = Some(0);
                        (4e-2, 2e-4)
                    }
                };
                let prepared = renderer.resident(&sc, MapShape::of(&clean)).unwrap();
                let gpu = map_twin::raw_gpu_map(&ctx, &broken);
                for (map, want_zeroed) in [(&zeroed_map, 3u32), (&clean, 0)] {
                    if want_zeroed == 0 {
                        // The next frame, into the same image.
                        map_twin::write_raw(&ctx, &gpu, &clean);
                    }
                    let got = renderer.render_resident(&prepared, &gpu).unwrap();
                    let host = renderer.render(&sc, map).unwrap();
                    // A non-finite pixel fails here, at its place.
                    let errors = common::compare::frame_errors(&got.frame, &host.frame);
                    assert!(
                        errors.worst() <= top && errors.mean() <= mean,
                        "{mapping:?} lights {lit} ({want_zeroed} zeroed): {:e} at {:?}, {:e} \
                         on average",
                        errors.worst(),
                        errors.at(),
                        errors.mean()
                    );
                    let counted = map_twin::read_u32(&ctx, prepared.zeroed_texels());
                    assert_eq!(counted, want_zeroed, "{mapping:?}");
                }
            }
        }
    }
    common::finish(ctx);
}

/// Asserts that `lit`, the resident frame of `sc` (which extracts lights) from `gpu` (`env`
/// on the GPU), differs by more than 5% from the frame of the same scene with the lights
/// left in the map: the lights matter.
fn lights_matter(
    renderer: &envlight::render::Renderer,
    sc: &envlight::scene::Scene,
    env: &EnvMap,
    gpu: &GpuEnvMap,
    lit: &EnvMap,
) {
    let mut unlit = sc.clone();
    unlit.environment.lights = envlight::scene::LightsMode::None;
    let shape = envlight::render::MapShape::of(env);
    let prepared = renderer.resident(&unlit, shape).unwrap();
    let plain = renderer.render_resident(&prepared, gpu).unwrap();
    let apart = common::compare::frame_errors(&plain.frame, lit).worst();
    assert!(
        apart > 5e-2,
        "{:?}: lights change nothing ({apart:e})",
        env.mapping
    );
}

/// Diffuse lights on the resident path: a scene that extracts lights (`lights = "extract"`)
/// for SH irradiance and a prefiltered irradiance map (beside SH-BRDF and a mirror, which take
/// none) renders from a GPU image with the lights found on the GPU each frame: their
/// clusters, and the residual's own SH. The host path subtracts the light texels'
/// coefficients from the map's instead; the frames agree within 1e-4 (measured 1.1e-5 and 1.7e-5:
/// float32 sums of the same terms) on a lat-long and a cube sky whose sun is 5·10⁴ × the
/// zenith, and the lights matter: without them SH 2 shades the spheres otherwise (> 5%).
#[test]
fn the_resident_path_extracts_diffuse_lights_on_the_gpu() {
    use envlight::render::{MapShape, Renderer};
    use envlight::scene::LightsMode;
    let ctx = common::ctx();
    {
        let renderer = Renderer::new(&ctx);
        // The resident scene's SH, SH-BRDF, prefiltered map and point mirror (no chain lights:
        // see the next test).
        let full = resident_scene(false);
        let mut sc = full.clone();
        sc.objects = [0, 1, 4, 5].map(|k| full.objects[k].clone()).to_vec();
        sc.environment.lights = LightsMode::Extract;
        let sky = envlight::math::synth::Sky::default();
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Cube, 16, 16)] {
            let env = EnvMap::from_fn(mapping, w, h, 2, |d| sky.radiance(d));
            let gpu = GpuEnvMap::upload(&ctx, &env).unwrap();
            let host = renderer.render(&sc, &env).unwrap();
            let prepared = renderer.resident(&sc, MapShape::of(&env)).unwrap();
            let got = renderer.render_resident(&prepared, &gpu).unwrap();
            let errors = common::compare::frame_errors(&got.frame, &host.frame);
            assert!(
                errors.worst() <= 1e-4,
                "{mapping:?}: resident differs by {:e} at {:?}",
                errors.worst(),
                errors.at()
            );
            assert!(got.records.iter().any(|r| r.kind == PassKind::Lights));
            lights_matter(&renderer, &sc, &env, &gpu, &got.frame);
        }
    }
    common::finish(ctx);
}

/// Chain lights on the resident path: the resident scene with every technique, footprint
/// lookups included, extracting lights (`lights = "extract"`, at most 24 texels, the
/// residual filled under them as by default and clamped: `light_fill = 0`) renders from a
/// GPU image whose light texels are found, sorted and built into a light tree on the GPU each
/// frame (FIS, split-sum and the footprint mirror add them; the paraboloid holds the
/// residual). The host path builds its tree over the same texels by median splits, the GPU
/// by a spatial order, and each takes nodes whole where one's error is below `TREE_BUDGET`
/// (1e-2) of the pixel; the host's quadratures are as fine as the largest texel found needs,
/// the GPU's as the map's largest (it reads nothing back). Filled, the frames agree within
/// 1e-3 relative at worst (floor 1e-3; measured 1.3e-5 lat-long, 5.3e-5 cube) and 1e-5 on
/// average (2.6e-7, 4.6e-7; a clamped GPU residual against the host's fill: 2.3e-2 and
/// 2.3e-4, fails); clamped, within 4e-2 (1.0e-5 lat-long, 2.6e-2 cube at a sphere's rim, where
/// the quadratures differ) and 2e-4 on average (3.9e-7, 3.5e-5). The lights matter: without
/// them the frames differ by more than 5%.
#[test]
fn the_resident_path_extracts_chain_lights_on_the_gpu() {
    use envlight::render::{MapShape, Renderer};
    use envlight::scene::LightsMode;
    let ctx = common::ctx();
    {
        let renderer = Renderer::new(&ctx);
        let sky = envlight::math::synth::Sky::default();
        let cases = [Mapping::LatLong, Mapping::Cube]
            .into_iter()
            .flat_map(|m| [(m, Some(0)), (m, None)]);
        for (mapping, fill) in cases {
            let mut sc = resident_scene(true);
            sc.environment.lights = LightsMode::Extract;
            (sc.environment.light_texels, sc.environment.light_fill) = (Some(24), fill);
            let (w, h) = if mapping == Mapping::Cube {
                (16, 16)
            } else {
                (64, 32)
            };
            let env = EnvMap::from_fn(mapping, w, h, 2, |d| sky.radiance(d));
            let gpu = GpuEnvMap::upload(&ctx, &env).unwrap();
            let host = renderer.render(&sc, &env).unwrap();
            let prepared = renderer.resident(&sc, MapShape::of(&env)).unwrap();
            let before = ctx.submissions();
            let got = renderer.render_resident(&prepared, &gpu).unwrap();
            assert_eq!(ctx.submissions() - before, 1);
            let errors = common::compare::frame_errors(&got.frame, &host.frame);
            eprintln!(
                "{mapping:?} light_fill {fill:?}: resident differs by {:.1e} at {:?}, {:.1e} \
                 on average",
                errors.worst(),
                errors.at(),
                errors.mean()
            );
            let (top, mean) = if fill.is_some() {
                (4e-2, 2e-4)
            } else {
                (1e-3, 1e-5)
            };
            assert!(
                errors.worst() <= top && errors.mean() <= mean,
                "{mapping:?} light_fill {fill:?}: resident differs by {:e} at {:?}, {:e} on \
                 average",
                errors.worst(),
                errors.at(),
                errors.mean()
            );
            let spans: Vec<&str> = got
                .records
                .iter()
                .flat_map(|r| r.timings.iter().map(|t| t.label.as_str()))
                .collect();
            assert!(spans.contains(&"prepare lights (gpu)"), "{spans:?}");
            lights_matter(&renderer, &sc, &env, &gpu, &got.frame);
        }
    }
    common::finish(ctx);
}

/// Time slicing (`Resident::set_time_slices`): with the split-sum chain's rough levels spread
/// over 3 frames, the first frame refilters everything (= the host path's frame of its map);
/// after the map changes, the frames before the last slice still show some levels of the old
/// map (the split-sum sphere differs from the host's frame of the new map by more than 1e-2)
/// and the third frame equals it: every (level, half) was refiltered exactly once. Equal is
/// within 2e-5, as in `the_resident_path_renders_what_the_host_path_does`: the resident path
/// converts the paraboloid from a plan, the host path without (measured 3.9e-6; within 1e-6
/// with the plan left out). `refilter_all` makes the next frame whole again; one slice is no
/// slicing. Refused: 0 slices, a scene without split-sum.
#[test]
fn a_time_sliced_chain_catches_up_with_its_map() {
    use envlight::math::synth::Sky;
    use envlight::render::{MapShape, Renderer};
    let ctx = common::ctx();
    {
        let renderer = Renderer::new(&ctx);
        let sky_at = |az: f64| {
            let (el, az) = (30f64.to_radians(), az.to_radians());
            let sky = Sky {
                sun_dir: glam::DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos()),
                ..Sky::default()
            };
            EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, move |d| sky.radiance(d))
        };
        let (a, b) = (sky_at(40.0), sky_at(100.0));
        let (ga, gb) = (
            GpuEnvMap::upload(&ctx, &a).unwrap(),
            GpuEnvMap::upload(&ctx, &b).unwrap(),
        );
        // Three levels of 32² halves: units (1, 0), (1, 1) and both halves of level 2.
        let sc = resident_scene(false);
        let (host_a, host_b) = (
            renderer.render(&sc, &a).unwrap().frame,
            renderer.render(&sc, &b).unwrap().frame,
        );
        let mut prepared = renderer.resident(&sc, MapShape::of(&a)).unwrap();
        assert!(prepared.set_time_slices(0).is_err());
        prepared.set_time_slices(3).unwrap();
        assert_eq!(prepared.time_slices(), 3);
        let frame = |p: &envlight::render::Resident, g: &GpuEnvMap| {
            renderer.render_resident(p, g).unwrap().frame
        };
        let worst = |got: &EnvMap, want: &EnvMap| common::compare::frame_errors(got, want).worst();
        assert!(prepared.conversion_plan().is_some());
        let equal = 2e-5;
        let first = worst(&frame(&prepared, &ga), &host_a);
        assert!(first <= equal, "the first frame differs by {first:e}");
        let behind: Vec<f64> = (0..2)
            .map(|_| worst(&frame(&prepared, &gb), &host_b))
            .collect();
        let caught = worst(&frame(&prepared, &gb), &host_b);
        assert!(
            behind.iter().all(|&e| e > 1e-2) && caught <= equal,
            "frames after the change: {behind:?}, then {caught:e}"
        );
        prepared.refilter_all();
        let again = worst(&frame(&prepared, &ga), &host_a);
        assert!(again <= equal, "a whole refilter differs by {again:e}");
        prepared.set_time_slices(1).unwrap();
        let whole = worst(&frame(&prepared, &gb), &host_b);
        assert!(whole <= equal, "one slice differs by {whole:e}");
        let mut no_split = resident_scene(false);
        no_split.objects.retain(|o| {
            !matches!(
                o.material.technique,
                Some(envlight::scene::Technique::SplitSum)
            )
        });
        let mut other = renderer.resident(&no_split, MapShape::of(&a)).unwrap();
        let err = other.set_time_slices(2).err().unwrap().to_string();
        assert!(err.contains("split-sum"), "{err}");
    }
    common::finish(ctx);
}

/// Frames after the first create no Vulkan object, for each technique of the resident scene
/// alone (SH, SH-BRDF, FIS, split-sum, a prefiltered map, lookups), for SH with a
/// prefiltered irradiance map taking diffuse lights extracted on the GPU, and for the whole
/// scene taking the chain's lights and the diffuse ones (recorded untimed: objects
/// created while recording, the submission's own fence aside); the first frame makes the
/// descriptor sets, scratch buffers and scratch images the rest reuse.
#[test]
fn resident_frames_after_the_first_create_nothing() {
    use envlight::render::{MapShape, Renderer};
    let ctx = common::ctx();
    {
        let sky = envlight::math::synth::Sky::default();
        let renderer = Renderer::new(&ctx);
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
        let gpu = GpuEnvMap::upload(&ctx, &env).unwrap();
        let full = resident_scene(true);
        let mut scenes: Vec<(String, envlight::scene::Scene)> = full
            .objects
            .iter()
            .map(|object| {
                let mut sc = full.clone();
                sc.objects = vec![object.clone()];
                (format!("{:?}", object.material.technique), sc)
            })
            .collect();
        // Diffuse lights extracted on the GPU (SH and a prefiltered irradiance map).
        let mut lit = full.clone();
        lit.objects = vec![full.objects[0].clone(), full.objects[4].clone()];
        lit.environment.lights = envlight::scene::LightsMode::Extract;
        lit.environment.filter = envlight::scene::LookupFilter::Point;
        scenes.push(("diffuse lights".into(), lit));
        // Every light extracted on the GPU: the chain's for FIS, split-sum and the footprint
        // mirror, the diffuse ones for SH and the prefiltered map.
        let mut every = full.clone();
        every.environment.lights = envlight::scene::LightsMode::Extract;
        every.environment.light_texels = Some(24);
        scenes.push(("chain and diffuse lights".into(), every));
        for (technique, sc) in &scenes {
            let prepared = renderer.resident(sc, MapShape::of(&env)).unwrap();
            let mut created = Vec::new();
            for _ in 0..3 {
                let n = ctx
                    .run_untimed("a resident frame", |rec| {
                        let before = ctx.objects_created();
                        renderer.record_resident(rec, &prepared, &gpu)?;
                        Ok(ctx.objects_created() - before)
                    })
                    .unwrap();
                created.push(n);
            }
            assert!(created[0] > 0, "{technique}: the first frame made nothing");
            assert_eq!(&created[1..], [0, 0], "{technique}: created {created:?}");
        }
    }
    common::finish(ctx);
}
