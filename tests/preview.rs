//! The preview is a check: on real probes baked for Bevy and for Khronos' viewer, "files
//! against intent" stays small for the files as written and grows by more than 10× for each
//! way users get the files wrong (`bake::preview::breakage`: a cube mirrored, irradiance π×
//! too bright, the levels in reverse order), applied to the written KTX2 files themselves.

mod common;

use envlight::bake::files::probe_files;
use envlight::bake::output::Preset;
use envlight::bake::plan::{BakePlan, BakeSettings};
use envlight::bake::preview::breakage::Breakage;
use envlight::bake::preview::{preview, PreviewCubes, SPHERES};
use envlight::bake::Baker;
use envlight::LoadOptions;
use std::path::Path;

/// Bakes `probe` with `preset` (cubes 64² so that lavapipe is quick; the files' formats and
/// frames are the preset's) into `dir`; returns the plan and the intent.
fn bake(baker: &Baker, probe: &Path, preset: Preset, dir: &Path) -> (BakePlan, PreviewCubes) {
    let mut s = BakeSettings::default();
    s.preset = Some(preset);
    (s.specular_size, s.irradiance_size, s.samples) = (Some(64), Some(16), Some(64));
    let plan = BakePlan::new(&s).unwrap();
    let map = envlight::load(probe, &LoadOptions::default()).unwrap();
    let (source, lights) = plan.split_lights(map).unwrap();
    let baked = baker
        .submit(&source, &plan.orientation, &plan.options)
        .unwrap()
        .wait()
        .unwrap();
    std::fs::create_dir_all(dir).unwrap();
    for (path, bytes) in probe_files(dir, &baked, &plan, lights.as_ref())
        .unwrap()
        .files
    {
        std::fs::write(path, bytes).unwrap();
    }
    let intent = PreviewCubes::intent(&baked, &plan, lights.as_ref());
    (plan, intent)
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

#[test]
fn files_against_intent_is_small_when_right_and_catches_each_breakage() {
    let Some(probes) = common::probes() else {
        return;
    };
    let dir = common::bake::temp("preview");
    let ctx = common::ctx();
    {
        let baker = Baker::new(&ctx).unwrap();
        // A sun 10⁵× its sky, and a studio of soft boxes.
        for name in ["spiaggia_di_mondello_1k.hdr", "studio_small_08_1k.hdr"] {
            for preset in [Preset::Bevy, Preset::Khronos] {
                let out = dir.join(format!("{name}-{preset:?}"));
                let (plan, intent) = bake(&baker, &probes.join(name), preset, &out);
                let right = preview(&out, &plan, &intent).unwrap().check;
                // The formats' rounding alone: e5b9g9r9's 9-bit mantissas, rgba16f's 11.
                assert!(right.worst <= 0.01, "{name} {preset:?}: {right:?}");
                for b in Breakage::ALL {
                    let broken = dir.join(format!("{name}-{preset:?}-{b:?}"));
                    copy_dir(&out, &broken);
                    b.apply(&broken).unwrap();
                    let got = preview(&broken, &plan, &intent).unwrap().check;
                    // The spheres the breakage concerns.
                    let concerned: Vec<usize> = match b {
                        Breakage::Mirrored => vec![0],
                        Breakage::IrradianceTimesPi => vec![4],
                        Breakage::LevelsReversed => vec![1, 2, 3],
                    };
                    for k in concerned {
                        let (e, base) = (got.files_vs_intent[k], right.files_vs_intent[k]);
                        assert!(
                            e >= 10.0 * base && e >= 0.01,
                            "{name} {preset:?} {}: {} at {e:.2e}, right {base:.2e}",
                            b.name(),
                            SPHERES[k].label()
                        );
                    }
                    assert!(got.worst >= 10.0 * right.worst);
                    eprintln!(
                        "{name} {preset:?}: right {:.2e}, {} {:.2e}",
                        right.worst,
                        b.name(),
                        got.worst
                    );
                }
            }
        }
    }
    common::finish(ctx);
    let _ = std::fs::remove_dir_all(&dir);
}
