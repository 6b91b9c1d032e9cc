//! `envlight-lab table`: the accuracy table. Every real-time technique on five
//! real probes, with light extraction and without, scored per pixel against a converged
//! reference: table.md (the table, the goals checked, the rotate comparison), table.csv (one
//! row per probe × material × technique × settings) and error_maps.png (signed per-pixel
//! error of a selection of rows, one row of maps per probe).

use anyhow::{anyhow, Context as _, Result};
use envlight::math::brdf::Brdf;
use envlight::math::camera::{Camera, Shape};
use envlight::math::envmap::luminance;
use envlight::render::score::{average, scene, sphere_pixels};
use envlight::render::{MapShape, Renderer};
use envlight::scene::{LightsMode, LookupFilter, Scene, SplitSumSettings, Technique};
use envlight::EnvMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The probes of the table, with what kind of light each is.
pub const PROBES: [(&str, &str); 5] = [
    ("spiaggia_di_mondello_1k.hdr", "sun"),
    ("quarry_01_1k.hdr", "sun"),
    ("studio_small_08_1k.hdr", "studio"),
    ("photo_studio_01_1k.hdr", "studio"),
    ("venice_sunset_1k.hdr", "soft"),
];

/// GGX roughnesses measured.
const ALPHAS: [f64; 4] = [0.05, 0.1, 0.3, 0.6];
/// FIS sample counts measured.
const FIS_N: [u32; 3] = [16, 64, 256];
/// Phong exponents measured by prefiltered maps, with each map's size (lat-long width): a
/// texel (5.6°) under the lobe's scale 1/√n (7.2°); a finer map errs about as much (its
/// error is the reference's noise and the bilinear read) for several times the brute force.
const PHONG: [(f64, u32); 1] = [(64.0, 64)];

/// A subset of the table: only these materials and probes (all where empty).
pub struct Pick {
    /// Material names, as the table's rows name them.
    pub materials: Vec<String>,
    /// Parts of probe file names.
    pub probes: Vec<String>,
    /// Render through the resident path (`Renderer::resident`, the map on the GPU, its
    /// lights extracted there) instead of the host path.
    pub resident: bool,
    /// The scenes' `light_texels` (the chain's most light texels), where given.
    pub light_texels: Option<u32>,
}

/// One measured case.
#[derive(Clone)]
struct Case {
    material: String,
    brdf: Brdf,
    technique: Technique,
    /// Short label: "sh 2", "prefiltered 32", "fis 64", "lookup".
    label: String,
    lights: LightsMode,
    filter: LookupFilter,
}

impl Case {
    fn lights_name(&self) -> &'static str {
        match self.lights {
            LightsMode::Extract => "extract",
            LightsMode::None => "none",
        }
    }
    fn rotate(&self) -> &'static str {
        match self.technique {
            Technique::Fis { rotate: true, .. } => "on",
            Technique::Fis { .. } => "off",
            _ => "",
        }
    }
    fn filter_name(&self) -> &'static str {
        match (self.technique, self.filter) {
            (Technique::Lookup, LookupFilter::Point) => "point",
            (Technique::Lookup, _) => "footprint",
            _ => "",
        }
    }
}

fn cases() -> Vec<Case> {
    let both = [LightsMode::Extract, LightsMode::None];
    let mut v = Vec::new();
    let mut push = |material: &str, brdf, technique, label: String, lights, filter| {
        v.push(Case {
            material: material.to_string(),
            brdf,
            technique,
            label,
            lights,
            filter,
        })
    };
    for lights in both {
        for order in [2, 8] {
            let t = Technique::Sh { order };
            push(
                "diffuse",
                Brdf::Lambert,
                t,
                format!("sh {order}"),
                lights,
                LookupFilter::Auto,
            );
        }
        let t = Technique::Prefiltered { size: 32 };
        push(
            "diffuse",
            Brdf::Lambert,
            t,
            "prefiltered 32".into(),
            lights,
            LookupFilter::Auto,
        );
    }
    for alpha in ALPHAS {
        let brdf = Brdf::Ggx {
            alpha,
            correlated: true,
        };
        for lights in both {
            for rotate in [false, true] {
                for samples in FIS_N {
                    let t = Technique::Fis {
                        samples,
                        bias: None,
                        rotate,
                    };
                    let m = format!("ggx {alpha}");
                    push(
                        &m,
                        brdf,
                        t,
                        format!("fis {samples}"),
                        lights,
                        LookupFilter::Auto,
                    );
                }
            }
        }
    }
    for (n, size) in PHONG {
        for lights in both {
            let t = Technique::Prefiltered { size };
            push(
                &format!("phong {n}"),
                Brdf::Phong { n },
                t,
                format!("prefiltered {size}"),
                lights,
                LookupFilter::Auto,
            );
        }
    }
    for lights in both {
        let t = Technique::Lookup;
        push(
            "mirror",
            Brdf::Mirror,
            t,
            "lookup".into(),
            lights,
            LookupFilter::Auto,
        );
    }
    let t = Technique::Lookup;
    push(
        "mirror",
        Brdf::Mirror,
        t,
        "lookup".into(),
        LightsMode::None,
        LookupFilter::Point,
    );
    v
}

/// One row of the table.
struct Row {
    probe: String,
    case: Case,
    rms: f64,
    ratio: f64,
    tile: f64,
    noise: f64,
    gpu_ms: f64,
    /// Signed relative error of luminance per image pixel (NaN off the sphere).
    errors: Vec<f32>,
}

/// Per-pixel scores of `a` against `truth` over `pixels` ((image index, 8×8 tile)): (relative
/// RMS of luminance per pixel, mean ratio of luminance, worst tile's |ratio − 1| among tiles
/// of at least 16 sphere pixels, each pixel's signed relative error).
fn score(a: &EnvMap, truth: &EnvMap, pixels: &[(usize, u32)]) -> (f64, f64, f64, Vec<f32>) {
    let lum = |m: &EnvMap, k: usize| luminance(m.texels[k].map(f64::from));
    let mut errors = vec![f32::NAN; a.texels.len()];
    let (mut sq, mut sa, mut sb) = (0.0, 0.0, 0.0);
    let mut tiles: std::collections::BTreeMap<u32, (f64, f64, u32)> = Default::default();
    for &(k, tile) in pixels {
        let (ya, yb) = (lum(a, k), lum(truth, k));
        let e = (ya - yb) / yb.max(1e-12);
        errors[k] = e as f32;
        sq += e * e;
        sa += ya;
        sb += yb;
        let t = tiles.entry(tile).or_default();
        t.0 += ya;
        t.1 += yb;
        t.2 += 1;
    }
    let worst = tiles
        .values()
        .filter(|t| t.2 >= 16 && t.1 > 0.0)
        .map(|t| (t.0 / t.1 - 1.0).abs())
        .fold(0.0, f64::max);
    let n = pixels.len().max(1) as f64;
    ((sq / n).sqrt(), sa / sb, worst, errors)
}

/// The per-pixel relative noise of the mean of two independent renders: half their per-pixel
/// difference, relative to the mean, RMS over the pixels.
fn noise_of_mean(r1: &EnvMap, r2: &EnvMap, mean: &EnvMap, pixels: &[(usize, u32)]) -> f64 {
    let lum = |m: &EnvMap, k: usize| luminance(m.texels[k].map(f64::from));
    let sq: f64 = pixels
        .iter()
        .map(|&(k, _)| (0.5 * (lum(r1, k) - lum(r2, k)) / lum(mean, k).max(1e-12)).powi(2))
        .sum();
    (sq / pixels.len().max(1) as f64).sqrt()
}

fn with_case(sc: &mut Scene, c: &Case) {
    sc.environment.lights = c.lights;
    sc.environment.filter = c.filter;
}

/// Runs the table on the probes in `dir`: a `size`² unit sphere seen orthographically, the
/// reference of each lobe two `reference`-spp MIS Monte Carlo renders (their mean; its noise
/// from their difference), of the mirror its 16×16-supersampled render.
pub fn table(
    renderer: &Renderer,
    dir: &Path,
    size: u32,
    reference: u32,
    out: &Path,
    device: &str,
    pick: &Pick,
) -> Result<()> {
    let cam = envlight::math::camera::sphere_camera(size);
    let pixels = sphere_pixels(&cam);
    let split = SplitSumSettings::default();
    let started = Instant::now();
    let mut rows = Vec::new();
    let all: Vec<Case> = cases()
        .into_iter()
        .filter(|c| pick.materials.is_empty() || pick.materials.contains(&c.material))
        .collect();
    let mut materials: Vec<(String, Brdf)> = Vec::new();
    for c in &all {
        if !materials.iter().any(|m| m.0 == c.material) {
            materials.push((c.material.clone(), c.brdf));
        }
    }
    let probes = PROBES
        .iter()
        .filter(|p| pick.probes.is_empty() || pick.probes.iter().any(|q| p.0.contains(q.as_str())));
    for (n, (file, _)) in probes.enumerate() {
        let path = dir.join(file);
        let env = envlight::io::load(&path, &envlight::io::LoadOptions::default())
            .with_context(|| format!("report --table: probe {} (set --probes)", path.display()))?;
        let probe = file.trim_end_matches(".hdr").to_string();
        if n == 0 {
            warm_up(renderer, &env, &all, split)?;
        }
        let gpu = pick
            .resident
            .then(|| envlight::passes::GpuEnvMap::upload(renderer.context(), &env))
            .transpose()?;
        for (material, brdf) in &materials {
            let (material, brdf) = (material.as_str(), *brdf);
            let (truth, noise) =
                reference_of(renderer, &env, cam, brdf, reference, &pixels, split)?;
            for c in all.iter().filter(|c| c.material == material) {
                let mut sc = scene(cam, brdf, c.technique, None, 7, split);
                with_case(&mut sc, c);
                if pick.light_texels.is_some() {
                    sc.environment.light_texels = pick.light_texels;
                }
                let r = match &gpu {
                    Some(gpu) => {
                        let prepared = renderer.resident(&sc, MapShape::of(&env))?;
                        renderer.render_resident(&prepared, gpu)?
                    }
                    None => renderer.render(&sc, &env)?,
                };
                let (rms, ratio, tile, errors) = score(&r.frame, &truth, &pixels);
                let gpu_ms: f64 = r.records.iter().map(|p| p.ms()).sum();
                eprintln!(
                    "{probe:>28} {material:>9} {:<15} lights {:<7} {:<3} {:<9} rms {:>6.2}% ratio {:.4} tile {:>6.2}% noise {:.2}% gpu {:>9.2} ms",
                    c.label,
                    c.lights_name(),
                    c.rotate(),
                    c.filter_name(),
                    100.0 * rms,
                    ratio,
                    100.0 * tile,
                    100.0 * noise,
                    gpu_ms
                );
                rows.push(Row {
                    probe: probe.clone(),
                    case: c.clone(),
                    rms,
                    ratio,
                    tile,
                    noise,
                    gpu_ms,
                    errors,
                });
            }
        }
    }
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    write_csv(&out.join("table.csv"), &rows)?;
    let chain = envlight::math::lights::ExtractOptions::chain();
    let settings = format!(
        "Device: {device}. {}Unit sphere {size}² seen orthographically (normal to grazing \
         incidence), pixels whose centre sees it. Reference of every lobe: the mean of two \
         {reference}-spp MIS Monte Carlo renders with the whole map (its noise, per pixel: \
         half their difference); of the mirror: its 16×16-supersampled render (the \
         pixel-area mean). `rms`: per-pixel relative RMS of luminance; `ratio`: mean \
         luminance against the reference's; `tile`: the worst 8×8 tile's |ratio − 1|. \
         Defaults elsewhere: the FIS paraboloid sized by the source; FIS lod bias {} ({} \
         reading the residual); FIS, split-sum, footprint lookups and prefiltered Phong maps \
         extract above {} × the mean luminance, up to {} light texels (grown by {} rings, the \
         residual filled under them, where FIS, split-sum or a prefiltered Phong map reads \
         it); diffuse techniques above {} ×. Run took {:.0} s.",
        match pick.resident {
            true => format!(
                "Rendered through the resident path (the map on the GPU, its lights extracted \
                 there each frame by the host path's rule: at most {} texels for the chain's \
                 techniques). ",
                pick.light_texels.unwrap_or(envlight::render::CHAIN_GPU_MAX)
            ),
            false => String::new(),
        },
        envlight::scene::DEFAULT_FIS_BIAS,
        envlight::scene::DEFAULT_FIS_BIAS_RESIDUAL,
        chain.ratio,
        pick.light_texels.unwrap_or(chain.max_texels as u32),
        chain.fill.unwrap_or_default(),
        envlight::math::lights::DIFFUSE_RATIO,
        started.elapsed().as_secs_f64()
    );
    std::fs::write(out.join("table.md"), markdown(&rows, &settings)).with_context(|| "table.md")?;
    maps(&out.join("error_maps.png"), &rows, size, device)?;
    println!(
        "wrote {}/table.md, table.csv, error_maps.png ({} rows)",
        out.display(),
        rows.len()
    );
    Ok(())
}

/// Pipelines are built, and lavapipe compiles shaders, on first use: one small render of
/// each kind of case in `all` keeps that out of the GPU times measured after it.
fn warm_up(renderer: &Renderer, env: &EnvMap, all: &[Case], split: SplitSumSettings) -> Result<()> {
    let small = envlight::math::camera::sphere_camera(8);
    let mut seen: Vec<(&'static str, LightsMode, LookupFilter, &'static str)> = Vec::new();
    for c in all {
        let key = (c.technique.name(), c.lights, c.filter, c.rotate());
        if seen.contains(&key) || matches!(c.technique, Technique::Prefiltered { .. }) {
            continue;
        }
        seen.push(key);
        let mut sc = scene(small, c.brdf, c.technique, None, 7, split);
        with_case(&mut sc, c);
        renderer.render(&sc, env)?;
    }
    Ok(())
}

/// The reference for `brdf`: for lobes the mean of two MIS Monte Carlo renders (seeds 1 and
/// 2) and the per-pixel noise of that mean; for the mirror its supersampled render (noise 0).
fn reference_of(
    renderer: &Renderer,
    env: &EnvMap,
    cam: Camera,
    brdf: Brdf,
    reference: u32,
    pixels: &[(usize, u32)],
    split: SplitSumSettings,
) -> Result<(EnvMap, f64)> {
    if matches!(brdf, Brdf::Mirror) {
        let sphere = [Shape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        }];
        return Ok((
            envlight::math::footprint::supersampled(env, &cam, &sphere, 16),
            0.0,
        ));
    }
    let mc = |seed| {
        let t = Technique::Mc {
            samples: reference,
            error: None,
        };
        let mut sc = scene(cam, brdf, t, None, seed, split);
        sc.environment.lights = LightsMode::None;
        renderer.render(&sc, env).map(|r| r.frame)
    };
    let (r1, r2) = (mc(1)?, mc(2)?);
    let truth = average(&r1, &r2);
    let noise = noise_of_mean(&r1, &r2, &truth, pixels);
    Ok((truth, noise))
}

fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut s = String::from(
        "probe,material,technique,lights,rotate,filter,relative_rms,mean_ratio,worst_tile,reference_noise,gpu_ms\n",
    );
    for r in rows {
        let c = &r.case;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{:.6e},{:.6},{:.6e},{:.3e},{:.3}",
            r.probe,
            c.material,
            c.label,
            c.lights_name(),
            c.rotate(),
            c.filter_name(),
            r.rms,
            r.ratio,
            r.tile,
            r.noise,
            r.gpu_ms
        );
    }
    std::fs::write(path, s).with_context(|| path.display().to_string())
}

/// The rows of a probe-independent case key, one per probe in [`PROBES`] order.
fn by_probe<'a>(rows: &'a [Row], pick: &dyn Fn(&Case) -> bool) -> Vec<&'a Row> {
    let mut v: Vec<&Row> = rows.iter().filter(|r| pick(&r.case)).collect();
    v.sort_by_key(|r| PROBES.iter().position(|p| p.0.starts_with(&r.probe)));
    v
}

fn short(probe: &str) -> &str {
    probe.trim_end_matches("_1k")
}

fn markdown(rows: &[Row], settings: &str) -> String {
    let mut md = String::from("# Accuracy on real probes, with and without light extraction\n\n");
    let _ = writeln!(md, "{settings}\n");
    goals(&mut md, rows);
    materials(&mut md, rows);
    rotation(&mut md, rows);
    md
}

/// The goals, each met or not, with its per-probe figures.
fn goals(md: &mut String, rows: &[Row]) {
    md.push_str("## Goals\n\n");
    let goal =
        |md: &mut String, name: &str, pick: &dyn Fn(&Case) -> bool, max: f64, bias: Option<f64>| {
            let v = by_probe(rows, pick);
            if v.is_empty() {
                // A goal whose cases this run left out (`--materials`, `--only`) is not met.
                let _ = writeln!(md, "- {name}: not measured in this run");
                return;
            }
            let ok = v
                .iter()
                .all(|r| r.rms <= max && bias.is_none_or(|b| (r.ratio - 1.0).abs() <= b));
            let cells: Vec<String> = v
                .iter()
                .map(|r| {
                    format!(
                        "{} {:.2}% ({:+.2}%)",
                        short(&r.probe),
                        100.0 * r.rms,
                        100.0 * (r.ratio - 1.0)
                    )
                })
                .collect();
            let _ = writeln!(
                md,
                "- {name}: **{}**: {}",
                if ok { "met" } else { "not met" },
                cells.join(", ")
            );
        };
    goal(
        md,
        "Diffuse by SH order 2 plus lights ≤ 1.5%",
        &|c| c.label == "sh 2" && c.lights == LightsMode::Extract,
        0.015,
        None,
    );
    for alpha in ALPHAS {
        let m = format!("ggx {alpha}");
        goal(
            md,
            &format!("GGX α {alpha} by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%"),
            &|c| {
                c.material == m
                    && c.label == "fis 64"
                    && c.lights == LightsMode::Extract
                    && c.rotate() == "off"
            },
            0.03,
            Some(0.01),
        );
    }
    goal(
        md,
        "Mirror, footprint-filtered, ≤ 3% against the pixel-area mean",
        &|c| {
            c.material == "mirror"
                && c.filter == LookupFilter::Auto
                && c.lights == LightsMode::Extract
        },
        0.03,
        None,
    );
}

/// Per material, each technique's cells per probe and mean GPU time, and the references' noise.
fn materials(md: &mut String, rows: &[Row]) {
    let probes: Vec<&str> = PROBES
        .iter()
        .map(|p| p.0.trim_end_matches("_1k.hdr"))
        .collect();
    md.push_str(
        "\nIn parentheses: the mean ratio − 1 (bias). Each cell below: per-pixel relative RMS \
         · mean ratio · worst 8×8 tile.\n\n![error maps](error_maps.png)\n",
    );
    let header = |md: &mut String, first: &str| {
        let _ = writeln!(
            md,
            "\n| {first} | lights | {} | mean GPU ms |\n|---|---|{}---|",
            probes.join(" | "),
            "---|".repeat(probes.len())
        );
    };
    let mut materials: Vec<&str> = Vec::new();
    for r in rows {
        if !materials.contains(&r.case.material.as_str()) {
            materials.push(&r.case.material);
        }
    }
    for m in materials {
        let _ = writeln!(md, "\n## {m}");
        header(md, "technique");
        let mut keys: Vec<(String, LightsMode, LookupFilter)> = Vec::new();
        for r in rows
            .iter()
            .filter(|r| r.case.material == m && r.case.rotate() != "on")
        {
            let k = (r.case.label.clone(), r.case.lights, r.case.filter);
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        for (label, lights, filter) in keys {
            let v = by_probe(rows, &|c| {
                c.material == m
                    && c.label == label
                    && c.lights == lights
                    && c.filter == filter
                    && c.rotate() != "on"
            });
            let Some(first) = v.first() else { continue };
            let name = match first.case.filter_name() {
                "" => label.clone(),
                f => format!("{label} ({f})"),
            };
            let cells: Vec<String> = v
                .iter()
                .map(|r| {
                    format!(
                        "{:.2}% · {:.3} · {:.1}%",
                        100.0 * r.rms,
                        r.ratio,
                        100.0 * r.tile
                    )
                })
                .collect();
            let ms = v.iter().map(|r| r.gpu_ms).sum::<f64>() / v.len() as f64;
            let _ = writeln!(
                md,
                "| {name} | {} | {} | {ms:.1} |",
                first.case.lights_name(),
                cells.join(" | ")
            );
        }
        // Every row of a probe and material shares its reference, so its noise.
        let noise: Vec<String> = PROBES
            .iter()
            .filter_map(|(file, _)| {
                let probe = file.trim_end_matches(".hdr");
                rows.iter()
                    .find(|r| r.probe == probe && r.case.material == m)
            })
            .map(|r| format!("{} {:.2}%", short(&r.probe), 100.0 * r.noise))
            .collect();
        if m != "mirror" {
            let _ = writeln!(md, "\nReference noise (per pixel): {}.", noise.join(", "));
        }
    }
}

/// FIS with the sequence rotated per pixel against the same set everywhere.
fn rotation(md: &mut String, rows: &[Row]) {
    md.push_str(
        "\n## Per-pixel sequence rotation (item 5)\n\nFIS with the Hammersley set shifted per \
         pixel (`rotate = true`) against the same set everywhere (`false`): per-pixel relative \
         RMS, mean over the five probes (worst probe in parentheses).\n\n| α | N | lights | \
         rotate off | rotate on |\n|---|---|---|---|---|\n",
    );
    let (mut off_wins, mut pairs) = (0, 0);
    for alpha in ALPHAS {
        let m = format!("ggx {alpha}");
        for lights in [LightsMode::Extract, LightsMode::None] {
            for n in FIS_N {
                let mean = |rot: &str| {
                    let v = by_probe(rows, &|c| {
                        c.material == m
                            && c.label == format!("fis {n}")
                            && c.lights == lights
                            && c.rotate() == rot
                    });
                    v.iter().map(|r| r.rms).sum::<f64>() / v.len().max(1) as f64
                };
                pairs += 1;
                if mean("off") <= mean("on") {
                    off_wins += 1;
                }
                let stat = |rot: &str| {
                    let v = by_probe(rows, &|c| {
                        c.material == m
                            && c.label == format!("fis {n}")
                            && c.lights == lights
                            && c.rotate() == rot
                    });
                    let mean = v.iter().map(|r| r.rms).sum::<f64>() / v.len().max(1) as f64;
                    let worst = v.iter().map(|r| r.rms).fold(0.0, f64::max);
                    format!("{:.2}% ({:.2}%)", 100.0 * mean, 100.0 * worst)
                };
                let name = if lights == LightsMode::Extract {
                    "extract"
                } else {
                    "none"
                };
                let _ = writeln!(
                    md,
                    "| {alpha} | {n} | {name} | {} | {} |",
                    stat("off"),
                    stat("on")
                );
            }
        }
    }
    let _ = writeln!(
        md,
        "\nRotation off is at least as accurate in {off_wins} of these {pairs} rows."
    );
}

/// The error maps drawn: (column title, material, label, lights, filter), rotate off.
fn columns() -> Vec<(
    &'static str,
    &'static str,
    &'static str,
    LightsMode,
    LookupFilter,
)> {
    use LightsMode::{Extract, None as Off};
    use LookupFilter::{Auto, Point};
    vec![
        ("SH 2", "diffuse", "sh 2", Off, Auto),
        ("SH 2 + lights", "diffuse", "sh 2", Extract, Auto),
        ("FIS-64 α 0.1", "ggx 0.1", "fis 64", Off, Auto),
        ("FIS-64 α 0.1 + lights", "ggx 0.1", "fis 64", Extract, Auto),
        ("FIS-64 α 0.6", "ggx 0.6", "fis 64", Off, Auto),
        ("FIS-64 α 0.6 + lights", "ggx 0.6", "fis 64", Extract, Auto),
        ("mirror, point", "mirror", "lookup", Off, Point),
        (
            "mirror, footprint + lights",
            "mirror",
            "lookup",
            Extract,
            Auto,
        ),
    ]
}

/// Colour of a signed relative error: white at 0, red above, blue below, saturating at
/// ±100% on a log scale from 0.1%.
fn error_colour(e: f32) -> (u8, u8, u8) {
    if !e.is_finite() {
        return (200, 200, 200);
    }
    let t = ((e.abs().max(1e-3).log10() + 3.0) / 3.0).clamp(0.0, 1.0);
    let fade = (255.0 * (1.0 - t)) as u8;
    if e >= 0.0 {
        (255, fade, fade)
    } else {
        (fade, fade, 255)
    }
}

fn maps(path: &Path, rows: &[Row], size: u32, device: &str) -> Result<()> {
    use plotters::prelude::*;
    let e = |e: &dyn std::fmt::Display| anyhow!("error_maps.png: {e}");
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow!("error_maps.png: the bundled font did not load"))?;
    let cols = columns();
    let cell = size.max(96);
    let (left, top, gap) = (150u32, 76u32, 6u32);
    let w = left + cols.len() as u32 * (cell + gap) + 10;
    let h = top + PROBES.len() as u32 * (cell + gap) + 50;
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let title = [
        "Signed per-pixel relative error of luminance against the reference (white 0, red over, \
         blue under; log scale 0.1% to 100%); below each map its per-pixel relative RMS"
            .to_string(),
        format!("device: {device}"),
    ];
    for (k, line) in title.iter().enumerate() {
        root.draw(&Text::new(
            line.clone(),
            (10, 6 + 16 * k as i32),
            ("sans-serif", 13),
        ))
        .map_err(|x| e(&x))?;
    }
    for (ci, (title, ..)) in cols.iter().enumerate() {
        let x = (left + ci as u32 * (cell + gap)) as i32;
        root.draw(&Text::new(title.to_string(), (x, 56), ("sans-serif", 11)))
            .map_err(|x| e(&x))?;
    }
    for (pi, (file, _)) in PROBES.iter().enumerate() {
        let probe = file.trim_end_matches(".hdr");
        let y0 = (top + pi as u32 * (cell + gap)) as i32;
        root.draw(&Text::new(
            short(probe).to_string(),
            (6, y0 + cell as i32 / 2),
            ("sans-serif", 12),
        ))
        .map_err(|x| e(&x))?;
        for (ci, (_, material, label, lights, filter)) in cols.iter().enumerate() {
            let Some(r) = rows.iter().find(|r| {
                r.probe == probe
                    && r.case.material == *material
                    && r.case.label == *label
                    && r.case.lights == *lights
                    && r.case.filter == *filter
                    && r.case.rotate() != "on"
            }) else {
                continue;
            };
            let x0 = (left + ci as u32 * (cell + gap)) as i32;
            for py in 0..cell {
                for px in 0..cell {
                    let (i, j) = (px * size / cell, py * size / cell);
                    let (cr, cg, cb) = error_colour(r.errors[(j * size + i) as usize]);
                    root.draw_pixel((x0 + px as i32, y0 + py as i32), &RGBColor(cr, cg, cb))
                        .map_err(|x| e(&x))?;
                }
            }
            root.draw(&Text::new(
                format!("{:.2}%", 100.0 * r.rms),
                (x0 + 2, y0 + cell as i32 - 14),
                ("sans-serif", 11),
            ))
            .map_err(|x| e(&x))?;
        }
    }
    // The colour key.
    let ky = (h - 36) as i32;
    for (k, v) in [-1.0f32, -0.1, -0.01, -0.001, 0.0, 0.001, 0.01, 0.1, 1.0]
        .iter()
        .enumerate()
    {
        let x = left as i32 + k as i32 * 90;
        let (cr, cg, cb) = error_colour(*v);
        root.draw(&Rectangle::new(
            [(x, ky), (x + 20, ky + 14)],
            RGBColor(cr, cg, cb).filled(),
        ))
        .map_err(|x| e(&x))?;
        root.draw(&Rectangle::new([(x, ky), (x + 20, ky + 14)], BLACK))
            .map_err(|x| e(&x))?;
        root.draw(&Text::new(
            format!("{:+}%", 100.0 * v),
            (x + 24, ky + 1),
            ("sans-serif", 11),
        ))
        .map_err(|x| e(&x))?;
    }
    root.present().map_err(|x| e(&x))?;
    Ok(())
}

/// `envlight-lab table`: the accuracy table (table.md, table.csv, error_maps.png): five
/// probes, diffuse by SH 2 and 8 and prefiltered, GGX α 0.05 to 0.6 by FIS 16/64/256
/// (sequence rotation off and on), Phong 64 prefiltered and the mirror, with light extraction
/// and without, per-pixel errors against the reference
#[derive(clap::Args)]
pub struct TableArgs {
    /// Folder of the probes (default: $ENVLIGHT_PROBES; one of the two is needed)
    #[arg(long)]
    probes: Option<PathBuf>,
    /// Output folder
    #[arg(long, default_value = "docs/accuracy")]
    out: PathBuf,
    /// Side of the sphere image
    #[arg(long, default_value_t = 128)]
    size: u32,
    /// Samples per pixel of each of the two Monte Carlo reference renders
    #[arg(long, default_value_t = 4096)]
    reference: u32,
    /// Only these materials ("diffuse", "ggx 0.05" … "ggx 0.6", "phong 64", "mirror")
    #[arg(long, value_delimiter = ',')]
    materials: Vec<String>,
    /// Only the probes whose file names contain one of these
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Render through the resident path (`envlight render --resident`: the map on the GPU,
    /// its lights extracted there) instead of the host path
    #[arg(long)]
    resident: bool,
    /// The scenes' light_texels (the most light texels FIS, split-sum and footprint lookups
    /// extract; default 16384)
    #[arg(long)]
    light_texels: Option<u32>,
}

/// Runs `envlight-lab table`.
pub fn run(g: &crate::common::Global, a: &TableArgs) -> Result<()> {
    let ctx = crate::common::context(g)?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver.trim());
    eprintln!("device: {device}");
    let pick = Pick {
        materials: a.materials.clone(),
        probes: a.only.clone(),
        resident: a.resident,
        light_texels: a.light_texels,
    };
    let dir = crate::common::probes_dir(a.probes.as_deref())?;
    table(
        &Renderer::new(&ctx),
        &dir,
        a.size,
        a.reference,
        &a.out,
        &device,
        &pick,
    )
}
