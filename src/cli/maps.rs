//! `envlight convert`, `sh`, `irradiance` and `prefilter`: one map in, one result out.

use super::{
    finite_f32, finite_f64, load_with_context, print_timings, save, spinner, upload_while,
    write_map, FilterOut, Global, HostClock, Input, MappingArg, Orient,
};
use crate::gpu::Timed;
use crate::io::ToneMap;
use crate::math::filter::Kernel;
use crate::math::sh::{self, Window};
use crate::math::Mapping;
use crate::passes::brute::PhongLevels;
use crate::passes::sh_project::Subgroups;
use crate::passes::{BruteFilter, ConvertOptions, Converter, ShEvaluator, ShProjector};
use crate::scene::defaults;
use crate::GpuEnvMap;
use anyhow::{bail, Context as _, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// Convert a map to another mapping and resolution on the GPU
#[derive(Args)]
pub struct ConvertArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    orient: Orient,
    /// Output map, in the format its extension names: .exr (float32 OpenEXR), .hdr (Radiance
    /// RGBE) or .pfm (a cube is six faces stacked vertically, a dual paraboloid its upper half
    /// above its lower half)
    #[arg(short, long)]
    output: PathBuf,
    /// Output mapping
    #[arg(long, value_enum)]
    to: MappingArg,
    /// Output size: lat-long width, angular side, cube face, paraboloid half
    #[arg(long)]
    size: u32,
    /// Samples per axis per output texel (default: chosen from the resolutions)
    #[arg(long)]
    supersample: Option<u32>,
    /// Also write a tone-mapped PNG preview beside the output
    #[arg(long)]
    png: bool,
    /// Exposure of the PNG preview, in stops
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite_f32)]
    exposure: f32,
}

/// Project a map onto spherical harmonics on the GPU and write them as JSON
#[derive(Args)]
pub struct ShArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    orient: Orient,
    /// Highest band l (0 to 8)
    #[arg(long, default_value_t = defaults::SH_ORDER)]
    order: u32,
    /// Output JSON: {"order", "coefficients": [[r,g,b], ...], "irradiance_matrices"}
    #[arg(short, long)]
    output: PathBuf,
}

/// How an irradiance map is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// SH projection and evaluation (Ramamoorthi & Hanrahan 2001).
    Sh,
    /// Brute-force convolution of every source texel.
    Brute,
}

/// A window against SH ringing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum WindowArg {
    /// No window.
    None,
    /// Hanning, of width --lambda (default 2·(order+1)).
    Hanning,
    /// Sloan's 1/(1 + λ l²(l+1)²), with --lambda.
    Sloan,
    /// The smallest Sloan λ that makes E non-negative.
    Auto,
}

/// A window by name, with an error that says what the names are.
fn parse_window(s: &str) -> Result<WindowArg, String> {
    WindowArg::from_str(s, true)
        .map_err(|_| format!("unknown window {s:?} (none, hanning, sloan, auto)"))
}

/// Irradiance map E(n) of a map, from SH (R&H 2001) or by brute-force convolution
#[derive(Args)]
pub struct IrradianceArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    orient: Orient,
    /// How to compute it
    #[arg(long, value_enum, default_value = "sh")]
    method: Method,
    /// Highest SH band (sh only; 0 to 8)
    #[arg(long, default_value_t = defaults::SH_ORDER)]
    order: u32,
    /// Window against ringing (sh only): none, hanning, sloan, auto
    #[arg(long, value_parser = parse_window, default_value = "none")]
    window: WindowArg,
    /// Strength of the Sloan window, or width of the Hanning window (default 2·(order+1))
    #[arg(long, value_parser = finite_f64)]
    lambda: Option<f64>,
    #[command(flatten)]
    out: FilterOut,
}

/// Prefilter a map with a normalised Phong lobe (Miller & Hoffman 1984), brute force,
/// indexed by the reflection direction
#[derive(Args)]
pub struct PrefilterArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    orient: Orient,
    /// Phong exponent n (1 to 1e7)
    #[arg(long, value_parser = finite_f64, required_unless_present = "phong_levels", conflicts_with = "phong_levels")]
    phong: Option<f64>,
    /// Write K levels instead, like cmft's radiance filter: level k is --size halved k times,
    /// filtered with n = 2^(scale·(1 − k/(K−1)) + bias) + 1, each from the coarsest level of
    /// the source's moment pyramid its lobe allows; files OUT's stem + `.level<k>.exr` and
    /// a JSON list of the levels at OUT's stem + ".levels.json"
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16))]
    phong_levels: Option<u32>,
    /// cmft's glossScale for --phong-levels
    #[arg(long, value_parser = finite_f64, default_value_t = 10.0)]
    gloss_scale: f64,
    /// cmft's glossBias for --phong-levels
    #[arg(long, value_parser = finite_f64, default_value_t = 1.0)]
    gloss_bias: f64,
    /// Benchmark instrument (`cargo xtask lab peers`), with --phong: write, per output texel,
    /// the sum of L·Ω over the source texels the exact sum visits, read once each without the
    /// lobe's rule, so that the time printed is the floor of visiting them; not a prefiltered map
    #[arg(long, conflicts_with = "phong_levels")]
    visit_floor: bool,
    #[command(flatten)]
    out: FilterOut,
}

/// Host span labels shared by the commands here (`cargo xtask lab peers` reads them back).
const LOAD: &str = "load file ∥ create device";
const UPLOAD: &str = "upload ∥ build pipelines";
const RUN: &str = "record, GPU work, wait";
const DOWNLOAD_WRITE: &str = "download, write";

/// `envlight convert`.
pub fn convert(g: &Global, a: &ConvertArgs) -> Result<()> {
    if a.size == 0 || a.size > 16384 {
        bail!("--size must be between 1 and 16384 (got {})", a.size);
    }
    crate::io::check_map_path(&a.output)?;
    let mut clock = HostClock::start();
    let (map, ctx) = load_with_context(g, &a.input)?;
    clock.lap(LOAD);
    let pb = spinner("converting on the GPU");
    let conv = Converter::new(&ctx)?;
    let (src, ()) = upload_while(&ctx, &map, || conv.prepare(map.mapping, a.to.into()))?;
    clock.lap(UPLOAD);
    let opts = ConvertOptions::new(a.to.into(), a.size)
        .with_orientation(a.orient.orientation())
        .with_supersample(a.supersample);
    let Timed {
        value: dst,
        timings,
    } = conv.run(&src, &opts)?;
    clock.lap(RUN);
    let out = dst.download(&ctx)?;
    clock.lap("download");
    pb.finish_and_clear();
    let tm = ToneMap {
        exposure: a.exposure,
    };
    save(&out, &a.output, a.png.then_some(tm))?;
    clock.lap("write");
    print_timings(&timings);
    clock.print();
    Ok(())
}

/// `envlight sh`.
pub fn sh(g: &Global, a: &ShArgs) -> Result<()> {
    let mut clock = HostClock::start();
    let (map, ctx) = load_with_context(g, &a.input)?;
    clock.lap(LOAD);
    let pb = spinner("projecting onto SH on the GPU");
    let proj = ShProjector::new(&ctx, Subgroups::Auto)?;
    let (gm, ()) = upload_while(&ctx, &map, || proj.prepare(a.order, map.mapping))?;
    clock.lap(UPLOAD);
    let Timed {
        value: coeffs,
        timings,
    } = proj.run_oriented(&gm, a.order, &a.orient.orientation())?;
    clock.lap(RUN);
    pb.finish_and_clear();
    let text = serde_json::to_string_pretty(&coeffs.to_json())?;
    std::fs::write(&a.output, text).with_context(|| a.output.display().to_string())?;
    clock.lap("write");
    println!(
        "wrote {} ({} coefficients per channel)",
        a.output.display(),
        coeffs.coeffs.len()
    );
    print_timings(&timings);
    clock.print();
    Ok(())
}

/// `envlight irradiance`.
pub fn irradiance(g: &Global, a: &IrradianceArgs) -> Result<()> {
    crate::io::check_map_path(&a.out.output)?;
    let mut clock = HostClock::start();
    let (map, ctx) = load_with_context(g, &a.input)?;
    clock.lap(LOAD);
    let order = a.order;
    let sh = a.method == Method::Sh;
    // The projector's pipelines build on a second thread while this one uploads the map and
    // then builds the evaluator's.
    let (gm, projector, evaluator) = std::thread::scope(|s| {
        let building = s.spawn(|| -> crate::Result<Option<ShProjector>> {
            if !sh {
                return Ok(None);
            }
            let p = ShProjector::new(&ctx, Subgroups::Auto)?;
            p.prepare(order, map.mapping)?;
            Ok(Some(p))
        });
        let gm = GpuEnvMap::upload(&ctx, &map);
        let evaluator = sh.then(|| ShEvaluator::new(&ctx)).transpose();
        let projector = building
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        anyhow::Ok((gm?, projector?, evaluator?))
    })?;
    clock.lap(UPLOAD);
    let target = a.out.target();
    let o = a.orient.orientation();
    let Timed {
        value: out,
        timings,
    } = match a.method {
        Method::Brute => {
            let pb = spinner("brute-force irradiance on the GPU");
            let r = BruteFilter::new(&ctx)?.run(&gm, &o, Kernel::Cosine, target)?;
            pb.finish_and_clear();
            r
        }
        Method::Sh => {
            let projector = projector.context("the SH projector is built for --method sh")?;
            let Timed {
                value: c,
                mut timings,
            } = projector.run_oriented(&gm, order, &o)?;
            let dirs = crate::math::synth::fibonacci_sphere(20_000);
            let raw = sh::negativity(&sh::irradiance_coeffs(&c.coeffs), &dirs);
            if raw.fraction > 0.0 {
                println!(
                    "unwindowed order-{order} irradiance is negative on {:.1}% of the sphere, down to {:.2}% of its mean, at ({:.3}, {:.3}, {:.3})",
                    100.0 * raw.fraction,
                    100.0 * raw.worst,
                    raw.at.x,
                    raw.at.y,
                    raw.at.z
                );
            } else {
                println!("unwindowed order-{order} irradiance is non-negative");
            }
            let w = match a.window {
                WindowArg::None => Window::None,
                WindowArg::Hanning => Window::Hanning {
                    width: a.lambda.unwrap_or(2.0 * (order as f64 + 1.0)),
                },
                WindowArg::Sloan => Window::Sloan {
                    lambda: a.lambda.context("--window sloan needs --lambda")?,
                },
                WindowArg::Auto => Window::Sloan {
                    lambda: sh::smallest_nonnegative_window(&c.coeffs, &dirs),
                },
            };
            if w != Window::None {
                let n = sh::negativity(&sh::irradiance_coeffs(&w.apply(&c.coeffs)), &dirs);
                println!(
                    "window {w:?}: negative on {:.1}% of the sphere",
                    100.0 * n.fraction
                );
            }
            let irr = sh::irradiance_coeffs(&w.apply(&c.coeffs));
            let evaluator = evaluator.context("the SH evaluator is built for --method sh")?;
            let Timed {
                value: out,
                timings: t,
            } = evaluator.run(&irr, target)?;
            timings.extend(t);
            Timed::new(out, timings)
        }
    };
    clock.lap(RUN);
    write_map(&ctx, &out, &a.out.output, a.out.png)?;
    clock.lap(DOWNLOAD_WRITE);
    print_timings(&timings);
    clock.print();
    Ok(())
}

/// `envlight prefilter`.
pub fn prefilter(g: &Global, a: &PrefilterArgs) -> Result<()> {
    crate::io::check_map_path(&a.out.output)?;
    let mut clock = HostClock::start();
    let (map, ctx) = load_with_context(g, &a.input)?;
    clock.lap(LOAD);
    let gm = GpuEnvMap::upload(&ctx, &map)?;
    clock.lap("upload");
    let pb = spinner("brute-force Phong prefiltering on the GPU");
    let mut filter = BruteFilter::new(&ctx)?;
    filter.set_visit_floor(a.visit_floor);
    let o = a.orient.orientation();
    let Some(count) = a.phong_levels else {
        let n = a.phong.context("--phong or --phong-levels is required")?;
        let Timed {
            value: out,
            timings,
        } = filter.run(&gm, &o, Kernel::Phong { n }, a.out.target())?;
        clock.lap(RUN);
        pb.finish_and_clear();
        write_map(&ctx, &out, &a.out.output, a.out.png)?;
        clock.lap(DOWNLOAD_WRITE);
        print_timings(&timings);
        clock.print();
        return Ok(());
    };
    let levels = PhongLevels {
        count,
        scale: a.gloss_scale,
        bias: a.gloss_bias,
    };
    let Timed {
        value: (maps, sources),
        timings,
    } = filter.run_levels(&gm, &o, &levels, a.out.target())?;
    clock.lap(RUN);
    pb.finish_and_clear();
    let stem = a.out.output.with_extension("");
    let ext = a
        .out
        .output
        .extension()
        .unwrap_or_default()
        .to_string_lossy();
    let mut listing = Vec::new();
    for (k, (map, source)) in maps.iter().zip(&sources).enumerate() {
        let path = PathBuf::from(format!("{}.level{k}.{ext}", stem.display()));
        write_map(&ctx, map, &path, a.out.png)?;
        listing.push(serde_json::json!({
            "level": k,
            "file": path.file_name().map(|f| f.to_string_lossy().into_owned()),
            "width": map.width,
            "height": map.height,
            "phong_exponent": levels.exponent(k as u32),
            "source_level": source,
        }));
    }
    let json = PathBuf::from(format!("{}.levels.json", stem.display()));
    let doc = serde_json::json!({
        "mapping": Mapping::from(a.out.to).name(),
        "rule": "n_k = 2^(gloss_scale * (1 - k/(levels-1)) + gloss_bias) + 1",
        "gloss_scale": levels.scale,
        "gloss_bias": levels.bias,
        "levels": listing,
    });
    std::fs::write(&json, serde_json::to_string_pretty(&doc)?)
        .with_context(|| json.display().to_string())?;
    println!("wrote {}", json.display());
    clock.lap(DOWNLOAD_WRITE);
    print_timings(&timings);
    clock.print();
    Ok(())
}
