//! A render runs exactly the passes its plan lists and creates no other pipeline.

mod common;

use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::render::render;
use envlight::scene::{plan, LookupFilter, PassKind, Scene};
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
    assert_eq!(plan(&mirror, Mapping::LatLong).kinds(), point);
    let mut diffuse = Scene::load(&dir.join("diffuse.toml")).unwrap();
    diffuse.environment.filter = LookupFilter::Footprint;
    assert!(plan(&diffuse, Mapping::LatLong)
        .kinds()
        .contains(&PassKind::MipChain));
    for (file, kinds) in expect {
        let mut sc = Scene::load(&dir.join(file)).unwrap();
        let p = plan(&sc, Mapping::LatLong);
        assert_eq!(p.kinds(), kinds, "{file}: plan");
        // Small and quick: the plan does not depend on resolution or sample counts.
        sc.camera.width = 24;
        sc.camera.height = 16;
        sc.fis.size = Some(16);
        for o in &mut sc.objects {
            match &mut o.material.technique {
                Some(envlight::scene::Technique::Mc { samples, .. }) => *samples = 8,
                Some(envlight::scene::Technique::Prefiltered { size }) => *size = 8,
                _ => {}
            }
        }
        let ctx = common::ctx();
        {
            let r = render(&ctx, &sc, &env).unwrap();
            assert_eq!(r.kinds(), kinds, "{file}: passes run");
            assert!(r
                .records
                .iter()
                .all(|rec| !rec.timings.is_empty() || ctx.info().timestamp_valid_bits == 0));
            let created = ctx.pipelines_created();
            let allowed: Vec<&str> = kinds
                .iter()
                .flat_map(|k| k.pipelines().iter().map(|id| id.name()))
                .collect();
            for name in &created {
                assert!(
                    allowed.contains(name),
                    "{file}: pipeline {name} is outside the plan {kinds:?}"
                );
            }
            for k in kinds {
                assert!(
                    k.pipelines().iter().any(|n| created.contains(&n.name())),
                    "{file}: {k:?} created none of {:?}",
                    k.pipelines()
                );
            }
            eprintln!("{file}: {:?} -> pipelines {created:?}", r.kinds());
        }
        common::finish(ctx);
    }
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
        assert_eq!(plan(&sc, mapping).kinds(), kinds);
        let ctx = common::ctx();
        {
            let r = render(&ctx, &sc, &env).unwrap();
            assert_eq!(r.kinds(), kinds);
            assert_eq!(r.mc.map(|m| m.0), Some(8));
            // The shade pass's vote variant where fragment shaders have subgroup vote.
            let shade = if ctx.info().fragment_vote {
                "shade_vote"
            } else {
                "shade"
            };
            let mut want: Vec<&str> = pipelines
                .iter()
                .map(|&p| if p == "shade" { shade } else { p })
                .collect();
            // In any order: the shade pipeline builds beside the host's light extraction.
            let mut created = ctx.pipelines_created();
            created.sort_unstable();
            want.sort_unstable();
            assert_eq!(created, want);
        }
        common::finish(ctx);
    }
}
