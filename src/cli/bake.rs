//! `envlight bake`: a folder of probes to what an engine loads, one folder per probe (SH JSON,
//! irradiance cube, specular cube with a level per roughness), with a manifest that makes
//! re-runs skip what is done, deterministic shards, and a merge of the shards' manifests.
//! The bake is the library's (`bake::set`); this is its arguments, progress bar and summary.

use super::schedule::{exit_for, Exit, EXIT_RETRY};
use super::{context, Global};
use crate::bake::manifest::{Entry, Failure, Manifest};
use crate::bake::plan::{BakePlan, BakeSettings};
use crate::bake::schedule::{parse_items, parse_shard, shard_auto};
use crate::bake::set::{recorded_split, Part, ProbeSet, Progress, SetBake, Written};
use crate::bake::Baker;
use anyhow::{bail, Context as _, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

mod args;

use args::cli_settings;
pub use args::BakeArgs;

/// The inputs: files, folders and glob matches (the library's [`ProbeSet`] takes the files
/// and folders).
fn collect(inputs: &[String]) -> Result<ProbeSet> {
    let mut v = Vec::new();
    for s in inputs {
        let p = PathBuf::from(s);
        if p.exists() {
            v.push(p);
        } else {
            let matches: Vec<PathBuf> = glob::glob(s)
                .with_context(|| format!("{s}: not a file, a folder or a glob"))?
                .filter_map(|m| m.ok())
                .filter(|p| p.is_file())
                .collect();
            if matches.is_empty() {
                bail!("{s}: no such file, and no file matches it as a glob");
            }
            v.extend(matches);
        }
    }
    Ok(ProbeSet::new(v)?)
}

/// The progress bar as a set's bake reports to it: notes printed above it.
struct Bar(ProgressBar);

impl Progress for Bar {
    fn probe(&self, name: &str) {
        self.0.set_message(name.to_string());
    }

    fn done(&self, _entry: &Entry) {
        self.0.inc(1);
    }

    fn note(&self, message: &str) {
        self.0.suspend(|| eprintln!("{message}"));
    }
}

/// `bake --merge`: joins the shard manifests in `out` into `out/manifest.json` and lists
/// what the set still lacks (the probes of shards that left no manifest, and failed probes);
/// exits non-zero while it lacks any (`schedule`'s codes: only bad inputs failed, or some
/// probe is missing or failed for the system's sake).
fn merge(out: &Path) -> Result<()> {
    let merged = crate::bake::set::merge(out)?;
    println!(
        "merged {} manifests ({} probes) into {}",
        merged.parts,
        merged.manifest.probes.len(),
        out.join("manifest.json").display()
    );
    for (name, part) in &merged.missing {
        println!("missing: {name} ({part}, no manifest or not reached)");
    }
    for e in merged.failed() {
        let why = match e.failure {
            Some(Failure::Input) => "bad input",
            _ => "device or system",
        };
        let error = e.error.as_deref().unwrap_or("");
        println!("failed: {} ({why}): {error}", e.input);
    }
    let n = merged
        .manifest
        .inputs
        .len()
        .max(merged.manifest.probes.len());
    let message = format!(
        "the set is incomplete: {} of {n} probes missing, {} failed",
        merged.missing.len(),
        merged.failed().count()
    );
    if !merged.missing.is_empty() {
        return Err(Exit {
            code: EXIT_RETRY,
            message,
        }
        .into());
    }
    failures_exit(&merged.manifest.probes, message)
}

/// The part of the set `--shard` or `--items` names (`auto`: the job array's task,
/// `schedule::shard_auto`, with the count the folder's shards record where the scheduler
/// gives none).
fn part(a: &BakeArgs, plan: &BakePlan, set: &ProbeSet) -> Result<Part> {
    if let Some(spec) = a.shard.as_deref() {
        let (index, count) = match spec.starts_with("auto") {
            true => shard_auto(
                spec,
                |k| std::env::var(k).ok(),
                recorded_split(&a.out, plan)?,
            )?,
            false => parse_shard(spec)?,
        };
        return Ok(Part::Shard { index, count });
    }
    if let Some(spec) = a.items.as_deref() {
        let (first, last) = parse_items(spec, set.len())?;
        return Ok(Part::Items { first, last });
    }
    Ok(Part::All)
}

/// Runs `envlight bake`.
pub fn bake(g: &Global, a: &BakeArgs) -> Result<()> {
    if a.merge {
        return merge(&a.out);
    }
    let file = match &a.config {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| p.display().to_string())?;
            BakeSettings::from_toml(&text).with_context(|| p.display().to_string())?
        }
        None => BakeSettings::default(),
    };
    let plan = BakePlan::new(&cli_settings(a).over(file))?;
    let set = collect(&a.inputs)?;
    let job = SetBake::new(&set, &plan, &a.out, part(a, &plan, &set)?)?;
    // No device, or none that starts: a system failure, worth retrying elsewhere.
    let ctx = context(g).map_err(|e| Exit {
        code: EXIT_RETRY,
        message: super::error_text(&e),
    })?;
    check_gpu(g, &ctx, a.require_gpu)?;
    let baker = Baker::new(&ctx)?;
    let pb = ProgressBar::new(job.len() as u64);
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} probes, ETA {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let bar = Bar(pb);
    let written = job.run(&ctx, &baker, a.force, &bar);
    bar.0.finish_and_clear();
    let Written { manifest, path } = written?;
    summary(&manifest, &plan);
    println!("wrote {}", path.display());
    let failed = manifest
        .probes
        .iter()
        .filter(|e| e.status == "failed")
        .count();
    let message = format!(
        "{failed} of {} probes failed (see above and the manifest)",
        manifest.probes.len()
    );
    failures_exit(&manifest.probes, message)
}

/// Ends a run whose entries are `probes` by their failures (`schedule::exit_for`: none, only
/// bad inputs, or some system failure), with `message`.
fn failures_exit(probes: &[Entry], message: String) -> Result<()> {
    let failures: Vec<Failure> = probes
        .iter()
        .filter(|e| e.status == "failed")
        .map(|e| e.failure.unwrap_or(Failure::System))
        .collect();
    match exit_for(&failures, message) {
        Some(exit) => Err(exit.into()),
        None => Ok(()),
    }
}

/// Warns (or with `require_gpu` refuses, exiting 75) when `ctx` is a CPU implementation the
/// user did not ask for: on a farm that is a container without the GPU's graphics driver.
fn check_gpu(g: &Global, ctx: &crate::gpu::Context, require_gpu: bool) -> Result<()> {
    use crate::gpu::DeviceSelector;
    let info = ctx.info();
    if info.device_type != ash::vk::PhysicalDeviceType::CPU {
        return Ok(());
    }
    let asked = match g.device.as_deref() {
        Some(d) => DeviceSelector::parse(d),
        None => DeviceSelector::from_env(),
    };
    let why = format!(
        "{} is a CPU implementation of Vulkan: bakes run about 100 times slower than on a \
         GPU. If this machine has a GPU, the Vulkan loader does not see its driver: in a \
         container, the NVIDIA runtime must expose the graphics capability \
         (NVIDIA_DRIVER_CAPABILITIES=all, or one listing graphics) and its ICD \
         (nvidia_icd.json); `envlight devices` shows what the loader sees",
        info.name
    );
    if require_gpu {
        return Err(Exit {
            code: EXIT_RETRY,
            message: format!("--require-gpu: {why}"),
        }
        .into());
    }
    if asked == DeviceSelector::Auto {
        eprintln!("warning: {why} (`--device cpu` silences this, `--require-gpu` refuses)");
    }
    Ok(())
}

/// Prints the run's table: per probe its status, times, errors and what clamping took.
fn summary(manifest: &Manifest, plan: &BakePlan) {
    println!(
        "| probe | status | seconds | GPU ms | irradiance error | specular error (worst level) \
         | power clamped (worst level) | power in lights.json |\n|---|---|---|---|---|---|---|---|"
    );
    for e in &manifest.probes {
        let (irr, spec) = match &e.check {
            Some(c) => (
                format!("{:.2e}", c.irradiance),
                format!("{:.2e}", c.specular_worst()),
            ),
            None => ("–".into(), "–".into()),
        };
        let clamped = e
            .clamped
            .as_ref()
            .map_or("0".into(), |c| format!("{:.2e}", c.worst()));
        let separated = e.separated.map_or("–".into(), |s| {
            format!("{:.3}", crate::math::envmap::luminance(s))
        });
        println!(
            "| {} | {} | {:.3} | {:.1} | {irr} | {spec} | {clamped} | {separated} |",
            e.input,
            e.error
                .as_deref()
                .map(|m| format!("failed: {m}"))
                .unwrap_or_else(|| e.status.clone()),
            e.seconds,
            e.gpu_ms
        );
    }
    if plan.check > 0 {
        println!(
            "errors: worst relative luminance error at {} texels a level (the brightest \
             source texel's first) against float64 exact filters: the irradiance cube (SH to \
             order {}) against the cosine integral, the specular levels against GGX at n = v = r",
            plan.check, plan.options.sh_order
        );
    }
    println!(
        "power clamped: the share of a cube level's luminance power (∑ Ω·Y) that clamping into \
         {} removed (texels brighter than the format holds; --lights separate or rgba32f keep it)",
        plan.texels.name()
    );
    for e in &manifest.probes {
        if let Some(r) = &e.reduced {
            println!(
                "reduced: {} baked at {} × {} from {} × {} ({}, power kept; largest side {})",
                e.input, r.to[0], r.to[1], r.from[0], r.from[1], r.how, r.limit
            );
        }
    }
}
