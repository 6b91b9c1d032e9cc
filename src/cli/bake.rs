//! `envlight bake`: a folder of probes to what an engine loads, one folder per probe (SH JSON,
//! irradiance cube, specular cube with a level per roughness), with a manifest that makes
//! re-runs skip what is done, deterministic shards, and a merge of the shards' manifests.

use super::schedule::{classify, exit_for, parse_items, shard_auto, Exit, EXIT_RETRY};
use super::{context, Global};
use crate::bake::files::{probe_files, Clamps};
use crate::bake::manifest::Failure;
use crate::bake::manifest::{
    lock_probe, manifest_name, outputs_intact, read_manifests, recorded, sha256, write_outputs,
    Entry, Manifest, Output, Record, Reduced, Settings, Stages, RECORD,
};
use crate::bake::output::{Irradiance, Preset, SeparateLights};
use crate::bake::plan::{BakePlan, BakeSettings, Container, LightsKey, LightsMode};
use crate::bake::{Baked, Baker, PendingBake, SpotCheckPlan};
use crate::gpu::total_ms;
use crate::io::ktx2::{self, Ktx2Format, Ktx2Image};
use crate::io::{write_atomic, LoadOptions};
use crate::math::convert::{reduce_to_fit, Reduction};
use crate::math::split_sum::DfgAxes;
use crate::{EnvMap, Mapping};
use anyhow::{anyhow, bail, Context as _, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

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

/// A probe as the reader thread hands it over.
enum Prepared {
    /// Unchanged since a previous run: its entry, marked skipped.
    Skip(Box<Entry>),
    /// To bake: the decoded map, or why it could not be read.
    Bake {
        path: PathBuf,
        input: String,
        input_sha256: String,
        map: Result<EnvMap>,
        /// Seconds spent reading, hashing and decoding it.
        read_s: f64,
    },
}

/// `map` reduced to fit `limit` texels a side ([`reduce_to_fit`]), and how; as it is where
/// it fits.
fn fit(map: EnvMap, limit: u32) -> (EnvMap, Option<Reduced>) {
    match reduce_to_fit(&map, limit) {
        None => (map, None),
        Some((small, how)) => {
            let r = Reduced {
                from: [map.width, map.height],
                to: [small.width, small.height],
                limit,
                how: match how {
                    Reduction::Blocks(k) => format!("blocks {k}"),
                    Reduction::Resampled => "resampled".into(),
                },
            };
            (small, Some(r))
        }
    }
}

/// A probe whose bake is on the GPU.
struct InGpu {
    path: PathBuf,
    name: String,
    input: String,
    input_sha256: String,
    /// The source, until the spot check takes it.
    map: Option<EnvMap>,
    /// Seconds spent reading, hashing and decoding it.
    read_s: f64,
    pending: PendingBake,
    /// With `--lights separate`: the lights the cubes leave out.
    lights: Option<SeparateLights>,
    /// The probe's lock, held until its files and record are written.
    _lock: std::fs::File,
    /// Seconds spent waiting for the lock (None: it was free).
    lock_wait: Option<f64>,
    /// How the source was reduced to fit, where it was.
    reduced: Option<Reduced>,
}

/// The manifest entry of a probe that failed, reported above the progress bar.
fn failed(
    pb: &ProgressBar,
    input: String,
    input_sha256: String,
    e: anyhow::Error,
    read_seconds: f64,
) -> Entry {
    pb.suspend(|| eprintln!("error: {e:#}"));
    let failure = classify(&e, Path::new(&input));
    Entry {
        error: Some(format!("{e:#}")),
        failure: Some(failure),
        read_seconds,
        ..Entry::new(input, input_sha256, "failed")
    }
}

/// (i, n) from "i/n", 1 ≤ i ≤ n.
fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| anyhow!("--shard {s}: expected i/n, e.g. 2/8"))?;
    let (i, n): (usize, usize) = (
        i.trim().parse().with_context(|| format!("--shard {s}"))?,
        n.trim().parse().with_context(|| format!("--shard {s}"))?,
    );
    if n == 0 || i == 0 || i > n {
        bail!("--shard {s}: i must be between 1 and n");
    }
    Ok((i, n))
}

/// The inputs: files, folders' probe files and glob matches, sorted and without repeats.
fn collect(inputs: &[String]) -> Result<Vec<PathBuf>> {
    let mut v = Vec::new();
    for s in inputs {
        let p = PathBuf::from(s);
        if p.is_dir() {
            v.extend(crate::io::probes_in(&p)?);
        } else if p.is_file() {
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
    v.sort();
    v.dedup();
    Ok(v)
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

/// Writes one probe's files into `dir` (`bake::files::probe_files`); returns them (paths
/// relative to `root`, with their sizes and hashes) and what clamping took.
fn write_probe(
    root: &Path,
    dir: &Path,
    baked: &Baked,
    plan: &BakePlan,
    lights: Option<&SeparateLights>,
) -> Result<(Vec<Output>, Option<Clamps>)> {
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    let made = probe_files(dir, baked, plan, lights)?;
    let outputs = write_outputs(root, made.files)?;
    Ok((outputs, made.clamped))
}

/// `bake --merge`: joins the shard manifests in `out` into `out/manifest.json` and lists
/// what the set still lacks (the probes of shards that left no manifest, and failed probes);
/// exits non-zero while it lacks any (`schedule`'s codes: only bad inputs failed, or some
/// probe is missing or failed for the system's sake).
fn merge(out: &Path) -> Result<()> {
    let parts: Vec<Manifest> = read_manifests(out)
        .into_iter()
        .filter(|m| m.shard.is_some() || m.items.is_some())
        .collect();
    let Some(first) = parts.first() else {
        bail!(
            "{}: no shard or range manifests (manifest-shard-I-of-N.json, \
             manifest-items-A-B.json) to merge",
            out.display()
        );
    };
    // Shards' split: n, and which shards left a manifest.
    let mut n = None;
    let mut seen = Vec::new();
    let mut probes: Vec<Entry> = Vec::new();
    for m in &parts {
        if m.settings_sha256 != first.settings_sha256 {
            bail!("the parts were baked with different settings; bake them again alike");
        }
        if m.inputs != first.inputs {
            bail!("the parts split different lists of inputs; bake them again alike");
        }
        if let Some(s) = m.shard.as_deref() {
            let (i, ni) = parse_shard(s)?;
            let n = *n.get_or_insert(ni);
            if ni != n {
                bail!("shard {i}/{ni} does not belong to a split into {n}");
            }
            seen.resize(n, false);
            seen[i - 1] = true;
        }
        probes.extend(m.probes.iter().cloned());
    }
    let absent: Vec<usize> = (1..=seen.len()).filter(|i| !seen[i - 1]).collect();
    if first.inputs.is_empty() {
        // Manifests from before inputs were recorded: a missing shard is all one can say.
        if let (Some(i), Some(n)) = (absent.first(), n) {
            bail!("shard {i}/{n} has no manifest in {}", out.display());
        }
    }
    // One entry a probe (ranges may overlap), a baked one before a failed one.
    probes.sort_by(|a, b| (&a.input, a.status == "failed").cmp(&(&b.input, b.status == "failed")));
    probes.dedup_by(|later, kept| later.input == kept.input);
    // Probes no part baked, with the shard (k mod n) or item (k + 1) that holds them.
    let baked: std::collections::HashSet<&str> = probes.iter().map(|e| e.input.as_str()).collect();
    let missing: Vec<(String, String)> = first
        .inputs
        .iter()
        .enumerate()
        .filter(|(_, name)| !baked.contains(name.as_str()))
        .map(|(k, name)| {
            let part = match n {
                Some(n) => format!("shard {}", k % n + 1),
                None => format!("item {}", k + 1),
            };
            (name.clone(), part)
        })
        .collect();
    let merged = Manifest {
        settings: first.settings.clone(),
        settings_sha256: first.settings_sha256.clone(),
        shard: None,
        items: None,
        inputs: first.inputs.clone(),
        probes,
    };
    write_atomic(
        &out.join("manifest.json"),
        serde_json::to_string_pretty(&merged)?.as_bytes(),
    )?;
    println!(
        "merged {} manifests ({} probes) into {}",
        parts.len(),
        merged.probes.len(),
        out.join("manifest.json").display()
    );
    merge_verdict(&merged, &missing)
}

/// Lists what the merged set lacks and ends `bake --merge` accordingly.
fn merge_verdict(merged: &Manifest, missing: &[(String, String)]) -> Result<()> {
    let n = merged.inputs.len().max(merged.probes.len());
    for (name, part) in missing {
        println!("missing: {name} ({part}, no manifest or not reached)");
    }
    let failed: Vec<&Entry> = merged
        .probes
        .iter()
        .filter(|e| e.status == "failed")
        .collect();
    for e in &failed {
        let why = match e.failure {
            Some(Failure::Input) => "bad input",
            _ => "device or system",
        };
        let error = e.error.as_deref().unwrap_or("");
        println!("failed: {} ({why}): {error}", e.input);
    }
    let message = format!(
        "the set is incomplete: {} of {n} probes missing, {} failed",
        missing.len(),
        failed.len()
    );
    if !missing.is_empty() {
        return Err(Exit {
            code: EXIT_RETRY,
            message,
        }
        .into());
    }
    failures_exit(&merged.probes, message)
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
    let inputs = collect(&a.inputs)?;
    if inputs.is_empty() {
        bail!("no probes among the inputs");
    }
    // Output folders are named by file name: two inputs with one name would overwrite.
    for w in inputs.windows(2) {
        if w[0].file_name() == w[1].file_name() {
            bail!(
                "{} and {} share a file name, so their outputs would collide",
                w[0].display(),
                w[1].display()
            );
        }
    }
    let settings = Settings::of(&plan);
    let settings_sha256 = settings.sha256()?;
    let out = &a.out;
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let manifests: Vec<Manifest> = read_manifests(out)
        .into_iter()
        .filter(|m| m.settings_sha256 == settings_sha256)
        .collect();
    let names: Vec<String> = inputs.iter().map(|p| input_name(p)).collect();
    let shard = match a.shard.as_deref() {
        Some(s) => Some(resolve_shard(s, &manifests, &names)?),
        None => None,
    };
    let items = match a.items.as_deref() {
        Some(s) => {
            let r = parse_items(s, names.len())?;
            same_inputs(&format!("--items {s}"), &manifests, &names)?;
            Some(r)
        }
        None => None,
    };
    let mine: Vec<PathBuf> = match (shard, items) {
        (Some((i, n)), _) => inputs
            .iter()
            .enumerate()
            .filter(|(k, _)| k % n == i - 1)
            .map(|(_, p)| p.clone())
            .collect(),
        (None, Some((first, last))) => inputs[first - 1..last].to_vec(),
        (None, None) => inputs.clone(),
    };
    let previous: Vec<Entry> = manifests
        .into_iter()
        .flat_map(|m| m.probes)
        .filter(|e| e.status != "failed")
        .collect();

    // No device, or none that starts: a system failure, worth retrying elsewhere.
    let ctx = context(g).map_err(|e| Exit {
        code: EXIT_RETRY,
        message: format!("{e:#}"),
    })?;
    check_gpu(g, &ctx, a.require_gpu)?;
    let baker = Baker::new(&ctx)?;
    if plan.dfg {
        write_dfg(&baker, &plan, out)?;
    }
    let info = ctx.info();
    let user = a.max_source_side.unwrap_or(u32::MAX).max(1);
    let run = Run {
        plan: &plan,
        baker: &baker,
        out,
        settings_sha256: &settings_sha256,
        force: a.force,
        max_side: (
            info.max_image_dimension_2d.min(user),
            info.max_image_dimension_cube.min(user),
        ),
    };
    let entries = run.probes(&mine, &previous);
    let manifest = Manifest {
        settings,
        settings_sha256,
        shard: shard.map(|(i, n)| format!("{i}/{n}")),
        items: items.map(|(first, last)| format!("{first}-{last}")),
        inputs: match shard.is_some() || items.is_some() {
            true => names,
            false => Vec::new(),
        },
        probes: entries,
    };
    let mpath = out.join(manifest_name(shard, items));
    write_atomic(&mpath, serde_json::to_string_pretty(&manifest)?.as_bytes())?;
    summary(&manifest, &plan);
    println!("wrote {}", mpath.display());
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

/// An input's name in the manifests.
fn input_name(path: &Path) -> String {
    path.to_string_lossy().replace('\\', "/")
}

/// The shard `spec` names (i/n, auto or auto/N: `schedule::shard_auto`), checked against
/// the shard manifests already in the output folder with these settings (`recorded`): a
/// split into another n, or of another input list, is refused.
fn resolve_shard(spec: &str, recorded: &[Manifest], inputs: &[String]) -> Result<(usize, usize)> {
    let splits: Vec<(usize, &Manifest)> = recorded
        .iter()
        .filter_map(|m| {
            let (_, n) = parse_shard(m.shard.as_deref()?).ok()?;
            Some((n, m))
        })
        .collect();
    let (i, n) = match spec.starts_with("auto") {
        true => shard_auto(spec, |k| std::env::var(k).ok(), splits.first().map(|s| s.0))?,
        false => parse_shard(spec)?,
    };
    for (rn, m) in &splits {
        let shard = m.shard.as_deref().unwrap_or_default();
        if *rn != n {
            bail!(
                "--shard {i}/{n}: the output folder holds shard {shard} of a split into {rn} \
                 with these settings; bake every shard with one n (or into another folder)"
            );
        }
    }
    same_inputs(&format!("--shard {i}/{n}"), recorded, inputs)?;
    Ok((i, n))
}

/// Refuses a part (`what`: a shard or a range) of a set whose other parts in the output
/// folder (`recorded`, these settings) split another list of inputs.
fn same_inputs(what: &str, recorded: &[Manifest], inputs: &[String]) -> Result<()> {
    for m in recorded {
        if !m.inputs.is_empty() && m.inputs != inputs {
            let part = match (&m.shard, &m.items) {
                (Some(s), _) => format!("shard {s}"),
                (None, Some(r)) => format!("items {r}"),
                (None, None) => "a bake".to_string(),
            };
            bail!(
                "{what}: {part} in the output folder split another list of inputs ({} \
                 against these {}); give every part the same inputs",
                m.inputs.len(),
                inputs.len()
            );
        }
    }
    Ok(())
}

/// Writes the split-sum table once: `dfg.ktx2` (RGBA32F, A and B in R and G, row √α after
/// row), and for presets that want one `lut.png` (8-bit R = A, G = B, B = 0, row 0 at the
/// smallest roughness: glTF-IBL-Sampler's `outputLUT.png`).
fn write_dfg(baker: &Baker, plan: &BakePlan, out: &Path) -> Result<()> {
    let size = plan.options.dfg_size;
    // Kept between runs (`bake::dfg_cache`): it depends on no probe.
    let cache = crate::bake::dfg_cache::default_dir();
    let t = baker.dfg_cached(size, true, plan.dfg_axes, cache.as_deref())?;
    let level: Vec<[f32; 4]> = t.iter().map(|v| [v[0], v[1], 0.0, 1.0]).collect();
    let img = Ktx2Image {
        width: size,
        height: size,
        faces: 1,
        layers: 0,
        levels: std::slice::from_ref(&level),
    };
    ktx2::write(&out.join("dfg.ktx2"), &img, Ktx2Format::Rgba32f)?;
    if plan.preset.is_some_and(|p| p.lut()) {
        let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let rgb: Vec<u8> = t.iter().flat_map(|v| [byte(v[0]), byte(v[1]), 0]).collect();
        let png = image::RgbImage::from_raw(size, size, rgb)
            .ok_or_else(|| anyhow!("the LUT's size does not match its texels"))?;
        let mut bytes = Vec::new();
        png.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )?;
        write_atomic(&out.join("lut.png"), &bytes)?;
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

/// A probe the main loop took up: on the GPU, or done (skipped or failed) with its entry.
enum Started {
    Gpu(Box<InGpu>),
    Done(Box<Entry>),
}

/// Texels past which a probe is large (4 Mi, a 2896 × 1448 lat-long: 64 MiB of RGBA32F): its
/// bake overlaps no other probe's, and the next probe is read only once it is finished, so
/// that a set of large maps holds one at a time.
const LARGE_TEXELS: usize = 1 << 22;

/// One run's fixed parts, shared by its probes.
struct Run<'a> {
    plan: &'a BakePlan,
    baker: &'a Baker,
    out: &'a Path,
    settings_sha256: &'a str,
    force: bool,
    /// The largest side a source is baked at: a lat-long's, an angular's or a paraboloid's
    /// (the device's largest 2D image), a cube's face (its largest cube), either no more
    /// than `--max-source-side`.
    max_side: (u32, u32),
}

impl Run<'_> {
    /// Reads, bakes and writes `mine`, skipping what `previous` (or a probe's own record) holds
    /// done; returns their manifest entries in order.
    fn probes(&self, mine: &[PathBuf], previous: &[Entry]) -> Vec<Entry> {
        let pb = ProgressBar::new(mine.len() as u64);
        pb.set_style(
            ProgressStyle::with_template("{bar:30} {pos}/{len} probes, ETA {eta} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        // A reader thread reads, hashes, checks and decodes the next probe while this one
        // bakes and its files are written. It reads a probe only with a permit, which the
        // baking side hands back as soon as it takes a small probe, but only once it has
        // finished a large one ([`LARGE_TEXELS`]): small probes overlap, a large map is alone
        // in memory (its bake not overlapping another's, and the next not read meanwhile).
        let (tx, rx) = std::sync::mpsc::sync_channel::<Prepared>(1);
        let (permit, permits) = std::sync::mpsc::channel::<()>();
        let _ = permit.send(());
        let (out, force) = (self.out, self.force);
        let entries = std::thread::scope(|scope| {
            scope.spawn(move || read_probes(mine, previous, out, force, tx, permits));
            self.bake_all(rx, permit, &pb)
        });
        pb.finish_and_clear();
        entries
    }

    /// The main loop: one probe on the GPU while the previous one is read back, written and
    /// checked, so its upload and recording overlap that work and the GPU does not idle.
    fn bake_all(
        &self,
        rx: std::sync::mpsc::Receiver<Prepared>,
        permit: std::sync::mpsc::Sender<()>,
        pb: &ProgressBar,
    ) -> Vec<Entry> {
        // Each probe's seconds: the run's wall time from the previous probe's end to its own,
        // so that they add up to the run's (reading happens alongside, on the reader thread).
        let mut entries = Vec::new();
        let mut mark = Instant::now();
        let mut push = |entries: &mut Vec<Entry>, mut e: Entry| {
            e.seconds = mark.elapsed().as_secs_f64();
            mark = Instant::now();
            entries.push(e);
            pb.inc(1);
        };
        let mut in_gpu: Option<Box<InGpu>> = None;
        for job in rx {
            let large =
                matches!(&job, Prepared::Bake { map: Ok(m), .. } if m.texels.len() > LARGE_TEXELS);
            if large {
                if let Some(w) = in_gpu.take() {
                    push(&mut entries, self.finish(w, pb));
                }
            } else {
                let _ = permit.send(());
            }
            let next = match job {
                Prepared::Skip(e) => Started::Done(e),
                Prepared::Bake {
                    path,
                    input,
                    input_sha256,
                    map,
                    read_s,
                } => self.start(path, input, input_sha256, map, read_s, pb),
            };
            // The previous probe finishes while this one runs on the GPU.
            if let Some(w) = in_gpu.take() {
                push(&mut entries, self.finish(w, pb));
            }
            match next {
                Started::Gpu(w) if large => push(&mut entries, self.finish(w, pb)),
                Started::Gpu(w) => in_gpu = Some(w),
                Started::Done(e) => push(&mut entries, *e),
            }
            if large {
                let _ = permit.send(());
            }
        }
        if let Some(w) = in_gpu.take() {
            push(&mut entries, self.finish(w, pb));
        }
        entries
    }

    /// Locks a probe and submits its bake; or its entry when it is done already (by another
    /// run that held the lock) or could not be read or submitted.
    fn start(
        &self,
        path: PathBuf,
        input: String,
        input_sha256: String,
        map: Result<EnvMap>,
        read_s: f64,
        pb: &ProgressBar,
    ) -> Started {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        pb.set_message(name.clone());
        let waiting = || pb.suspend(|| eprintln!("waiting for another bake of {name} to finish"));
        let (lock, lock_wait) = match lock_probe(self.out, &name, waiting)
            .map_err(anyhow::Error::from)
        {
            Ok(l) => l,
            Err(e) => return Started::Done(Box::new(failed(pb, input, input_sha256, e, read_s))),
        };
        if !self.force {
            if let Some(e) = recorded(self.out, &name, self.settings_sha256, &input_sha256) {
                return Started::Done(Box::new(Entry {
                    status: "skipped".into(),
                    lock_wait_seconds: lock_wait,
                    stages: None,
                    reduced: None,
                    ..e
                }));
            }
        }
        let plan = self.plan;
        let mut reduced = None;
        let map = map.map(|m| {
            let limit = match m.mapping {
                Mapping::Cube => self.max_side.1,
                _ => self.max_side.0,
            };
            let (m, r) = fit(m, limit);
            if let Some(r) = &r {
                pb.suspend(|| {
                    eprintln!(
                        "{name}: {} × {} reduced to {} × {} ({}; largest side {})",
                        r.from[0], r.from[1], r.to[0], r.to[1], r.how, r.limit
                    )
                });
            }
            reduced = r;
            m
        });
        let submitted = map.and_then(|map| {
            // Separate lights: the cubes see the residual, lights.json the lights.
            let (source, lights) = plan.split_lights(map)?;
            let pending = self
                .baker
                .submit(&source, &plan.orientation, &plan.options)?;
            Ok((source, pending, lights))
        });
        match submitted {
            Ok((map, pending, lights)) => Started::Gpu(Box::new(InGpu {
                path,
                name,
                input,
                input_sha256,
                map: Some(map),
                read_s,
                pending,
                lights,
                _lock: lock,
                lock_wait,
                reduced,
            })),
            Err(e) => {
                let e = e.context(path.display().to_string());
                Started::Done(Box::new(failed(pb, input, input_sha256, e, read_s)))
            }
        }
    }

    /// Waits for a probe's bake, writes its files and record, checks it; its entry.
    fn finish(&self, w: Box<InGpu>, pb: &ProgressBar) -> Entry {
        let mut w = *w;
        let plan = self.plan;
        let host = w.pending.host_seconds();
        let stages = Stages {
            read: w.read_s,
            lights: host.lights,
            upload: host.upload,
            ..Stages::default()
        };
        // The spot check's exact filters need the source alone: they run while the GPU bakes.
        let map = w.map.take().filter(|_| plan.check > 0);
        std::thread::scope(|s| {
            let checking = map.map(|map| {
                s.spawn(move || {
                    let t = Instant::now();
                    let o = &plan.options;
                    let c = SpotCheckPlan::new(&map, &plan.orientation, o, plan.check);
                    (c, t.elapsed().as_secs_f64())
                })
            });
            self.finish_with(w, pb, stages, checking)
        })
    }

    /// [`Run::finish`] once the spot check's exact filters are under way (`checking`).
    fn finish_with(
        &self,
        w: InGpu,
        pb: &ProgressBar,
        mut stages: Stages,
        checking: Option<std::thread::ScopedJoinHandle<'_, (SpotCheckPlan, f64)>>,
    ) -> Entry {
        let plan = self.plan;
        let t0 = Instant::now();
        let result = w
            .pending
            .wait()
            .map_err(anyhow::Error::from)
            .and_then(|baked| {
                stages.gpu_wait = t0.elapsed().as_secs_f64();
                (stages.gpu_convert_ms, stages.gpu_filter_ms) = Stages::gpu(&baked.timings);
                let dir = self.out.join(&w.name);
                let t1 = Instant::now();
                let (outputs, clamped) =
                    write_probe(self.out, &dir, &baked, plan, w.lights.as_ref())?;
                stages.write = t1.elapsed().as_secs_f64();
                let checked = checking.map(|h| {
                    let (c, seconds) = h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
                    stages.check = seconds;
                    c.compare(&baked)
                });
                let gpu_ms = total_ms(&baked.timings);
                Ok((outputs, gpu_ms, checked, clamped))
            })
            .with_context(|| w.path.display().to_string());
        let entry = match result {
            Ok((outputs, gpu_ms, check, clamped)) => Entry {
                outputs,
                read_seconds: w.read_s,
                gpu_ms,
                check,
                clamped,
                separated: w.lights.as_ref().map(|l| l.share),
                lock_wait_seconds: w.lock_wait,
                stages: Some(stages),
                reduced: w.reduced,
                ..Entry::new(w.input, w.input_sha256, "baked")
            },
            Err(e) => return failed(pb, w.input, w.input_sha256, e, w.read_s),
        };
        let record = Record {
            settings_sha256: self.settings_sha256.into(),
            entry: entry.clone(),
        };
        let path = self.out.join(&w.name).join(RECORD);
        match serde_json::to_vec_pretty(&record)
            .map_err(anyhow::Error::from)
            .and_then(|b| Ok(write_atomic(&path, &b)?))
        {
            Ok(()) => entry,
            Err(e) => failed(pb, entry.input, entry.input_sha256, e, w.read_s),
        }
    }
}

/// The reader thread: each probe of `mine` read, hashed and decoded, or marked skipped when a
/// previous manifest with these settings holds it intact; each read only with a permit from
/// `permits` (see `Run::probes`).
fn read_probes(
    mine: &[PathBuf],
    previous: &[Entry],
    out: &Path,
    force: bool,
    tx: std::sync::mpsc::SyncSender<Prepared>,
    permits: std::sync::mpsc::Receiver<()>,
) {
    for path in mine {
        if permits.recv().is_err() {
            return;
        }
        let t0 = Instant::now();
        let input = input_name(path);
        let bytes = std::fs::read(path);
        let input_sha256 = bytes.as_ref().map(|b| sha256(b)).unwrap_or_default();
        let done = previous
            .iter()
            .find(|e| e.input == input && e.input_sha256 == input_sha256 && outputs_intact(out, e));
        let job = match (done, force) {
            (Some(e), false) => Prepared::Skip(Box::new(Entry {
                status: "skipped".into(),
                lock_wait_seconds: None,
                stages: None,
                reduced: None,
                ..e.clone()
            })),
            _ => {
                let map = bytes
                    .map_err(|source| {
                        anyhow::Error::from(crate::Error::Io {
                            path: path.clone(),
                            source,
                        })
                    })
                    .and_then(|b| Ok(crate::io::load_bytes(path, &b, &LoadOptions::default())?));
                Prepared::Bake {
                    path: path.clone(),
                    input,
                    input_sha256,
                    map,
                    read_s: t0.elapsed().as_secs_f64(),
                }
            }
        };
        if tx.send(job).is_err() {
            return;
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
