//! An asset pipeline baking probes in-process, as an engine's editor would: the same settings
//! a bake file holds, resolved into a plan, each probe baked on the GPU and its files written
//! where the pipeline wants them, byte for byte what `envlight bake` writes for the same
//! settings (`tests/bake_example.rs` checks that), with each probe's preview.
//!
//! `cargo run --example bake PROBE... [--out DIR]` bakes each probe with the Bevy preset and
//! light separation into `DIR/<probe file name>/` (default `out/baked`).

use envlight::bake::files::probe_files;
use envlight::bake::output::Preset;
use envlight::bake::plan::{BakePlan, BakeSettings, LightsKey, LightsMode};
use envlight::bake::preview::{preview, reference_view, PreviewCubes, Source, PREVIEW_FILE};
use envlight::bake::Baker;
use envlight::{Context, ContextOptions, LoadOptions};
use std::path::{Path, PathBuf};

type Error = Box<dyn std::error::Error>;

/// What the pipeline asks for: the preset its engine reads, lights apart, small cubes.
pub fn settings() -> BakeSettings {
    let mut s = BakeSettings::default();
    s.preset = Some(Preset::Bevy);
    s.lights = Some(LightsKey::Mode(LightsMode::Separate));
    s.specular_size = Some(32);
    s.irradiance_size = Some(8);
    s.samples = Some(16);
    s
}

/// Bakes each of `probes` into `out/<file name>/`; returns the files written.
pub fn bake(
    ctx: &Context,
    settings: &BakeSettings,
    probes: &[PathBuf],
    out: &Path,
) -> Result<Vec<PathBuf>, Error> {
    let plan = BakePlan::new(settings)?;
    // Pipelines are built once, for every probe.
    let baker = Baker::new(ctx)?;
    let mut written = Vec::new();
    for probe in probes {
        let map = envlight::load(probe, &LoadOptions::default())?;
        let (source, lights) = plan.split_lights(map)?;
        let baked = baker
            .submit(&source, &plan.orientation, &plan.options)?
            .wait()?;
        let name = probe
            .file_name()
            .ok_or("a probe path without a file name")?;
        let dir = out.join(name);
        std::fs::create_dir_all(&dir)?;
        for (path, bytes) in probe_files(&dir, &baked, &plan, lights.as_ref())?.files {
            std::fs::write(&path, bytes)?;
            written.push(path);
        }
        // The preview, rendered from the files just written and checked against the float
        // data they came from (a pipeline can stop on `check.worst`).
        let intent = PreviewCubes::intent(&baked, &plan, lights.as_ref());
        // Recipe against reference: split-sum against envlight's reference on the map the
        // cubes came from and the lights handed out.
        let source = Source {
            map: &source,
            separated: lights.as_ref(),
        };
        let reference = reference_view(source, &plan);
        let p = preview(&dir, &plan, &intent, Some(&reference))?;
        let path = dir.join(PREVIEW_FILE);
        std::fs::write(&path, p.png)?;
        written.push(path);
    }
    Ok(written)
}

#[allow(dead_code)]
fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let out = match args.iter().position(|a| a == "--out") {
        Some(k) if k + 1 < args.len() => {
            let dir = PathBuf::from(args.remove(k + 1));
            args.remove(k);
            dir
        }
        _ => PathBuf::from("out/baked"),
    };
    let probes: Vec<PathBuf> = args.into_iter().map(PathBuf::from).collect();
    if probes.is_empty() {
        eprintln!("usage: cargo run --example bake PROBE... [--out DIR]");
        std::process::exit(2);
    }
    let run = Context::new(&ContextOptions::default())
        .map_err(Error::from)
        .and_then(|ctx| bake(&ctx, &settings(), &probes, &out));
    match run {
        Ok(files) => {
            for f in files {
                println!("wrote {}", f.display());
            }
        }
        Err(e) => {
            eprintln!("bake example: {e}");
            std::process::exit(1);
        }
    }
}
