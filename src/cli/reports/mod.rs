//! The user's `report` and `bench` of envlight's own passes on their device (the library's
//! `envlight::bench`, printed). The project's lab (benchmarks against the peers, the
//! accuracy table, the performance pages) is `tools/lab`.

pub mod report;

use super::{context, Global};
use crate::bench;
use anyhow::Result;
use clap::Subcommand;

/// Benchmarks (GPU time from timestamp queries)
#[derive(Subcommand)]
pub enum Bench {
    /// SH projection time at several widths, against a plain copy of the same map
    Sh {
        /// Lat-long widths
        #[arg(long, value_delimiter = ',', default_value = "512,1024,2048,4096")]
        sizes: Vec<u32>,
        /// Timed repetitions per case (the median is reported)
        #[arg(long, default_value_t = 5)]
        reps: usize,
    },
    /// Every pass (upload, conversions, MIP chain, SH by order, filters, lights, shading per
    /// technique) against its floor, a copy of its input, with its error
    Floors {
        /// Lat-long widths of the source
        #[arg(long, value_delimiter = ',', default_value = "512,1024,2048")]
        sizes: Vec<u32>,
        /// Timed repetitions per case (the median is reported)
        #[arg(long, default_value_t = 3)]
        reps: usize,
    },
    /// What refiltering an environment that changes every frame costs: SH 2 + irradiance,
    /// light extraction and the GGX chain recorded into one submission a frame, per-stage GPU
    /// time, error and the frame's floor
    Dynamic {
        /// Cube inputs (face sides)
        #[arg(long, value_delimiter = ',', default_value = "64,128,256")]
        cubes: Vec<u32>,
        /// Lat-long inputs (widths)
        #[arg(long, value_delimiter = ',', default_value = "512,1024,2048")]
        widths: Vec<u32>,
        /// Sides of the GGX chain's cube, each measured on every input (the paraboloid it
        /// filters: twice this)
        #[arg(long, value_delimiter = ',', default_value = "128")]
        chain: Vec<u32>,
        /// FIS samples per chain texel (64, with the rough levels' boost: every level's mean
        /// error within 1% of the exact prefilter on the sun sky)
        #[arg(long, default_value_t = bench::FrameSettings::DEFAULT_SAMPLES)]
        samples: u32,
        /// The most times the samples the chain's roughest levels take, whose layers are 8²
        /// texels or fewer (1: the same samples at every level; without it, 64 samples leave
        /// α = 1 at 1.9%)
        #[arg(long, default_value_t = bench::FrameSettings::DEFAULT_ROUGH_BOOST)]
        rough_boost: u32,
        /// Read each FIS sample trilinearly, between the paraboloid's two MIP levels about its
        /// lod, instead of from the nearest one (slower on the narrow levels; both keep every
        /// level's mean error within 1%)
        #[arg(long)]
        trilinear: bool,
        /// Spread the chain's rough levels over this many frames (Unity-style time slicing:
        /// level 0 and one slice a frame; 1: every level every frame). Above 1 the result is
        /// the page's "dynamic-sliced" section
        #[arg(long, default_value_t = 1)]
        slices: u32,
        /// Timed rounds of three frames each (the median is reported)
        #[arg(long, default_value_t = 3)]
        reps: usize,
    },
    /// Brute-force irradiance against SH (projection + evaluation) at equal output sizes
    Irradiance {
        /// Output sizes N (angular maps of N×N texels)
        #[arg(long, value_delimiter = ',', default_value = "32,64,128")]
        sizes: Vec<u32>,
        /// Width of the lat-long source (the bundled sky, resampled)
        #[arg(long, default_value_t = 128)]
        source: u32,
        /// Timed repetitions per case (the median is reported)
        #[arg(long, default_value_t = 3)]
        reps: usize,
    },
    /// Conversion time at several source widths, against a plain copy of the same source
    Convert {
        /// Source lat-long widths
        #[arg(long, value_delimiter = ',', default_value = "512,1024,2048,4096")]
        sizes: Vec<u32>,
        /// Timed repetitions per case (the median is reported)
        #[arg(long, default_value_t = 5)]
        reps: usize,
    },
}

/// The commit a report is made at: $ENVLIGHT_COMMIT, else `git rev-parse --short HEAD` in the
/// working directory, else the package version.
pub fn commit() -> String {
    std::env::var("ENVLIGHT_COMMIT")
        .ok()
        .or_else(|| {
            let o = std::process::Command::new("git")
                .args(["rev-parse", "--short", "HEAD"])
                .output()
                .ok()?;
            o.status
                .success()
                .then(|| String::from_utf8_lossy(&o.stdout).trim().to_string())
        })
        .unwrap_or_else(|| format!("envlight {}", env!("CARGO_PKG_VERSION")))
}

/// `envlight bench`.
pub fn bench(g: &Global, what: &Bench) -> Result<()> {
    let ctx = context(g)?;
    let device = || println!("device: {} ({})", ctx.info().name, ctx.info().driver.trim());
    let progress = |m: &str| eprintln!("{m}");
    let report = match what {
        Bench::Convert { sizes, reps } => {
            device();
            bench::convert(&ctx, sizes, *reps)?
        }
        Bench::Irradiance {
            sizes,
            source,
            reps,
        } => {
            device();
            bench::irradiance(&ctx, sizes, *source, *reps)?
        }
        Bench::Sh { sizes, reps } => {
            device();
            bench::sh(&ctx, sizes, *reps)?
        }
        Bench::Dynamic {
            cubes,
            widths,
            chain,
            samples,
            rough_boost,
            trilinear,
            slices,
            reps,
        } => {
            let mut settings = bench::FrameSettings::new(*samples, *rough_boost, *slices);
            settings.nearest_mip = !*trilinear;
            bench::dynamic(&ctx, cubes, widths, chain, &settings, *reps, &progress)?
        }
        Bench::Floors { sizes, reps } => bench::floors(&ctx, sizes, *reps, &progress)?,
    };
    print!("{}", report.text());
    Ok(())
}
