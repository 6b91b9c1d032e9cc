//! `envlight report`: every technique on real probes and several materials, scored against the
//! exact texel sums (`--reference N`: Monte Carlo of 2N samples a pixel), with its GPU time (`envlight::bench::report`): report.md
//! (tables, the Pareto front per material and a headline), table.md (the accuracy table: the
//! same rows by probe), report.csv (one row per technique × parameters × probe × material)
//! and report.png (error against time, one panel per
//! material); or prefiltered cubes a user has, scored (`envlight::bench::cubes`).

use super::super::{context, Global};
use crate::bench::cubes::{CubeConvention, PeerCube};
use crate::bench::pareto::markdown;
use crate::bench::report::{csv, ExactOn, ReportOptions};
use crate::math::camera::sphere_camera;
use crate::render::Renderer;
use crate::scene::{Scene, SplitSumSettings};
use anyhow::{anyhow, bail, Context as _, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod plot;

use plot::plot;

/// Every technique against a noise-free reference on real probes: error and GPU time, with a
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
    /// Score against Monte Carlo of twice this many samples per pixel (16 renders; their
    /// spread is its noise) instead of the exact texel sums (the reference by default: no noise); also the --cube scores'
    /// reference (default 16384, quick 1024)
    #[arg(long)]
    reference: Option<u32>,
    /// Only redraw OUT/report.png and rewrite OUT/table.md from OUT/report.csv (and the
    /// device and settings its report.md names), measuring nothing
    #[arg(long)]
    replot: bool,
    /// Only these probes of the set (their file names, with or without .hdr, separated by
    /// commas)
    #[arg(long, value_delimiter = ',')]
    probe: Vec<String>,
    /// Where the exact reference is summed: gpu (`passes::ExactShader`, a dozen pixels of
    /// each probe and material checked against its float64 twin), host (the float64 twin),
    /// or auto: the GPU unless the device is the CPU, where the host is the faster
    #[arg(long, default_value = "auto", value_parser = ["auto", "gpu", "host"])]
    exact_on: String,
    /// Instead: score these prefiltered cubes (KTX2 or DDS) as split-sum shading on
    /// --cube-probe against the exact texel sums (or --reference's Monte Carlo), beside
    /// envlight's own renders (cubes.md, cubes.csv)
    #[arg(long)]
    cube: Vec<PathBuf>,
    /// Each --cube's conventions, in order (the last repeats): envlight, khronos
    /// (glTF-IBL-Sampler), bevy or cmft (its radiance filter, phongbrdf, gloss scale 10, bias 1)
    #[arg(long, value_parser = super::super::named(&CubeConvention::NAMES, CubeConvention::parse))]
    cube_convention: Vec<CubeConvention>,
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

/// Runs glTF-IBL-Sampler (`sampler`, its wrapper) on the lat-long `probe` once per sample
/// count and a cube of `size` (its default, half the panorama's height, where `None`), with
/// its defaults otherwise (log2 of the size levels, rgba16f), in `scratch`. It reads Radiance
/// files only (stb_image): any other probe is handed to it written as one in `scratch` (RGBE,
/// a shared 8-bit exponent: within 0.4% of each texel), outside its timed runs.
fn sampler_cubes(
    sampler: &Path,
    probe: &Path,
    scratch: &Path,
    counts: &[u32],
    size: Option<u32>,
) -> Result<Vec<PeerCube>> {
    let radiance = probe
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("hdr"));
    let probe = match radiance {
        true => probe.to_path_buf(),
        false => {
            let input = scratch.join("iblsampler-input.hdr");
            let map = crate::io::load(probe, &Default::default())?;
            crate::io::save_map(&map, &input)?;
            input
        }
    };
    let probe = probe.as_path();
    let mut out = Vec::new();
    for &n in counts {
        let cube = scratch.join(format!("iblsampler-{n}.ktx2"));
        let mut c = std::process::Command::new(sampler);
        c.arg("-inputPath").arg(probe).arg("-outCubeMap").arg(&cube);
        c.arg("-outLUT").arg(scratch.join("iblsampler-lut.png"));
        c.args(["-distribution", "GGX", "-sampleCount", &n.to_string()]);
        if let Some(s) = size {
            c.args(["-cubeMapResolution", &s.to_string()]);
            c.args(["-mipLevelCount", &s.ilog2().to_string()]);
        }
        let t0 = std::time::Instant::now();
        let o = c.output().with_context(|| sampler.display().to_string())?;
        let seconds = t0.elapsed().as_secs_f64();
        if !o.status.success() {
            bail!(
                "{} on {}: {}",
                sampler.display(),
                probe.display(),
                String::from_utf8_lossy(&o.stderr)
            );
        }
        out.push(PeerCube::read(&cube, CubeConvention::Khronos, n, seconds)?);
    }
    Ok(out)
}

/// The page's last section: the techniques that cannot shade each material (the scene's
/// own check refuses them), and the probes left out with the reason.
fn limits(quick: bool, skipped: &[String]) -> String {
    let mut s = String::from(
        "\n## What is not measured\n\n| material | techniques that cannot shade it |\n|---|---|\n",
    );
    for (material, refused) in crate::bench::report::cannot_shade(quick) {
        let list = match refused.is_empty() {
            true => "—".to_string(),
            false => refused.join(", "),
        };
        s.push_str(&format!("| {material} | {list} |\n"));
    }
    if !skipped.is_empty() {
        s.push_str("\nProbes left out:\n\n");
        for k in skipped {
            s.push_str(&format!("- {k}\n"));
        }
    }
    s
}

/// Redraws `out`/report.png and rewrites table.md from its report.csv, with the device and
/// settings its report.md names.
fn replot(out: &Path) -> Result<()> {
    let path = out.join("report.csv");
    let text = std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
    let rows =
        crate::bench::report::parse_csv(&text).with_context(|| path.display().to_string())?;
    let md = std::fs::read_to_string(out.join("report.md")).unwrap_or_default();
    let device = md
        .split("Device: ")
        .nth(1)
        .and_then(|d| d.split(". Sphere").next())
        .unwrap_or("(not named in report.md)")
        .to_string();
    plot(&out.join("report.png"), &rows, &device)?;
    let settings = md.lines().nth(2).unwrap_or_default();
    let table = crate::bench::pareto::table_markdown(&rows, settings);
    std::fs::write(out.join("table.md"), table).context("table.md")?;
    println!(
        "wrote {}/report.png, table.md ({} rows)",
        out.display(),
        rows.len()
    );
    Ok(())
}

/// Runs the report.
pub fn report(g: &Global, args: &ReportArgs) -> Result<()> {
    if args.replot {
        return replot(&args.out);
    }
    let mut o = ReportOptions::new(args.quick);
    o.size = args.size.unwrap_or(o.size);
    o.reference = args.reference.unwrap_or(o.reference);
    o.exact = args.reference.is_none();
    o.split = args.split();
    o.probes = args.probe.clone();
    o.exact_on = match args.exact_on.as_str() {
        "gpu" => ExactOn::Gpu,
        "host" => ExactOn::Host,
        _ => ExactOn::Auto,
    };
    let ctx = context(g)?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver.trim());
    eprintln!("device: {device}");
    let progress = |m: &str| eprintln!("{m}");
    if !args.cube.is_empty() {
        let probe = args.cube_probe.as_deref().ok_or_else(|| {
            anyhow!("--cube needs --cube-probe, the probe the cubes were made from")
        })?;
        let cubes = crate::bench::cubes::with_conventions(&args.cube, &args.cube_convention);
        let renderer = Renderer::new(&ctx);
        let cam = sphere_camera(o.size);
        let reference = (!o.exact).then_some(o.reference);
        let s = crate::bench::cubes::score(&renderer, cam, reference, probe, &cubes, &progress)?;
        let out = &args.out;
        std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
        std::fs::write(out.join("cubes.csv"), s.csv()).context("cubes.csv")?;
        std::fs::write(out.join("cubes.md"), s.markdown(&device)).context("cubes.md")?;
        println!("wrote {}/cubes.md, cubes.csv", out.display());
        return Ok(());
    }
    let dir = probes_dir(args)?;
    let started = Instant::now();
    // glTF-IBL-Sampler's cubes join the GGX materials where it is present.
    let sampler = sampler_from_env();
    let counts: &[u32] = if o.quick { &[16, 64] } else { &[64, 1024] };
    let scratch = std::env::temp_dir().join(format!("envlight-report-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| scratch.display().to_string())?;
    let library = |e: anyhow::Error| crate::Error::Invalid(format!("{e:#}"));
    let peers = |probe: &Path| match &sampler {
        Some(exe) => {
            sampler_cubes(exe, probe, &scratch, counts, o.quick.then_some(64)).map_err(library)
        }
        None => Ok(Vec::new()),
    };
    let process = |sc: &Scene| process_seconds(g, sc, &scratch).map_err(library);
    let hooks = crate::bench::report::Hooks {
        process: &process,
        peers: &peers,
        progress: &progress,
    };
    let crate::bench::report::Report { rows, skipped } =
        crate::bench::report::run(&ctx, &dir, &o, &hooks)?;
    let _ = std::fs::remove_dir_all(&scratch);
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let path = out.join("report.csv");
    std::fs::write(&path, csv(&rows)).with_context(|| path.display().to_string())?;
    let reference = match (o.exact, o.exact_on_gpu(&ctx)) {
        (true, true) => "the exact sum over the map's texels at each pixel, on the GPU \
                 (`passes::ExactShader`: no sampling noise; checked against its float64 twin \
                 `ExactFilter::shade` at a dozen pixels of each probe and material, the worst \
                 error stated under each material, as is the sums' own error estimated by \
                 doubling their cells; the mirror against its pixel-area mean)"
            .to_string(),
        (true, false) => "the exact sum over the map's texels at each pixel, in float64 on the \
                 host (`ExactFilter::shade`, the GPU pass's twin, the faster on a CPU device: no \
                 sampling noise; its own error, estimated by doubling its cells, stated under \
                 each material; the mirror against its pixel-area mean)"
            .to_string(),
        (false, _) => format!(
            "2 × {} spp MIS Monte Carlo (the mean of {} renders; its noise is that mean's \
             standard error, from their spread)",
            o.reference,
            crate::render::score::REPLICAS
        ),
    };
    let settings = format!(
        "Device: {device}. Sphere {}² (orthographic, normal to grazing incidence), \
         reference {reference}. FIS paraboloid {}; split-sum {:?}; sh_brdf grid 32, no \
         window; commit {}. Run took {:.0} s{}.",
        o.size,
        o.paraboloid()
            .map(|d| format!("{d}²"))
            .unwrap_or_else(|| "sized by the source (1024² for a 1k lat-long)".into()),
        o.split,
        super::commit(),
        started.elapsed().as_secs_f64(),
        if o.quick { " (--quick)" } else { "" }
    );
    let mut md = markdown(&rows, &settings);
    md.push_str(&crate::bench::pareto::goals_markdown(&rows));
    md.push_str(&limits(o.quick, &skipped));
    std::fs::write(out.join("report.md"), md).with_context(|| "report.md")?;
    let table = crate::bench::pareto::table_markdown(&rows, &settings);
    std::fs::write(out.join("table.md"), table).with_context(|| "table.md")?;
    plot(&out.join("report.png"), &rows, &device)?;
    println!(
        "wrote {}/report.md, table.md, report.csv, report.png ({} rows)",
        out.display(),
        rows.len()
    );
    Ok(())
}
