//! The library's bake of a set (`bake::set`), called as an application calls it, with no
//! process spawned: resumed runs, the per-probe lock, shards and item ranges with their
//! merge, separate lights, and a bad input among good ones. The command line's own tests
//! (cli_bake.rs, slurm.rs) run the same code through `envlight bake`.

mod common;

use common::bake::{probes, temp, walk};
use envlight::bake::manifest::{lock_probe, Entry, Failure, Manifest};
use envlight::bake::plan::{BakePlan, BakeSettings, LightsKey, LightsMode};
use envlight::bake::set::{merge, Part, ProbeSet, Progress, SetBake, Silent, Written};
use envlight::bake::Baker;
use envlight::Context;
use std::path::{Path, PathBuf};

/// Small cubes: the set's plumbing is under test, not the filters.
fn plan(lights: LightsMode) -> BakePlan {
    let mut s = BakeSettings::default();
    s.specular_size = Some(16);
    s.specular_levels = Some(4);
    s.irradiance_size = Some(8);
    s.samples = Some(16);
    s.check = Some(0);
    s.lights = Some(LightsKey::Mode(lights));
    BakePlan::new(&s).unwrap()
}

fn run(
    ctx: &Context,
    baker: &Baker,
    set: &ProbeSet,
    plan: &BakePlan,
    out: &Path,
    part: Part,
) -> Written {
    SetBake::new(set, plan, out, part)
        .unwrap()
        .run(ctx, baker, false, &Silent)
        .unwrap()
}

/// A scratch folder named `name` with the three small probes in `in/`, its output folder
/// `out/`, and a baker.
fn scratch(ctx: &Context, name: &str) -> (PathBuf, PathBuf, Baker) {
    let dir = temp(name);
    let (inputs, out) = (dir.join("in"), dir.join("out"));
    std::fs::create_dir_all(&inputs).unwrap();
    probes(&inputs);
    (inputs, out, Baker::new(ctx).unwrap())
}

fn statuses(m: &Manifest) -> Vec<&str> {
    m.probes.iter().map(|e| e.status.as_str()).collect()
}

/// Every file under `dir` but the manifests, records and gallery (which hold timings), with
/// its bytes.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<(PathBuf, Vec<u8>)> = walk(dir)
        .into_iter()
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            !(n.starts_with("manifest") || n == "probe.json" || n == ".lock" || n == "index.html")
        })
        .map(|p| {
            (
                p.strip_prefix(dir).unwrap().to_path_buf(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// A second run skips every probe its manifest holds intact, a changed input is baked again
/// (and only it), a deleted output brings its probe back, and each run's manifest lists
/// every probe in order.
#[test]
fn a_rerun_bakes_only_what_changed() {
    let ctx = common::ctx();
    {
        let (inputs, out, baker) = scratch(&ctx, "set-resume");
        let maps = probes(&inputs);
        let plan = plan(LightsMode::Exact);
        let set = ProbeSet::new([inputs.clone()]).unwrap();
        assert_eq!(set.len(), 3);
        let first = run(&ctx, &baker, &set, &plan, &out, Part::All);
        assert_eq!(statuses(&first.manifest), ["baked"; 3]);
        assert_eq!(first.path, out.join("manifest.json"));
        let before = files(&out);
        let again = run(&ctx, &baker, &set, &plan, &out, Part::All);
        assert_eq!(statuses(&again.manifest), ["skipped"; 3]);
        assert_eq!(
            files(&out),
            before,
            "a skipped probe's files are left alone"
        );
        // p1 changes; p2 loses an output.
        let mut m = maps[1].clone();
        m.texels[0][0] += 1.0;
        envlight::io::save_exr(&m, inputs.join("p1.exr")).unwrap();
        std::fs::remove_file(out.join("p2.exr").join("specular.ktx2")).unwrap();
        let third = run(&ctx, &baker, &set, &plan, &out, Part::All);
        assert_eq!(statuses(&third.manifest), ["skipped", "baked", "baked"]);
        let inputs: Vec<&str> = third
            .manifest
            .probes
            .iter()
            .map(|e| e.input.as_str())
            .collect();
        assert_eq!(inputs, set.names());
    }
    common::finish(ctx);
}

/// A [`Progress`] that forwards what the run tells the user.
struct Notes(std::sync::mpsc::Sender<String>);

impl Progress for Notes {
    fn note(&self, message: &str) {
        let _ = self.0.send(message.to_string());
    }
}

/// A probe whose lock another bake holds waits for it: the run says so, bakes once the lock
/// is free, and records the wait; the lock is free again after the run.
#[test]
fn a_locked_probe_waits_for_the_other_bake() {
    let ctx = common::ctx();
    {
        let (inputs, out, baker) = scratch(&ctx, "set-lock");
        let plan = plan(LightsMode::Exact);
        let set = ProbeSet::new([inputs.join("p0.exr"), inputs.join("p1.exr")]).unwrap();
        let (held, waited) = lock_probe(&out, "p1.exr", || {}).unwrap();
        assert_eq!(waited, None);
        let (tx, rx) = std::sync::mpsc::channel();
        let written = std::thread::scope(|s| {
            let job = SetBake::new(&set, &plan, &out, Part::All).unwrap();
            let (ctx, baker) = (&ctx, &baker);
            let running = s.spawn(move || job.run(ctx, baker, false, &Notes(tx)).unwrap());
            let note = rx.recv().unwrap();
            assert_eq!(note, "waiting for another bake of p1.exr to finish");
            std::thread::sleep(std::time::Duration::from_millis(100));
            drop(held);
            running.join().unwrap()
        });
        assert_eq!(statuses(&written.manifest), ["baked", "baked"]);
        let waits: Vec<Option<f64>> = written
            .manifest
            .probes
            .iter()
            .map(|e| e.lock_wait_seconds)
            .collect();
        assert_eq!(waits[0], None);
        assert!(waits[1].is_some_and(|w| w >= 0.05), "{waits:?}");
        let (_again, waited) = lock_probe(&out, "p1.exr", || panic!("still locked")).unwrap();
        assert_eq!(waited, None);
    }
    common::finish(ctx);
}

/// Two shards of one set, baked into one folder and merged, hold the files of a whole run
/// byte for byte, with every probe once in the merged manifest; so do two item ranges. A
/// shard of another split into the same folder is refused, as is a merge of nothing.
#[test]
fn shards_and_ranges_merge_into_the_whole_run() {
    let ctx = common::ctx();
    {
        let (inputs, out, baker) = scratch(&ctx, "set-shards");
        let plan = plan(LightsMode::Exact);
        let set = ProbeSet::new([inputs.clone()]).unwrap();
        let whole = out.join("whole");
        run(&ctx, &baker, &set, &plan, &whole, Part::All);
        let shards = out.join("shards");
        let one = run(
            &ctx,
            &baker,
            &set,
            &plan,
            &shards,
            Part::Shard { index: 1, count: 2 },
        );
        assert_eq!(one.path, shards.join("manifest-shard-1-of-2.json"));
        let taken: Vec<&str> = one
            .manifest
            .probes
            .iter()
            .map(|e| e.input.as_str())
            .collect();
        let names = set.names();
        assert_eq!(taken, [names[0].as_str(), names[2].as_str()]);
        let half = merge(&shards).unwrap();
        assert_eq!(half.missing, [(names[1].clone(), "shard 2".to_string())]);
        assert!(!half.complete());
        run(
            &ctx,
            &baker,
            &set,
            &plan,
            &shards,
            Part::Shard { index: 2, count: 2 },
        );
        let merged = merge(&shards).unwrap();
        assert!(merged.complete() && merged.parts == 2);
        let inputs_of = |m: &Manifest| m.probes.iter().map(|e| e.input.clone()).collect::<Vec<_>>();
        assert_eq!(inputs_of(&merged.manifest), names);
        assert_eq!(files(&shards), files(&whole));
        let e = SetBake::new(&set, &plan, &shards, Part::Shard { index: 1, count: 3 })
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("a split into 2"), "{e}");
        let ranges = out.join("ranges");
        run(
            &ctx,
            &baker,
            &set,
            &plan,
            &ranges,
            Part::Items { first: 1, last: 2 },
        );
        run(
            &ctx,
            &baker,
            &set,
            &plan,
            &ranges,
            Part::Items { first: 3, last: 3 },
        );
        let merged = merge(&ranges).unwrap();
        assert!(merged.complete());
        assert_eq!(inputs_of(&merged.manifest), names);
        assert_eq!(files(&ranges), files(&whole));
        let e = merge(&whole).unwrap_err().to_string();
        assert!(e.contains("no shard or range manifests"), "{e}");
    }
    common::finish(ctx);
}

/// With separate lights, the sun sky's probe writes lights.json beside its cubes, listed in
/// its entry with its hash, and the entry's share of the power in lights is lights.json's
/// total; the smooth probe, with no compact light, still bakes.
#[test]
fn separate_lights_are_written_and_recorded() {
    let ctx = common::ctx();
    {
        let (inputs, out, baker) = scratch(&ctx, "set-lights");
        let plan = plan(LightsMode::Separate);
        let set = ProbeSet::new([inputs.join("p0.exr"), inputs.join("p1.exr")]).unwrap();
        let written = run(&ctx, &baker, &set, &plan, &out, Part::All);
        assert_eq!(statuses(&written.manifest), ["baked", "baked"]);
        let sun: &Entry = &written.manifest.probes[1];
        let listed = sun
            .outputs
            .iter()
            .find(|o| o.file.ends_with("lights.json"))
            .expect("lights.json among the outputs");
        let bytes = std::fs::read(out.join(&listed.file)).unwrap();
        assert_eq!(bytes.len() as u64, listed.bytes);
        let json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        let lights = json["lights"].as_array().unwrap();
        assert!(!lights.is_empty(), "{json}");
        let share = sun.separated.expect("the share in lights");
        assert!(share.iter().all(|s| *s > 0.3 && *s < 1.0), "{share:?}");
    }
    common::finish(ctx);
}

/// A file that is not a map fails alone: its entry says why and blames the input; the other
/// probes bake.
#[test]
fn a_bad_input_fails_alone() {
    let ctx = common::ctx();
    {
        let (inputs, out, baker) = scratch(&ctx, "set-bad");
        std::fs::write(inputs.join("bad.hdr"), b"not a map").unwrap();
        let plan = plan(LightsMode::Exact);
        let set = ProbeSet::new([inputs.clone()]).unwrap();
        let written = run(&ctx, &baker, &set, &plan, &out, Part::All);
        assert_eq!(
            statuses(&written.manifest),
            ["failed", "baked", "baked", "baked"]
        );
        let bad = &written.manifest.probes[0];
        assert_eq!(bad.failure, Some(Failure::Input));
        let error = bad.error.as_deref().unwrap();
        assert!(
            error.contains("bad.hdr") && error.contains("unrecognised file format"),
            "{error}"
        );
        let e = ProbeSet::new([inputs.join("p0.exr"), inputs.join("sub").join("p0.exr")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("share a file name"), "{e}");
    }
    common::finish(ctx);
}

/// Each baked probe gets preview.png, listed among its outputs with its check in its entry
/// (rgba32f files: nothing lost, so files and intent agree to float32's rounding); without
/// previews there is neither, and the settings say so.
#[test]
fn previews_are_written_and_recorded_unless_turned_off() {
    let ctx = common::ctx();
    {
        let (inputs, out, baker) = scratch(&ctx, "set-previews");
        let set = ProbeSet::new([inputs.join("p0.exr"), inputs.join("p1.exr")]).unwrap();
        let with = plan(LightsMode::Exact);
        let written = run(&ctx, &baker, &set, &with, &out, Part::All);
        for e in &written.manifest.probes {
            let listed = e.outputs.iter().find(|o| o.file.ends_with("/preview.png"));
            let listed = listed.expect("preview.png among the outputs");
            assert!(out.join(&listed.file).is_file());
            let check = e.preview.as_ref().expect("the preview's check");
            assert_eq!(check.files_vs_intent.len(), 5);
            assert!(check.worst < 1e-6, "{check:?}");
        }
        assert!(written.manifest.settings.preview);
        assert!(out.join("index.html").is_file());

        let mut without = plan(LightsMode::Exact);
        without.preview = false;
        let out2 = out.with_file_name("out-no-preview");
        let written = run(&ctx, &baker, &set, &without, &out2, Part::All);
        for e in &written.manifest.probes {
            assert!(e.preview.is_none());
            assert!(e.outputs.iter().all(|o| !o.file.ends_with("preview.png")));
        }
        assert!(!written.manifest.settings.preview);
        assert!(walk(&out2).iter().all(|p| !p.ends_with("preview.png")));
    }
    common::finish(ctx);
}
