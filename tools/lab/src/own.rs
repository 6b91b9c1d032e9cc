//! `envlight-lab floors` and `envlight-lab dynamic`: the library's benchmarks of envlight's
//! own passes (`envlight::bench`, which `envlight bench floors` and `envlight bench dynamic`
//! print), written as their sections of a device's performance page.

use crate::common::{context, Global};
use crate::page::{write_section, Provenance, Section};
use anyhow::Result;
use envlight::bench::Report;
use envlight::Context;
use std::path::PathBuf;

/// `envlight-lab floors`: every pass against its floor (as `envlight bench floors`), as the
/// "floors" section of a performance page
#[derive(clap::Args)]
pub struct FloorsArgs {
    /// Lat-long widths of the source
    #[arg(long, value_delimiter = ',', default_value = "512,1024,2048")]
    sizes: Vec<u32>,
    /// Timed repetitions per case (the median is reported)
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// The performance page (docs/performance/DEVICE.md) to write the section into
    #[arg(long)]
    out: PathBuf,
}

/// `envlight-lab dynamic`: an environment that changes every frame (as `envlight bench
/// dynamic`), as the "dynamic" (or, time-sliced, "dynamic-sliced") section of a page
#[derive(clap::Args)]
pub struct DynamicArgs {
    /// Cube inputs (face sides)
    #[arg(long, value_delimiter = ',', default_value = "64,128,256")]
    cubes: Vec<u32>,
    /// Lat-long inputs (widths)
    #[arg(long, value_delimiter = ',', default_value = "512,1024,2048")]
    widths: Vec<u32>,
    /// Sides of the GGX chain's cube
    #[arg(long, value_delimiter = ',', default_value = "128")]
    chain: Vec<u32>,
    /// FIS samples per chain texel
    #[arg(long, default_value_t = envlight::bench::FrameSettings::DEFAULT_SAMPLES)]
    samples: u32,
    /// The most times the samples the chain's roughest levels take (1: the same at every
    /// level)
    #[arg(long, default_value_t = envlight::bench::FrameSettings::DEFAULT_ROUGH_BOOST)]
    rough_boost: u32,
    /// Read each FIS sample trilinearly instead of from the nearest MIP level
    #[arg(long)]
    trilinear: bool,
    /// Spread the chain's rough levels over this many frames
    #[arg(long, default_value_t = 1)]
    slices: u32,
    /// Timed rounds of three frames each (the median is reported)
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// The performance page (docs/performance/DEVICE.md) to write the section into
    #[arg(long)]
    out: PathBuf,
}

/// Writes `report`, measured on `ctx`'s device, as its section of the page `out`, after
/// printing it.
fn write(ctx: &Context, report: &Report, out: &std::path::Path) -> Result<()> {
    print!("{}", report.text());
    let section = Section {
        job: report.job,
        title: report.title,
        method: &report.method,
        body: &report.body,
    };
    write_section(out, &section, &Provenance::of(ctx.info()))
}

/// Runs `envlight-lab floors`.
pub fn floors(g: &Global, a: &FloorsArgs) -> Result<()> {
    let ctx = context(g)?;
    let report = envlight::bench::floors(&ctx, &a.sizes, a.reps, &|m| eprintln!("{m}"))?;
    write(&ctx, &report, &a.out)
}

/// Runs `envlight-lab dynamic`.
pub fn dynamic(g: &Global, a: &DynamicArgs) -> Result<()> {
    let ctx = context(g)?;
    let mut settings = envlight::bench::FrameSettings::new(a.samples, a.rough_boost, a.slices);
    settings.nearest_mip = !a.trilinear;
    let report = envlight::bench::dynamic(
        &ctx,
        &a.cubes,
        &a.widths,
        &a.chain,
        &settings,
        a.reps,
        &|m| eprintln!("{m}"),
    )?;
    write(&ctx, &report, &a.out)
}
