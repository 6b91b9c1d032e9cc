//! `envlight-lab peers`: the jobs a user would otherwise give cmft, timed as whole processes
//! in paired, alternating runs on the same machine, with each result's error beside its time.

use anyhow::{bail, Context as _, Result};
use envlight::io::{load, LoadOptions};
use envlight::math::filter::{Kernel, Prepared};
use envlight::math::sh;
use envlight::passes::brute::PhongLevels;
use envlight::EnvMap;
use glam::{DMat3, DVec3};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Options of `envlight-lab peers`.
pub struct PeersOptions<'a> {
    /// The map every job reads (cmft reads .hdr and .dds, not EXR).
    pub map: &'a Path,
    /// cmft's executable, if present.
    pub cmft: Option<&'a Path>,
    /// Timed pairs per fast job.
    pub reps: usize,
    /// Timed pairs for the Phong job (each envlight run takes many seconds on lavapipe).
    pub phong_reps: usize,
    /// The performance page to write the job's section into (the section is also printed),
    /// and the device, CPU, commit, date and command it names.
    pub page: Option<(&'a Path, crate::page::Provenance)>,
}

/// How `bench peers` measures, as its page section states it.
const METHOD: &str = "whole-process wall time, median of paired alternating runs (envlight, \
     cmft) after one untimed run of each (Mesa's shader cache warm); 'cold' is one envlight \
     run with the shader cache disabled, as a first run has it. GPU is the sum of envlight's \
     timestamp spans (warm). Each output's error is against its float64 reference, beside \
     its time.";

/// One job, as both programs run it.
struct Job {
    name: &'static str,
    envlight: Vec<String>,
    /// cmft's arguments; `None` where cmft has no such job.
    cmft: Option<Vec<String>>,
    reps: usize,
    goal: &'static str,
}

/// Wall-clock seconds of one run; its stdout.
fn run(program: &Path, args: &[String], env: &[(&str, &str)]) -> Result<(f64, String)> {
    let start = Instant::now();
    let out = Command::new(program)
        .args(args)
        .envs(env.iter().copied())
        .output()
        .with_context(|| format!("running {}", program.display()))?;
    let secs = start.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "{} {} failed: {}",
            program.display(),
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok((secs, String::from_utf8_lossy(&out.stdout).into_owned()))
}

/// The medians of the start-up lines in `outs` (`envlight devices` runs), each of the five
/// numbers alone; None where no run printed one.
fn startup_medians(outs: &[String]) -> Option<[f64; 5]> {
    let lines: Vec<[f64; 5]> = outs
        .iter()
        .filter_map(|o| crate::common::parse_startup_line(o))
        .collect();
    if lines.is_empty() {
        return None;
    }
    Some(std::array::from_fn(|k| {
        median(&mut lines.iter().map(|l| l[k]).collect::<Vec<_>>())
    }))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// The "host x ms label" lines envlight prints, in order.
fn host_spans(stdout: &str) -> Vec<(String, f64)> {
    stdout
        .lines()
        .filter_map(|l| {
            let rest = l.trim_start().strip_prefix("host")?;
            let (ms, label) = rest.trim_start().split_once(" ms")?;
            Some((label.trim().to_string(), ms.trim().parse::<f64>().ok()?))
        })
        .collect()
}

/// Sum of the "GPU  x ms  label" lines envlight prints; for `render`, its "total  x" line.
fn gpu_ms(stdout: &str) -> f64 {
    stdout
        .lines()
        .filter_map(|l| {
            let mut w = l.split_whitespace();
            matches!(w.next(), Some("GPU" | "total")).then(|| w.next()?.parse::<f64>().ok())?
        })
        .sum()
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// Largest |a − b| / |b| over texels and channels where |b| is above 1e-6 of the largest.
fn worst_relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let top = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .filter(|(_, r)| r.abs() > 1e-6 * top)
        .map(|(x, r)| ((x - r) / r).abs())
        .fold(0.0, f64::max)
}

fn texels_f64(m: &EnvMap) -> Vec<[f64; 3]> {
    m.texels.iter().map(|t| t.map(f64::from)).collect()
}

fn centres(m: &EnvMap) -> Vec<DVec3> {
    let mut d = Vec::new();
    for layer in 0..m.layers() {
        for j in 0..m.height {
            for i in 0..m.width {
                d.push(m.texel_dir(layer, i, j));
            }
        }
    }
    d
}

/// Power error of a map against the source's, worst channel, relative.
fn power_error(out: &EnvMap, src: &EnvMap) -> f64 {
    let (p, q) = (out.power(), src.power());
    (0..3)
        .map(|c| (p[c] / q[c] - 1.0).abs())
        .fold(0.0, f64::max)
}

/// Irradiance of SH radiance coefficients at every texel centre of `like`, over `divide`.
fn sh_irradiance_at(coeffs: &[[f64; 3]], like: &EnvMap, divide: f64) -> Vec<[f64; 3]> {
    let e = sh::irradiance_coeffs(coeffs);
    centres(like)
        .into_iter()
        .map(|d| sh::eval(&e, d).map(|v| v / divide))
        .collect()
}

fn load_any(path: &Path) -> Result<EnvMap> {
    load(path, &LoadOptions::default()).with_context(|| path.display().to_string())
}

/// Runs the table and writes the report.
pub fn bench_peers(opts: &PeersOptions) -> Result<()> {
    let me = crate::common::envlight_exe()?;
    if !opts.map.exists() {
        bail!(
            "{}: no such map (give an existing .hdr with --map)",
            opts.map.display()
        );
    }
    let tmp = tempdir()?;
    let jobs = peer_jobs(opts, &tmp)?;
    let measured = measure(&me, opts, &jobs, &tmp)?;
    let md = peers_markdown(opts, &measured);
    println!("{md}");
    if let Some((out, provenance)) = &opts.page {
        let section = crate::page::Section {
            job: "peers",
            title: "The jobs users give cmft, paired with cmft",
            method: METHOD,
            body: &md,
        };
        crate::page::write_section(out, &section, provenance)?;
    }
    let _ = std::fs::remove_dir_all(&tmp);
    Ok(())
}

/// The table's jobs on `opts.map`, their outputs in `tmp` (the FIS job's scene written there).
fn peer_jobs(opts: &PeersOptions, tmp: &Path) -> Result<Vec<Job>> {
    let map = opts.map.display().to_string();
    let t = |name: &str| tmp.join(name).display().to_string();
    let cmft_common = |filter: &str, out: &str| {
        let mut v = strings(&["--input", &map, "--filter", filter]);
        v.extend(strings(&[
            "--numCpuProcessingThreads",
            "3",
            "--outputNum",
            "1",
            "--output0",
            out,
            "--output0params",
            "dds,rgba32f,cubemap",
        ]));
        v
    };
    // cmft's phongbrdf radiance filter into a 64 cube, `mips` levels by BENCH_LEVELS' rule.
    let cmft_phong = |out: &str, mips: u32| {
        let mut v = cmft_common("radiance", &t(out));
        v.extend(strings(&[
            "--dstFaceSize",
            "64",
            "--lightingModel",
            "phongbrdf",
            "--excludeBase",
            "false",
            "--mipCount",
            &mips.to_string(),
            "--glossScale",
            &BENCH_LEVELS.scale.to_string(),
            "--glossBias",
            &BENCH_LEVELS.bias.to_string(),
        ]));
        v
    };
    // The one-level Phong job (BENCH_LEVELS' level 0), or its visit floor.
    let phong_one = |out: &str, floor: bool| {
        let mut v = strings(&["prefilter", &map, "--phong", "2049", "--to", "cube"]);
        v.extend(strings(&["--size", "64"]));
        if floor {
            v.push("--visit-floor".into());
        }
        v.extend(strings(&["-o", &t(out)]));
        v
    };
    let jobs = vec![
        Job {
            name: "SH coefficients (envlight l = 2; cmft l = 4)",
            envlight: strings(&["sh", &map, "--order", "2", "-o", &t("sh.json")]),
            cmft: Some(cmft_common("shcoeffs", &t("cmft_sh"))),
            reps: opts.reps,
            goal: "≤ 1.0×",
        },
        Job {
            name: "irradiance cube 64 (envlight SH l = 2; cmft SH l = 4)",
            envlight: strings(&[
                "irradiance",
                &map,
                "--method",
                "sh",
                "--order",
                "2",
                "--to",
                "cube",
                "--size",
                "64",
                "-o",
                &t("irr.exr"),
            ]),
            cmft: Some({
                let mut v = cmft_common("irradiance", &t("cmft_irr"));
                v.extend(strings(&["--dstFaceSize", "64"]));
                v
            }),
            reps: opts.reps,
            goal: "≤ 1.0×",
        },
        Job {
            name: CONVERT_JOB,
            envlight: strings(&[
                "convert",
                &map,
                "--to",
                "cube",
                "--size",
                "256",
                "-o",
                &t("conv.exr"),
            ]),
            cmft: Some({
                let mut v = cmft_common("none", &t("cmft_conv"));
                v.extend(strings(&["--dstFaceSize", "256"]));
                v
            }),
            reps: opts.reps,
            goal: "≤ 2×, power within 0.01%",
        },
        Job {
            name: PHONG_JOB,
            envlight: phong_one("phong.exr", false),
            cmft: Some(cmft_phong("cmft_phong", 1)),
            reps: opts.phong_reps,
            goal: "≤ 1.0×, error ≤ 1e-3",
        },
        Job {
            name: PHONG_FLOOR_JOB,
            envlight: phong_one("phong_floor.exr", true),
            cmft: None,
            reps: opts.phong_reps,
            goal: "the row above's floor",
        },
        Job {
            name: LEVELS_JOB,
            envlight: strings(&[
                "prefilter",
                &map,
                "--phong-levels",
                &BENCH_LEVELS.count.to_string(),
                "--to",
                "cube",
                "--size",
                "64",
                "-o",
                &t("levels.exr"),
            ]),
            cmft: Some(cmft_phong("cmft_levels", BENCH_LEVELS.count)),
            reps: opts.phong_reps,
            goal: "≤ 1.0×, every level within 1e-3",
        },
        Job {
            name: FIS_JOB,
            envlight: strings(&["render", &t("fis.toml"), "-o", &t("fis.exr")]),
            cmft: None,
            reps: opts.reps,
            goal: "≤ 0.15 s whole process",
        },
    ];
    write_fis_scene(opts.map, tmp)?;
    Ok(jobs)
}

/// The FIS job's scene, `tmp/fis.toml`: a GGX α 0.3 unit sphere, 128², FIS with 64 samples,
/// lit by `map` (lights extracted, the default), seen orthographically.
fn write_fis_scene(map: &Path, tmp: &Path) -> Result<()> {
    let map_abs = std::fs::canonicalize(map).with_context(|| map.display().to_string())?;
    std::fs::write(
        tmp.join("fis.toml"),
        format!(
            "[environment]\nfile = {:?}\n\n[camera]\nprojection = {{ kind = \"orthographic\", height = 2.2 }}\n\
             eye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nwidth = 128\nheight = 128\n\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
             material = {{ type = \"ggx\", alpha = 0.3, technique = {{ kind = \"fis\", samples = 64 }} }}\n",
            map_abs.display().to_string()
        ),
    )?;

    Ok(())
}

/// One job's medians: (job, envlight s, cmft s, envlight cold s, GPU ms, envlight error,
/// cmft error).
type Row<'j> = (&'j Job, f64, f64, f64, f64, String, String);
/// One job's whole time and its host spans (label, median ms).
type Spans = (&'static str, f64, Vec<(String, f64)>);

/// What the timed runs measured: the device, the floors of `devices` and `info`, the driver's
/// start-up medians, the rows and the breakdowns.
struct Measured<'j> {
    device: String,
    floor_devices: f64,
    floor_info: f64,
    startup: Option<[f64; 5]>,
    rows: Vec<Row<'j>>,
    breakdown: Vec<Spans>,
}

/// Runs every job in paired alternating runs (envlight, then cmft where it has the job).
fn measure<'j>(
    me: &Path,
    opts: &PeersOptions,
    jobs: &'j [Job],
    tmp: &Path,
) -> Result<Measured<'j>> {
    let map = opts.map.display().to_string();
    let (_, devices) = run(me, &strings(&["devices"]), &[])?;
    let device = devices
        .lines()
        .next()
        .unwrap_or("?")
        .trim_start_matches("envlight uses: ")
        .to_string();
    // Each run's output too: `devices` reports what its start-up and teardown cost.
    let floor = |args: &[String]| -> Result<(f64, Vec<String>)> {
        run(me, args, &[])?;
        let (mut v, mut outs) = (Vec::new(), Vec::new());
        for _ in 0..opts.reps.max(1) {
            let (t, out) = run(me, args, &[])?;
            v.push(t);
            outs.push(out);
        }
        Ok((median(&mut v), outs))
    };
    let (floor_devices, outs) = floor(&strings(&["devices"]))?;
    let startup = startup_medians(&outs);
    let (floor_info, _) = floor(&strings(&["info", &map]))?;
    // `info` also extracts the map's lights; the breakdown below has the load alone.

    let src = load_any(opts.map)?;
    let mut rows = Vec::new();
    let mut breakdown = Vec::new();
    for job in jobs {
        eprintln!("{} …", job.name);
        // One untimed run of each warms the file cache and Mesa's shader cache.
        run(me, &job.envlight, &[])?;
        let cmft = opts.cmft.zip(job.cmft.as_ref());
        if let Some((c, args)) = cmft {
            run(c, args, &[])?;
        }
        let (mut te, mut tc) = (Vec::new(), Vec::new());
        let mut gpu = Vec::new();
        let mut spans: Vec<(String, Vec<f64>)> = Vec::new();
        for _ in 0..job.reps.max(1) {
            let (s, out) = run(me, &job.envlight, &[])?;
            te.push(s);
            gpu.push(gpu_ms(&out));
            for (k, (label, ms)) in host_spans(&out).into_iter().enumerate() {
                if spans.len() <= k {
                    spans.push((label, Vec::new()));
                }
                spans[k].1.push(ms);
            }
            if let Some((c, args)) = cmft {
                tc.push(run(c, args, &[])?.0);
            }
        }
        // A first run as a new user has it: no shader cache, so llvmpipe compiles every shader.
        let (cold, _) = run(me, &job.envlight, &[("MESA_SHADER_CACHE_DISABLE", "true")])?;
        let (e_err, c_err) = errors(job.name, &src, tmp, cmft.is_some())?;
        let spans: Vec<(String, f64)> = spans
            .into_iter()
            .map(|(label, mut v)| (label, median(&mut v)))
            .collect();
        breakdown.push((job.name, median(&mut te), spans));
        rows.push((
            job,
            median(&mut te),
            median(&mut tc),
            cold,
            median(&mut gpu),
            e_err,
            c_err,
        ));
    }

    Ok(Measured {
        device,
        floor_devices,
        floor_info,
        startup,
        rows,
        breakdown,
    })
}

/// The report's markdown.
fn peers_markdown(opts: &PeersOptions, m: &Measured<'_>) -> String {
    let map = opts.map.display().to_string();
    let Measured {
        device,
        floor_devices,
        floor_info,
        startup,
        rows,
        breakdown,
    } = m;
    let mut md = String::new();
    md.push_str(&format!(
        "envlight on {device}. Map: `{map}`. cmft: {}.\n\n",
        opts.cmft.map_or(
            "absent (set ENVLIGHT_CMFT): its columns are empty".into(),
            |c| { format!("`{}`, 2 worker threads", c.display()) }
        )
    ));
    md.push_str(&format!(
        "Floor of any envlight job here: process start + Vulkan instance and device \
         (`envlight devices`) {floor_devices:.3} s{}; `envlight info` (loading the map, its \
         statistics and its lights) {floor_info:.3} s. The load itself runs beside device \
         creation: see the breakdown below.\n\n",
        startup.map_or(
            String::new(),
            |[loader, instance, device, rest, teardown]| format!(
                ", of which the driver's, timed inside the process (medians, ms): loading the \
             Vulkan loader {loader:.1}, vkCreateInstance {instance:.1}, vkCreateDevice \
             {device:.1}, the allocator and the rest {rest:.1}, destroying it all {teardown:.1}"
            )
        )
    ));
    md.push_str("| job | cmft s | envlight s | ratio | envlight cold s | envlight GPU ms | envlight error | cmft error | goal |\n|---|---|---|---|---|---|---|---|---|\n");
    for (job, te, tc, cold, gpu, ee, ce) in rows.iter() {
        let have_c = opts.cmft.is_some() && job.cmft.is_some();
        md.push_str(&format!(
            "| {} | {} | {te:.3} | {} | {cold:.3} | {gpu:.1} | {ee} | {} | {} |\n",
            job.name,
            if have_c {
                format!("{tc:.3}")
            } else {
                "–".into()
            },
            if have_c {
                format!("{:.2}×", te / tc)
            } else {
                "–".into()
            },
            if have_c { ce.as_str() } else { "–" },
            job.goal
        ));
    }
    // Phong's floor against its row: what visiting the exact sum's texels costs alone.
    let row = |name: &str| rows.iter().find(|r| r.0.name == name);
    if let (Some(p), Some(fl)) = (row(PHONG_JOB), row(PHONG_FLOOR_JOB)) {
        let (whole, cmft, gpu, floor, floor_gpu) = (p.1, p.2, p.4, fl.1, fl.4);
        md.push_str(&format!(
            "\nPhong's floor (the row marked so): the one-level job with its walk over the same \
             texels, each read once and summed without the lobe's rule (`prefilter \
             --visit-floor`; the process, upload and preparation of the source's texels as the \
             job has them), {floor:.3} s whole, {floor_gpu:.0} of the job's {gpu:.0} ms of \
             GPU{}. The exact sum visits every texel whose cone reaches the lobe above \
             e^({:.2}) of its peak, the bound on the energy it drops: where this ratio is above \
             the goal, no sum over those texels meets it on this device, however cheap its \
             rule. The other {:.0} ms of GPU ({:.0}% of the job's whole time) are the rule's \
             per-texel integrals of the lobe.\n",
            if opts.cmft.is_some() && cmft > 0.0 {
                format!(": {:.2}× cmft's one-level time", floor / cmft)
            } else {
                String::new()
            },
            envlight::math::filter::LOG_CUTOFF,
            gpu - floor_gpu,
            100.0 * (whole - floor) / whole.max(1e-9),
        ));
        // The levels job filters its level 0 as the one-level job does, from the whole map.
        if let Some(l) = row(LEVELS_JOB).filter(|l| opts.cmft.is_some() && l.2 > 0.0) {
            md.push_str(&format!(
                "\nThe levels job's level 0 is the one-level job (n = {}, from the whole map): \
                 that level's floor alone is {:.2}× cmft's whole {}-level time ({:.3} s).\n",
                BENCH_LEVELS.exponent(0),
                floor / l.2,
                BENCH_LEVELS.count,
                l.2
            ));
        }
    }
    // The rows whose goal is a time: what is left of it without the GPU's work.
    if let Some(c) = row(CONVERT_JOB).filter(|_| opts.cmft.is_some()) {
        let (whole, cmft, gpu) = (c.1, c.2, c.4);
        let rest = whole - gpu / 1e3;
        md.push_str(&format!(
            "\nThe conversion's floor: its whole time less its GPU work is {rest:.3} s \
             ({:.2}× cmft's {cmft:.3} s; the goal is 2×): process start, device, load, upload \
             and pipeline builds, download and EXR write, in the breakdown below. The exact \
             areas' GPU work ({gpu:.1} ms) comes on top.\n",
            rest / cmft.max(1e-9)
        ));
    }
    if let Some(f) = row(FIS_JOB) {
        let (whole, gpu) = (f.1, f.4);
        let rest = whole - gpu / 1e3;
        md.push_str(&if whole <= FIS_GOAL_S {
            format!(
                "\nThe FIS render meets its {FIS_GOAL_S} s goal: {whole:.3} s whole, of which \
                 {gpu:.1} ms of GPU work (`envlight render` prints each pass's time).\n"
            )
        } else if rest > FIS_GOAL_S {
            format!(
                "\nThe FIS render less its GPU work: {rest:.3} s, above the {FIS_GOAL_S} s goal \
                 before any GPU work: the process, device, load and pipeline builds of the \
                 breakdown below.\n"
            )
        } else {
            format!(
                "\nThe FIS render less its GPU work: {rest:.3} s, under the {FIS_GOAL_S} s goal; \
                 its GPU work, {gpu:.1} ms (`envlight render` prints each pass's time), is what \
                 must shrink.\n"
            )
        });
    }
    notes_and_breakdown(&mut md, breakdown);
    md
}

/// The errors' definitions, and where envlight's whole-process time goes.
fn notes_and_breakdown(md: &mut String, breakdown: &[Spans]) {
    md.push_str(
        "\nErrors: SH, worst coefficient against the float64 projection (relative to the largest); \
         irradiance, worst texel against float64 SH of the same order (cmft's E/π against order 4); \
         conversion, total power against the source's; Phong, worst of 128 texels spread over \
         the cube and the 8 nearest the map's poles (levels: 32 and 8 per level) against the \
         float64 brute force over every source texel with Gauss cells everywhere. cmft's \
         irradiance and Phong cubes are not compared texel by texel: \
         their face frame is not yet matched to docs/design.md's, so a difference would measure the \
         frames; ../shared/peers/README.md measured 1–16% lobe-tail error for its Phong.\n",
    );
    md.push_str(
        "\nWhere envlight's whole-process time goes: the host spans each command prints \
         ('host x ms label'; '∥' marks work on two threads at once), medians of the timed runs; \
         'rest' is the whole process less their sum (process start, argument parsing, exit and \
         teardown).\n\n| job | whole s | host spans, ms | rest, ms |\n|---|---|---|---|\n",
    );
    for (name, whole, spans) in breakdown.iter() {
        let sum: f64 = spans.iter().map(|(_, ms)| ms).sum();
        let list: Vec<String> = spans
            .iter()
            .map(|(label, ms)| format!("{label} {ms:.1}"))
            .collect();
        md.push_str(&format!(
            "| {name} | {whole:.3} | {} | {:.1} |\n",
            list.join("; "),
            whole * 1e3 - sum
        ));
    }
}

/// The errors of each program's output for a job (see the report's note).
fn errors(job: &str, src: &EnvMap, tmp: &Path, cmft: bool) -> Result<(String, String)> {
    let f = |v: f64| format!("{v:.1e}");
    let dash = || "–".to_string();
    if job.starts_with("SH") {
        let text = std::fs::read_to_string(tmp.join("sh.json"))?;
        let json: envlight::passes::sh_project::ShJson = serde_json::from_str(&text)?;
        let cpu = sh::project(src, 2);
        let top = cpu.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = json
            .coefficients
            .iter()
            .flatten()
            .zip(cpu.iter().flatten())
            .map(|(g, c)| (g - c).abs() / top)
            .fold(0.0, f64::max);
        return Ok((f(worst), dash()));
    }
    if job.starts_with("irradiance") {
        let ours = load_any(&tmp.join("irr.exr"))?;
        let want = sh_irradiance_at(&sh::project(src, 2), &ours, 1.0);
        let e = f(worst_relative(&texels_f64(&ours), &want));
        // cmft's output cube has not been matched to docs/design.md's frame (a texel-by-texel
        // comparison gave relative errors of 5 to 11, far beyond any filter's error), so it
        // would measure the frames, not the filter: its error column stays empty here.
        let c = if cmft { NOT_COMPARED.into() } else { dash() };
        return Ok((e, c));
    }
    if job == PHONG_FLOOR_JOB {
        return Ok(("– (Σ L·Ω visited, not a map)".into(), dash()));
    }
    if job == FIS_JOB {
        // Its accuracy against converged Monte Carlo is docs/accuracy's table (FIS-64 with
        // lights within 2.42% on five probes).
        return Ok(("see docs/accuracy".into(), dash()));
    }
    if job == CONVERT_JOB {
        let e = power_error(&load_any(&tmp.join("conv.exr"))?, src);
        let c = if cmft {
            f(power_error(&load_any(&tmp.join("cmft_conv.dds"))?, src))
        } else {
            dash()
        };
        return Ok((format!("power {}", f(e)), format!("power {c}")));
    }
    // Phong: texels spread over the cube (128; 32 per level for the levels), against the
    // float64 brute force over every source texel with Gauss cells everywhere (not the tilted
    // rule nor the moment pyramid the GPU takes), so the error includes both. And the 4
    // texels nearest each of the lat-long's poles, whose lobes reach the rows there that take
    // Gauss cells (on CPU devices in a second walk): the stride samples none of them, so a
    // loss there would go unseen.
    let prep = Prepared::new(src, DMat3::IDENTITY).without_tilt();
    let worst = |ours: &EnvMap, n: f64, count: usize| {
        let kernel = Kernel::Phong { n };
        let dirs = centres(ours);
        let step = (dirs.len() / count).max(1);
        let mut picks: Vec<usize> = (0..dirs.len()).step_by(step).collect();
        for pole in [DVec3::Y, DVec3::NEG_Y] {
            let mut near: Vec<usize> = (0..dirs.len()).collect();
            near.sort_by(|&a, &b| dirs[b].dot(pole).total_cmp(&dirs[a].dot(pole)));
            picks.extend(near.into_iter().take(4));
        }
        picks.sort_unstable();
        picks.dedup();
        let want: Vec<[f64; 3]> = picks
            .iter()
            .map(|&i| prep.convolve(kernel, dirs[i]))
            .collect();
        let got: Vec<[f64; 3]> = picks
            .iter()
            .map(|&i| ours.texels[i].map(f64::from))
            .collect();
        worst_relative(&got, &want)
    };
    let c = if cmft { NOT_COMPARED.into() } else { dash() };
    if job.starts_with("Phong levels") {
        let mut e: f64 = 0.0;
        for k in 0..BENCH_LEVELS.count {
            let ours = load_any(&tmp.join(format!("levels.level{k}.exr")))?;
            e = e.max(worst(&ours, BENCH_LEVELS.exponent(k), 32));
        }
        return Ok((format!("{} (worst level)", f(e)), c));
    }
    let ours = load_any(&tmp.join("phong.exr"))?;
    Ok((f(worst(&ours, BENCH_LEVELS.exponent(0), 128)), c))
}

/// The Phong jobs' levels: cmft's `--glossScale 10 --glossBias 1` (n = 2049 at level 0; the
/// one-level job is level 0), seven levels for the 64 cube.
const BENCH_LEVELS: PhongLevels = PhongLevels {
    count: 7,
    scale: 10.0,
    bias: 1.0,
};

/// The conversion row of the table.
const CONVERT_JOB: &str = "lat-long → cube 256";

/// The Phong one-level row of the table.
const PHONG_JOB: &str = "Phong n = 2049, cube 64, one level";

/// The Phong one-level job's floor: its walk, each texel read once, no rule.
const PHONG_FLOOR_JOB: &str = "Phong n = 2049, cube 64, one level: its visits alone (floor)";

/// The Phong levels row; its level 0 is [`PHONG_JOB`].
const LEVELS_JOB: &str = "Phong levels, cube 64, 7 levels (n = 2049 … 3)";

/// The FIS render's goal: whole seconds.
const FIS_GOAL_S: f64 = 0.15;

/// The FIS render row of the table (cmft has no such job).
const FIS_JOB: &str = "FIS render, 128² GGX α 0.3 sphere, 64 samples, lights";

/// What the cmft error column says where its output's frame is not matched to envlight's.
const NOT_COMPARED: &str = "not compared (frame)";

fn tempdir() -> Result<PathBuf> {
    let d = std::env::temp_dir().join(format!("envlight-peers-{}", std::process::id()));
    std::fs::create_dir_all(&d).with_context(|| d.display().to_string())?;
    Ok(d)
}

/// `envlight-lab peers`: whole-process times of the jobs users give cmft, paired with cmft on
/// the same machine, each with its error (markdown; --out writes its section of a page)
#[derive(clap::Args)]
pub struct PeersArgs {
    /// The map every job reads (.hdr, which cmft reads too)
    #[arg(long)]
    map: PathBuf,
    /// cmft's executable (default: $ENVLIGHT_CMFT); without it cmft's columns stay empty
    #[arg(long)]
    cmft: Option<PathBuf>,
    /// Timed pairs per fast job (the median is reported)
    #[arg(long, default_value_t = 5)]
    reps: usize,
    /// Timed pairs for the Phong job
    #[arg(long, default_value_t = 1)]
    phong_reps: usize,
    /// The performance page (docs/performance/DEVICE.md) to write this job's section into
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs `envlight-lab peers`.
pub fn cli(g: &crate::common::Global, a: &PeersArgs) -> Result<()> {
    let cmft = a
        .cmft
        .clone()
        .or_else(|| std::env::var_os("ENVLIGHT_CMFT").map(PathBuf::from));
    if cmft.is_none() {
        eprintln!("ENVLIGHT_CMFT is not set: timing envlight alone, cmft skipped");
    }
    bench_peers(&PeersOptions {
        map: &a.map,
        cmft: cmft.as_deref(),
        reps: a.reps,
        phong_reps: a.phong_reps,
        // The parent's context only names the device; it is gone before any timing.
        page: match &a.out {
            Some(p) => Some((
                p.as_path(),
                crate::page::Provenance::of(crate::common::context(g)?.info()),
            )),
            None => None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The floor's split reads back what `envlight devices` prints (its start-up line),
    /// each number's median across runs alone; runs without the line are left out.
    #[test]
    fn startup_lines_are_read_back_as_medians() {
        // As `envlight devices` prints it (its `startup_line`).
        let line = |k: f64| {
            format!(
                "envlight uses: x\nstart-up ms: loader {:.1}, instance {:.1}, device {:.1}, \
                 rest {:.1}; teardown ms {:.1}\n",
                0.5 * k,
                20.0 + k,
                3.0 * k,
                0.25,
                10.0 - k
            )
        };
        let outs = [
            line(1.0),
            line(3.0),
            "envlight uses: x\n".to_string(),
            line(2.0),
        ];
        let m = startup_medians(&outs).unwrap();
        assert_eq!(m, [1.0, 22.0, 6.0, 0.2, 8.0]);
        assert_eq!(startup_medians(&outs[2..3]), None);
        assert_eq!(
            crate::common::parse_startup_line("start-up ms: loader 1.0"),
            None
        );
    }

    /// The line the `envlight` program beside the lab prints (`envlight devices`) is the one
    /// read back: five finite, non-negative numbers.
    #[test]
    fn the_programs_startup_line_is_read_back() {
        let exe = crate::common::envlight_exe().unwrap();
        let o = Command::new(exe)
            .args(["--device", "cpu", "devices"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = String::from_utf8_lossy(&o.stdout);
        let v = crate::common::parse_startup_line(&text).unwrap_or_else(|| panic!("{text}"));
        assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0), "{v:?}");
    }

    /// The breakdown reads back exactly what the commands print (`cli::HostClock`).
    #[test]
    fn host_spans_are_read_back() {
        let out = "wrote x.json\n  GPU    13.920 ms  sh project\n  host   34.418 ms  load file ∥ create device\n  host    0.564 ms  write\n";
        assert_eq!(
            host_spans(out),
            vec![
                ("load file ∥ create device".to_string(), 34.418),
                ("write".to_string(), 0.564)
            ]
        );
        assert!((gpu_ms(out) - 13.92).abs() < 1e-9);
    }
}
