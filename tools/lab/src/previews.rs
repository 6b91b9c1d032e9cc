//! `envlight-lab previews`: the bake's previews on a folder of probes (the "Bake previews"
//! section of docs/performance/<device>.md). Per probe and preset (Bevy, Khronos), files
//! against intent for the files as written and for each way users break them
//! (`bake::preview::breakage`), in-process; then what the previews cost, as whole-process
//! `envlight bake` runs of the folder with and without them, alternating; and, where asked, a
//! screenshot of a gallery in headless Chromium (the README's).

use crate::common::{context, envlight_exe, probes_dir, Global};
use anyhow::{bail, Context as _, Result};
use clap::Args;
use envlight::bake::files::probe_files;
use envlight::bake::output::Preset;
use envlight::bake::plan::{BakePlan, BakeSettings};
use envlight::bake::preview::breakage::Breakage;
use envlight::bake::preview::{preview, reference_view, PreviewCubes, Source};
use envlight::bake::Baker;
use envlight::LoadOptions;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// `envlight-lab previews` options.
#[derive(Args)]
pub struct PreviewsArgs {
    /// The probes folder [default: $ENVLIGHT_PROBES]
    #[arg(long)]
    probes: Option<PathBuf>,
    /// Write the section into this performance page
    #[arg(long)]
    out: Option<PathBuf>,
    /// Rounds of the whole-process timing (a bake with previews, then one without)
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// Also write a screenshot of the gallery of four probes and a truncated file here
    #[arg(long)]
    shot: Option<PathBuf>,
}

/// One probe baked for one preset: files against intent, right and broken.
struct Row {
    probe: String,
    preset: Preset,
    right: f64,
    /// Per breakage, the worst sphere.
    broken: Vec<f64>,
    /// Recipe against reference per compared sphere.
    recipe: Vec<f64>,
}

fn copy_dir(from: &Path, to: &Path) -> Result<()> {
    std::fs::create_dir_all(to)?;
    for e in std::fs::read_dir(from)?.flatten() {
        std::fs::copy(e.path(), to.join(e.file_name()))?;
    }
    Ok(())
}

/// Files against intent per probe and preset, right and broken, baking in-process.
fn checks(g: &Global, files: &[PathBuf], scratch: &Path) -> Result<Vec<Row>> {
    let ctx = context(g)?;
    let baker = Baker::new(&ctx)?;
    let mut rows = Vec::new();
    for preset in [Preset::Bevy, Preset::Khronos] {
        let mut s = BakeSettings::default();
        s.preset = Some(preset);
        let plan = BakePlan::new(&s)?;
        for path in files {
            let probe = path
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string();
            let map =
                envlight::load(path, &LoadOptions::default()).with_context(|| probe.clone())?;
            let (source, lights) = plan.split_lights(map)?;
            let baked = baker
                .submit(&source, &plan.orientation, &plan.options)?
                .wait()?;
            let dir = scratch.join(format!("{preset:?}")).join(&probe);
            std::fs::create_dir_all(&dir)?;
            for (p, bytes) in probe_files(&dir, &baked, &plan, lights.as_ref())?.files {
                std::fs::write(p, bytes)?;
            }
            let intent = PreviewCubes::intent(&baked, &plan, lights.as_ref());
            let src = Source {
                map: &source,
                separated: lights.as_ref(),
            };
            let reference = reference_view(src, &plan);
            let check = preview(&dir, &plan, &intent, Some(&reference))?.check;
            let (right, recipe) = (check.worst, check.recipe_vs_reference);
            let mut broken = Vec::new();
            for b in Breakage::ALL {
                let d = scratch.join(format!("{preset:?}-{b:?}")).join(&probe);
                copy_dir(&dir, &d)?;
                b.apply(&d)?;
                broken.push(preview(&d, &plan, &intent, None)?.check.worst);
            }
            eprintln!("{probe} {preset:?}: right {right:.2e}, broken {broken:?}");
            rows.push(Row {
                probe,
                preset,
                right,
                broken,
                recipe,
            });
        }
    }
    Ok(rows)
}

/// Seconds of `envlight bake` of `inputs` into a fresh `out` with the Bevy preset, `extra`
/// flags added.
fn bake_seconds(inputs: &Path, out: &Path, device: Option<&str>, extra: &[&str]) -> Result<f64> {
    let _ = std::fs::remove_dir_all(out);
    let mut c = Command::new(envlight_exe()?);
    if let Some(d) = device {
        c.args(["--device", d]);
    }
    c.arg("bake").arg(inputs).arg("-o").arg(out);
    c.args(["--preset", "bevy"]).args(extra);
    let t = Instant::now();
    let o = c.output()?;
    let s = t.elapsed().as_secs_f64();
    if !o.status.success() {
        bail!(
            "envlight bake failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    Ok(s)
}

/// The sum of the manifest's preview stage and of its probes' seconds.
fn preview_stage(out: &Path) -> Result<(f64, f64)> {
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json"))?)?;
    let probes = m["probes"]
        .as_array()
        .context("a manifest without probes")?;
    let sum = |f: &dyn Fn(&serde_json::Value) -> f64| probes.iter().map(f).sum::<f64>();
    Ok((
        sum(&|p| p["stages"]["preview"].as_f64().unwrap_or(0.0)),
        sum(&|p| p["seconds"].as_f64().unwrap_or(0.0)),
    ))
}

/// A gallery of four of `files` and a truncated copy of a fifth, screenshot into `shot`.
fn screenshot(g: &Global, files: &[PathBuf], scratch: &Path, shot: &Path) -> Result<()> {
    let inputs = scratch.join("shot-in");
    std::fs::create_dir_all(&inputs)?;
    for f in files.iter().take(4) {
        std::fs::copy(f, inputs.join(f.file_name().unwrap_or_default()))?;
    }
    if let Some(f) = files.get(4) {
        let bytes = std::fs::read(f)?;
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        std::fs::write(
            inputs.join(format!("truncated_{name}")),
            &bytes[..bytes.len() / 3],
        )?;
    }
    let out = scratch.join("shot-out");
    // A failed probe makes the run exit non-zero; the gallery is written all the same.
    let _ = bake_seconds(&inputs, &out, g.device.as_deref(), &[]);
    let page = out.join("index.html");
    if !page.is_file() {
        bail!("the bake wrote no gallery at {}", page.display());
    }
    let st = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
        ])
        .args(["--window-size=1120,1500"])
        .arg(format!(
            "--user-data-dir={}",
            scratch.join("profile").display()
        ))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", page.display()))
        .status()
        .context("running chromium")?;
    if !st.success() {
        bail!("chromium failed");
    }
    eprintln!("wrote {}", shot.display());
    Ok(())
}

/// Runs `envlight-lab previews`.
pub fn run(g: &Global, a: &PreviewsArgs) -> Result<()> {
    let dir = probes_dir(a.probes.as_deref())?;
    let mut files = envlight::io::probes_in(&dir)?;
    files.sort();
    let scratch =
        std::env::temp_dir().join(format!("envlight-lab-previews-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch)?;
    let rows = checks(g, &files, &scratch.join("check"))?;
    // Whole-process time, with previews and without, alternating.
    let (mut with, mut without) = (Vec::new(), Vec::new());
    let mut stage = (0.0, 0.0);
    for _ in 0..a.rounds.max(1) {
        let out = scratch.join("with");
        with.push(bake_seconds(&dir, &out, g.device.as_deref(), &[])?);
        stage = preview_stage(&out)?;
        without.push(bake_seconds(
            &dir,
            &scratch.join("without"),
            g.device.as_deref(),
            &["--no-preview"],
        )?);
    }
    if let Some(shot) = &a.shot {
        screenshot(g, &files, &scratch, shot)?;
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let (method, body) = markdown(&rows, &with, &without, stage, files.len());
    print!("{method}\n\n{body}");
    if let Some(out) = &a.out {
        let ctx = context(g)?;
        let section = crate::page::Section {
            job: "previews",
            title: "Bake previews: files against intent, and their cost",
            method: &method,
            body: &body,
        };
        crate::page::write_section(out, &section, &crate::page::Provenance::of(ctx.info()))?;
    }
    Ok(())
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn markdown(
    rows: &[Row],
    with: &[f64],
    without: &[f64],
    stage: (f64, f64),
    n: usize,
) -> (String, String) {
    let method = format!(
        "Each probe baked in-process with `--preset bevy` (e5b9g9r9 + Zstandard) and \
         `--preset khronos` (rgba16f) at the presets' sizes, its files written, read back and \
         rendered by `bake::preview`; files against intent is the worst sphere's relative RMS \
         against the same spheres from the bake's float cubes. Each breakage \
         (`bake::preview::breakage`) rewrites a copy of the written files: every specular face \
         mirrored, the irradiance π× too bright, the specular levels in reverse order. Recipe \
         vs reference: the preview's split-sum (GGX) and E/π (diffuse) from the Bevy or \
         Khronos files against envlight's float64 reference (FIS of the residual with the light \
         texels summed through a tree; the exact irradiance sum), relative RMS over even rows \
         and columns of the report's 32² sphere view. Cost: \
         `envlight bake` of the {n} probes with `--preset bevy`, with previews and with \
         `--no-preview`, alternating, {r} runs each, wall-clock seconds of the whole process; \
         and the manifest's own preview stage against its probes' seconds.",
        r = with.len()
    );
    let mut b = String::new();
    let names: Vec<&str> = Breakage::ALL.iter().map(|x| x.name()).collect();
    let _ = writeln!(
        b,
        "| probe | preset | files vs intent | {} | smallest ratio broken / right | recipe vs \
         reference: GGX 0.1 / 0.3 / 0.6 / diffuse |",
        names.join(" | ")
    );
    let _ = writeln!(b, "|---|---|---|{}---|---|", "---|".repeat(names.len()));
    for r in rows {
        let ratio = r
            .broken
            .iter()
            .map(|x| x / r.right)
            .fold(f64::INFINITY, f64::min);
        let broken: Vec<String> = r
            .broken
            .iter()
            .map(|x| format!("{:.1}%", 100.0 * x))
            .collect();
        let _ = writeln!(
            b,
            "| {} | {:?} | {:.3}% | {} | {:.0}× | {} |",
            r.probe,
            r.preset,
            100.0 * r.right,
            broken.join(" | "),
            ratio,
            r.recipe
                .iter()
                .map(|x| format!("{:.1}%", 100.0 * x))
                .collect::<Vec<_>>()
                .join(" / ")
        );
    }
    // NaN kept (f64::max would drop it).
    let worse = |a: f64, b: f64| {
        if a.is_nan() || b.is_nan() {
            f64::NAN
        } else {
            a.max(b)
        }
    };
    let worst_right = rows.iter().map(|r| r.right).fold(0.0, worse);
    let least_ratio = rows
        .iter()
        .flat_map(|r| r.broken.iter().map(move |x| x / r.right))
        .fold(
            f64::INFINITY,
            |a: f64, b| if b.is_nan() || b < a { b } else { a },
        );
    let (w, wo) = (median(with), median(without));
    let _ = write!(
        b,
        "\nWorst files against intent on a correct bake: {:.3}% (bound 1%); the smallest \
         ratio of a broken bake's to its correct one's: {:.0}× (bound 10×).\n\n\
         Cost, {n} probes with `--preset bevy`: with previews {} s, without {} s (median of \
         {}): the previews add {:.1}% to the bake. The manifest's preview stage: {:.2} s of \
         the probes' {:.2} s ({:.1}%).\n",
        100.0 * worst_right,
        least_ratio,
        fmt_list(with),
        fmt_list(without),
        with.len(),
        100.0 * (w - wo) / wo,
        stage.0,
        stage.1,
        100.0 * stage.0 / stage.1.max(1e-9),
    );
    (method, b)
}

fn fmt_list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.2}"))
        .collect::<Vec<_>>()
        .join(", ")
}
