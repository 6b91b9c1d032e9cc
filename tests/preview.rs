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
    bake_with(baker, probe, s, dir)
}

/// As [`bake`], with settings `s` (sizes made small).
fn bake_with(
    baker: &Baker,
    probe: &Path,
    mut s: BakeSettings,
    dir: &Path,
) -> (BakePlan, PreviewCubes) {
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

/// Without a preset the files hold E (not E/π) in envlight's frame; as float32 KTX2 or EXR
/// nothing is lost, so files and intent agree to rounding, with separated lights added back
/// from lights.json; BC6H's blocks show as a loss of their own size.
#[test]
fn own_frames_containers_and_formats_read_back_as_written() {
    use envlight::bake::plan::{Container, LightsKey, LightsMode};
    use envlight::io::ktx2::Ktx2Format;
    let Some(probes) = common::probes() else {
        return;
    };
    let dir = common::bake::temp("preview-own");
    let probe = probes.join("quarry_01_1k.hdr");
    let ctx = common::ctx();
    {
        let baker = Baker::new(&ctx).unwrap();
        let mut cases: Vec<(&str, BakeSettings, f64)> = Vec::new();
        let mut s = BakeSettings::default();
        s.texels = Some(Ktx2Format::Rgba32f);
        cases.push(("rgba32f", s.clone(), 1e-6));
        s.lights = Some(LightsKey::Mode(LightsMode::Separate));
        s.rotate_y = Some(30.0);
        cases.push(("rgba32f, separate lights, turned", s, 1e-6));
        let mut s = BakeSettings::default();
        s.format = Some(Container::Exr);
        cases.push(("exr", s, 1e-6));
        // The BC6H encoder is the `bc6h` feature's (on by default).
        if cfg!(feature = "bc6h") {
            let mut s = BakeSettings::default();
            s.texels = Some(Ktx2Format::Bc6h);
            cases.push(("bc6h", s, 0.05));
        }
        for (name, s, bound) in cases {
            let out = dir.join(name);
            let (plan, intent) = bake_with(&baker, &probe, s, &out);
            let check = preview(&out, &plan, &intent).unwrap().check;
            eprintln!("{name}: files vs intent {:.2e}", check.worst);
            assert!(check.worst <= bound, "{name}: {check:?}");
            assert!(check.worst > 0.0 || name != "bc6h");
        }
    }
    common::finish(ctx);
    let _ = std::fs::remove_dir_all(&dir);
}
