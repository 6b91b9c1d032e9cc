//! `envlight bake`: a folder of probes to what an engine loads, one folder per probe (SH JSON,
//! irradiance cube, specular cube with a level per roughness), with a manifest that makes
//! re-runs skip what is done, deterministic shards, and a merge of the shards' manifests.
//! The bake is the library's (`bake::set`); this is its arguments, progress bar and summary.

use super::schedule::{exit_for, Exit, EXIT_RETRY};
use super::{context, Global};
use crate::bake::manifest::{Entry, Failure, Manifest};
use crate::bake::output::{Irradiance, Preset};
use crate::bake::plan::{BakePlan, BakeSettings, Container, LightsKey, LightsMode};
use crate::bake::schedule::{parse_items, parse_shard, shard_auto};
use crate::bake::set::{recorded_split, Part, ProbeSet, Progress, SetBake, Written};
use crate::bake::Baker;
use crate::io::ktx2::Ktx2Format;
use crate::math::split_sum::DfgAxes;
use anyhow::{bail, Context as _, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

/// Bake probes for engines: SH, an irradiance cube and a GGX specular cube per probe (KTX2 or
/// EXR), resumable, shardable across machines
#[derive(Args)]
pub struct BakeArgs {
    /// Probe files, folders (their .hdr, .exr, .dds and .pfm files) or globs
    inputs: Vec<String>,
    /// Output folder (one folder per probe, named as its file, and the manifest)
    #[arg(short, long)]
    out: PathBuf,
    /// A TOML bake file with the options below (the command line wins)
    #[arg(long)]
    config: Option<PathBuf>,
    /// Highest SH band written [default: 2]
    #[arg(long)]
    sh_order: Option<u32>,
    /// Irradiance cube face size [default: 32]
    #[arg(long)]
    irradiance_size: Option<u32>,
    /// Specular cube face size at level 0 [default: 256]
    #[arg(long)]
    specular_size: Option<u32>,
    /// Specular levels: level k holds GGX α = (k/(levels − 1))² [default: 8, or as many as a
    /// smaller cube has]
    #[arg(long)]
    specular_levels: Option<u32>,
    /// FIS samples per specular texel [default: 256]
    #[arg(long)]
    samples: Option<u32>,
    /// Output container [default: ktx2]
    #[arg(long, value_parser = named(FORMATS, Container::parse))]
    format: Option<Container>,
    /// KTX2 texels (texels beyond a format's range are clamped into it and the power clamped
    /// away reported) [default: rgba32f]
    #[arg(long, ignore_case = true, value_parser = named(TEXELS, Ktx2Format::parse))]
    texels: Option<Ktx2Format>,
    /// Also write each probe's dual-paraboloid MIP chain (chain.ktx2, RGBA32F premultiplied:
    /// a lookup divides rgb by alpha after filtering), what FIS reads at run time
    #[arg(long)]
    chain: bool,
    /// The same as --lights off
    #[arg(long)]
    no_lights: bool,
    /// Also write the split-sum DFG table once (dfg.ktx2: A, B per n·v column and √α row)
    #[arg(long)]
    dfg: bool,
    /// Where the DFG table's entries sit: endpoints (n·v = i/(size − 1), envlight's lookups) or
    /// centres (texel centres, (i + ½)/size, as a plain texture lookup reads them)
    /// [default: endpoints; khronos: centres]
    #[arg(long, value_parser = named(DFG_AXES, DfgAxes::parse))]
    dfg_samples: Option<DfgAxes>,
    /// Bake only the i-th of n deterministic subsets (1-based), e.g. 2/8; or `auto`: the
    /// task of a job array (Slurm, AWS Batch, Google Batch; Kubernetes Indexed Jobs with
    /// `auto/N`), from the scheduler's variables
    #[arg(long)]
    shard: Option<String>,
    /// Bake only inputs A to B of the sorted list (1-based, inclusive): a frame range, for
    /// schedulers that hand out ranges (Deadline, OpenCue, OpenJD)
    #[arg(long, conflicts_with = "shard")]
    items: Option<String>,
    /// Bake again probes whose inputs and options are unchanged
    #[arg(long)]
    force: bool,
    /// Refuse to bake on a CPU implementation of Vulkan (lavapipe, SwiftShader), exiting 75 as
    /// for a missing device, instead of warning and baking ~100× slower
    #[arg(long)]
    require_gpu: bool,
    /// Reduce a source wider or taller than this many texels before baking it (the means of
    /// blocks of texels, its power kept; noted in the summary and the manifest) [default:
    /// the device's largest image side, or cube face]
    #[arg(long, value_name = "TEXELS")]
    max_source_side: Option<u32>,
    /// Merge the shards' manifests found in OUT into OUT/manifest.json, and bake nothing
    #[arg(long)]
    merge: bool,
    /// Texels per cube level checked against float64 exact filters (0: none); the errors go
    /// to the summary and the manifest [default: 2]
    #[arg(long)]
    check: Option<u32>,
    /// Bake for an engine: bevy (cubes for its (x, y, −z) lookup, irradiance E/π, e5b9g9r9 +
    /// zstd, skybox.ktx2) or khronos (glTF-IBL-Sampler's yaw, E/π, rgba16f, ⌊log2 size⌋
    /// levels). Options given one by one still apply on top
    #[arg(long, value_parser = named(PRESETS, Preset::parse))]
    preset: Option<Preset>,
    /// Turn the probe about +Y by this many degrees before baking
    #[arg(long, allow_negative_numbers = true)]
    rotate_y: Option<f64>,
    /// Mirror the probe left–right
    #[arg(long)]
    flip_u: bool,
    /// Turn the probe upside down
    #[arg(long)]
    flip_v: bool,
    /// Irradiance cube normalisation: e (irradiance) or e-over-pi (a white Lambertian
    /// surface's radiance, what engines multiply by albedo) [default: e]
    #[arg(long, value_parser = named(IRRADIANCE, Irradiance::parse))]
    irradiance: Option<Irradiance>,
    /// Lights: exact (extract them and add them exactly into the cubes), separate (write them
    /// to lights.json and bake only the residual), or off (filter the whole map) [default: exact]
    #[arg(long, value_parser = named(LIGHTS, LightsMode::parse))]
    lights: Option<LightsMode>,
    /// Supercompress the KTX2 levels with Zstandard
    #[arg(long)]
    zstd: bool,
}

/// `--format` values.
const FORMATS: &[&str] = &["ktx2", "exr"];
/// `--lights` values.
const LIGHTS: &[&str] = &["exact", "separate", "off"];
/// `--texels` values.
const TEXELS: &[&str] = &["rgba32f", "rgba16f", "b10g11r11", "e5b9g9r9", "bc6h"];
/// `--preset` values.
const PRESETS: &[&str] = &["bevy", "khronos"];
/// `--irradiance` values.
const IRRADIANCE: &[&str] = &["e", "e-over-pi"];
/// `--dfg-samples` values.
const DFG_AXES: &[&str] = &["endpoints", "centres"];

/// The value parser of an option whose values are one of the library's enums, by their
/// `names` (clap lists them in the help and in a refusal); `parse` is the library's, which
/// the bake file's keys go through too.
fn named<T: Clone + Send + Sync + 'static>(
    names: &'static [&'static str],
    parse: fn(&str) -> Option<T>,
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(names)
        .map(move |s| parse(&s).unwrap_or_else(|| unreachable!("{s} is listed, so it parses")))
}

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

/// The settings the command line gives (each flag absent where not given).
fn cli_settings(a: &BakeArgs) -> BakeSettings {
    let flag = |on: bool| on.then_some(true);
    let lights = match (a.lights, a.no_lights) {
        (Some(m), _) => Some(m),
        (None, true) => Some(LightsMode::Off),
        (None, false) => None,
    };
    BakeSettings {
        sh_order: a.sh_order,
        irradiance_size: a.irradiance_size,
        specular_size: a.specular_size,
        specular_levels: a.specular_levels,
        samples: a.samples,
        format: a.format,
        texels: a.texels,
        dfg: flag(a.dfg),
        dfg_samples: a.dfg_samples,
        chain: flag(a.chain),
        lights: lights.map(LightsKey::Mode),
        check: a.check,
        preset: a.preset,
        rotate_y: a.rotate_y,
        flip_u: flag(a.flip_u),
        flip_v: flag(a.flip_v),
        irradiance: a.irradiance,
        zstd: flag(a.zstd),
        max_source_side: a.max_source_side,
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Each value the command line offers for an enum option is a name the bake file's
    /// parser takes, and together they name every variant.
    #[test]
    fn command_line_values_are_the_bake_file_names() {
        fn all<T: PartialEq + std::fmt::Debug>(
            names: &[&str],
            parse: fn(&str) -> Option<T>,
        ) -> Vec<T> {
            let mut seen: Vec<T> = Vec::new();
            for n in names {
                let v = parse(n).unwrap_or_else(|| panic!("{n} does not parse"));
                assert!(!seen.contains(&v), "{n} names {v:?} twice");
                seen.push(v);
            }
            seen
        }
        let texels = all(TEXELS, Ktx2Format::parse);
        assert_eq!(texels.len(), 5);
        for t in texels {
            assert!(TEXELS.contains(&t.name()));
        }
        assert_eq!(all(PRESETS, Preset::parse), [Preset::Bevy, Preset::Khronos]);
        assert_eq!(
            all(IRRADIANCE, Irradiance::parse),
            [Irradiance::E, Irradiance::EOverPi]
        );
        assert_eq!(
            all(DFG_AXES, DfgAxes::parse),
            [DfgAxes::Endpoints, DfgAxes::Centres]
        );
        assert_eq!(
            all(LIGHTS, LightsMode::parse),
            [LightsMode::Exact, LightsMode::Separate, LightsMode::Off]
        );
        assert_eq!(
            all(FORMATS, Container::parse),
            [Container::Ktx2, Container::Exr]
        );
        for f in [Container::Ktx2, Container::Exr] {
            assert!(FORMATS.contains(&f.name()));
        }
    }
}
