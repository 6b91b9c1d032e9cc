//! A render runs exactly the passes its plan lists and creates no other pipeline.

mod common;

use common::compare::{abs_err, max_abs, max_of};
use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::render::{plan, render, PassKind, Renderer};
use envlight::scene::{LookupFilter, Scene, Technique};
use envlight::EnvMap;
use std::path::Path;

/// The shipped example scenes (diffuse only, mirror only, SH-BRDF, glossy, mixed with
/// shadows, and every material), at a small resolution on a small sky: the passes the timing records show
/// equal the plan; each planned pass created its pipelines; no pipeline outside the plan was
/// created (each scene on a fresh context, whose log lists every pipeline made on it).
#[test]
fn renders_run_exactly_the_planned_passes() {
    let sky = Sky::default();
    let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    let expect: [(&str, &[PassKind]); 7] = [
        (
            "diffuse.toml",
            &[PassKind::ShProjection, PassKind::GBuffer, PassKind::Shade],
        ),
        (
            "mirror.toml",
            &[
                PassKind::DualParaboloid,
                PassKind::MipChain,
                PassKind::GBuffer,
                PassKind::Shade,
            ],
        ),
        (
            "sh_brdf.toml",
            &[
                PassKind::ShProjection,
                PassKind::ShBrdfTable,
                PassKind::GBuffer,
                PassKind::Shade,
            ],
        ),
        (
            "split_sum.toml",
            &[
                PassKind::DualParaboloid,
                PassKind::MipChain,
                PassKind::SplitSum,
                PassKind::GBuffer,
                PassKind::Shade,
            ],
        ),
        (
            "glossy.toml",
            &[
                PassKind::DualParaboloid,
                PassKind::MipChain,
                PassKind::GBuffer,
                PassKind::Shade,
            ],
        ),
        (
            "mixed_shadows.toml",
            &[
                PassKind::DualParaboloid,
                PassKind::MipChain,
                PassKind::GBuffer,
                PassKind::MonteCarlo,
                PassKind::Shade,
            ],
        ),
        (
            "materials.toml",
            &[
                PassKind::ShProjection,
                PassKind::DualParaboloid,
                PassKind::MipChain,
                PassKind::Prefilter,
                PassKind::GBuffer,
                PassKind::MonteCarlo,
                PassKind::Shade,
            ],
        ),
    ];
    // Point lookups need no chain; a background asked to be filtered builds one.
    let mut mirror = Scene::load(&dir.join("mirror.toml")).unwrap();
    mirror.environment.filter = LookupFilter::Point;
    let point = [PassKind::GBuffer, PassKind::Shade];
    assert_eq!(plan(&mirror, &env).kinds(), point);
    let mut diffuse = Scene::load(&dir.join("diffuse.toml")).unwrap();
    diffuse.environment.filter = LookupFilter::Footprint;
    assert!(plan(&diffuse, &env).kinds().contains(&PassKind::MipChain));
    for (file, kinds) in expect {
        let mut sc = Scene::load(&dir.join(file)).unwrap();
        let p = plan(&sc, &env);
        assert_eq!(p.kinds(), kinds, "{file}: plan");
        small(&mut sc);
        let ctx = common::ctx();
        {
            let r = render(&ctx, &sc, &env).unwrap();
            assert_eq!(r.kinds(), kinds, "{file}: passes run");
            assert!(r
                .records
                .iter()
                .all(|rec| !rec.timings.is_empty() || ctx.info().timestamp_valid_bits == 0));
            let created = envlight::passes::testing::pipelines_created(&ctx);
            let allowed: Vec<&str> = kinds.iter().flat_map(|k| k.pipelines()).collect();
            for name in &created {
                assert!(
                    allowed.contains(name),
                    "{file}: pipeline {name} is outside the plan {kinds:?}"
                );
            }
            for k in kinds {
                assert!(
                    k.pipelines().iter().any(|n| created.contains(n)),
                    "{file}: {k:?} created none of {:?}",
                    k.pipelines()
                );
            }
            eprintln!("{file}: {:?} -> pipelines {created:?}", r.kinds());
        }
        common::finish(ctx);
    }
}

/// Makes `sc` small and quick: the plan does not depend on resolution or sample counts.
fn small(sc: &mut Scene) {
    sc.camera.width = 24;
    sc.camera.height = 16;
    sc.fis.size = Some(16);
    for o in &mut sc.objects {
        match &mut o.material.technique {
            Some(Technique::Mc { samples, .. }) => *samples = 8,
            Some(Technique::Prefiltered { size }) => *size = 8,
            _ => {}
        }
    }
}

/// A scene of one technique is shaded by shade.frag's variant for that technique, whose
/// other techniques' code the preprocessor removes (the whole shader folds it by its
/// specialisation constant, which llvmpipe compiles 3x slower). Each of the seven
/// techniques, from the shipped scenes with the objects of one technique kept, and mirrors
/// with point lookups, render with their variant and with the whole shader on one context: the frames agree within 1e-6 of
/// the frame's largest value (the same arithmetic once folded; the tolerance leaves the
/// driver room to order it differently), and the variant built is one shade pipeline besides
/// the whole shader's. Each scene renders with shadows, which take a variant's whole module,
/// and without shadows or footprint lookups, which take its LEAN one (their code removed).
#[test]
fn one_technique_scenes_take_their_shade_variant_and_match_the_whole_shader() {
    let sky = Sky::default();
    let env = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    // Mirrors without a chain: point lookups.
    let mut point = Scene::load(&dir.join("mirror.toml")).unwrap();
    point.environment.filter = LookupFilter::Point;
    small(&mut point);
    let mut scenes: Vec<(String, Scene)> = vec![("mirror.toml, point".into(), point)];
    for file in [
        "mirror.toml",
        "glossy.toml",
        "diffuse.toml",
        "materials.toml",
        "mixed_shadows.toml",
        "sh_brdf.toml",
        "split_sum.toml",
    ] {
        let sc = Scene::load(&dir.join(file)).unwrap();
        for o in &sc.objects {
            let t = o.material.technique();
            let kind = std::mem::discriminant(&t);
            if scenes
                .iter()
                .skip(1)
                .any(|(_, s)| std::mem::discriminant(&s.objects[0].material.technique()) == kind)
            {
                continue;
            }
            let mut one = sc.clone();
            one.objects
                .retain(|p| std::mem::discriminant(&p.material.technique()) == kind);
            small(&mut one);
            scenes.push((format!("{file}, {t:?}"), one));
        }
    }
    assert_eq!(scenes.len(), 8, "every technique once, and point mirrors");
    // Each with shadows (a variant's whole module) and without shadows or footprint lookups
    // (its LEAN module).
    let cases: Vec<(String, Scene)> = scenes
        .iter()
        .flat_map(|(what, sc)| {
            let mut shadows = sc.clone();
            shadows.shadows = true;
            let mut lean = sc.clone();
            lean.shadows = false;
            lean.environment.filter = LookupFilter::Point;
            [
                (format!("{what}, shadows"), shadows),
                (format!("{what}, no shadows, point lookups"), lean),
            ]
        })
        .collect();
    let mut variants = Vec::new();
    for (what, sc) in &cases {
        let ctx = common::ctx();
        {
            let variant = Renderer::new(&ctx).render(sc, &env).unwrap();
            let shades = |ctx: &envlight::gpu::Context| -> Vec<&str> {
                envlight::passes::testing::pipelines_created(ctx)
                    .into_iter()
                    .filter(|p| p.starts_with("shade"))
                    .collect()
            };
            let built = shades(&ctx);
            let mut renderer = Renderer::new(&ctx);
            renderer.set_whole_shade();
            let whole = renderer.render(sc, &env).unwrap();
            let both = shades(&ctx);
            let whole_name = if ctx.info().fragment_vote {
                "shade_vote"
            } else {
                "shade"
            };
            assert_eq!(built.len(), 1, "{what}: {built:?}");
            assert!(built[0] != whole_name, "{what}: {built:?}");
            assert_eq!(both, [built[0], whole_name], "{what}");
            let peak = max_abs(whole.frame.texels.iter().flatten().copied());
            assert!(peak > 0.0, "{what}: a black frame");
            let worst = max_of(
                variant
                    .frame
                    .texels
                    .iter()
                    .zip(&whole.frame.texels)
                    .enumerate()
                    .flat_map(|(k, (a, b))| (0..3).map(move |c| abs_err(a[c], b[c], (k, c)))),
            );
            eprintln!(
                "{what}: {} vs {whole_name}, worst {:.1e} of {peak}",
                built[0], worst
            );
            assert!(worst <= 1e-6 * peak, "{what}: {worst} of {peak}");
            assert_eq!(
                built[0].contains("_lean_"),
                !sc.shadows,
                "{what}: {built:?}"
            );
            variants.push(built[0]);
        }
        common::finish(ctx);
    }
    // The mirrors with a chain take the FIS variant, which keeps the lookup's code too.
    variants.sort_unstable();
    variants.dedup();
    assert_eq!(
        variants.len(),
        14,
        "each variant's two modules: {variants:?}"
    );
}

/// Monte Carlo alone: on a lat-long map it needs nothing but the G-buffer, its frames and the
/// shading; on a cube map it first converts to lat-long (and so builds that pipeline only).
#[test]
fn monte_carlo_alone_plans_and_runs_its_passes() {
    let sky = Sky::default();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    let mut sc = Scene::load(&dir.join("diffuse.toml")).unwrap();
    sc.camera.width = 16;
    sc.camera.height = 12;
    for o in &mut sc.objects {
        o.material.technique = Some(envlight::scene::Technique::Mc {
            samples: 8,
            error: None,
        });
    }
    for (mapping, w, h) in [(Mapping::LatLong, 32, 16), (Mapping::Cube, 8, 8)] {
        let env = EnvMap::from_fn(mapping, w, h, 2, |d| sky.radiance(d));
        let mut kinds = vec![PassKind::GBuffer, PassKind::MonteCarlo, PassKind::Shade];
        let mut pipelines = vec!["gbuffer", "mc", "shade"];
        if mapping == Mapping::Cube {
            kinds.insert(1, PassKind::LatLong);
            pipelines.insert(1, "convert_cube");
        }
        assert_eq!(plan(&sc, &env).kinds(), kinds);
        let ctx = common::ctx();
        {
            let r = render(&ctx, &sc, &env).unwrap();
            assert_eq!(r.kinds(), kinds);
            assert_eq!(r.mc.map(|m| m.0), Some(8));
            // The shade pass's Monte Carlo variant, with vote where fragment shaders have it,
            // LEAN (no shadows, no footprint lookups).
            let shade = if ctx.info().fragment_vote {
                "shade_vote_lean_mc"
            } else {
                "shade_lean_mc"
            };
            let mut want: Vec<&str> = pipelines
                .iter()
                .map(|&p| if p == "shade" { shade } else { p })
                .collect();
            // In any order: the shade pipeline builds beside the host's light extraction.
            let mut created = envlight::passes::testing::pipelines_created(&ctx);
            created.sort_unstable();
            want.sort_unstable();
            assert_eq!(created, want);
        }
        common::finish(ctx);
    }
}
