//! `envlight-lab recipes`: the specular recipes an engine can shade GGX
//! with from the same baked chain (split-sum as Karis wrote it, with and without extracted
//! lights, and the lobe taps recipe), beside FIS and SH-BRDF, against converged Monte Carlo on
//! every probe of a folder and GGX α 0.05 to 0.6, with each recipe's per-frame GPU time:
//! split_sum.md and split_sum.csv.

use anyhow::{Context as _, Result};
use envlight::math::brdf::Brdf;
use envlight::math::camera::{sphere_camera, Camera};
use envlight::render::score::{errors, scene, sphere_pixels, truth};
use envlight::render::PassKind;
use envlight::render::Renderer;
use envlight::scene::{LightsMode, Scene, SplitSumSettings, Technique};
use envlight::EnvMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The α of the sweep.
const ALPHAS: [f64; 6] = [0.05, 0.1, 0.2, 0.3, 0.45, 0.6];

/// The probes the recipe's goal is stated on: the sun and studio probes.
const GOAL_PROBES: [&str; 3] = [
    "spiaggia_di_mondello_1k",
    "quarry_01_1k",
    "studio_small_08_1k",
];

/// Side of the image the per-frame times are taken at (an engine shades whole frames).
const TIMING_SIZE: u32 = 512;

/// One way of shading GGX.
struct Recipe {
    label: &'static str,
    technique: Technique,
    taps: u32,
    lights: LightsMode,
}

fn recipes() -> Vec<Recipe> {
    let split = |label, taps, lights| Recipe {
        label,
        technique: Technique::SplitSum,
        taps,
        lights,
    };
    vec![
        split("split-sum, lights in the cube", 1, LightsMode::None),
        split("split-sum", 1, LightsMode::Extract),
        split("lobe taps 4", 4, LightsMode::Extract),
        split("lobe taps 8", 8, LightsMode::Extract),
        split("lobe taps 16", 16, LightsMode::Extract),
        Recipe {
            label: "fis N=64",
            technique: Technique::Fis {
                samples: 64,
                bias: None,
                rotate: true,
            },
            taps: 1,
            lights: LightsMode::Extract,
        },
        Recipe {
            label: "sh_brdf l=8",
            technique: Technique::ShBrdf {
                order: 8,
                grid: envlight::math::sh_brdf::DEFAULT_GRID,
                window: None,
            },
            taps: 1,
            lights: LightsMode::Extract,
        },
    ]
}

/// The scene of `recipe` on the sphere.
fn recipe_scene(cam: Camera, b: Brdf, r: &Recipe, split: SplitSumSettings) -> Scene {
    let mut sc = scene(
        cam,
        b,
        r.technique,
        None,
        7,
        SplitSumSettings {
            taps: r.taps,
            ..split
        },
    );
    sc.environment.lights = r.lights;
    sc
}

/// GPU ms of the passes a frame repeats (G-buffer and shading).
fn frame_ms(renderer: &Renderer, sc: &Scene, env: &EnvMap) -> Result<f64> {
    let r = renderer.render(sc, env)?;
    Ok(r.records
        .iter()
        .filter(|p| matches!(p.kind, PassKind::GBuffer | PassKind::Shade))
        .map(|p| p.ms())
        .sum::<f64>()
        + 0.0)
}

/// Median per-frame GPU ms of each recipe at α 0.3 on `env`, [`TIMING_SIZE`]², 5 renders
/// after one untimed.
fn timings(renderer: &Renderer, env: &EnvMap, split: SplitSumSettings) -> Result<Vec<f64>> {
    let cam = sphere_camera(TIMING_SIZE);
    let b = Brdf::Ggx {
        alpha: 0.3,
        correlated: true,
    };
    let mut out = Vec::new();
    for r in recipes() {
        let sc = recipe_scene(cam, b, &r, split);
        frame_ms(renderer, &sc, env)?;
        let mut v = (0..5)
            .map(|_| frame_ms(renderer, &sc, env))
            .collect::<Result<Vec<_>>>()?;
        v.sort_by(f64::total_cmp);
        out.push(v[2]);
    }
    Ok(out)
}

/// (probe, α, recipe index, relative RMS, bias, reference noise).
type Cell = (String, f64, usize, f64, f64, f64);

/// Runs the sweep over every probe of `dir` into `out`.
fn sweep(
    renderer: &Renderer,
    dir: &Path,
    cam: Camera,
    reference: u32,
    out: &Path,
    device: &str,
    split: SplitSumSettings,
) -> Result<()> {
    let pixels = sphere_pixels(&cam);
    let files = envlight::io::probes_in(dir)?;
    let list = recipes();
    let mut cells: Vec<Cell> = Vec::new();
    let mut times = None;
    for path in &files {
        let env = envlight::io::load(path, &envlight::io::LoadOptions::default())
            .with_context(|| path.display().to_string())?;
        let name = path
            .file_stem()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        if times.is_none() {
            times = Some(timings(renderer, &env, split)?);
        }
        for alpha in ALPHAS {
            let b = Brdf::Ggx {
                alpha,
                correlated: true,
            };
            let (truth, noise) = truth(renderer, cam, b, None, split, reference, &env)?;
            for (k, r) in list.iter().enumerate() {
                let f = renderer.render(&recipe_scene(cam, b, r, split), &env)?;
                let (rms, bias, _) = errors(&f.frame, &truth, &pixels);
                eprintln!("{name} α {alpha} {}: {rms:.3e} (bias {bias:+.2e})", r.label);
                cells.push((name.clone(), alpha, k, rms, bias, noise));
            }
        }
    }
    let times = times.unwrap_or_default();
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    std::fs::write(out.join("split_sum.csv"), csv(&cells, &list, &times))
        .with_context(|| "split_sum.csv")?;
    let head = format!(
        "Device: {device}. GGX (height-correlated Smith); chain {split:?} (taps per recipe); \
         sphere {}² from normal to grazing incidence; reference 2 × {reference} spp MIS; \
         relative RMS over the sphere (all channels), mean bias in parentheses. Per-frame GPU \
         time: G-buffer and shading of a {TIMING_SIZE}² sphere at α 0.3 on {}, median of 5.",
        cam.width,
        files
            .first()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default()
    );
    std::fs::write(
        out.join("split_sum.md"),
        markdown(&cells, &list, &times, &head),
    )
    .with_context(|| "split_sum.md")?;
    println!("wrote {}/split_sum.md, split_sum.csv", out.display());
    Ok(())
}

fn csv(cells: &[Cell], list: &[Recipe], times: &[f64]) -> String {
    let mut s =
        String::from("probe,alpha,recipe,relative_rms,mean_bias,reference_noise,frame_ms\n");
    for (probe, alpha, k, rms, bias, noise) in cells {
        let _ = writeln!(
            s,
            "{probe},{alpha},{},{rms:.5e},{bias:.5e},{noise:.3e},{:.4}",
            list[*k].label,
            times.get(*k).copied().unwrap_or(f64::NAN)
        );
    }
    s
}

/// Mean relative RMS of recipe `k` over the cells `keep` selects.
fn mean_of(cells: &[Cell], k: usize, keep: &dyn Fn(&Cell) -> bool) -> f64 {
    let v: Vec<f64> = cells
        .iter()
        .filter(|c| c.2 == k && keep(c))
        .map(|c| c.3)
        .collect();
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn markdown(cells: &[Cell], list: &[Recipe], times: &[f64], head: &str) -> String {
    let mut md = format!(
        "# Specular recipes against Monte Carlo on every probe\n\n{head}\n\n\
         ## Summary\n\nMean relative RMS at α ≥ 0.3 over the sun and studio probes ({}) and \
         over every probe, against split-sum (lights extracted, the render's default), and the \
         per-frame GPU time against split-sum's.\n\n\
         | recipe | sun + studio, α ≥ 0.3 | of split-sum's | every probe, α ≥ 0.3 | every probe, α < 0.3 | per-frame ms | of split-sum's |\n\
         |---|---|---|---|---|---|---|\n",
        GOAL_PROBES.join(", ")
    );
    let goal = |c: &Cell| c.1 >= 0.3 && GOAL_PROBES.contains(&c.0.as_str());
    let base_goal = mean_of(cells, 1, &goal);
    let base_ms = times.get(1).copied().unwrap_or(f64::NAN);
    for (k, r) in list.iter().enumerate() {
        let g = mean_of(cells, k, &goal);
        let ms = times.get(k).copied().unwrap_or(f64::NAN);
        let _ = writeln!(
            md,
            "| {} | {:.2}% | {:.2}× | {:.2}% | {:.2}% | {ms:.3} | {:.2}× |",
            r.label,
            100.0 * g,
            g / base_goal,
            100.0 * mean_of(cells, k, &|c| c.1 >= 0.3),
            100.0 * mean_of(cells, k, &|c| c.1 < 0.3),
            ms / base_ms
        );
    }
    let mut probes: Vec<&str> = cells.iter().map(|c| c.0.as_str()).collect();
    probes.dedup();
    for alpha in ALPHAS {
        let _ = write!(
            md,
            "\n## α {alpha}\n\n| probe | {} | reference noise |\n|---|{}---|\n",
            list.iter().map(|r| r.label).collect::<Vec<_>>().join(" | "),
            "---|".repeat(list.len())
        );
        for p in &probes {
            let row: Vec<&Cell> = cells.iter().filter(|c| c.0 == *p && c.1 == alpha).collect();
            let noise = row.first().map(|c| c.5).unwrap_or(0.0);
            let body: Vec<String> = row
                .iter()
                .map(|c| format!("{:.1}% ({:+.1}%)", 100.0 * c.3, 100.0 * c.4))
                .collect();
            let _ = writeln!(md, "| {p} | {} | {:.2}% |", body.join(" | "), 100.0 * noise);
        }
    }
    md
}

/// `envlight-lab recipes`: the specular recipes (split-sum with and without extracted lights,
/// lobe taps 4, 8, 16), FIS and SH-BRDF against the reference on every probe of the folder at
/// GGX α 0.05 to 0.6, with their per-frame GPU time (split_sum.md, split_sum.csv)
#[derive(clap::Args)]
pub struct RecipesArgs {
    /// Folder of the probes (default: $ENVLIGHT_PROBES; one of the two is needed)
    #[arg(long)]
    probes: Option<PathBuf>,
    /// Output folder
    #[arg(long, default_value = "out/report")]
    out: PathBuf,
    /// Side of the sphere image
    #[arg(long, default_value_t = 64)]
    size: u32,
    /// The Monte Carlo reference's samples per pixel, halved (16 renders in all)
    #[arg(long, default_value_t = 16384)]
    reference: u32,
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

/// Runs `envlight-lab recipes`.
pub fn run(g: &crate::common::Global, a: &RecipesArgs) -> Result<()> {
    let ctx = crate::common::context(g)?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver.trim());
    eprintln!("device: {device}");
    let d = SplitSumSettings::default();
    let split = SplitSumSettings {
        size: a.split_size.or(d.size),
        levels: a.split_levels.unwrap_or(d.levels),
        samples: a.split_samples.unwrap_or(d.samples),
        ..d
    };
    let dir = crate::common::probes_dir(a.probes.as_deref())?;
    let cam = sphere_camera(a.size);
    sweep(
        &Renderer::new(&ctx),
        &dir,
        cam,
        a.reference,
        &a.out,
        &device,
        split,
    )
}
