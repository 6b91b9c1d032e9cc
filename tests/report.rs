//! `bench::report::run`, the report's one code path, on one probe: a deliberately wrong
//! technique moves its row and no other. The SH packing pass is poisoned to scale every
//! coefficient it packs by 1.05 (`passes::testing::poison`): the SH rows must move by about
//! that, the rows of every technique that packs no SH coefficient (all but SH and SH-BRDF) must not
//! move.

mod common;

use envlight::bench::report::{run, ExactOn, Hooks, ReportOptions, Row};
use envlight::passes::testing::poison::{self, Corruption, PassId, Poison};

/// The quick set on venice_sunset at 8², scored against the float64 exact sums.
fn rows(ctx: &envlight::gpu::Context, dir: &std::path::Path) -> Vec<Row> {
    let mut o = ReportOptions::new(true);
    o.size = 8;
    o.exact_on = ExactOn::Host;
    o.probes = vec!["venice_sunset_1k".into()];
    let hooks = Hooks {
        // The whole-process time is not what this test checks.
        process: &|_| Ok(1.0),
        peers: &|_| Ok(Vec::new()),
        progress: &|_| {},
    };
    run(ctx, dir, &o, &hooks).unwrap().rows
}

#[test]
fn a_mis_scaled_sh_moves_its_rows_and_no_other() {
    let Some(dir) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    let clean = rows(&ctx, &dir);
    poison::set(
        &ctx,
        Some(Poison {
            pass: PassId::ShPack,
            corruption: Corruption::Scale(1.05),
        }),
    );
    let wrong = rows(&ctx, &dir);
    poison::set(&ctx, None);
    assert_eq!(clean.len(), wrong.len());
    let mut moved = 0;
    for (c, w) in clean.iter().zip(&wrong) {
        assert_eq!((c.label(), &c.material), (w.label(), &w.material));
        let shift = w.rms - c.rms;
        eprintln!(
            "{} {}: {:.3e} → {:.3e}",
            c.material,
            c.label(),
            c.rms,
            w.rms
        );
        if c.technique == "sh" {
            // 5% on the SH part of the shading (the lights, added apart, are not scaled).
            assert!(shift > 0.02, "{}: {} → {}", c.label(), c.rms, w.rms);
            moved += 1;
        } else if c.technique != "sh_brdf" {
            // Unchanged (to rounding: lavapipe's threads may add in another order).
            let still = shift.abs() <= 1e-6 * c.rms;
            assert!(
                still,
                "{} {} moved: {} → {}",
                c.material,
                c.label(),
                c.rms,
                w.rms
            );
        }
    }
    assert!(moved >= 2, "no SH row");
    common::finish(ctx);
}

/// A technique's spheres are drawn together (one render: the same wall time in both rows),
/// and each scores as its sphere alone does: SH-BRDF l = 2 on GGX 0.3 rendered alone,
/// scored against the same exact sums, gives the row's relative RMS to 1e-6 (seen 1e-8:
/// the float32 ray setup of a wider frame moves normals by an ulp or so).
#[test]
fn spheres_drawn_together_score_as_alone() {
    use envlight::math::brdf::Brdf;
    use envlight::render::score::{errors, exact_truth, scene, sphere_pixels};
    use envlight::scene::{SplitSumSettings, Technique};
    let Some(dir) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    let rows = rows(&ctx, &dir);
    let pick = |material: &str| {
        rows.iter()
            .find(|r| r.material == material && r.label() == "sh_brdf l=2")
            .unwrap_or_else(|| panic!("no sh_brdf l=2 row for {material}"))
    };
    let (diffuse, ggx) = (pick("diffuse"), pick("ggx 0.3"));
    assert_eq!(diffuse.wall_s, ggx.wall_s, "drawn apart");
    let env = envlight::io::load(dir.join("venice_sunset_1k.hdr"), &Default::default()).unwrap();
    let cam = envlight::math::camera::sphere_camera(8);
    let brdf = Brdf::Ggx {
        alpha: 0.3,
        correlated: true,
    };
    let w2f = envlight::math::Orientation::default().world_to_file();
    let truth = exact_truth(&cam, brdf, &env, w2f);
    let t = Technique::ShBrdf {
        order: 2,
        grid: envlight::math::sh_brdf::DEFAULT_GRID,
        window: None,
    };
    let o = ReportOptions::new(true);
    let sc = scene(cam, brdf, t, o.paraboloid(), 7, SplitSumSettings::default());
    let r = envlight::render::Renderer::new(&ctx)
        .render(&sc, &env)
        .unwrap();
    let alone = errors(&r.frame, &truth, &sphere_pixels(&cam)).0;
    eprintln!("alone {alone:.6e}, drawn together {:.6e}", ggx.rms);
    assert!((alone - ggx.rms).abs() <= 1e-6, "{alone} vs {}", ggx.rms);
    common::finish(ctx);
}
