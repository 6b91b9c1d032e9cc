//! `envlight report`: every technique on real probes and several materials, scored against a
//! converged Monte Carlo reference, with its GPU time: report.md (tables, the Pareto front per
//! material and a headline), report.csv (one row per technique × parameters × probe ×
//! material) and report.png (error against time, one panel per material).

use super::super::{context, Global};
use crate::math::brdf::Brdf;
use crate::math::camera::{sphere_camera, Camera};
use crate::render::score::{errors, scene, sphere_pixels, truth};
use crate::render::PassKind;
use crate::render::Renderer;
use crate::scene::{LightsMode, Scene, SplitSumSettings, Technique};
use crate::EnvMap;
use anyhow::{anyhow, bail, Context as _, Result};
use clap::Args;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Every technique against converged Monte Carlo on real probes: error and GPU time, with a
/// Pareto chart (report.md, report.csv, report.png)
#[derive(Args)]
pub struct ReportArgs {
    /// Folder of the probes (default: $ENVLIGHT_PROBES; one of the two is needed)
    #[arg(long)]
    probes: Option<PathBuf>,
    /// Output folder
    #[arg(long, default_value = "out/report")]
    out: PathBuf,
    /// A reduced set (two probes, two materials, fewer parameters, small images) that runs in
    /// a few minutes on lavapipe
    #[arg(long)]
    quick: bool,
    /// Side of the sphere image (default 64, quick 24)
    #[arg(long)]
    size: Option<u32>,
    /// Samples per pixel of each of the two Monte Carlo reference renders (default 16384,
    /// quick 1024)
    #[arg(long)]
    reference: Option<u32>,
    /// Instead: score these prefiltered cubes (KTX2 or DDS) as split-sum shading against
    /// Monte Carlo on --cube-probe, beside envlight's own renders (cubes.md, cubes.csv)
    #[arg(long)]
    cube: Vec<PathBuf>,
    /// Each --cube's conventions, in order (the last repeats): envlight, khronos
    /// (glTF-IBL-Sampler), bevy or cmft (its radiance filter, phongbrdf, gloss scale 10, bias 1)
    #[arg(long, value_enum)]
    cube_convention: Vec<super::cubes::CubeConvention>,
    /// The probe the --cube files were made from
    #[arg(long)]
    cube_probe: Option<PathBuf>,
    /// Split-sum's roughness levels (default: the scene default)
    #[arg(long)]
    split_levels: Option<u32>,
    /// Split-sum's chain size (default: the scene default)
    #[arg(long)]
    split_size: Option<u32>,
    /// Split-sum's FIS samples per texel (default: the scene default)
    #[arg(long)]
    split_samples: Option<u32>,
}

impl ReportArgs {
    /// The split-sum settings asked for.
    fn split(&self) -> SplitSumSettings {
        let d = SplitSumSettings::default();
        SplitSumSettings {
            size: self.split_size.or(d.size),
            levels: self.split_levels.unwrap_or(d.levels),
            samples: self.split_samples.unwrap_or(d.samples),
            ..d
        }
    }
}

/// One measurement.
struct Row {
    probe: String,
    kind: &'static str,
    material: String,
    technique: &'static str,
    params: String,
    rms: f64,
    bias: f64,
    tile: f64,
    gpu_ms: f64,
    pre_ms: f64,
    wall_s: f64,
    process_s: f64,
    noise: f64,
    /// GPU ms of a frame when the environment changes every frame: the resident path's
    /// whole frame (projection, extraction, chains, shading); Monte Carlo's host render
    /// (its sampling tables, rebuilt on the host at each change, not counted); a peer's
    /// bake (its whole process) plus split-sum's shading.
    frame_ms: f64,
    /// Relative RMS of that path's render.
    frame_rms: f64,
}

impl Row {
    fn label(&self) -> String {
        if self.params.is_empty() {
            self.technique.to_string()
        } else {
            format!("{} {}", self.technique, self.params)
        }
    }
}

/// The probes: (file, what kind of light it is).
fn probes(quick: bool) -> Vec<(&'static str, &'static str)> {
    let mut v = vec![
        ("venice_sunset_1k.hdr", "soft"),
        ("spiaggia_di_mondello_1k.hdr", "sun"),
    ];
    if !quick {
        v.push(("studio_small_08_1k.hdr", "studio"));
        v.push(("quarry_01_1k.hdr", "sun"));
    }
    v
}

fn materials(quick: bool) -> Vec<(&'static str, Brdf)> {
    let ggx = |alpha| Brdf::Ggx {
        alpha,
        correlated: true,
    };
    if quick {
        return vec![("diffuse", Brdf::Lambert), ("ggx 0.3", ggx(0.3))];
    }
    vec![
        ("diffuse", Brdf::Lambert),
        ("ggx 0.1", ggx(0.1)),
        ("ggx 0.3", ggx(0.3)),
        ("ggx 0.6", ggx(0.6)),
        ("phong 50", Brdf::Phong { n: 50.0 }),
        ("mirror", Brdf::Mirror),
    ]
}

/// A technique to score: its label, split-sum taps, and whether the probe's lights are
/// extracted (the default) or left in the map.
type Case = (Technique, String, u32, bool);

/// The techniques that apply to `brdf`, each with light extraction and, where a technique
/// reads it (not the Monte Carlo reference, not the mirror lookup), without; quick runs take
/// the second row for SH order 2, FIS 64 and split-sum only.
fn cases(brdf: &Brdf, quick: bool) -> Vec<Case> {
    let with: Vec<(Technique, String, u32)> = techniques(brdf, quick);
    let mut v = Vec::new();
    for (t, label, taps) in with {
        let both = match t {
            Technique::Mc { .. } | Technique::Lookup => false,
            _ if !quick => true,
            Technique::Sh { order } => order == 2,
            Technique::Fis { samples, .. } => samples == 64,
            Technique::SplitSum => taps == 1,
            _ => false,
        };
        if both {
            // No comma: the label is a CSV field.
            let off = match label.is_empty() {
                true => "(no lights)".to_string(),
                false => format!("{label} (no lights)"),
            };
            v.push((t, off, taps, false));
        }
        v.push((t, label, taps, true));
    }
    v
}

/// The techniques that apply to `brdf`, with their labels and split-sum taps.
fn techniques(brdf: &Brdf, quick: bool) -> Vec<(Technique, String, u32)> {
    let (fis, mc, orders): (&[u32], &[u32], &[u32]) = if quick {
        (&[16, 64], &[64, 256], &[2, 8])
    } else {
        (&[4, 16, 64, 256], &[16, 64, 256, 1024], &[2, 4, 8])
    };
    let mut v = Vec::new();
    if matches!(brdf, Brdf::Mirror) {
        return vec![(Technique::Lookup, String::new(), 1)];
    }
    if matches!(brdf, Brdf::Lambert) {
        for &order in orders {
            v.push((Technique::Sh { order }, format!("l={order}")));
        }
    }
    if matches!(brdf, Brdf::Lambert | Brdf::Phong { .. }) && !quick {
        let size = if matches!(brdf, Brdf::Lambert) {
            32
        } else {
            64
        };
        v.push((Technique::Prefiltered { size }, format!("{size}")));
    }
    for &samples in fis {
        let t = Technique::Fis {
            samples,
            bias: None,
            rotate: true,
        };
        v.push((t, format!("N={samples}")));
    }
    for &samples in mc {
        let t = Technique::Mc {
            samples,
            error: None,
        };
        v.push((t, format!("N={samples}")));
    }
    for &order in orders {
        let t = Technique::ShBrdf {
            order,
            grid: crate::math::sh_brdf::DEFAULT_GRID,
            window: None,
        };
        v.push((t, format!("l={order}")));
    }
    let mut v: Vec<(Technique, String, u32)> = v.into_iter().map(|(t, l)| (t, l, 1)).collect();
    if matches!(brdf, Brdf::Ggx { .. }) {
        v.push((Technique::SplitSum, String::new(), 1));
        let taps = 8;
        v.push((Technique::SplitSum, format!("taps={taps}"), taps));
    }
    v
}

/// Whole-process seconds of `envlight render` on `sc` (its environment a file): the load, the
/// precomputation, the shading and the EXR written, as a user runs it.
fn process_seconds(g: &Global, sc: &Scene, dir: &Path) -> Result<f64> {
    let file = dir.join("scene.toml");
    std::fs::write(&file, toml::to_string(sc)?).with_context(|| file.display().to_string())?;
    let mut cmd = std::process::Command::new(std::env::current_exe()?);
    if let Some(d) = &g.device {
        cmd.args(["--device", d]);
    }
    cmd.arg("render")
        .arg(&file)
        .arg("-o")
        .arg(dir.join("frame.exr"));
    let t0 = Instant::now();
    let o = cmd.output()?;
    let s = t0.elapsed().as_secs_f64();
    if !o.status.success() {
        bail!(
            "envlight render {}: {}",
            file.display(),
            String::from_utf8_lossy(&o.stderr)
        );
    }
    Ok(s)
}

/// What a case is measured against: a probe (file, kind; on disk at `absolute`, in memory
/// and on the GPU), a material and its reference (with its noise).
struct Against<'a> {
    g: &'a Global,
    renderer: &'a Renderer,
    probe: (&'a str, &'static str),
    material: &'a str,
    absolute: &'a Path,
    env: &'a EnvMap,
    gpu: &'a crate::passes::GpuEnvMap,
    truth: (&'a EnvMap, f64),
    pixels: &'a [(usize, u32)],
    scratch: &'a Path,
}

/// One case's row: the host path's render timed and scored, the whole process timed, and
/// the frame of a changing environment (the resident path, except Monte Carlo's).
fn measure(a: &Against<'_>, sc: &Scene, t: Technique, params: String) -> Result<Row> {
    let truth = a.truth.0;
    // One untimed render first: pipelines are built on first use.
    a.renderer.render(sc, a.env)?;
    let t0 = Instant::now();
    let r = a.renderer.render(sc, a.env)?;
    let wall_s = t0.elapsed().as_secs_f64();
    let (rms, bias, tile) = errors(&r.frame, truth, a.pixels);
    let mut on_disk = sc.clone();
    on_disk.environment.file = a.absolute.to_path_buf();
    let process_s = process_seconds(a.g, &on_disk, a.scratch)?;
    let per_frame = |k: PassKind| {
        matches!(
            k,
            PassKind::GBuffer | PassKind::Shade | PassKind::MonteCarlo
        )
    };
    let gpu_ms: f64 = r.records.iter().map(|p| p.ms()).sum();
    // (+ 0.0: an empty float sum is −0.)
    let pre_ms: f64 = r
        .records
        .iter()
        .filter(|p| !per_frame(p.kind))
        .map(|p| p.ms())
        .sum::<f64>()
        + 0.0;
    let (frame_ms, frame_rms) = match t {
        Technique::Mc { .. } => (gpu_ms, rms),
        _ => changing_frame(a.renderer, sc, a.gpu, truth, a.pixels)?,
    };
    let row = Row {
        probe: a.probe.0.trim_end_matches(".hdr").to_string(),
        kind: a.probe.1,
        material: a.material.to_string(),
        technique: t.name(),
        params,
        rms,
        bias,
        tile,
        gpu_ms,
        pre_ms,
        wall_s,
        process_s,
        noise: a.truth.1,
        frame_ms,
        frame_rms,
    };
    eprintln!(
        "{:>28} {:>9} {:<16} rms {:>8.2e} bias {:>+9.2e} tile {:>8.2e} gpu {:>9.2} ms (pre {:>8.2}) wall {:.3} s; changing: {:>9.2} ms rms {:>8.2e}",
        row.probe, row.material, row.label(), rms, bias, tile, gpu_ms, pre_ms, wall_s, frame_ms, frame_rms
    );
    Ok(row)
}

/// The resident path's frame of `sc` from `gpu` (`Renderer::resident`, one untimed frame
/// first: pipelines are built on first use): its GPU ms and its relative RMS against `truth`.
fn changing_frame(
    renderer: &Renderer,
    sc: &Scene,
    gpu: &crate::passes::GpuEnvMap,
    truth: &EnvMap,
    pixels: &[(usize, u32)],
) -> Result<(f64, f64)> {
    let prepared = renderer.resident(
        sc,
        crate::render::MapShape {
            mapping: gpu.mapping,
            width: gpu.width,
            height: gpu.height,
        },
    )?;
    renderer.render_resident(&prepared, gpu)?;
    let r = renderer.render_resident(&prepared, gpu)?;
    let ms = r.records.iter().map(|p| p.ms()).sum();
    Ok((ms, errors(&r.frame, truth, pixels).0))
}

/// The rows of glTF-IBL-Sampler's cubes of `file` (`at`: file, probe kind, material) for a
/// GGX `brdf`: each shaded by split-sum in float64 and scored against `truth`. Its bake is
/// precomputation, timed as its whole process (it has no timestamps, so its wall time bounds
/// its GPU time): with one environment a frame costs split-sum's `shading` ms, and when the
/// environment changes every frame, the bake as well.
fn peer_rows(
    peers: &[super::cubes::PeerCube],
    (file, kind, material): (&str, &'static str, &str),
    brdf: Brdf,
    cam: &Camera,
    truth: &EnvMap,
    noise: f64,
    shading: f64,
) -> Vec<Row> {
    let Brdf::Ggx { alpha, .. } = brdf else {
        return Vec::new();
    };
    let table = crate::math::split_sum::dfg_table(super::cubes::DFG_SIZE, true);
    let pixels = sphere_pixels(cam);
    peers
        .iter()
        .map(|p| {
            let f = super::cubes::shade_frame(cam, &p.chain, &table, alpha, 1);
            let (rms, bias, tile) = errors(&f, truth, &pixels);
            Row {
                probe: file.trim_end_matches(".hdr").to_string(),
                kind,
                material: material.to_string(),
                technique: super::cubes::PEER,
                params: format!("N={}", p.samples),
                rms,
                bias,
                tile,
                gpu_ms: 1e3 * p.seconds + shading,
                pre_ms: 1e3 * p.seconds,
                wall_s: p.seconds,
                process_s: p.seconds,
                noise,
                frame_ms: 1e3 * p.seconds + shading,
                frame_rms: rms,
            }
        })
        .collect()
}

/// glTF-IBL-Sampler's wrapper from ENVLIGHT_IBLSAMPLER, if that names a file (said when not).
fn sampler_from_env() -> Option<PathBuf> {
    let s = std::env::var_os("ENVLIGHT_IBLSAMPLER")
        .map(PathBuf::from)
        .filter(|p| p.is_file());
    if s.is_none() {
        eprintln!("ENVLIGHT_IBLSAMPLER is not set to glTF-IBL-Sampler: its cubes are left out");
    }
    s
}

/// The probes' folder: `--probes`, else `ENVLIGHT_PROBES` (no default: the user says which).
fn probes_dir(args: &ReportArgs) -> Result<PathBuf> {
    args.probes
        .clone()
        .or_else(|| std::env::var_os("ENVLIGHT_PROBES").map(PathBuf::from))
        .ok_or_else(|| anyhow!("report: which probes? Give --probes DIR or set ENVLIGHT_PROBES"))
}

/// Runs the report.
pub fn report(g: &Global, args: &ReportArgs) -> Result<()> {
    let quick = args.quick;
    let size = args.size.unwrap_or(if quick { 24 } else { 64 });
    let reference = args.reference.unwrap_or(if quick { 1024 } else { 16384 });
    // Quick: a 256² paraboloid instead of the source-sized one, so lavapipe converts fast.
    let dp = quick.then_some(256);
    let ctx = context(g)?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver.trim());
    eprintln!("device: {device}");
    let renderer = Renderer::new(&ctx);
    let cam = sphere_camera(size);
    let pixels = sphere_pixels(&cam);
    let split = args.split();
    if !args.cube.is_empty() {
        let a = super::cubes::CubeArgs {
            probe: args.cube_probe.as_deref().ok_or_else(|| {
                anyhow!("--cube needs --cube-probe, the probe the cubes were made from")
            })?,
            cubes: super::cubes::with_conventions(&args.cube, &args.cube_convention),
            out: &args.out,
        };
        return super::cubes::score(&renderer, cam, reference, &device, &a);
    }
    let dir = probes_dir(args)?;
    let mut rows = Vec::new();
    let started = Instant::now();
    // glTF-IBL-Sampler's cubes join the GGX materials where it is present.
    let sampler = sampler_from_env();
    let sampler_counts: &[u32] = if quick { &[16, 64] } else { &[64, 1024] };
    let scratch = std::env::temp_dir().join(format!("envlight-report-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| scratch.display().to_string())?;
    for (file, kind) in probes(quick) {
        let path = dir.join(file);
        let absolute = path
            .canonicalize()
            .with_context(|| format!("report: probe {} (set --probes)", path.display()))?;
        let env = crate::io::load(&path, &crate::io::LoadOptions::default())
            .with_context(|| format!("report: probe {} (set --probes)", path.display()))?;
        let peers = match &sampler {
            Some(exe) => super::cubes::sampler_cubes(
                exe,
                &path,
                &scratch,
                sampler_counts,
                quick.then_some(64),
            )?,
            None => Vec::new(),
        };
        // The map on the GPU once, for the resident path's frames (the paraboloid sized by
        // the source there: the resident path follows the scene, and quick runs' 256² is
        // the host path's setting).
        let gpu = crate::passes::GpuEnvMap::upload(&ctx, &env)?;
        for (name, brdf) in materials(quick) {
            let (truth, noise) = truth(&renderer, cam, brdf, dp, split, reference, &env)?;
            for (t, params, taps, extract) in cases(&brdf, quick) {
                let mut sc = scene(cam, brdf, t, dp, 7, SplitSumSettings { taps, ..split });
                if !extract {
                    sc.environment.lights = LightsMode::None;
                }
                let at = Against {
                    g,
                    renderer: &renderer,
                    probe: (file, kind),
                    material: name,
                    absolute: &absolute,
                    env: &env,
                    gpu: &gpu,
                    truth: (&truth, noise),
                    pixels: &pixels,
                    scratch: &scratch,
                };
                let row = measure(&at, &sc, t, params)?;
                rows.push(row);
            }
            // The peers' cubes are shaded by split-sum: its per-frame shading cost here.
            let shading = rows
                .iter()
                .find(|r| {
                    r.probe == file.trim_end_matches(".hdr")
                        && r.material == name
                        && r.technique == "split_sum"
                        && r.params.is_empty()
                })
                .map_or(0.0, |r| r.gpu_ms - r.pre_ms);
            let at = (file, kind, name);
            rows.extend(peer_rows(&peers, at, brdf, &cam, &truth, noise, shading));
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    write_csv(&out.join("report.csv"), &rows)?;
    let settings = format!(
        "Device: {device}. Sphere {size}² (orthographic, normal to grazing incidence), \
         reference 2 × {reference} spp MIS Monte Carlo (their mean; its noise is half their \
         relative RMS difference). FIS paraboloid {}; split-sum {:?}; sh_brdf grid 32, no \
         window; commit {}. Run took {:.0} s{}.",
        dp.map(|d| format!("{d}²"))
            .unwrap_or_else(|| "sized by the source (1024² for a 1k lat-long)".into()),
        split,
        super::commit(),
        started.elapsed().as_secs_f64(),
        if quick { " (--quick)" } else { "" }
    );
    let md = markdown(&rows, &settings);
    std::fs::write(out.join("report.md"), md).with_context(|| "report.md")?;
    plot(&out.join("report.png"), &rows, &device)?;
    println!(
        "wrote {}/report.md, report.csv, report.png ({} rows)",
        out.display(),
        rows.len()
    );
    Ok(())
}

fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut s = String::from(
        "technique,params,probe,probe_kind,material,relative_rms,mean_bias,worst_tile,gpu_ms,precompute_gpu_ms,render_wall_s,process_s,reference_noise,changing_frame_gpu_ms,changing_frame_relative_rms\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:.6e},{:.6e},{:.6e},{:.4},{:.4},{:.4},{:.4},{:.3e},{:.4},{:.6e}",
            r.technique,
            r.params,
            r.probe,
            r.kind,
            r.material,
            r.rms,
            r.bias,
            r.tile,
            r.gpu_ms,
            r.pre_ms,
            r.wall_s,
            r.process_s,
            r.noise,
            r.frame_ms,
            r.frame_rms
        );
    }
    std::fs::write(path, s).with_context(|| path.display().to_string())
}

/// A technique's summary over the probes for one material: (label, mean GPU ms, mean
/// relative RMS, worst relative RMS, mean |bias|, worst tile, mean precompute ms).
struct Point {
    label: String,
    technique: &'static str,
    ms: f64,
    rms: f64,
    worst: f64,
    bias: f64,
    tile: f64,
    pre: f64,
    process: f64,
    /// Mean per-frame GPU ms when the environment changes every frame, and its mean error.
    frame: f64,
    frame_rms: f64,
}

fn points(rows: &[Row], material: &str) -> Vec<Point> {
    let mut labels: Vec<(String, &'static str)> = Vec::new();
    for r in rows.iter().filter(|r| r.material == material) {
        if !labels.iter().any(|l| l.0 == r.label()) {
            labels.push((r.label(), r.technique));
        }
    }
    labels
        .into_iter()
        .map(|(label, technique)| {
            let v: Vec<&Row> = rows
                .iter()
                .filter(|r| r.material == material && r.label() == label)
                .collect();
            let n = v.len() as f64;
            Point {
                ms: v.iter().map(|r| r.gpu_ms).sum::<f64>() / n,
                rms: v.iter().map(|r| r.rms).sum::<f64>() / n,
                worst: v.iter().map(|r| r.rms).fold(0.0, f64::max),
                bias: v.iter().map(|r| r.bias.abs()).sum::<f64>() / n,
                tile: v.iter().map(|r| r.tile).fold(0.0, f64::max),
                pre: v.iter().map(|r| r.pre_ms).sum::<f64>() / n,
                process: v.iter().map(|r| r.process_s).sum::<f64>() / n,
                frame: v.iter().map(|r| r.frame_ms).sum::<f64>() / n,
                frame_rms: v.iter().map(|r| r.frame_rms).sum::<f64>() / n,
                label,
                technique,
            }
        })
        .collect()
}

/// Indices of the Pareto front, fastest first: each is more accurate than everything faster.
fn front(p: &[Point]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..p.len()).collect();
    idx.sort_by(|&a, &b| {
        p[a].ms
            .total_cmp(&p[b].ms)
            .then(p[a].rms.total_cmp(&p[b].rms))
    });
    let mut best = f64::INFINITY;
    idx.into_iter()
        .filter(|&i| {
            let keep = p[i].rms < best;
            best = best.min(p[i].rms);
            keep
        })
        .collect()
}

/// The front of `p` as "≥ T ms: **label** (E%)" steps.
fn front_line(p: &[Point]) -> String {
    front(p)
        .iter()
        .map(|&i| {
            format!(
                "≥ {:.2} ms: **{}** ({:.2}%)",
                p[i].ms,
                p[i].label,
                100.0 * p[i].rms
            )
        })
        .collect::<Vec<_>>()
        .join(" → ")
}

fn material_names(rows: &[Row]) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in rows {
        if !v.contains(&r.material) {
            v.push(r.material.clone());
        }
    }
    v
}

fn markdown(rows: &[Row], settings: &str) -> String {
    let mut md = String::from("# envlight report: accuracy against time\n\n");
    let _ = writeln!(md, "{settings}\n");
    md.push_str("## Headline: what to use at which time budget\n\n");
    md.push_str(
        "**The environment changes every frame** (a time of day, a moving sun, a probe the \
         engine renders): the Pareto front per material by the GPU time of a whole frame \
         through the resident path (`Renderer::record_resident`: SH projection, light \
         extraction, the paraboloid and its chains, prefiltered maps and the shading, all on \
         the GPU, one submission, nothing read back), mean over the probes, against its mean \
         relative RMS. Monte Carlo counts its host render's GPU time (its sampling tables, \
         rebuilt on the host at each change, are not counted); a peer's bake counts its whole \
         process, since a changed environment must be baked again, plus split-sum's shading.\n\n",
    );
    let mats = material_names(rows);
    for m in &mats {
        let mut p = points(rows, m);
        for q in &mut p {
            (q.ms, q.rms) = (q.frame, q.frame_rms);
        }
        let _ = writeln!(md, "- **{m}**: {}", front_line(&p));
    }
    md.push_str(
        "\n**One environment, many frames** (the precomputation amortised): the front by the \
         per-frame GPU time alone (G-buffer, shading, Monte Carlo frames) of the host path's \
         render; a peer's cube costs split-sum's shading.\n\n",
    );
    for m in &mats {
        let mut p = points(rows, m);
        for q in &mut p {
            q.ms -= q.pre;
        }
        let _ = writeln!(md, "- **{m}**: {}", front_line(&p));
    }
    md.push_str(
        "\nRows marked \"(no lights)\" leave the probe's lights in the map; the others extract \
         them (the default) and add them exactly where the technique can (the resident path \
         clamps the chain's residual where the host path fills it). \
         split_sum taps=8 is the lobe taps recipe. gltf-ibl-sampler rows are \
         glTF-IBL-Sampler's GGX cube of the probe (its defaults, N samples) shaded by \
         split-sum in float64. \"GPU ms\" below is the host path's whole render, \
         precomputation included (\"of it precompute\"), as the chart plots it.\n\n\
         ![Pareto chart](report.png)\n",
    );
    for m in &mats {
        let p = points(rows, m);
        let f = front(&p);
        let _ = writeln!(
            md,
            "\n## {m}\n\n| technique | mean rel. RMS | worst probe | mean abs bias | worst tile | GPU ms | of it precompute | whole process s | changing env: frame ms | its rel. RMS | front |\n|---|---|---|---|---|---|---|---|---|---|---|"
        );
        for (i, q) in p.iter().enumerate() {
            let _ = writeln!(
                md,
                "| {} | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2} | {:.2} | {:.3} | {:.2} | {:.2}% | {} |",
                q.label,
                100.0 * q.rms,
                100.0 * q.worst,
                100.0 * q.bias,
                100.0 * q.tile,
                q.ms,
                q.pre,
                q.process,
                q.frame,
                100.0 * q.frame_rms,
                if f.contains(&i) { "yes" } else { "" }
            );
        }
        let noise = rows
            .iter()
            .filter(|r| &r.material == m)
            .map(|r| r.noise)
            .fold(0.0, f64::max);
        let _ = writeln!(
            md,
            "\nReference noise (worst probe): {:.3}% relative RMS; errors near it are at the \
             reference's floor.",
            100.0 * noise
        );
    }
    md.push_str("\n## Per probe\n\n| probe | kind | material | technique | rel. RMS | bias | worst tile | GPU ms | render wall s | whole process s |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {:.2}% | {:+.2}% | {:.2}% | {:.2} | {:.3} | {:.3} |",
            r.probe,
            r.kind,
            r.material,
            r.label(),
            100.0 * r.rms,
            100.0 * r.bias,
            100.0 * r.tile,
            r.gpu_ms,
            r.wall_s,
            r.process_s
        );
    }
    md
}

/// Colour of a technique family.
fn colour(technique: &str) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match technique {
        "lookup" => RGBColor(0, 0, 0),
        "sh" => RGBColor(31, 119, 180),
        "prefiltered" => RGBColor(140, 86, 75),
        "fis" => RGBColor(44, 160, 44),
        "mc" => RGBColor(214, 39, 40),
        "sh_brdf" => RGBColor(148, 103, 189),
        super::cubes::PEER => RGBColor(127, 127, 127),
        _ => RGBColor(255, 127, 14),
    }
}

/// The chart's point labels: their font size, and their height and width in pixels (DejaVu
/// Sans averages under 0.6 em a character; the estimate errs wide).
const LABEL_PX: i32 = 12;
const LABEL_H: i32 = 14;

fn label_width(label: &str) -> i32 {
    (label.chars().count() as f64 * 0.6 * LABEL_PX as f64).ceil() as i32 + 2
}

/// Where each point's label goes, as the offset of its top-left corner from the point: the
/// first of twelve places around the point where it overlaps no label placed before it and no
/// marker and stays inside `area` (x0, y0, x1, y1); where none is free, the place that
/// overlaps least.
fn place_labels(
    points: &[(i32, i32)],
    widths: &[i32],
    area: (i32, i32, i32, i32),
) -> Vec<(i32, i32)> {
    type Rect = (i32, i32, i32, i32);
    let overlap = |a: Rect, b: Rect| {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0);
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0);
        w * h
    };
    let markers: Vec<Rect> = points
        .iter()
        .map(|&(x, y)| (x - 6, y - 6, x + 6, y + 6))
        .collect();
    let mut placed: Vec<Rect> = Vec::new();
    let mut out = Vec::with_capacity(points.len());
    for (&(x, y), &w) in points.iter().zip(widths) {
        let h = LABEL_H;
        let tries = [
            (7, -h),
            (7, 2),
            (-7 - w, -h),
            (-7 - w, 2),
            (-w / 2, -h - 6),
            (-w / 2, 7),
            (7, -2 * h),
            (-7 - w, 2 + h),
            (7, 2 + h),
            (-7 - w, -2 * h),
            (-w / 2, -2 * h - 6),
            (-w / 2, 7 + h),
        ];
        let cost = |&(dx, dy): &(i32, i32)| {
            let r = (x + dx, y + dy, x + dx + w, y + dy + h);
            let outside = (area.0 - r.0).max(0)
                + (r.2 - area.2).max(0)
                + (area.1 - r.1).max(0)
                + (r.3 - area.3).max(0);
            let hits: i32 = placed.iter().chain(&markers).map(|&o| overlap(r, o)).sum();
            hits + outside * h
        };
        let best = tries
            .iter()
            .copied()
            .min_by_key(|t| cost(t))
            .unwrap_or((7, -h));
        let r = (x + best.0, y + best.1, x + best.0 + w, y + best.1 + h);
        placed.push(r);
        out.push(best);
    }
    out
}

fn plot(path: &Path, rows: &[Row], device: &str) -> Result<()> {
    use plotters::prelude::*;
    let e = |e: &dyn std::fmt::Display| anyhow!("report.png: {e}");
    // Text comes from the DejaVu Sans the `dejavu` crate ships; no system font is read.
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow!("report.png: the bundled font did not load"))?;
    let mats = material_names(rows);
    let cols = mats.len().clamp(1, 3);
    let rows_n = mats.len().div_ceil(cols).max(1);
    let (w, h) = (620 * cols as u32, 520 * rows_n as u32 + 90);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let root = root
        .titled(
            "envlight: error against converged Monte Carlo vs GPU time (mean over the probes)",
            ("sans-serif", 22),
        )
        .map_err(|x| e(&x))?;
    let (legend, body) = root.split_vertically(56);
    legend
        .draw(&Text::new(
            format!("device: {device}; black line: the Pareto front"),
            (20, 34),
            ("sans-serif", 14),
        ))
        .map_err(|x| e(&x))?;
    let families = [
        "lookup",
        "sh",
        "prefiltered",
        "fis",
        "mc",
        "sh_brdf",
        "split_sum",
        super::cubes::PEER,
    ];
    for (k, f) in families.iter().enumerate() {
        let x = 20 + k as i32 * 150;
        legend
            .draw(&Circle::new((x, 12), 6, colour(f).filled()))
            .map_err(|x| e(&x))?;
        legend
            .draw(&Text::new(*f, (x + 12, 4), ("sans-serif", 16)))
            .map_err(|x| e(&x))?;
    }
    let panels = body.split_evenly((rows_n, cols));
    for (panel, m) in panels.iter().zip(&mats) {
        let p = points(rows, m);
        let f = front(&p);
        let floor = 1e-4;
        let (x0, x1) = p.iter().fold((f64::INFINITY, 0.0f64), |a, q| {
            (a.0.min(q.ms.max(1e-3)), a.1.max(q.ms.max(1e-3)))
        });
        let y1 = p.iter().map(|q| q.rms).fold(floor * 10.0, f64::max);
        let mut chart = ChartBuilder::on(panel)
            .caption(m, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(
                (x0 / 2.0..x1 * 2.0).log_scale(),
                (floor..y1 * 2.0).log_scale(),
            )
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("GPU ms per render (precomputation included)")
            .y_desc("relative RMS vs MC")
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(|x| e(&x))?;
        let at = |q: &Point| (q.ms.max(1e-3), q.rms.max(floor));
        chart
            .draw_series(LineSeries::new(
                f.iter().map(|&i| at(&p[i])),
                ShapeStyle::from(&BLACK).stroke_width(2),
            ))
            .map_err(|x| e(&x))?;
        let pixels: Vec<(i32, i32)> = p.iter().map(|q| chart.backend_coord(&at(q))).collect();
        let widths: Vec<i32> = p.iter().map(|q| label_width(&q.label)).collect();
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let area = (xs.start, ys.start, xs.end, ys.end);
        let offsets = place_labels(&pixels, &widths, area);
        for (q, offset) in p.iter().zip(offsets) {
            let c = colour(q.technique);
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at(at(q))
                        + Circle::new((0, 0), 5, c.filled())
                        + Text::new(q.label.clone(), offset, ("sans-serif", LABEL_PX)),
                ))
                .map_err(|x| e(&x))?;
        }
    }
    root.present().map_err(|x| e(&x))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Labels of points in a cluster (the chart's worst case: equal times, near errors) and at
    /// the plot's right edge overlap no other label and no marker and stay inside.
    #[test]
    fn labels_of_clustered_points_do_not_overlap() {
        let points = [
            (100, 100),
            (104, 103),
            (108, 98),
            (300, 200),
            (395, 60),
            (392, 64),
        ];
        let widths: Vec<i32> = [
            "sh l=2 (no lights)",
            "sh_brdf l=2",
            "mc N=64",
            "x",
            "split_sum (no lights)",
            "split_sum",
        ]
        .iter()
        .map(|l| label_width(l))
        .collect();
        let area = (0, 0, 400, 300);
        let at = place_labels(&points, &widths, area);
        let rect = |k: usize| {
            let (x, y) = (points[k].0 + at[k].0, points[k].1 + at[k].1);
            (x, y, x + widths[k], y + LABEL_H)
        };
        for a in 0..points.len() {
            let r = rect(a);
            assert!(
                r.0 >= 0 && r.1 >= 0 && r.2 <= 400 && r.3 <= 300,
                "label {a} outside: {r:?}"
            );
            for (b, &m) in points.iter().enumerate() {
                let o = rect(b);
                let apart = |p: (i32, i32, i32, i32), q: (i32, i32, i32, i32)| {
                    p.2 <= q.0 || q.2 <= p.0 || p.3 <= q.1 || q.3 <= p.1
                };
                assert!(
                    apart(r, (m.0 - 5, m.1 - 5, m.0 + 5, m.1 + 5)),
                    "label {a} on marker {b}"
                );
                if a != b {
                    assert!(apart(r, o), "labels {a} and {b} overlap: {r:?} {o:?}");
                }
            }
        }
    }

    fn point(label: &str, ms: f64, rms: f64) -> Point {
        Point {
            label: label.into(),
            technique: "mc",
            ms,
            rms,
            worst: rms,
            bias: 0.0,
            tile: 0.0,
            pre: 0.0,
            process: 0.0,
            frame: ms,
            frame_rms: rms,
        }
    }

    #[test]
    fn the_front_keeps_what_beats_everything_faster() {
        let p = vec![
            point("slow and bad", 10.0, 0.5),
            point("fast", 1.0, 0.3),
            point("better", 2.0, 0.1),
            point("worse, slower", 3.0, 0.2),
            point("best", 20.0, 0.01),
        ];
        let labels: Vec<&str> = front(&p).iter().map(|&i| p[i].label.as_str()).collect();
        assert_eq!(labels, ["fast", "better", "best"]);
    }

    #[test]
    fn errors_measure_rms_bias_and_tiles() {
        let m = EnvMap::new(crate::Mapping::LatLong, 8, 8, vec![[1.0; 3]; 64]);
        let mut a = m.clone();
        for t in &mut a.texels[..32] {
            *t = [1.5; 3];
        }
        let pixels: Vec<(usize, u32)> = (0..64).map(|k| (k, (k / 32) as u32)).collect();
        let (rms, bias, tile) = errors(&a, &m, &pixels);
        assert!((rms - (0.25f64 * 32.0 / 64.0).sqrt()).abs() < 1e-12);
        assert!((bias - 0.25).abs() < 1e-12);
        assert!((tile - 0.5).abs() < 1e-12);
    }
}
