//! `envlight-lab ibl`: `envlight bake --preset khronos` beside glTF-IBL-Sampler (the Khronos
//! reference prefilter) on the same probes and device, at several sample counts for each:
//! whole-process times from interleaved runs, and each GGX cube's error per level against
//! the float64 exact prefilter at that level's α, read from the files both tools write.
//!
//! Both tools read the same lat-long Radiance file (a probe in another mapping or format is
//! converted first, untimed: the sampler reads panoramas alone). Its cubes are in its own
//! conventions (its frame, roughness = level/(levels − 1), α = roughness², rgba16f), which
//! the Khronos preset shares, so one exact filter in that frame scores both.

use crate::common::Global;
use anyhow::{anyhow, bail, Context as _, Result};
use envlight::bake::output::Preset;
use envlight::io::ktx2;
use envlight::math::envmap::luminance;
use envlight::math::exact::ExactFilter;
use envlight::math::split_sum::level_alpha;
use envlight::math::Mapping;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// What `envlight-lab ibl` is asked.
pub struct IblOptions {
    /// Probes, or folders of probes.
    pub inputs: Vec<PathBuf>,
    /// glTF-IBL-Sampler's wrapper, if present.
    pub sampler: Option<PathBuf>,
    /// Cube face size at level 0.
    pub size: u32,
    /// Runs of each configuration (interleaved).
    pub runs: u32,
    /// envlight's FIS samples per texel, one configuration each.
    pub ours: Vec<u32>,
    /// glTF-IBL-Sampler's sample counts, one configuration each.
    pub theirs: Vec<u32>,
    /// Texels checked per level.
    pub texels: u32,
    /// Where the page goes.
    pub out: Option<PathBuf>,
}

/// One tool at one sample count.
#[derive(Clone, Copy, PartialEq)]
enum Tool {
    Envlight(u32),
    Sampler(u32),
}

impl Tool {
    fn label(self) -> String {
        match self {
            Tool::Envlight(n) => format!("envlight bake, {n} samples"),
            Tool::Sampler(n) => format!("glTF-IBL-Sampler, {n} samples"),
        }
    }
}

/// A configuration's results on one probe.
struct Measured {
    tool: Tool,
    /// Whole-process seconds, one per run.
    seconds: Vec<f64>,
    /// Relative RMS per level (level 0 first, NaN where not checked).
    errors: Vec<f64>,
}

impl Measured {
    fn median(&self) -> f64 {
        let mut v = self.seconds.clone();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    }
}

/// The command that runs `tool` on `hdr`, writing its GGX cube to `cube`.
fn command(g: &Global, o: &IblOptions, tool: Tool, hdr: &Path, dir: &Path) -> Result<Command> {
    let levels = o.size.ilog2().to_string();
    Ok(match tool {
        Tool::Envlight(n) => {
            let mut c = Command::new(crate::common::envlight_exe()?);
            if let Some(d) = &g.device {
                c.args(["--device", d]);
            }
            c.arg("bake").arg(hdr).arg("--out").arg(dir);
            c.args([
                "--preset",
                "khronos",
                "--check",
                "0",
                "--specular-levels",
                &levels,
            ]);
            c.args([
                "--specular-size",
                &o.size.to_string(),
                "--samples",
                &n.to_string(),
            ]);
            c
        }
        Tool::Sampler(n) => {
            let mut c = Command::new(o.sampler.as_ref().ok_or_else(|| anyhow!("no sampler"))?);
            c.arg("-inputPath").arg(hdr);
            c.arg("-outCubeMap").arg(dir.join("ggx.ktx2"));
            c.arg("-outLUT").arg(dir.join("lut.png"));
            c.args(["-distribution", "GGX", "-sampleCount", &n.to_string()]);
            c.args([
                "-cubeMapResolution",
                &o.size.to_string(),
                "-mipLevelCount",
                &levels,
            ]);
            c.args(["-targetFormat", "R16G16B16A16_SFLOAT"]);
            c
        }
    })
}

/// The GGX cube `tool` wrote into `dir` for `hdr`.
fn cube_path(tool: Tool, hdr: &Path, dir: &Path) -> PathBuf {
    match tool {
        Tool::Envlight(_) => dir
            .join(hdr.file_name().unwrap_or_default())
            .join("specular.ktx2"),
        Tool::Sampler(_) => dir.join("ggx.ktx2"),
    }
}

/// Runs `c` with a fresh `dir`; its wall seconds.
fn timed(mut c: Command, dir: &Path) -> Result<f64> {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    let t0 = Instant::now();
    let o = c.output().with_context(|| format!("{c:?}"))?;
    let s = t0.elapsed().as_secs_f64();
    if !o.status.success() {
        bail!(
            "{c:?} failed: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
    }
    Ok(s)
}

/// The checked texels of each level ≥ 1 (index into the level, exact luminance): the texel
/// holding the probe's brightest direction, then `texels` − 1 spread over the faces.
fn exact_texels(map: &envlight::EnvMap, size: u32, texels: u32) -> Vec<Vec<(usize, f64)>> {
    let frame = Preset::Khronos.cube_frame().world_to_file().transpose();
    let exact = ExactFilter::new(map, frame);
    let levels = size.ilog2();
    let sun = exact.brightest();
    let mut jobs = Vec::new();
    for k in 1..levels {
        let s = (size >> k).max(1);
        for q in 0..texels.min(6 * s * s) {
            let (layer, i, j) = if q == 0 {
                let c = Mapping::Cube.dir_to_coord(sun);
                let t = |x: f64| ((x * s as f64) as u32).min(s - 1);
                (c.layer, t(c.u), t(c.v))
            } else {
                (q % 6, (q * 37 + 11) % s, (q * 23 + 5) % s)
            };
            let d = Mapping::Cube.coord_to_dir(Mapping::texel_center(s, s, layer, i, j));
            jobs.push((k, ((layer * s + j) * s + i) as usize, d));
        }
    }
    let alpha = |k: u32| level_alpha(k, levels);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let values: Vec<f64> = std::thread::scope(|scope| {
        let exact = &exact;
        let handles: Vec<_> = jobs
            .chunks(jobs.len().div_ceil(threads).max(1))
            .map(|chunk| {
                scope.spawn(move || {
                    chunk
                        .iter()
                        .map(|&(k, _, d)| luminance(exact.ggx(d, alpha(k))))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    let mut out = vec![Vec::new(); levels as usize];
    for ((k, at, _), v) in jobs.iter().zip(values) {
        out[*k as usize].push((*at, v));
    }
    out
}

/// Relative RMS (luminance) of each level of the cube at `path` against `exact`.
fn level_errors(path: &Path, exact: &[Vec<(usize, f64)>]) -> Result<Vec<f64>> {
    let bytes = std::fs::read(path).with_context(|| path.display().to_string())?;
    let tex = ktx2::decode(&bytes).with_context(|| path.display().to_string())?;
    if tex.levels.len() < exact.len() || tex.faces != 6 {
        bail!(
            "{}: {} levels, {} faces; expected a cube of {}",
            path.display(),
            tex.levels.len(),
            tex.faces,
            exact.len()
        );
    }
    Ok(exact
        .iter()
        .enumerate()
        .map(|(k, texels)| {
            if texels.is_empty() {
                return f64::NAN;
            }
            let (mut se, mut s2) = (0.0, 0.0);
            for &(at, want) in texels {
                let t = tex.levels[k][at];
                let got = luminance([t[0] as f64, t[1] as f64, t[2] as f64]);
                se += (got - want).powi(2);
                s2 += want * want;
            }
            (se / s2).sqrt()
        })
        .collect())
}

/// The probe as a lat-long Radiance file both tools read: itself, or its 1024 × 512
/// resampling (bilinear, as the GPU reads a map) written into `dir`.
fn latlong_hdr(probe: &Path, dir: &Path) -> Result<PathBuf> {
    let map = envlight::io::load(probe, &Default::default())
        .with_context(|| probe.display().to_string())?;
    let is_hdr = probe
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("hdr"));
    if map.mapping == Mapping::LatLong && is_hdr {
        return Ok(probe.to_path_buf());
    }
    let (w, h) = (1024u32, 512u32);
    let mut texels = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            let d = Mapping::LatLong.coord_to_dir(Mapping::texel_center(w, h, 0, i, j));
            let v = envlight::math::convert::sample(&map, d);
            texels.push(image::Rgb([v[0] as f32, v[1] as f32, v[2] as f32]));
        }
    }
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    let stem = probe.file_stem().unwrap_or_default().to_string_lossy();
    let out = dir.join(format!("{stem}.hdr"));
    let file = std::fs::File::create(&out).with_context(|| out.display().to_string())?;
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file))
        .encode(&texels, w as usize, h as usize)
        .with_context(|| out.display().to_string())?;
    Ok(out)
}

/// Runs the benchmark.
pub fn bench_ibl(g: &Global, o: &IblOptions) -> Result<()> {
    if !o.size.is_power_of_two() || !(8..=2048).contains(&o.size) {
        bail!("--size {}: a power of two from 8 to 2048", o.size);
    }
    let mut files = Vec::new();
    for p in &o.inputs {
        if p.is_dir() {
            files.extend(envlight::io::probes_in(p)?);
        } else {
            files.push(p.clone());
        }
    }
    let mut tools: Vec<Tool> = o.ours.iter().map(|&n| Tool::Envlight(n)).collect();
    match &o.sampler {
        Some(s) if s.is_file() => tools.extend(o.theirs.iter().map(|&n| Tool::Sampler(n))),
        Some(s) => eprintln!(
            "glTF-IBL-Sampler not found at {}: envlight alone",
            s.display()
        ),
        None => eprintln!("no glTF-IBL-Sampler (--sampler or ENVLIGHT_IBLSAMPLER): envlight alone"),
    }
    let scratch = std::env::temp_dir().join(format!("envlight-bench-ibl-{}", std::process::id()));
    let mut results = Vec::new();
    for probe in &files {
        let hdr = latlong_hdr(probe, &scratch)?;
        let map = envlight::io::load(&hdr, &Default::default())
            .with_context(|| hdr.display().to_string())?;
        let exact = exact_texels(&map, o.size, o.texels);
        let mut rows: Vec<Measured> = tools
            .iter()
            .map(|&tool| Measured {
                tool,
                seconds: Vec::new(),
                errors: Vec::new(),
            })
            .collect();
        for run in 0..o.runs as usize {
            // Interleaved, the order turned each run, so drift reaches every tool alike.
            for q in 0..rows.len() {
                let m = &mut rows[(q + run) % tools.len()];
                let dir = scratch.join("run");
                let s = timed(command(g, o, m.tool, &hdr, &dir)?, &dir)?;
                m.seconds.push(s);
                if m.errors.is_empty() {
                    m.errors = level_errors(&cube_path(m.tool, &hdr, &dir), &exact)?;
                }
                eprintln!("{} {}: {s:.3} s", probe.display(), m.tool.label());
            }
        }
        let name = probe.file_name().unwrap_or_default().to_string_lossy();
        results.push((name.to_string(), rows));
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let (method, md) = markdown(o, &results);
    print!("{method}\n\n{md}");
    if let Some(out) = &o.out {
        let ctx = crate::common::context(g)?;
        let section = crate::page::Section {
            job: "ibl",
            title: "GGX cubes: envlight bake beside glTF-IBL-Sampler",
            method: &method,
            body: &md,
        };
        crate::page::write_section(out, &section, &crate::page::Provenance::of(ctx.info()))?;
    }
    Ok(())
}

/// Levels whose α lies in the goal's range, 0.05 to 0.6.
fn goal_levels(levels: u32) -> Vec<usize> {
    (1..levels)
        .filter(|&k| (0.05..=0.6).contains(&level_alpha(k, levels)))
        .map(|k| k as usize)
        .collect()
}

/// For each sampler row, whether an envlight row has ≤ its median time and ≤ half its error
/// at every goal level.
fn dominated(rows: &[Measured], theirs: &Measured, levels: &[usize]) -> bool {
    rows.iter()
        .filter(|m| matches!(m.tool, Tool::Envlight(_)))
        .any(|m| {
            m.median() <= theirs.median()
                && levels
                    .iter()
                    .all(|&k| m.errors[k] <= 0.5 * theirs.errors[k])
        })
}

/// The method and the tables.
fn markdown(o: &IblOptions, results: &[(String, Vec<Measured>)]) -> (String, String) {
    let levels = o.size.ilog2();
    let goal = goal_levels(levels);
    let method = format!(
        "cube {0}², {levels} levels, {1} \
         interleaved runs of each configuration (the order turned each run), median \
         whole-process seconds; envlight's time is the whole `bake --preset khronos` (SH, \
         irradiance, GGX cube, DFG table), glTF-IBL-Sampler's one `-distribution GGX` run. \
         Error: relative RMS of each level's luminance at {2} texels (the brightest \
         direction's first) against the float64 exact n = v = r prefilter at the level's \
         α = (k/{3})². A sampler row is dominated when an envlight row takes no longer and \
         errs at most half as much at every level of α 0.05 to 0.6.",
        o.size,
        o.runs,
        o.texels,
        levels - 1,
    );
    let mut md = String::new();
    let alphas: Vec<String> = (1..levels - 1)
        .map(|k| format!("α {:.3}", level_alpha(k, levels)))
        .collect();
    let (mut total, mut beaten) = (0, 0);
    for (probe, rows) in results {
        let _ = write!(
            md,
            "### {probe}\n\n| tool | seconds (min–max) | {} | dominated |\n|---|---|{}---|\n",
            alphas.join(" | "),
            "---|".repeat(alphas.len())
        );
        for m in rows {
            let lo = m.seconds.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = m.seconds.iter().copied().fold(0.0, f64::max);
            let errs: Vec<String> = (1..levels as usize - 1)
                .map(|k| format!("{:.2}%", 100.0 * m.errors[k]))
                .collect();
            let dom = match m.tool {
                Tool::Envlight(_) => String::new(),
                Tool::Sampler(_) => {
                    total += 1;
                    let d = dominated(rows, m, &goal);
                    beaten += d as u32;
                    if d { "yes" } else { "**no**" }.into()
                }
            };
            let _ = writeln!(
                md,
                "| {} | {:.3} ({lo:.3}–{hi:.3}) | {} | {dom} |",
                m.tool.label(),
                m.median(),
                errs.join(" | ")
            );
        }
        md.push('\n');
    }
    let _ = match total {
        0 => writeln!(
            md,
            "No glTF-IBL-Sampler ran (--sampler or ENVLIGHT_IBLSAMPLER): envlight's rows alone, \
             nothing to dominate.\n"
        ),
        _ => writeln!(
            md,
            "glTF-IBL-Sampler configurations dominated by an envlight one: {beaten} of {total}.\n"
        ),
    };
    (method, md)
}

/// `envlight-lab ibl`: GGX cubes of `envlight bake --preset khronos` beside
/// glTF-IBL-Sampler's on the same probes: whole-process seconds and each level's error against
/// the exact prefilter, at several sample counts for each (markdown)
#[derive(clap::Args)]
pub struct IblArgs {
    /// Probes, or folders whose .hdr/.exr/.dds/.pfm files are all taken
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// glTF-IBL-Sampler's wrapper (default: $ENVLIGHT_IBLSAMPLER); without it envlight runs
    /// alone
    #[arg(long)]
    sampler: Option<PathBuf>,
    /// Cube face size at level 0 (levels: log2 of it, as the sampler's default)
    #[arg(long, default_value_t = 256)]
    size: u32,
    /// Interleaved runs of each configuration (the median is reported)
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// envlight's FIS samples per texel, one configuration each
    #[arg(long, value_delimiter = ',', default_value = "16,64,256")]
    ours: Vec<u32>,
    /// glTF-IBL-Sampler's sample counts, one configuration each
    #[arg(long, value_delimiter = ',', default_value = "16,64,256,1024")]
    theirs: Vec<u32>,
    /// Texels checked per level against the exact prefilter
    #[arg(long, default_value_t = 192)]
    texels: u32,
    /// The performance page (docs/performance/DEVICE.md) to write this job's section into
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs `envlight-lab ibl`.
pub fn run(g: &Global, a: &IblArgs) -> Result<()> {
    bench_ibl(
        g,
        &IblOptions {
            inputs: a.inputs.clone(),
            sampler: a
                .sampler
                .clone()
                .or_else(|| std::env::var_os("ENVLIGHT_IBLSAMPLER").map(PathBuf::from)),
            size: a.size,
            runs: a.runs.max(1),
            ours: a.ours.clone(),
            theirs: a.theirs.clone(),
            texels: a.texels.max(1),
            out: a.out.clone(),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options() -> IblOptions {
        IblOptions {
            inputs: Vec::new(),
            sampler: None,
            size: 256,
            runs: 3,
            ours: vec![16],
            theirs: vec![16],
            texels: 192,
            out: None,
        }
    }

    fn row(tool: Tool, seconds: f64, error: f64) -> Measured {
        Measured {
            tool,
            seconds: vec![seconds; 3],
            errors: vec![error; 8],
        }
    }

    /// The page's summary counts the sampler's rows an envlight row dominates, and says so
    /// where no sampler ran instead of "0 of 0".
    #[test]
    fn the_summary_names_a_missing_sampler() {
        let ours = row(Tool::Envlight(16), 0.3, 0.01);
        let alone = vec![("a.hdr".to_string(), vec![ours])];
        let (_, md) = markdown(&options(), &alone);
        assert!(md.contains("No glTF-IBL-Sampler ran"), "{md}");
        assert!(!md.contains("0 of 0"), "{md}");
        let pair = vec![(
            "a.hdr".to_string(),
            vec![
                row(Tool::Envlight(16), 0.3, 0.01),
                row(Tool::Sampler(16), 0.4, 0.5),
                row(Tool::Sampler(64), 0.2, 0.5),
            ],
        )];
        let (_, md) = markdown(&options(), &pair);
        assert!(md.contains("dominated by an envlight one: 1 of 2."), "{md}");
    }
}
