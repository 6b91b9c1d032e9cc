//! `envlight render`, `plan` and `demo`.

use super::{context, context_while, preview, Global, HostClock};
use crate::gpu::total_ms;
use crate::gpu::Timed;
use crate::io::{self, LoadOptions, ToneMap};
use crate::passes::{ConvertOptions, Converter};
use crate::{GpuEnvMap, Mapping};
use anyhow::{Context as _, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

/// Render a scene file: an HDR image, a tone-mapped PNG beside it, and a per-pass timing table
#[derive(Args)]
pub struct RenderArgs {
    /// The scene (TOML)
    scene: PathBuf,
    /// Output image: .exr, .hdr or .pfm, as its extension says (the PNG gets the same name
    /// with .png)
    #[arg(short, long)]
    output: PathBuf,
    /// Render through the resident path, as an engine does with a map on the GPU: the map is
    /// uploaded once, then one frame is recorded from the GPU image with nothing read back
    /// before the frame (no Monte Carlo; lights extracted on the GPU by the host path's rule)
    #[arg(long)]
    resident: bool,
}

/// Print the GPU passes a render of a scene will run, and why
#[derive(Args)]
pub struct PlanArgs {
    /// The scene (TOML)
    scene: PathBuf,
}

/// Convert the bundled probe to all four mappings, render every material, and show what each
/// step cost
#[derive(Args)]
pub struct DemoArgs {
    /// Input probe
    #[arg(long, default_value = "assets/sky_latlong.exr")]
    input: PathBuf,
    /// Output folder
    #[arg(long, default_value = "out/demo")]
    out: PathBuf,
    /// Size of the outputs (lat-long width; the others get half of it)
    #[arg(long, default_value_t = 512)]
    size: u32,
}

/// `envlight render`.
pub fn render(g: &Global, a: &RenderArgs) -> Result<()> {
    render_scene(g, &a.scene, &a.output, a.resident)
}

/// `envlight plan`.
pub fn plan(a: &PlanArgs) -> Result<()> {
    let scene = &a.scene;
    let sc = crate::scene::Scene::load(scene)?;
    let base = scene.parent().unwrap_or(Path::new("."));
    let path = base.join(&sc.environment.file);
    let env = sc.load_environment(base)?;
    let plan = crate::render::plan(&sc, &env);
    println!(
        "{} ({}, {} {}×{})",
        scene.display(),
        path.display(),
        env.mapping.name(),
        env.width,
        env.height
    );
    for (k, p) in plan.passes.iter().enumerate() {
        println!("{:>2}. {:<16} {}", k + 1, p.kind.name(), p.why);
    }
    for n in &plan.notes {
        println!("    note: {n}");
    }
    for line in plan.settings() {
        println!("    {line}");
    }
    Ok(())
}

/// `envlight demo`.
pub fn demo(g: &Global, a: &DemoArgs) -> Result<()> {
    demo_maps(g, &a.input, &a.out, a.size)
}

fn demo_maps(cli: &Global, input: &Path, out: &Path, size: u32) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let t0 = std::time::Instant::now();
    let map = io::load(input, &LoadOptions::default())?;
    println!(
        "loaded {} ({} {} x {}) in {:.0} ms",
        input.display(),
        map.mapping.name(),
        map.width,
        map.height,
        t0.elapsed().as_secs_f64() * 1e3
    );
    let ctx = context(cli)?;
    println!("device: {} ({})", ctx.info().name, ctx.info().driver.trim());
    let src = GpuEnvMap::upload(&ctx, &map)?;
    let conv = Converter::new(&ctx)?;
    let tm = ToneMap::default();
    let pb = ProgressBar::new(4);
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut previews = Vec::new();
    let mut rows = Vec::new();
    for to in Mapping::ALL {
        pb.set_message(to.name());
        let n = if to == Mapping::LatLong {
            size
        } else {
            size / 2
        };
        let opts = ConvertOptions::new(to, n.max(1));
        let Timed {
            value: dst,
            timings,
        } = conv.run(&src, &opts)?;
        let result = dst.download(&ctx)?;
        let exr = out.join(format!("sky_{}.exr", to.name()));
        let png = out.join(format!("sky_{}.png", to.name()));
        io::save_exr(&result, &exr)?;
        let p = preview::preview(&result, tm);
        p.save(&png).with_context(|| png.display().to_string())?;
        previews.push(p);
        let pin = map.power();
        let pout = result.power();
        rows.push((to, exr, png, timings, (pout[1] / pin[1] - 1.0) * 100.0));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let sheet = out.join("contact_sheet.png");
    preview::contact_sheet(&previews, 256)
        .save(&sheet)
        .with_context(|| sheet.display().to_string())?;
    println!("\nPreviews: {}", tm.describe());
    for (to, exr, png, timings, dp) in &rows {
        let ms: f64 = total_ms(timings);
        println!(
            "{:<16} {:>9.3} ms GPU  power {:+.3}%  {}  {}",
            to.name(),
            ms,
            dp,
            exr.display(),
            png.display()
        );
    }
    println!("contact sheet: {}", sheet.display());
    drop(src);
    drop(ctx);
    demo_scene(cli, out)?;
    Ok(())
}

/// Renders `assets/scenes/materials.toml`: every material side by side.
fn demo_scene(cli: &Global, out: &Path) -> Result<()> {
    let scene = Path::new("assets/scenes/materials.toml");
    println!("\nevery material side by side ({}):", scene.display());
    render_scene(cli, scene, &out.join("materials.exr"), false)
}

fn render_scene(cli: &Global, scene: &Path, output: &Path, resident: bool) -> Result<()> {
    crate::io::check_map_path(output)?;
    let mut clock = HostClock::start();
    let sc = crate::scene::Scene::load(scene)?;
    let base = scene.parent().unwrap_or(Path::new("."));
    // The environment loads on a second thread while the device is created (as the map
    // commands do); a bad file is reported before a missing driver.
    let (env, ctx) = context_while(cli, || Ok(sc.load_environment(base)?))?;
    clock.lap("load scene and map ∥ create device");
    let t0 = std::time::Instant::now();
    let r = match resident {
        false => crate::render::render(&ctx, &sc, &env)?,
        true => {
            let renderer = crate::render::Renderer::new(&ctx);
            let prepared = renderer.resident(&sc, crate::render::MapShape::of(&env))?;
            let gpu = GpuEnvMap::upload(&ctx, &env)?;
            renderer.render_resident(&prepared, &gpu)?
        }
    };
    let wall = t0.elapsed().as_secs_f64();
    clock.lap("render (pipelines, passes, waits)");
    if let Some(dir) = output.parent() {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    }
    crate::io::save_map(&r.frame, output)?;
    let png = output.with_extension("png");
    let tm = ToneMap::default();
    preview::preview(&r.frame, tm)
        .save(&png)
        .with_context(|| png.display().to_string())?;
    clock.lap("write the image and its PNG");
    println!("{}  {}", output.display(), png.display());
    println!("{:<16} {:>11}  spans", "pass", "GPU ms");
    let mut total = 0.0;
    for rec in &r.records {
        println!(
            "{:<16} {:>11.3}  {}",
            rec.kind.name(),
            rec.ms(),
            rec.timings.len()
        );
        total += rec.ms();
    }
    println!("{:<16} {:>11.3}  (wall {wall:.2} s)", "total", total);
    if let Some([extract, prepare]) = r.lights_ms {
        println!(
            "lights (host): extraction {extract:.1} ms, quadratures, tree and clusters {prepare:.1} ms"
        );
    }
    if let Some((n, e)) = r.mc {
        match e {
            Some(e) => println!("monte carlo: {n} samples per pixel, relative error {e:.2e}"),
            None => println!("monte carlo: {n} samples per pixel"),
        }
    }
    println!("tone map: {tm:?} (PNG only; the EXR is linear)");
    for n in r.plan.notes.iter().filter(|n| n.starts_with("ringing")) {
        println!("{n}");
    }
    clock.print();
    Ok(())
}
