//! `envlight bake`: a folder of probes to what an engine loads, one folder per probe (SH JSON,
//! irradiance cube, specular cube with a level per roughness), with a manifest that makes
//! re-runs skip what is done, deterministic shards, and a merge of the shards' manifests.

use super::{context, Global};
use anyhow::{anyhow, bail, Context as _, Result};
use clap::Args;
use envlight::bake::{spot_check, BakeOptions, Baked, Baker, PendingBake, SpotCheck};
use envlight::io::ktx2::{self, Ktx2Format, Ktx2Image};
use envlight::io::{write_atomic, LoadOptions};
use envlight::{EnvMap, Mapping, Orientation};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
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
    /// Specular levels: level k holds GGX α = (k/(levels − 1))² [default: 8]
    #[arg(long)]
    specular_levels: Option<u32>,
    /// FIS samples per specular texel [default: 256]
    #[arg(long)]
    samples: Option<u32>,
    /// Output container: ktx2 or exr [default: ktx2]
    #[arg(long)]
    format: Option<String>,
    /// KTX2 texels: rgba32f, rgba16f, b10g11r11 or e5b9g9r9 (the last three refuse values
    /// they cannot hold) [default: rgba32f]
    #[arg(long)]
    texels: Option<String>,
    /// Also write each probe's dual-paraboloid MIP chain (chain.ktx2, RGBA32F premultiplied:
    /// a lookup divides rgb by alpha after filtering), what FIS reads at run time
    #[arg(long)]
    chain: bool,
    /// Filter the whole map by SH and FIS instead of extracting its lights and adding them
    /// exactly (the default extracts)
    #[arg(long)]
    no_lights: bool,
    /// Also write the split-sum DFG table once (dfg.ktx2: A, B per n·v column and √α row)
    #[arg(long)]
    dfg: bool,
    /// Bake only the i-th of n deterministic subsets (1-based), e.g. 2/8
    #[arg(long)]
    shard: Option<String>,
    /// Bake again probes whose inputs and options are unchanged
    #[arg(long)]
    force: bool,
    /// Merge the shards' manifests found in OUT into OUT/manifest.json, and bake nothing
    #[arg(long)]
    merge: bool,
    /// Texels per cube level checked against float64 exact filters (0: none); the errors go
    /// to the summary and the manifest [default: 2]
    #[arg(long)]
    check: Option<u32>,
}

/// A bake file: every field optional, unknown keys refused.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct BakeFile {
    sh_order: Option<u32>,
    irradiance_size: Option<u32>,
    specular_size: Option<u32>,
    specular_levels: Option<u32>,
    samples: Option<u32>,
    format: Option<String>,
    texels: Option<String>,
    dfg: Option<bool>,
    chain: Option<bool>,
    lights: Option<bool>,
    check: Option<u32>,
}

/// Everything that decides the outputs' bytes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Settings {
    envlight: String,
    options: BakeOptions,
    format: String,
    texels: String,
}

/// One output file in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Output {
    file: String,
    bytes: u64,
    sha256: String,
}

/// A probe as the reader thread hands it over.
enum Prepared {
    /// Unchanged since a previous run: its entry, marked skipped.
    Skip(Entry),
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

/// One probe in the manifest.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Entry {
    input: String,
    input_sha256: String,
    status: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    outputs: Vec<Output>,
    /// The run's wall time from the previous probe's end to this one's (they add up).
    seconds: f64,
    /// Of which the reader thread spent this long reading, hashing and decoding it
    /// alongside the GPU work.
    #[serde(default)]
    read_seconds: f64,
    gpu_ms: f64,
    /// Errors against exact filters at a few texels (absent when not checked).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    check: Option<SpotCheck>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Manifest {
    settings: Settings,
    settings_sha256: String,
    shard: Option<String>,
    probes: Vec<Entry>,
}

/// A probe whose bake is on the GPU.
struct InGpu {
    path: PathBuf,
    name: String,
    input: String,
    input_sha256: String,
    map: EnvMap,
    /// Seconds spent reading, hashing and decoding it.
    read_s: f64,
    pending: PendingBake,
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
    Entry {
        input,
        input_sha256,
        status: "failed".into(),
        error: Some(format!("{e:#}")),
        outputs: Vec::new(),
        seconds: 0.0,
        read_seconds,
        gpu_ms: 0.0,
        check: None,
    }
}

fn sha256(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
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
            v.extend(super::probe_files(&p)?);
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

fn read_manifests(out: &Path) -> Vec<Manifest> {
    let Ok(rd) = std::fs::read_dir(out) else {
        return Vec::new();
    };
    let mut paths: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("manifest") && n.ends_with(".json"))
        })
        .collect();
    paths.sort();
    paths
        .iter()
        .filter_map(|p| std::fs::read(p).ok())
        .filter_map(|b| serde_json::from_slice(&b).ok())
        .collect()
}

fn manifest_name(shard: Option<(usize, usize)>) -> String {
    match shard {
        Some((i, n)) => format!("manifest-shard-{i}-of-{n}.json"),
        None => "manifest.json".into(),
    }
}

fn cube_image(texels: &[[f32; 4]], size: u32) -> EnvMap {
    EnvMap::new(
        Mapping::Cube,
        size,
        size,
        texels.iter().map(|t| [t[0], t[1], t[2]]).collect(),
    )
}

/// Writes one probe's files into `dir`; returns them (paths relative to `root`).
fn write_probe(
    root: &Path,
    dir: &Path,
    baked: &Baked,
    o: &BakeOptions,
    format: &str,
    texels: Ktx2Format,
) -> Result<Vec<Output>> {
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let sh = serde_json::to_string_pretty(&baked.sh.to_json())?;
    files.push((dir.join("sh.json"), sh.into_bytes()));
    match format {
        "ktx2" => {
            let irr = std::slice::from_ref(&baked.irradiance);
            let img = |levels, size| Ktx2Image {
                width: size,
                height: size,
                faces: 6,
                layers: 0,
                levels,
            };
            files.push((
                dir.join("irradiance.ktx2"),
                ktx2::encode(&img(irr, o.irradiance_size), texels)?,
            ));
            files.push((
                dir.join("specular.ktx2"),
                ktx2::encode(&img(&baked.specular, o.specular_size), texels)?,
            ));
            if let Some(first) = baked.chain.first() {
                // Premultiplied with a weight that reaches 4 at the poles: float32, so that
                // neither a sun nor the weight is refused or rounded.
                let side = ((first.len() / 2) as f64).sqrt() as u32;
                let chain = Ktx2Image {
                    width: side,
                    height: side,
                    faces: 1,
                    layers: 2,
                    levels: &baked.chain,
                };
                files.push((
                    dir.join("chain.ktx2"),
                    ktx2::encode(&chain, Ktx2Format::Rgba32f)?,
                ));
            }
        }
        _ => {
            let tmp = dir.join(format!(".bake-{}.exr", std::process::id()));
            let exr = |map: &EnvMap| -> Result<Vec<u8>> {
                envlight::io::save_exr(map, &tmp)?;
                let b = std::fs::read(&tmp)?;
                let _ = std::fs::remove_file(&tmp);
                Ok(b)
            };
            let b = exr(&cube_image(&baked.irradiance, o.irradiance_size))?;
            files.push((dir.join("irradiance.exr"), b));
            for (k, level) in baked.specular.iter().enumerate() {
                let size = (o.specular_size >> k).max(1);
                let b = exr(&cube_image(level, size))?;
                files.push((dir.join(format!("specular.level{k}.exr")), b));
            }
            // The chain's radiance (rgb / weight), a dual-paraboloid map per level.
            for (k, level) in baked.chain.iter().enumerate() {
                let side = ((level.len() / 2) as f64).sqrt() as u32;
                let texels = level
                    .iter()
                    .map(|t| {
                        let w = if t[3] > 0.0 { 1.0 / t[3] } else { 0.0 };
                        [t[0] * w, t[1] * w, t[2] * w]
                    })
                    .collect();
                let map = EnvMap::new(Mapping::DualParaboloid, side, side, texels);
                files.push((dir.join(format!("chain.level{k}.exr")), exr(&map)?));
            }
        }
    }
    let mut outputs = Vec::new();
    for (path, bytes) in files {
        write_atomic(&path, &bytes)?;
        outputs.push(Output {
            file: path
                .strip_prefix(root)
                .unwrap_or(&path)
                .to_string_lossy()
                .replace('\\', "/"),
            bytes: bytes.len() as u64,
            sha256: sha256(&bytes),
        });
    }
    Ok(outputs)
}

/// Whether every output of `e` under `root` is there with its recorded hash.
fn outputs_intact(root: &Path, e: &Entry) -> bool {
    !e.outputs.is_empty()
        && e.outputs.iter().all(|o| {
            std::fs::read(root.join(&o.file))
                .is_ok_and(|b| b.len() as u64 == o.bytes && sha256(&b) == o.sha256)
        })
}

fn merge(out: &Path) -> Result<()> {
    let shards: Vec<Manifest> = read_manifests(out)
        .into_iter()
        .filter(|m| m.shard.is_some())
        .collect();
    let Some(first) = shards.first() else {
        bail!(
            "{}: no shard manifests (manifest-shard-I-of-N.json) to merge",
            out.display()
        );
    };
    let n = parse_shard(first.shard.as_deref().unwrap_or("1/1"))?.1;
    let mut seen = vec![false; n];
    let mut probes: Vec<Entry> = Vec::new();
    for m in &shards {
        if m.settings_sha256 != first.settings_sha256 {
            bail!("the shards were baked with different settings; bake them again alike");
        }
        let (i, ni) = parse_shard(m.shard.as_deref().unwrap_or("1/1"))?;
        if ni != n {
            bail!("shard {i}/{ni} does not belong to a split into {n}");
        }
        seen[i - 1] = true;
        probes.extend(m.probes.iter().cloned());
    }
    if let Some(missing) = seen.iter().position(|s| !s) {
        bail!(
            "shard {}/{n} has no manifest in {}",
            missing + 1,
            out.display()
        );
    }
    probes.sort_by(|a, b| a.input.cmp(&b.input));
    let merged = Manifest {
        settings: first.settings.clone(),
        settings_sha256: first.settings_sha256.clone(),
        shard: None,
        probes,
    };
    write_atomic(
        &out.join("manifest.json"),
        serde_json::to_string_pretty(&merged)?.as_bytes(),
    )?;
    println!(
        "merged {n} shard manifests ({} probes) into {}",
        merged.probes.len(),
        out.join("manifest.json").display()
    );
    Ok(())
}

/// Runs `envlight bake`.
pub fn bake(g: &Global, a: &BakeArgs) -> Result<()> {
    if a.merge {
        return merge(&a.out);
    }
    let file: BakeFile = match &a.config {
        Some(p) => {
            toml::from_str(&std::fs::read_to_string(p).with_context(|| p.display().to_string())?)
                .with_context(|| format!("{}: not a bake file", p.display()))?
        }
        None => BakeFile::default(),
    };
    let d = BakeOptions::default();
    let options = BakeOptions {
        sh_order: a.sh_order.or(file.sh_order).unwrap_or(d.sh_order),
        irradiance_size: a
            .irradiance_size
            .or(file.irradiance_size)
            .unwrap_or(d.irradiance_size),
        specular_size: a
            .specular_size
            .or(file.specular_size)
            .unwrap_or(d.specular_size),
        specular_levels: a
            .specular_levels
            .or(file.specular_levels)
            .unwrap_or(d.specular_levels),
        samples: a.samples.or(file.samples).unwrap_or(d.samples),
        chain: a.chain || file.chain == Some(true),
        lights: !a.no_lights && file.lights.unwrap_or(d.lights),
        ..d
    };
    options.validate()?;
    let format = a
        .format
        .clone()
        .or(file.format)
        .unwrap_or_else(|| "ktx2".into());
    if format != "ktx2" && format != "exr" {
        bail!("--format {format}: ktx2 or exr");
    }
    let texels_name = a
        .texels
        .clone()
        .or(file.texels)
        .unwrap_or_else(|| "rgba32f".into());
    let texels = Ktx2Format::parse(&texels_name).ok_or_else(|| {
        anyhow!("--texels {texels_name}: rgba32f, rgba16f, b10g11r11 or e5b9g9r9")
    })?;
    let shard = a.shard.as_deref().map(parse_shard).transpose()?;
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
    let mine: Vec<PathBuf> = match shard {
        Some((i, n)) => inputs
            .iter()
            .enumerate()
            .filter(|(k, _)| k % n == i - 1)
            .map(|(_, p)| p.clone())
            .collect(),
        None => inputs.clone(),
    };
    let settings = Settings {
        envlight: env!("CARGO_PKG_VERSION").into(),
        options,
        format: format.clone(),
        texels: texels_name.to_ascii_lowercase(),
    };
    let settings_sha256 = sha256(serde_json::to_string(&settings)?.as_bytes());
    let out = &a.out;
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let previous: Vec<Entry> = read_manifests(out)
        .into_iter()
        .filter(|m| m.settings_sha256 == settings_sha256)
        .flat_map(|m| m.probes)
        .filter(|e| e.status != "failed")
        .collect();

    let ctx = context(g)?;
    let baker = Baker::new(&ctx)?;
    if a.dfg || file.dfg == Some(true) {
        let t = baker.dfg(options.dfg_size, true)?;
        let level: Vec<[f32; 4]> = t.iter().map(|v| [v[0], v[1], 0.0, 1.0]).collect();
        let img = Ktx2Image {
            width: options.dfg_size,
            height: options.dfg_size,
            faces: 1,
            layers: 0,
            levels: std::slice::from_ref(&level),
        };
        ktx2::write(&out.join("dfg.ktx2"), &img, Ktx2Format::Rgba32f)?;
    }
    let pb = ProgressBar::new(mine.len() as u64);
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} probes, ETA {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    // A reader thread reads, hashes, checks and decodes the next probe while this one bakes
    // and its files are written; the channel holds one probe, so memory stays bounded.
    let (tx, rx) = std::sync::mpsc::sync_channel::<Prepared>(1);
    let force = a.force;
    let check = a.check.or(file.check).unwrap_or(2);
    let entries = std::thread::scope(|scope| {
        let previous = &previous;
        let mine = &mine;
        scope.spawn(move || {
            for path in mine {
                let t0 = Instant::now();
                let input = path.to_string_lossy().replace('\\', "/");
                let bytes = std::fs::read(path);
                let input_sha256 = bytes.as_ref().map(|b| sha256(b)).unwrap_or_default();
                let done = previous.iter().find(|e| {
                    e.input == input && e.input_sha256 == input_sha256 && outputs_intact(out, e)
                });
                let job = match (done, force) {
                    (Some(e), false) => Prepared::Skip(Entry {
                        status: "skipped".into(),
                        ..e.clone()
                    }),
                    _ => {
                        let map = bytes.map_err(anyhow::Error::from).and_then(|b| {
                            Ok(envlight::io::load_bytes(path, &b, &LoadOptions::default())?)
                        });
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
        });
        // One probe on the GPU while the previous one is read back, written and checked:
        // its upload and recording overlap that work, and the GPU does not idle between them.
        let finish = |w: InGpu| -> Entry {
            let result = w
                .pending
                .wait()
                .map_err(anyhow::Error::from)
                .and_then(|baked| {
                    let outputs =
                        write_probe(out, &out.join(&w.name), &baked, &options, &format, texels)?;
                    let o = Orientation::default();
                    let checked =
                        (check > 0).then(|| spot_check(&w.map, &o, &options, &baked, check));
                    let gpu_ms = baked.timings.iter().map(|t| t.ms).sum::<f64>();
                    Ok((outputs, gpu_ms, checked))
                })
                .with_context(|| w.path.display().to_string());
            match result {
                Ok((outputs, gpu_ms, check)) => Entry {
                    input: w.input,
                    input_sha256: w.input_sha256,
                    status: "baked".into(),
                    error: None,
                    outputs,
                    seconds: 0.0,
                    read_seconds: w.read_s,
                    gpu_ms,
                    check,
                },
                Err(e) => failed(&pb, w.input, w.input_sha256, e, w.read_s),
            }
        };
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
        let mut in_gpu: Option<InGpu> = None;
        for job in rx {
            match job {
                Prepared::Skip(e) => {
                    if let Some(w) = in_gpu.take() {
                        push(&mut entries, finish(w));
                    }
                    push(&mut entries, e);
                }
                Prepared::Bake {
                    path,
                    input,
                    input_sha256,
                    map,
                    read_s,
                } => {
                    let name = path
                        .file_name()
                        .map(|n| n.to_string_lossy().to_string())
                        .unwrap_or_default();
                    pb.set_message(name.clone());
                    let submitted = map.and_then(|map| {
                        let pending = baker.submit(&map, &Orientation::default(), &options)?;
                        Ok((map, pending))
                    });
                    // The previous probe finishes while this one runs on the GPU.
                    if let Some(w) = in_gpu.take() {
                        push(&mut entries, finish(w));
                    }
                    match submitted {
                        Ok((map, pending)) => {
                            in_gpu = Some(InGpu {
                                path,
                                name,
                                input,
                                input_sha256,
                                map,
                                read_s,
                                pending,
                            })
                        }
                        Err(e) => {
                            let e = e.context(path.display().to_string());
                            push(&mut entries, failed(&pb, input, input_sha256, e, read_s));
                        }
                    }
                }
            }
        }
        if let Some(w) = in_gpu.take() {
            push(&mut entries, finish(w));
        }
        entries
    });
    pb.finish_and_clear();
    let manifest = Manifest {
        settings,
        settings_sha256,
        shard: shard.map(|(i, n)| format!("{i}/{n}")),
        probes: entries,
    };
    let mpath = out.join(manifest_name(shard));
    write_atomic(&mpath, serde_json::to_string_pretty(&manifest)?.as_bytes())?;
    println!(
        "| probe | status | seconds | GPU ms | irradiance error | specular error (worst level) |\n\
         |---|---|---|---|---|---|"
    );
    for e in &manifest.probes {
        let (irr, spec) = match &e.check {
            Some(c) => (
                format!("{:.2e}", c.irradiance),
                format!("{:.2e}", c.specular_worst()),
            ),
            None => ("–".into(), "–".into()),
        };
        println!(
            "| {} | {} | {:.3} | {:.1} | {irr} | {spec} |",
            e.input,
            e.error
                .as_deref()
                .map(|m| format!("failed: {m}"))
                .unwrap_or_else(|| e.status.clone()),
            e.seconds,
            e.gpu_ms
        );
    }
    if check > 0 {
        println!(
            "errors: worst relative luminance error at {check} texels a level (the brightest \
             source texel's first) against float64 exact filters: the irradiance cube (SH to \
             order {}) against the cosine integral, the specular levels against GGX at n = v = r",
            options.sh_order
        );
    }
    let failed = manifest
        .probes
        .iter()
        .filter(|e| e.status == "failed")
        .count();
    println!("wrote {}", mpath.display());
    if failed > 0 {
        bail!(
            "{failed} of {} probes failed (see above and the manifest)",
            manifest.probes.len()
        );
    }
    Ok(())
}
