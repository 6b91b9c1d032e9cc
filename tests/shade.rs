//! The shading pass (`passes::shade`): filtered importance sampling and the mirror lookup against
//! their float64 twins, the furnace, suns, vote-ended walks and the paraboloid it reads.

mod common;
#[path = "twins/shade.rs"]
mod twin;

use common::compare::Errors;
use common::scenes::{fis, object, scene, sphere_camera, unit_sphere};
use envlight::math::brdf::Brdf;
use envlight::math::brdf::{local_view, Frame};
use envlight::math::camera::{trace, Shape};
use envlight::math::synth::smooth_env;
use envlight::math::{mip, Mapping};
use envlight::render::render;
use envlight::scene::Technique;
use envlight::EnvMap;

/// Each BRDF's directional albedo under a white environment, per pixel, against float64
/// quadrature of the same BRDF (`Brdf::albedo`) at the pixel's float64 normal and view.
/// Tolerance 1e-3, from the estimator alone: FIS at N = 16384 Hammersley points integrates a
/// bounded weight over the unit square, whose error for the smooth weights (GGX, Ward,
/// Blinn) is far below it; Phong's weight is the indicator of the part of the lobe above the
/// horizon, a discontinuous integrand, for which the net's error falls only as about N^-3/4
/// (1e-3 measured at N = 4096 at grazing). Pixels float32 cannot place (margin < 1e-3) are left out.
#[test]
fn furnace_renders_each_brdfs_albedo() {
    let ctx = common::ctx();
    {
        // Large enough that the 32² paraboloid has a six-level MIP chain and the rough
        // lobes read its coarse levels: a level left unfilled or mis-weighted breaks the
        // furnace (the 8 × 4 map this test once used made a chain of one level matter).
        let env = EnvMap::new(Mapping::LatLong, 64, 32, vec![[1.0; 3]; 64 * 32]);
        let cam = sphere_camera(20);
        let materials = [
            Brdf::Phong { n: 1.0 },
            Brdf::Phong { n: 10.0 },
            Brdf::Phong { n: 1e3 },
            Brdf::Phong { n: 1e6 },
            Brdf::Ggx {
                alpha: 0.0,
                correlated: false,
            },
            Brdf::Ggx {
                alpha: 0.01,
                correlated: false,
            },
            Brdf::Ggx {
                alpha: 0.3,
                correlated: false,
            },
            Brdf::Ggx {
                alpha: 1.0,
                correlated: false,
            },
            Brdf::Ggx {
                alpha: 0.5,
                correlated: true,
            },
            Brdf::Blinn { n: 50.0 },
            Brdf::Ward { ax: 0.5, ay: 0.05 },
        ];
        for kind in materials {
            let sc = scene(
                cam,
                vec![object(unit_sphere(), kind, [1.0; 3], fis(16384))],
                false,
                32,
            );
            let r = render(&ctx, &sc, &env).unwrap();
            let brdf = kind;
            let mut errors = Errors::new();
            for j in 0..cam.height {
                for i in 0..cam.width {
                    let px = r.frame.texels[(j * cam.width + i) as usize];
                    assert!(
                        px.iter().all(|v| v.is_finite() && *v >= 0.0),
                        "{kind:?} ({i}, {j}): {px:?}"
                    );
                    let (o, d) = cam.ray(i, j);
                    let Some(hit) = trace(&[unit_sphere()], o, d) else {
                        continue;
                    };
                    if hit.margin < 1e-3 {
                        continue;
                    }
                    let want = brdf.albedo(local_view(&Frame::new(hit.normal), -d));
                    let err = errors.abs(px[1], want, (i, j));
                    if err >= 1e-3 {
                        eprintln!("{kind:?} pixel ({i}, {j}): {} vs albedo {want}", px[1]);
                    }
                }
            }
            let (n, worst) = (errors.count(), errors.worst());
            eprintln!(
                "{kind:?}: {n} pixels, worst {worst:.1e}, mean {:.1e}",
                errors.mean()
            );
            assert!(n > 200);
            assert!(worst < 1e-3, "{kind:?}: worst error {worst}");
        }
    }
    common::finish(ctx);
}

/// The point-filtered mirror is one lookup: each pixel equals the texel of the environment its
/// float64
/// reflected direction falls in. Where float32 lands in a neighbouring texel (directions within
/// 1e-4 of a texel's edge), the neighbour's value is accepted; those pixels are counted.
/// GGX at α = 0 and Phong at n = 10⁶ by FIS converge to it: on a smooth 512 × 256 map they
/// agree with the mirror within 1 % (the FIS lookup is bilinear in a 256² paraboloid, the
/// mirror's nearest: half a 0.7° texel of a smooth map's gradient).
#[test]
fn mirror_is_the_lookup_and_the_glossy_limits_reach_it() {
    let ctx = common::ctx();
    {
        let env = EnvMap::from_fn(Mapping::LatLong, 512, 256, 2, smooth_env);
        let cam = sphere_camera(24);
        let mirror = object(unit_sphere(), Brdf::Mirror, [1.0; 3], Technique::Lookup);
        let mut sc = scene(cam, vec![mirror], false, 256);
        sc.environment.filter = envlight::scene::LookupFilter::Point;
        let r = render(&ctx, &sc, &env).unwrap();
        let (mut exact, mut edge) = (0, 0);
        for j in 0..cam.height {
            for i in 0..cam.width {
                let px = r.frame.texels[(j * cam.width + i) as usize];
                let (o, d) = cam.ray(i, j);
                let Some(hit) = trace(&[unit_sphere()], o, d) else {
                    // The background is the same lookup along the ray.
                    let c = env.coord(d);
                    let t = texel_at(&env, c.u, c.v);
                    assert_eq!(px, t, "background ({i}, {j})");
                    continue;
                };
                if hit.margin < 1e-3 {
                    continue;
                }
                let n = hit.normal;
                let r = 2.0 * n.dot(-d) * n + d;
                let c = env.coord(r);
                if px == texel_at(&env, c.u, c.v) {
                    exact += 1;
                } else {
                    let near = [(-1e-4, 0.0), (1e-4, 0.0), (0.0, -1e-4), (0.0, 1e-4)]
                        .iter()
                        .any(|(du, dv)| px == texel_at(&env, c.u + du, c.v + dv));
                    assert!(
                        near,
                        "mirror pixel ({i}, {j}) {px:?} is not the lookup of {r}"
                    );
                    edge += 1;
                }
            }
        }
        eprintln!("mirror: {exact} pixels exact, {edge} at a texel edge");
        assert!(exact > 300 && edge * 20 < exact);
        for kind in [
            Brdf::Ggx {
                alpha: 0.0,
                correlated: false,
            },
            Brdf::Phong { n: 1e6 },
        ] {
            let g = render(
                &ctx,
                &scene(
                    cam,
                    vec![object(unit_sphere(), kind, [1.0; 3], fis(16))],
                    false,
                    256,
                ),
                &env,
            )
            .unwrap();
            let mut errors = Errors::new();
            for (k, (a, b)) in g.frame.texels.iter().zip(&r.frame.texels).enumerate() {
                let (o, d) = cam.ray(k as u32 % cam.width, k as u32 / cam.width);
                if trace(&[unit_sphere()], o, d).is_none_or(|h| h.margin < 1e-3) {
                    continue;
                }
                for c in 0..3 {
                    errors.rel(a[c], b[c], 0.0, (k, c));
                }
            }
            assert!(errors.count() > 0);
            let worst = errors.worst();
            eprintln!("{kind:?} against the mirror: worst {worst:.2e}");
            assert!(worst < 1e-2, "{kind:?}: {worst}");
        }
    }
    common::finish(ctx);
}

fn texel_at(env: &EnvMap, u: f64, v: f64) -> [f32; 3] {
    let i = ((u.rem_euclid(1.0) * env.width as f64) as u32).min(env.width - 1);
    let j = ((v.clamp(0.0, 1.0) * env.height as f64) as u32).min(env.height - 1);
    env.texel(0, i, j)
}

/// The sky's sun is 5·10⁴ × the zenith; FIS never lets a NaN or Inf out at any roughness,
/// at N = 1 too.
#[test]
fn fis_stays_finite_with_a_sun() {
    let ctx = common::ctx();
    {
        let sky = envlight::math::synth::Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
        let cam = sphere_camera(16);
        for kind in [
            Brdf::Ggx {
                alpha: 1e-6,
                correlated: true,
            },
            Brdf::Ggx {
                alpha: 1.0,
                correlated: false,
            },
            Brdf::Phong { n: 1e6 },
            Brdf::Blinn { n: 1e6 },
            Brdf::Ward { ax: 1e-3, ay: 1.0 },
        ] {
            for n in [1, 64] {
                let sc = scene(
                    cam,
                    vec![object(
                        Shape::Sphere {
                            center: [0.0; 3],
                            radius: 1.0,
                        },
                        kind,
                        [1.0; 3],
                        Technique::Fis {
                            samples: n,
                            bias: Some(1.0),
                            rotate: true,
                        },
                    )],
                    true,
                    16,
                );
                let r = render(&ctx, &sc, &env).unwrap();
                assert!(
                    r.frame
                        .texels
                        .iter()
                        .flatten()
                        .all(|v| v.is_finite() && *v >= 0.0),
                    "{kind:?} N={n}"
                );
            }
        }
    }
    common::finish(ctx);
}

/// The FIS pass against its float64 twin (`math::fis::estimate` over the float64 conversion
/// and MIP chain): GGX, Phong and Ward on a smooth map, 16 samples, default bias, with and
/// without per-pixel rotation. Tolerance 1e-4 relative (measured worst 1.6e-5, Ward): the GPU
/// samples, converts and filters in float32, and its lod values round differently near a
/// level; pixels within 1e-3 of the silhouette are skipped, where float32 and float64 can
/// disagree on which samples fall below the horizon.
#[test]
fn fis_pass_matches_its_float64_twin() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// FIS with lights extracted (the default) against its float64 twin: the estimate over the
/// residual's float64 conversion and MIP chain (`math::fis::estimate`) plus the light texels
/// under the BRDF through their tree (`math::light_tree::LightTree::sum_brdf`), on the sky whose sun is 5·10⁴ × the
/// zenith, for GGX, Phong, Ward and Lambert, 16 samples. Tolerance 1e-4 relative as above
/// (measured: printed); and the sun's light reaches the lit pixels (the lights are added).
#[test]
fn fis_with_lights_matches_its_float64_twin() {
    use envlight::math::fis as fis64;
    use envlight::math::light_tree::LightTree;
    use envlight::math::lights::{extract, lobe_scale, prepare, ExtractOptions};
    use envlight::math::synth::Sky;
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, move |d| sky.radiance(d));
        let ex = extract(&env, &ExtractOptions::chain());
        assert!(!ex.lights.is_empty());
        let size = 32;
        let chain = mip::chain(&common::dp_f64_residual(&ex.residual, size));
        let cam = sphere_camera(20);
        for kind in [
            Brdf::Ggx {
                alpha: 0.3,
                correlated: true,
            },
            Brdf::Phong { n: 50.0 },
            Brdf::Ward { ax: 0.4, ay: 0.1 },
            Brdf::Lambert,
        ] {
            let scale = lobe_scale(&kind).unwrap();
            let tree = LightTree::new(prepare(&env, &ex, glam::DMat3::IDENTITY, scale.min(1.0)));
            let technique = Technique::Fis {
                samples: 16,
                bias: None,
                rotate: false,
            };
            let sc = scene(
                cam,
                vec![object(unit_sphere(), kind, [1.0; 3], technique)],
                false,
                size,
            );
            let r = render(&ctx, &sc, &env).unwrap();
            assert!(r.lights_ms.is_some_and(|ms| ms[0] >= 0.0 && ms[1] >= 0.0));
            let (mut errors, mut n, mut lit) = (Errors::new(), 0, 0);
            for j in 0..cam.height {
                for i in 0..cam.width {
                    let (o, d) = cam.ray(i, j);
                    let Some(hit) = trace(&[unit_sphere()], o, d) else {
                        continue;
                    };
                    if hit.margin < 1e-3 {
                        continue;
                    }
                    let bias = envlight::scene::defaults::FIS_BIAS_RESIDUAL;
                    let f = fis64::estimate(&chain, &kind, hit.normal, -d, 16, bias, [0.0; 2]);
                    let lum = envlight::math::envmap::luminance(f);
                    let l = tree.sum_brdf(&kind, hit.normal, -d, scale, lum);
                    let px = r.frame.texels[(j * cam.width + i) as usize];
                    for c in 0..3 {
                        errors.rel(px[c], f[c] + l[c], 1e-3, (i, j, c));
                    }
                    if l[1] > f[1] {
                        lit += 1;
                    }
                    n += 1;
                }
            }
            let worst = errors.worst();
            eprintln!("{kind:?}: {n} pixels, worst {worst:.2e}, {lit} lit mostly by the sun");
            assert!(n > 150 && lit > 10, "{n} {lit}");
            assert!(worst < 1e-4, "{kind:?}: worst {worst:e}");
        }
    }
    common::finish(ctx);
}

/// Where the source is finer than the paraboloid reads, FIS converts the residual halved
/// (`math::convert::paraboloid_source_halves`): on the sky (sun 5·10⁴ × the zenith, taken out
/// as lights) times a checker of 2 × 2-texel cells at 4 : 1, the content halving blurs most,
/// 256 × 128, GGX α 0.3 and 0.6 with 16 samples, paraboloids of 32 and 16. Against the
/// float64 twin of the halved residual the frame agrees as
/// fis_with_lights_matches_its_float64_twin's does (1e-4); against the whole residual's
/// twin, what halving costs: measured 3.0e-3 and 2.7e-3 worst relative (α 0.3; 1.3e-3 and
/// 1.2e-3 at α 0.6), bounds 1.3×. Halving twice erred 2.2e-2 at 16, 8× more: hence once.
#[test]
fn halved_residual_costs_little_against_the_whole() {
    use envlight::math::convert::{latlong_halved, paraboloid_source_halves};
    use envlight::math::fis as fis64;
    use envlight::math::light_tree::LightTree;
    use envlight::math::lights::{extract, lobe_scale, prepare, ExtractOptions};
    use envlight::math::synth::Sky;
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let (w, h) = (256u32, 128u32);
        let env = EnvMap::from_fn(Mapping::LatLong, w, h, 1, move |d| {
            let u = (d.z.atan2(d.x) / std::f64::consts::TAU + 0.5) * f64::from(w);
            let v = d.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI * f64::from(h);
            let light = ((u / 2.0).floor() as i64 + (v / 2.0).floor() as i64) % 2 == 0;
            sky.radiance(d).map(|c| c * if light { 1.6 } else { 0.4 })
        });
        let ex = extract(&env, &ExtractOptions::chain());
        assert!(!ex.lights.is_empty());
        let cam = sphere_camera(20);
        for (size, bound) in [(32u32, 4e-3), (16, 3.6e-3)] {
            assert!(paraboloid_source_halves(w, h, size));
            let half = latlong_halved(&ex.residual);
            let chains =
                [&half, &ex.residual].map(|m| mip::chain(&common::dp_f64_residual(m, size)));
            for alpha in [0.3, 0.6] {
                let kind = Brdf::Ggx {
                    alpha,
                    correlated: true,
                };
                let scale = lobe_scale(&kind).unwrap();
                let tree =
                    LightTree::new(prepare(&env, &ex, glam::DMat3::IDENTITY, scale.min(1.0)));
                let sc = scene(
                    cam,
                    vec![object(unit_sphere(), kind, [1.0; 3], fis(16))],
                    false,
                    size,
                );
                let r = render(&ctx, &sc, &env).unwrap();
                let mut worst = [Errors::new(), Errors::new()];
                let mut n = 0;
                for (k, normal, d) in common::scenes::sphere_pixels(&cam) {
                    let bias = envlight::scene::defaults::FIS_BIAS_RESIDUAL;
                    let px = r.frame.texels[k];
                    for (chain, worst) in chains.iter().zip(&mut worst) {
                        let f = fis64::estimate(chain, &kind, normal, -d, 16, bias, [0.0; 2]);
                        let lum = envlight::math::envmap::luminance(f);
                        let l = tree.sum_brdf(&kind, normal, -d, scale, lum);
                        for c in 0..3 {
                            worst.rel(px[c], f[c] + l[c], 1e-3, (k, c));
                        }
                    }
                    n += 1;
                }
                eprintln!(
                    "α {alpha}, paraboloid {size} of the residual halved: {n} pixels, \
                     worst {:.2e} against the halved twin, {:.2e} against the whole",
                    worst[0].worst(),
                    worst[1].worst()
                );
                assert!(n > 150);
                let [halved, whole] = [0, 1].map(|k| worst[k].worst());
                assert!(halved < 1e-4, "α {alpha} {size}: {halved:e}");
                assert!(whole < bound, "α {alpha} {size}: {whole:e}");
            }
        }
    }
    common::finish(ctx);
}

/// The render builds the paraboloid's conversion pipelines (the fast path and the general
/// walk's list) before the lights are extracted, specialised on the chords per texel edge;
/// the record takes the same ones, so one of each is built: GGX α 0.3 with 64 samples (a
/// paraboloid of 128) on the sky with its sun (a residual), on a smooth map with no texel
/// above the lights' threshold (the whole map, as sunless), and with the lights left in the
/// map.
#[test]
fn the_paraboloid_pipeline_built_early_is_the_one_recorded() {
    use envlight::scene::LightsMode;
    let sky = envlight::math::synth::Sky::default();
    let sunny = EnvMap::from_fn(Mapping::LatLong, 512, 256, 1, |d| sky.radiance(d));
    let dull = EnvMap::from_fn(Mapping::LatLong, 512, 256, 1, |d| {
        [1.0 + 0.2 * d.y, 1.0 + 0.1 * d.x, 1.0]
    });
    let ggx = Brdf::Ggx {
        alpha: 0.3,
        correlated: false,
    };
    for (what, env, lights) in [
        ("sun, extracted", &sunny, LightsMode::Extract),
        ("no light", &dull, LightsMode::Extract),
        ("sun, left in", &sunny, LightsMode::None),
    ] {
        let ctx = common::ctx();
        {
            let mut sc = scene(
                sphere_camera(16),
                vec![object(unit_sphere(), ggx, [1.0; 3], fis(64))],
                false,
                0,
            );
            sc.fis.size = None;
            sc.environment.lights = lights;
            let r = render(&ctx, &sc, env).unwrap();
            assert!(r.frame.texels.iter().flatten().all(|v| v.is_finite()));
            let created = envlight::passes::testing::pipelines_created(&ctx);
            let built = |name: &str| created.iter().filter(|p| **p == name).count();
            let paraboloid = [
                "convert_area_fast_paraboloid",
                "convert_area_list_paraboloid",
                "convert_area_paraboloid",
            ]
            .map(built);
            assert_eq!(paraboloid, [1, 1, 0], "{what}: {created:?}");
        }
        common::finish(ctx);
    }
}

/// The shade pass's light tree walks end on a subgroup vote where the device has one (on
/// llvmpipe a lane's own break does not end a loop: it runs on to its bound); without
/// subgroups ([`Subgroups::Off`]) each lane ends alone. Both must give the same frame:
/// FIS, split-sum and a footprint-filtered mirror with lights extracted, and the filtered
/// background, seen in perspective (footprints of every size), on the sky whose sun is
/// 5·10⁴ × the zenith. Bound 1e-6 relative: the same float32 operations in the same
/// order (measured: printed).
#[test]
fn walks_ending_by_vote_match_walks_ending_alone() {
    use envlight::math::camera::{Camera, Projection};
    use envlight::math::synth::Sky;
    use envlight::passes::shade::Subgroups;
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, move |d| sky.radiance(d));
        let cam = Camera {
            projection: Projection::Perspective { fov_y: 70.0 },
            eye: [0.0, 0.3, 4.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            width: 40,
            height: 24,
        };
        let at = |x: f64| Shape::Sphere {
            center: [x, 0.0, 0.0],
            radius: 0.9,
        };
        let ggx = |alpha| Brdf::Ggx {
            alpha,
            correlated: true,
        };
        let sc = scene(
            cam,
            vec![
                object(at(-2.0), ggx(0.1), [1.0; 3], fis(16)),
                object(at(0.0), ggx(0.3), [1.0; 3], Technique::SplitSum),
                object(at(2.0), Brdf::Mirror, [1.0; 3], Technique::Lookup),
            ],
            false,
            32,
        );
        if !common::require(
            ctx.info().fragment_vote,
            "subgroup vote in fragment shaders",
        ) {
            return;
        }
        let mut frames = Vec::new();
        for subgroups in [Subgroups::Auto, Subgroups::Off] {
            let before = envlight::passes::testing::pipelines_created(&ctx).len();
            let mut renderer = envlight::render::Renderer::new(&ctx);
            renderer.set_subgroups(subgroups);
            frames.push(renderer.render(&sc, &env).unwrap().frame);
            // Each arm built its own shading module: the vote's, then the lone walks'.
            let made = envlight::passes::testing::pipelines_created(&ctx)[before..].to_vec();
            let votes = made.iter().filter(|m| m.starts_with("shade_vote")).count();
            let alone = made
                .iter()
                .filter(|m| m.starts_with("shade") && !m.starts_with("shade_vote"))
                .count();
            let want = if subgroups == Subgroups::Auto {
                (1, 0)
            } else {
                (0, 1)
            };
            assert_eq!((votes, alone), want, "{subgroups:?}: {made:?}");
        }
        let (mut errors, mut bright) = (Errors::new(), 0);
        for (k, (a, b)) in frames[0].texels.iter().zip(&frames[1].texels).enumerate() {
            for c in 0..3 {
                errors.rel(a[c], b[c], 1e-3, (k, c));
            }
            if a[1] > 10.0 {
                bright += 1;
            }
        }
        let worst = errors.worst();
        eprintln!(
            "vote (device has it: {}) against alone: worst {worst:.2e}, {bright} bright pixels",
            ctx.info().fragment_vote
        );
        assert!(worst < 1e-6, "worst {worst:e}");
    }
    common::finish(ctx);
}

/// FIS builds its paraboloid only as fine as its lobes read (`Scene::fis_dp_size`): on the
/// sky with a sun 5·10⁴ × the zenith (512 × 256), GGX α 0.3 and 0.6 with 64 samples read a
/// paraboloid 4× and 8× coarser than the source-sized one. With lights extracted (the
/// default) the render is the source-sized render's to float rounding (relative RMS over the
/// sphere 6.2e-7 and 4.7e-6 measured, the second of the residual halved for the paraboloid of
/// 64, bound 2e-5). With the sun left in the chain the
/// coarser chain's level 0 and the finer chain's level are means over the same footprints
/// taken in two steps, and grazing views past 80° may read below lod 0: 5.9e-4 and 1.65e-3
/// measured, bounds 8e-4 and 2.2e-3 (1.3×); a paraboloid half as fine again errs by 3.0e-3
/// at α 0.3. A
/// perspective camera (its background reads the chain at pixel size), a split-sum object, a
/// mirror or an explicit size keep the source-sized paraboloid, and so does a map the area
/// conversion does not serve.
#[test]
fn lobe_sized_paraboloid_reads_as_the_source_sized_one() {
    use common::scenes::{rel_rms, sphere_pixels};
    use envlight::math::camera::Projection;
    use envlight::math::fis::default_dp_size;
    use envlight::scene::LightsMode;
    use envlight::scene::MapShape;
    let ctx = common::ctx();
    {
        let sky = envlight::math::synth::Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 512, 256, 2, |d| sky.radiance(d));
        let full = default_dp_size(&env);
        let cam = sphere_camera(40);
        let pixels = sphere_pixels(&cam);
        for (alpha, want, sun_bound) in [(0.3, full / 4, 8e-4), (0.6, full / 8, 2.2e-3)] {
            let kind = Brdf::Ggx {
                alpha,
                correlated: false,
            };
            for (lights, bound) in [(LightsMode::Extract, 2e-5), (LightsMode::None, sun_bound)] {
                let mut sc = scene(
                    cam,
                    vec![object(unit_sphere(), kind, [1.0; 3], fis(64))],
                    false,
                    0,
                );
                sc.fis.size = None;
                sc.environment.lights = lights;
                assert_eq!(sc.fis_dp_size(MapShape::of(&env)), want, "α {alpha}");
                let lobe = render(&ctx, &sc, &env).unwrap();
                sc.fis.size = Some(full);
                let whole = render(&ctx, &sc, &env).unwrap();
                let e = rel_rms(&lobe.frame, &whole.frame, &pixels);
                eprintln!(
                    "α {alpha}, {lights:?}: paraboloid {want} against {full}: relative RMS {e:.2e}"
                );
                assert!(e < bound, "α {alpha} {lights:?}: {e:e}");
                assert!(lobe.frame.texels.iter().flatten().all(|v| v.is_finite()));
            }
        }
        let ggx = Brdf::Ggx {
            alpha: 0.3,
            correlated: false,
        };
        let base = scene(
            cam,
            vec![object(unit_sphere(), ggx, [1.0; 3], fis(64))],
            false,
            0,
        );
        let mut perspective = base.clone();
        perspective.fis.size = None;
        perspective.camera.projection = Projection::Perspective { fov_y: 40.0 };
        assert_eq!(perspective.fis_dp_size(MapShape::of(&env)), full);
        let mut split = perspective.clone();
        split.camera = cam;
        split
            .objects
            .push(object(unit_sphere(), ggx, [1.0; 3], Technique::SplitSum));
        assert_eq!(split.fis_dp_size(MapShape::of(&env)), full);
        let mut mirror = split.clone();
        mirror.objects[1] = object(unit_sphere(), Brdf::Mirror, [1.0; 3], Technique::Lookup);
        assert_eq!(mirror.fis_dp_size(MapShape::of(&env)), full);
        mirror.objects.pop();
        assert_eq!(mirror.fis_dp_size(MapShape::of(&env)), full / 4);
        mirror.fis.size = Some(64);
        assert_eq!(mirror.fis_dp_size(MapShape::of(&env)), 64);
        let cube = EnvMap::from_fn(Mapping::Cube, 128, 128, 2, |d| sky.radiance(d));
        mirror.fis.size = None;
        assert_eq!(
            mirror.fis_dp_size(MapShape::of(&cube)),
            default_dp_size(&cube)
        );
    }
    common::finish(ctx);
}
