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

mod pareto;
mod plot;

use pareto::markdown;
use plot::plot;
