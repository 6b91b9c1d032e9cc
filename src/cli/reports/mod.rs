//! The user's `report` and `bench` of envlight's own passes on their device: GPU time from
//! timestamp queries, medians of repeated runs, ratios against a floor measured in the same
//! run, and the error beside each time. The project's lab (benchmarks against the peers, the
//! accuracy table, the performance pages) is `tools/lab`.

pub mod cubes;
mod dynamic;
mod floors;
pub mod report;

use super::{context, Global};
use crate::gpu::total_ms;
use crate::gpu::Timed;
use crate::math::filter::Kernel;
use crate::math::sh;
use crate::math::synth::Sky;
use crate::passes::sh_project::Subgroups;
use crate::passes::testing::copy::CopyPass;
use crate::passes::{
    BruteFilter, ConvertOptions, Converter, FilterTarget, ShEvaluator, ShProjector,
};
use crate::{EnvMap, GpuEnvMap, Mapping, Orientation};
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
        /// FIS samples per chain texel (128: every level's mean error within 1% of the exact
        /// prefilter on the sun sky; 64 leaves α = 1 at 1.5%)
        #[arg(long, default_value_t = 128)]
        samples: u32,
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
    match what {
        Bench::Convert { sizes, reps } => bench_convert(g, sizes, *reps),
        Bench::Irradiance {
            sizes,
            source,
            reps,
        } => bench_irradiance(g, sizes, *source, *reps),
        Bench::Sh { sizes, reps } => bench_sh(g, sizes, *reps),
        Bench::Dynamic {
            cubes,
            widths,
            chain,
            samples,
            slices,
            reps,
        } => {
            let settings = dynamic::FrameSettings {
                chain: 0,
                levels: 7,
                samples: *samples,
                slices: *slices,
                paraboloid: 0,
                irradiance: 32,
                ratio: crate::abi::lights::DIFFUSE_RATIO,
                max_lights: crate::abi::lights::CHAIN_MAX_TEXELS,
            };
            dynamic::bench_dynamic(&context(g)?, cubes, widths, chain, &settings, *reps)
        }
        Bench::Floors { sizes, reps } => floors::bench_floors(&context(g)?, sizes, *reps),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bench_convert(cli: &Global, sizes: &[u32], reps: usize) -> Result<()> {
    let ctx = context(cli)?;
    println!("device: {} ({})", ctx.info().name, ctx.info().driver.trim());
    println!(
        "GPU time from timestamps, median of {reps} runs. 'copy' reads and writes every source texel \
         once: the floor. Source: the analytic sky (sun ~1e5 x zenith) as a lat-long.\n"
    );
    println!("| source | conversion | output | ss (or areas) | copy ms | convert ms | ratio to copy | power error |");
    println!("|---|---|---|---|---|---|---|---|");
    let conv = Converter::new(&ctx)?;
    let copy = CopyPass::new(&ctx)?;
    let reps = reps.max(1);
    for &w in sizes {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 2, |d| {
            Sky::default().radiance(d)
        });
        let pin = map.power()[1];
        let src = GpuEnvMap::upload(&ctx, &map)?;
        // One untimed run of each pass first: pipeline and driver warm-up.
        copy.run(&src)?;
        let mut copy_ms = Vec::new();
        for _ in 0..reps {
            copy_ms.push(copy.run(&src)?.ms());
        }
        let floor = median(copy_ms);
        let cases = [
            (Mapping::LatLong, w, None),
            (Mapping::Cube, w / 4, Some(1)),
            (Mapping::Cube, w / 4, Some(2)),
            (Mapping::Cube, w / 4, None),
            (Mapping::Angular, w / 2, None),
            (Mapping::DualParaboloid, w / 2, None),
        ];
        for (to, size, supersample) in cases {
            let opts = ConvertOptions::new(to, size).with_supersample(supersample);
            let (ow, oh) = to.extent_for_size(size);
            // Exact footprint areas take no samples.
            let ss = if conv.uses_area((Mapping::LatLong, w, w / 2), &opts) {
                "areas".to_string()
            } else {
                supersample
                    .unwrap_or_else(|| {
                        Converter::supersampling((Mapping::LatLong, w, w / 2), (to, ow, oh))
                    })
                    .to_string()
            };
            conv.run(&src, &opts)?;
            let mut ms = Vec::new();
            let mut power = 0.0;
            for r in 0..reps {
                let Timed {
                    value: out,
                    timings: t,
                } = conv.run(&src, &opts)?;
                ms.push(total_ms(&t));
                if r == 0 {
                    power = out.download(&ctx)?.power()[1] / pin - 1.0;
                }
            }
            let m = median(ms);
            println!(
                "| latlong {w}x{} | -> {}{} | {ow}x{oh}x{} | {ss} | {floor:.3} | {m:.3} | {:.1} | {:+.3}% |",
                w / 2,
                to.name(),
                if supersample.is_some() { " (forced ss)" } else { "" },
                to.layers(),
                m / floor,
                power * 100.0
            );
        }
    }
    Ok(())
}

fn bench_irradiance(cli: &Global, sizes: &[u32], source: u32, reps: usize) -> Result<()> {
    let ctx = context(cli)?;
    println!("device: {} ({})", ctx.info().name, ctx.info().driver.trim());
    let w = source.max(4);
    let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 2, |d| {
        Sky::default().radiance(d)
    });
    println!("source: the analytic sky, lat-long {w}x{}; GPU time from timestamps, median of {reps} runs after one untimed run.\n", w / 2);
    println!("| output | brute ms | SH order | project ms | eval ms | brute / (project + eval) | brute / eval |");
    println!("|---|---|---|---|---|---|---|");
    let src = GpuEnvMap::upload(&ctx, &map)?;
    let brute = BruteFilter::new(&ctx)?;
    let proj = ShProjector::new(&ctx, Subgroups::Auto)?;
    let eval = ShEvaluator::new(&ctx)?;
    let reps = reps.max(1);
    let o = Orientation::default();
    for &n in sizes {
        let target = FilterTarget {
            to: Mapping::Angular,
            size: n,
        };
        brute.run(&src, &o, Kernel::Cosine, target)?;
        let mut b = Vec::new();
        for _ in 0..reps {
            b.push(total_ms(
                &brute.run(&src, &o, Kernel::Cosine, target)?.timings,
            ));
        }
        let b = median(b);
        for order in [2u32, 8] {
            let Timed { value: c, .. } = proj.run(&src, order)?;
            let irr = sh::irradiance_coeffs(&c.coeffs);
            eval.run(&irr, target)?;
            let (mut p, mut e) = (Vec::new(), Vec::new());
            for _ in 0..reps {
                p.push(total_ms(&proj.run(&src, order)?.timings));
                e.push(total_ms(&eval.run(&irr, target)?.timings));
            }
            let (p, e) = (median(p), median(e));
            println!(
                "| angular {n}x{n} | {b:.1} | {order} | {p:.3} | {e:.3} | {:.0}x | {:.0}x |",
                b / (p + e),
                b / e
            );
        }
    }
    Ok(())
}

fn bench_sh(cli: &Global, sizes: &[u32], reps: usize) -> Result<()> {
    let ctx = context(cli)?;
    println!("device: {} ({})", ctx.info().name, ctx.info().driver.trim());
    println!("GPU time from timestamps, median of {reps} runs after one untimed run; 'copy' reads and writes every texel once.\n");
    println!("| map | reduction | lmax | copy ms | project + reduce ms | ratio to copy |");
    println!("|---|---|---|---|---|---|");
    let copy = CopyPass::new(&ctx)?;
    let reps = reps.max(1);
    let projectors = [
        ("subgroups", ShProjector::new(&ctx, Subgroups::Auto)?),
        ("shared tree", ShProjector::new(&ctx, Subgroups::Off)?),
    ];
    for &w in sizes {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 1, |d| {
            Sky::default().radiance(d)
        });
        let src = GpuEnvMap::upload(&ctx, &map)?;
        copy.run(&src)?;
        let mut c = Vec::new();
        for _ in 0..reps {
            c.push(copy.run(&src)?.ms());
        }
        let floor = median(c);
        for (name, p) in &projectors {
            if *name == "subgroups" && !p.uses_subgroups() {
                continue;
            }
            for lmax in [2, 8] {
                p.run(&src, lmax)?;
                let mut ms = Vec::new();
                for _ in 0..reps {
                    ms.push(p.run(&src, lmax)?.ms());
                }
                let m = median(ms);
                println!(
                    "| latlong {w}x{} | {name} | {lmax} | {floor:.3} | {m:.3} | {:.1} |",
                    w / 2,
                    m / floor
                );
            }
        }
    }
    Ok(())
}
