//! The command line: one file per subcommand family, sharing the arguments and helpers here.
//! Only the `envlight` binary calls it (feature `cli`, [`main`]); the rest of the library
//! knows nothing of clap, indicatif or anyhow. Hidden from the documentation: not an API.

mod app;
pub mod bake;
pub mod info;
pub mod maps;
pub mod preview;
pub mod reports;
pub mod scene;
pub mod schedule;

pub use app::main;

use crate::gpu::{Context, ContextOptions, Timing};
use crate::io::{self, LoadOptions, Sanitize, ToneMap};
use crate::passes::FilterTarget;
use crate::{EnvMap, GpuEnvMap, Mapping, Orientation};
use anyhow::{Context as _, Result};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Options every subcommand takes.
#[derive(Args, Clone)]
pub struct Global {
    /// Vulkan device: auto, cpu (lavapipe), an index, part of a name, or its UUID (as `nvidia-smi
    /// -L` or `envlight devices` prints it) [env: ENVLIGHT_DEVICE]
    #[arg(long, global = true)]
    pub device: Option<String>,
    /// Enable the Vulkan validation layer
    #[arg(long, global = true)]
    pub validation: bool,
}

/// A mapping named on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MappingArg {
    /// Equirectangular.
    #[value(alias = "lat-long", alias = "equirect", alias = "equirectangular")]
    Latlong,
    /// Debevec's angular probe.
    #[value(alias = "probe", alias = "lightprobe")]
    Angular,
    /// Cube map (six faces).
    #[value(alias = "cubemap")]
    Cube,
    /// Dual paraboloid.
    #[value(alias = "dp", alias = "dualparaboloid", alias = "paraboloid")]
    DualParaboloid,
}

impl From<MappingArg> for Mapping {
    fn from(m: MappingArg) -> Mapping {
        match m {
            MappingArg::Latlong => Mapping::LatLong,
            MappingArg::Angular => Mapping::Angular,
            MappingArg::Cube => Mapping::Cube,
            MappingArg::DualParaboloid => Mapping::DualParaboloid,
        }
    }
}

/// An input map.
#[derive(Args, Clone)]
pub struct Input {
    /// Input file; a path containing {face} names six cube faces (px, nx, py, ny, pz, nz)
    pub input: String,
    /// Mapping of the input; inferred if absent
    #[arg(long, value_enum)]
    pub mapping: Option<MappingArg>,
    /// Replace NaN, infinite and negative texels by 0 instead of refusing the file
    #[arg(long)]
    pub sanitize: bool,
}

/// How the input file is oriented relative to the world frame.
#[derive(Args, Clone, Copy)]
pub struct Orient {
    /// Mirror the input left-right (reflects x)
    #[arg(long)]
    pub flip_u: bool,
    /// Turn the input upside down (reflects y)
    #[arg(long)]
    pub flip_v: bool,
    /// Turn the environment by this many degrees about +Y
    #[arg(
        long,
        value_name = "DEGREES",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        value_parser = finite_f64
    )]
    pub rotate_y: f64,
}

impl Orient {
    /// The library's orientation.
    pub fn orientation(&self) -> Orientation {
        Orientation {
            flip_u: self.flip_u,
            flip_v: self.flip_v,
            rotate_y_degrees: self.rotate_y,
        }
    }
}

/// Where a filtered map (irradiance, prefilter) goes.
#[derive(Args, Clone)]
pub struct FilterOut {
    /// Output mapping
    #[arg(long, value_enum, default_value = "cube")]
    pub to: MappingArg,
    /// Output size: lat-long width, angular side, cube face, paraboloid half
    #[arg(long, default_value_t = 32)]
    pub size: u32,
    /// Output map: .exr (float32 OpenEXR), .hdr (Radiance RGBE) or .pfm, as its extension says
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write a tone-mapped PNG preview beside the output
    #[arg(long)]
    pub png: bool,
}

impl FilterOut {
    /// The library's target.
    pub fn target(&self) -> FilterTarget {
        FilterTarget {
            to: self.to.into(),
            size: self.size,
        }
    }
}

/// A float option that must be a finite number (clap's own parser takes "nan" and "inf").
pub fn finite_f64(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("{v} is not a finite number")),
        Err(e) => Err(e.to_string()),
    }
}

/// As [`finite_f64`], for single-precision options.
pub fn finite_f32(s: &str) -> std::result::Result<f32, String> {
    let v = finite_f64(s)?;
    if v.abs() > f32::MAX as f64 {
        return Err(format!("{v} is out of range"));
    }
    Ok(v as f32)
}

/// The value parser of an option whose values are one of the library's enums, by their
/// `names` (clap lists them in the help and in a refusal); `parse` is the library's, which
/// the bake file's keys go through too.
pub fn named<T: Clone + Send + Sync + 'static>(
    names: &'static [&'static str],
    parse: fn(&str) -> Option<T>,
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(names)
        .map(move |s| parse(&s).unwrap_or_else(|| unreachable!("{s} is listed, so it parses")))
}

/// The device the options ask for.
pub fn context(g: &Global) -> Result<Context> {
    let opts = ContextOptions::from_flags(g.device.as_deref(), g.validation);
    Ok(VALIDATION.context(&opts)?)
}

/// This process's contexts' validation logs.
static VALIDATION: crate::gpu::ValidationRecord = crate::gpu::ValidationRecord::new();

/// Messages the validation layer reported on this process's contexts, teardown included:
/// `main` checks them after the command has dropped its contexts, and a non-empty list
/// fails the process (so tests that run the CLI with `--validation` see them).
pub fn validation_messages() -> Vec<String> {
    VALIDATION.messages()
}

/// A spinner on stderr while something runs.
pub fn spinner(msg: &str) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    pb.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    pb.set_message(msg.to_string());
    pb.enable_steady_tick(Duration::from_millis(120));
    pb
}

/// Loads the input map.
pub fn load_input(input: &Input) -> Result<EnvMap> {
    let opts = LoadOptions {
        mapping: input.mapping.map(Mapping::from),
        sanitize: if input.sanitize {
            Sanitize::Zero
        } else {
            Sanitize::Reject
        },
        ..Default::default()
    };
    let pb = spinner(&format!("loading {}", input.input));
    let map = match io::face_paths(&input.input) {
        Some(paths) => io::load_cube_faces(&paths, &opts),
        None => io::load(&input.input, &opts),
    };
    pb.finish_and_clear();
    Ok(map?)
}

/// Loads the input map on a second thread while this one creates the Vulkan device: each
/// takes tens of milliseconds (decoding a 1k .hdr; loading the driver), and neither needs the
/// other. A bad file is reported before a missing driver, as when they ran in turn.
pub fn load_with_context(g: &Global, input: &Input) -> Result<(EnvMap, Context)> {
    context_while(g, || load_input(input))
}

/// Runs `load` on a second thread while this one creates the Vulkan device (see
/// [`load_with_context`]); `load`'s error comes first.
pub fn context_while<T: Send>(
    g: &Global,
    load: impl FnOnce() -> Result<T> + Send,
) -> Result<(T, Context)> {
    std::thread::scope(|s| {
        let loading = s.spawn(load);
        let ctx = context(g);
        let loaded = loading
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        Ok((loaded, ctx?))
    })
}

/// Uploads `map` while a second thread runs `prepare` (building the pipelines that will read
/// it: on lavapipe each compiles its SPIR-V for tens of milliseconds, on every run).
pub fn upload_while<T: Send>(
    ctx: &Context,
    map: &EnvMap,
    prepare: impl FnOnce() -> crate::Result<T> + Send,
) -> Result<(GpuEnvMap, T)> {
    std::thread::scope(|s| {
        let building = s.spawn(prepare);
        let uploaded = GpuEnvMap::upload(ctx, map);
        let built = building
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        Ok((uploaded?, built))
    })
}

/// Writes a map ([`save`]), and a tone-mapped PNG beside it when asked.
pub fn write_map(ctx: &Context, map: &GpuEnvMap, output: &Path, png: bool) -> Result<()> {
    save(&map.download(ctx)?, output, png.then(ToneMap::default))
}

/// Writes `map` in the format `output`'s extension names (`io::save_map`: .exr, .hdr or
/// .pfm), and with `png` a PNG preview beside it.
pub fn save(map: &EnvMap, output: &Path, png: Option<ToneMap>) -> Result<()> {
    io::save_map(map, output)?;
    println!("wrote {}", output.display());
    if let Some(tm) = png {
        let p = output.with_extension("png");
        preview::preview(map, tm)
            .save(&p)
            .with_context(|| p.display().to_string())?;
        println!("wrote {} ({})", p.display(), tm.describe());
    }
    Ok(())
}

/// Host wall-clock spans of a command, printed as "host x ms label" lines beside its GPU
/// spans, so that where a whole process's time goes can be read off its output (`cargo xtask lab peers`
/// tabulates them).
pub struct HostClock {
    last: Instant,
    spans: Vec<(&'static str, f64)>,
}

impl HostClock {
    /// Starts the clock.
    pub fn start() -> HostClock {
        HostClock {
            last: Instant::now(),
            spans: Vec::new(),
        }
    }

    /// Ends the current span under `label` and starts the next.
    pub fn lap(&mut self, label: &'static str) {
        let now = Instant::now();
        self.spans
            .push((label, (now - self.last).as_secs_f64() * 1e3));
        self.last = now;
    }

    /// Prints the spans, one per line.
    pub fn print(&self) {
        for (label, ms) in &self.spans {
            println!("  host {ms:>8.3} ms  {label}");
        }
    }
}

/// Prints GPU timings, one per line.
pub fn print_timings(t: &[Timing]) {
    for t in t {
        println!("  GPU {:>9.3} ms  {}", t.ms, t.label);
    }
}

/// `e` and its causes, "error: cause: cause", each cause said once: a cause whose text ends
/// the message already (the library's errors name their OS error in their own text) is not
/// repeated.
pub fn error_text(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.ends_with(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cause the message already ends with is said once; other causes follow it.
    #[test]
    fn each_cause_is_said_once() {
        let os = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e: anyhow::Error = crate::Error::Io {
            path: "/x.exr".into(),
            source: os,
        }
        .into();
        assert_eq!(error_text(&e), "/x.exr: No such file");
        let e = e.context("loading the probe");
        assert_eq!(error_text(&e), "loading the probe: /x.exr: No such file");
    }
}
