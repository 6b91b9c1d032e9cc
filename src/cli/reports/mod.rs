//! Benchmarks and reports, in one place: GPU time from timestamp queries, medians of
//! repeated runs, ratios against a floor measured in the same run, and the error beside
//! each time.

pub mod accuracy;
pub mod cubes;
mod dynamic;
pub mod fis;
pub mod fis_report;
mod floors;
pub mod formats;
pub mod ibl;
pub mod page;
pub mod peers;
mod recipes;
pub mod report;
pub mod scale;
mod scoring;
pub mod table;

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
use anyhow::{Context as _, Result};
use clap::Subcommand;
use std::path::{Path, PathBuf};

/// What accuracy costs: SH irradiance of orders 0–8 against brute force, with GPU times
#[derive(Subcommand)]
pub enum AccuracyWhat {
    /// SH irradiance against brute force on maps or folders of maps
    Sh {
        /// Maps, or folders whose .hdr/.exr/.dds/.pfm files are all taken
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output folder for accuracy.md, accuracy.csv and accuracy.png
        #[arg(long, default_value = "out/accuracy")]
        out: PathBuf,
        /// Cube face size of the set of normals compared
        #[arg(long, default_value_t = 8)]
        size: u32,
    },
}

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
        /// Write the result as the "floors" section of this performance page
        /// (docs/performance/<device>.md)
        #[arg(long)]
        out: Option<PathBuf>,
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
        /// Write the result as the "dynamic" section of this performance page
        /// (docs/performance/<device>.md)
        #[arg(long)]
        out: Option<PathBuf>,
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
    /// What accuracy costs in time: FIS and plain BRDF-sampled MC against a converged MIS
    /// reference, on a studio and a sun map (CSV, markdown and a PNG plot)
    Fis {
        /// Environment maps (default: the bundled sky)
        #[arg(long, value_delimiter = ',')]
        maps: Vec<PathBuf>,
        /// Image sides
        #[arg(long, value_delimiter = ',', default_value = "512,1024")]
        sizes: Vec<u32>,
        /// FIS sample counts
        #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
        fis: Vec<u32>,
        /// Plain MC sample counts
        #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256,1024,4096")]
        mc: Vec<u32>,
        /// Samples per pixel of the MIS reference
        #[arg(long, default_value_t = 16384)]
        reference: u32,
        /// Lod biases swept at FIS 16 and 64
        #[arg(long, value_delimiter = ',', default_value = "-1,0,0.5,1,1.5,2,3", value_parser = crate::cli::finite_f64)]
        biases: Vec<f64>,
        /// Output folder
        #[arg(long, default_value = "docs/fis")]
        out: PathBuf,
    },
    /// Whole-process times of the jobs users give cmft, paired with cmft on the same machine,
    /// each with its error (markdown; --out writes its section of a performance page)
    Peers {
        /// The map every job reads (.hdr, which cmft reads too)
        #[arg(long)]
        map: PathBuf,
        /// cmft's executable (default: $ENVLIGHT_CMFT); without it cmft's columns stay empty
        #[arg(long)]
        cmft: Option<PathBuf>,
        /// Timed pairs per fast job (the median is reported)
        #[arg(long, default_value_t = 5)]
        reps: usize,
        /// Timed pairs for the Phong job
        #[arg(long, default_value_t = 1)]
        phong_reps: usize,
        /// The performance page (docs/performance/DEVICE.md) to write this job's section into
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// GGX cubes of `envlight bake --preset khronos` beside glTF-IBL-Sampler's on the same
    /// probes: whole-process seconds and each level's error against the exact prefilter, at
    /// several sample counts for each (markdown)
    Ibl {
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
    },
    /// What a bake costs against the source's resolution: a lat-long probe upsampled ×k (the
    /// same picture), baked in its own process: seconds, peak RSS, stages and errors
    /// (markdown)
    Scale {
        /// A lat-long probe
        input: PathBuf,
        /// Upsampling factors
        #[arg(long, value_delimiter = ',', default_value = "1,4,8,16")]
        factors: Vec<u32>,
        /// The performance page (docs/performance/DEVICE.md) to write this job's section into
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// What each KTX2 texel format and Zstandard cost and keep: per probe the bytes of its
    /// cubes and each specular level's error against rgba32f (markdown)
    Formats {
        /// Probes, or folders whose .hdr/.exr/.dds/.pfm files are all taken
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Specular cube face size at level 0
        #[arg(long, default_value_t = 256)]
        specular_size: u32,
        /// Specular levels
        #[arg(long, default_value_t = 8)]
        specular_levels: u32,
        /// Irradiance cube face size
        #[arg(long, default_value_t = 32)]
        irradiance_size: u32,
        /// The performance page (docs/performance/DEVICE.md) to write this job's section into
        #[arg(long)]
        out: Option<PathBuf>,
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

/// `envlight accuracy`.
pub fn accuracy(g: &Global, what: &AccuracyWhat) -> Result<()> {
    match what {
        AccuracyWhat::Sh { inputs, out, size } => accuracy::accuracy_sh(g, inputs, out, *size),
    }
}

/// The commit a page is made at: $ENVLIGHT_COMMIT, else `git rev-parse --short HEAD` in the
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
        Bench::Fis {
            maps,
            sizes,
            fis,
            mc,
            reference,
            biases,
            out,
        } => bench_fis(g, maps, sizes, fis, mc, *reference, biases, out),
        Bench::Convert { sizes, reps } => bench_convert(g, sizes, *reps),
        Bench::Ibl {
            inputs,
            sampler,
            size,
            runs,
            ours,
            theirs,
            texels,
            out,
        } => ibl::bench_ibl(
            g,
            &ibl::IblOptions {
                inputs: inputs.clone(),
                sampler: sampler
                    .clone()
                    .or_else(|| std::env::var_os("ENVLIGHT_IBLSAMPLER").map(PathBuf::from)),
                size: *size,
                runs: (*runs).max(1),
                ours: ours.clone(),
                theirs: theirs.clone(),
                texels: (*texels).max(1),
                out: out.clone(),
            },
        ),
        Bench::Scale {
            input,
            factors,
            out,
        } => scale::bench_scale(g, input, factors, out.as_ref()),
        Bench::Formats {
            inputs,
            specular_size,
            specular_levels,
            irradiance_size,
            out,
        } => {
            let opts = crate::bake::BakeOptions {
                specular_size: *specular_size,
                specular_levels: *specular_levels,
                irradiance_size: *irradiance_size,
                ..Default::default()
            };
            opts.validate()?;
            formats::bench_formats(g, inputs, &opts, out.as_deref())
        }
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
            out,
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
            dynamic::bench_dynamic(
                &context(g)?,
                cubes,
                widths,
                chain,
                &settings,
                *reps,
                out.as_deref(),
            )
        }
        Bench::Floors { sizes, reps, out } => {
            floors::bench_floors(&context(g)?, sizes, *reps, out.as_deref())
        }
        Bench::Peers {
            map,
            cmft,
            reps,
            phong_reps,
            out,
        } => {
            let cmft = cmft
                .clone()
                .or_else(|| std::env::var_os("ENVLIGHT_CMFT").map(PathBuf::from));
            if cmft.is_none() {
                eprintln!("ENVLIGHT_CMFT is not set: timing envlight alone, cmft skipped");
            }
            peers::bench_peers(&peers::PeersOptions {
                map,
                cmft: cmft.as_deref(),
                reps: *reps,
                phong_reps: *phong_reps,
                // The parent's context only names the device; it is gone before any timing.
                page: match out {
                    Some(p) => Some((p.as_path(), page::Provenance::of(context(g)?.info()))),
                    None => None,
                },
            })
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn bench_fis(
    cli: &Global,
    maps: &[PathBuf],
    sizes: &[u32],
    fis: &[u32],
    mc: &[u32],
    reference: u32,
    biases: &[f64],
    out: &Path,
) -> Result<()> {
    let ctx = context(cli)?;
    let default = [PathBuf::from("assets/sky_latlong.exr")];
    let paths = if maps.is_empty() { &default[..] } else { maps };
    let mut loaded = Vec::new();
    for p in paths {
        let m = crate::io::load(p, &Default::default())?;
        let name = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        loaded.push((name, m));
    }
    let cfg = fis::FisBench {
        sizes: sizes.to_vec(),
        fis: fis.to_vec(),
        mc: mc.to_vec(),
        reference,
        biases: biases.to_vec(),
        bias_at: vec![16, 64],
        bias: crate::scene::DEFAULT_FIS_BIAS,
    };
    let bar = indicatif::ProgressBar::new_spinner();
    let rows = fis::run(&ctx, &loaded, &cfg, |m| bar.set_message(m.to_string()))?;
    bar.finish_and_clear();
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver);
    std::fs::write(out.join("fis_vs_mc.csv"), fis_report::csv(&rows))?;
    let md = fis_report::markdown(&rows, &device);
    std::fs::write(out.join("fis_vs_mc.md"), &md)?;
    let png = out.join("fis_vs_mc.png");
    fis_report::plot(&rows)
        .save(&png)
        .with_context(|| png.display().to_string())?;
    println!("{md}");
    Ok(())
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
