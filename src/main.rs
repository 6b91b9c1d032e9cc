//! The `envlight` command line.

use anyhow::{bail, Context as _, Result};
use clap::{Args, Parser, Subcommand};
use envlight::accuracy::{self, Accuracy};
use envlight::gpu::{Context, ContextOptions, DeviceSelector, GpuEnvMap, Timing};
use envlight::io::{self, LoadOptions, Sanitize, ToneMap};
use envlight::math::filter::Kernel;
use envlight::math::sh::{self, Window};
use envlight::math::synth::Sky;
use envlight::passes::copy::CopyPass;
use envlight::passes::filter::{BruteFilter, FilterTarget, ShEvaluator};
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::passes::{ConvertOptions, Converter};
use envlight::{EnvMap, Mapping, Orientation};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Parser)]
#[command(
    name = "envlight",
    version,
    about = "Environment-map lighting on explicit Vulkan passes"
)]
struct Cli {
    /// Vulkan device: auto, cpu (lavapipe), an index, or part of a name [env: ENVLIGHT_DEVICE]
    #[arg(long, global = true)]
    device: Option<String>,
    /// Enable the Vulkan validation layer
    #[arg(long, global = true)]
    validation: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Args, Clone)]
struct Input {
    /// Input file; a path containing {face} names six cube faces (px, nx, py, ny, pz, nz)
    input: String,
    /// Mapping of the input (latlong, angular, cube, dual-paraboloid); inferred if absent
    #[arg(long)]
    mapping: Option<String>,
    /// Replace NaN, infinite and negative texels by 0 instead of refusing the file
    #[arg(long)]
    sanitize: bool,
}

#[derive(Args, Clone, Copy)]
struct Orient {
    /// Mirror the input left-right (reflects x)
    #[arg(long)]
    flip_u: bool,
    /// Turn the input upside down (reflects y)
    #[arg(long)]
    flip_v: bool,
    /// Turn the environment by this many degrees about +Y
    #[arg(
        long,
        value_name = "DEGREES",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    rotate_y: f64,
}

/// Where a filtered map (irradiance, prefilter) goes.
#[derive(Args, Clone)]
struct FilterOut {
    /// Output mapping
    #[arg(long, default_value = "cube")]
    to: String,
    /// Output size: lat-long width, angular side, cube face, paraboloid half
    #[arg(long, default_value_t = 32)]
    size: u32,
    /// Output EXR (float32)
    #[arg(short, long)]
    output: PathBuf,
    /// Also write a tone-mapped PNG preview beside the EXR
    #[arg(long)]
    png: bool,
}

impl FilterOut {
    fn target(&self) -> Result<FilterTarget> {
        Ok(FilterTarget {
            to: parse_mapping(&self.to)?,
            size: self.size,
        })
    }
}

#[derive(Subcommand)]
enum Command {
    /// Print a map's mapping, size, radiance statistics and total power
    Info {
        #[command(flatten)]
        input: Input,
    },
    /// Convert a map to another mapping and resolution on the GPU
    Convert {
        #[command(flatten)]
        input: Input,
        #[command(flatten)]
        orient: Orient,
        /// Output EXR (float32; a cube is six faces stacked vertically, a dual paraboloid its
        /// upper half above its lower half)
        #[arg(short, long)]
        output: PathBuf,
        /// Output mapping
        #[arg(long)]
        to: String,
        /// Output size: lat-long width, angular side, cube face, paraboloid half
        #[arg(long)]
        size: u32,
        /// Samples per axis per output texel (default: chosen from the resolutions)
        #[arg(long)]
        supersample: Option<u32>,
        /// Also write a tone-mapped PNG preview beside the EXR
        #[arg(long)]
        png: bool,
        /// Exposure of the PNG preview, in stops
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
    },
    /// Project a map onto spherical harmonics on the GPU and write them as JSON
    Sh {
        #[command(flatten)]
        input: Input,
        #[command(flatten)]
        orient: Orient,
        /// Highest band l (0 to 8)
        #[arg(long, default_value_t = 2)]
        order: u32,
        /// Output JSON: {"order", "coefficients": [[r,g,b], ...], "irradiance_matrices"}
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Irradiance map E(n) of a map, from SH (R&H 2001) or by brute-force convolution
    Irradiance {
        #[command(flatten)]
        input: Input,
        #[command(flatten)]
        orient: Orient,
        /// sh (projection + evaluation) or brute (every source texel)
        #[arg(long, default_value = "sh")]
        method: String,
        /// Highest SH band (sh only; 0 to 8)
        #[arg(long, default_value_t = 2)]
        order: u32,
        /// Window against ringing (sh only): none, hanning, sloan (with --lambda), or auto (the
        /// smallest Sloan window that makes E non-negative)
        #[arg(long, default_value = "none")]
        window: String,
        /// Strength of the Sloan window, or width of the Hanning window (default 2·(order+1))
        #[arg(long)]
        lambda: Option<f64>,
        #[command(flatten)]
        out: FilterOut,
    },
    /// Prefilter a map with a normalised Phong lobe (Miller & Hoffman 1984), brute force,
    /// indexed by the reflection direction
    Prefilter {
        #[command(flatten)]
        input: Input,
        #[command(flatten)]
        orient: Orient,
        /// Phong exponent n (1 to 1e6)
        #[arg(long)]
        phong: f64,
        #[command(flatten)]
        out: FilterOut,
    },
    /// What accuracy costs: SH irradiance of orders 0–8 against brute force, with GPU times
    Accuracy {
        #[command(subcommand)]
        what: AccuracyWhat,
    },
    /// Convert the bundled probe to all four mappings and show what each step cost
    Demo {
        /// Input probe
        #[arg(long, default_value = "assets/sky_latlong.exr")]
        input: PathBuf,
        /// Output folder
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        /// Size of the outputs (lat-long width; the others get half of it)
        #[arg(long, default_value_t = 512)]
        size: u32,
    },
    /// Render a scene file: an HDR EXR, a tone-mapped PNG beside it, and a per-pass timing table
    Render {
        /// The scene (TOML)
        scene: PathBuf,
        /// Output EXR (the PNG gets the same name with .png)
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Print the GPU passes a render of a scene will run, and why
    Plan {
        /// The scene (TOML)
        scene: PathBuf,
    },
    /// List the Vulkan devices and the one envlight would pick
    Devices,
    /// Write the analytic sky (gradient, sun 5·10⁴ × the zenith, ground) as a lat-long EXR
    SynthSky {
        /// Output EXR
        #[arg(short, long)]
        output: PathBuf,
        /// Width (height is half)
        #[arg(long, default_value_t = 256)]
        width: u32,
    },
    /// Benchmarks (GPU time from timestamp queries)
    Bench {
        #[command(subcommand)]
        what: Bench,
    },
}

#[derive(Subcommand)]
enum AccuracyWhat {
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

#[derive(Subcommand)]
enum Bench {
    /// SH projection time at several widths, against a plain copy of the same map
    Sh {
        /// Lat-long widths
        #[arg(long, value_delimiter = ',', default_value = "512,1024,2048,4096")]
        sizes: Vec<u32>,
        /// Timed repetitions per case (the median is reported)
        #[arg(long, default_value_t = 5)]
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
        #[arg(long, value_delimiter = ',', default_value = "-1,0,0.5,1,1.5,2,3")]
        biases: Vec<f64>,
        /// Output folder
        #[arg(long, default_value = "docs/fis")]
        out: PathBuf,
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

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn context(cli: &Cli) -> Result<Context> {
    let mut opts = ContextOptions::default();
    if let Some(d) = &cli.device {
        opts.device = DeviceSelector::parse(d);
    }
    opts.validation |= cli.validation;
    Ok(Context::new(&opts)?)
}

fn spinner(msg: &str) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    pb.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    pb.set_message(msg.to_string());
    pb.enable_steady_tick(Duration::from_millis(120));
    pb
}

fn parse_mapping(s: &str) -> Result<Mapping> {
    Mapping::parse(s)
        .with_context(|| format!("unknown mapping '{s}' (latlong, angular, cube, dual-paraboloid)"))
}

fn load_input(input: &Input) -> Result<EnvMap> {
    let opts = LoadOptions {
        mapping: input.mapping.as_deref().map(parse_mapping).transpose()?,
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

fn orientation(o: &Orient) -> Orientation {
    Orientation {
        flip_u: o.flip_u,
        flip_v: o.flip_v,
        rotate_y_degrees: o.rotate_y,
    }
}

fn write_map(ctx: &Context, map: &GpuEnvMap, output: &Path, png: bool) -> Result<()> {
    let out = map.download(ctx)?;
    io::save_exr(&out, output)?;
    println!("wrote {}", output.display());
    if png {
        let p = output.with_extension("png");
        let tm = ToneMap::default();
        envlight::preview::preview(&out, tm)
            .save(&p)
            .with_context(|| p.display().to_string())?;
        println!("wrote {} ({})", p.display(), tm.describe());
    }
    Ok(())
}

fn accuracy_sh(cli: &Cli, inputs: &[PathBuf], out: &Path, size: u32) -> Result<()> {
    let mut files = Vec::new();
    for i in inputs {
        if i.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(i)
                .with_context(|| i.display().to_string())?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.is_file()
                        && matches!(
                            p.extension().and_then(|e| e.to_str()),
                            Some("hdr" | "exr" | "dds" | "pfm")
                        )
                })
                .collect();
            v.sort();
            files.extend(v);
        } else {
            files.push(i.clone());
        }
    }
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let ctx = context(cli)?;
    let acc = Accuracy::new(&ctx)?;
    let pb = ProgressBar::new(files.len() as u64);
    let mut reports = Vec::new();
    for f in &files {
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        pb.set_message(name.clone());
        let map = io::load(f, &LoadOptions::default())?;
        reports.push(acc.run(&name, &map, size)?);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let device = format!("{}, {}", ctx.info().name, ctx.info().driver.trim());
    let mut md = accuracy::markdown(&reports, &device);
    md.push_str("\nPlot `accuracy.png`: unwindowed RMS error (log scale, 1e-4 to 10, a gridline per decade) against order 0–8; black squares are the seed's 25%, 8%, 1%. Curves:\n\n");
    for (i, r) in reports.iter().enumerate() {
        let [cr, cg, cb] = accuracy::plot_colour(i);
        md.push_str(&format!("- rgb({cr}, {cg}, {cb}): {}\n", r.name));
    }
    print!("{md}");
    for (name, text) in [
        ("accuracy.md", md),
        ("accuracy.csv", accuracy::csv(&reports)),
    ] {
        let p = out.join(name);
        std::fs::write(&p, text).with_context(|| p.display().to_string())?;
    }
    let p = out.join("accuracy.png");
    accuracy::plot(&reports)
        .save(&p)
        .with_context(|| p.display().to_string())?;
    println!("wrote {}", out.display());
    Ok(())
}

fn print_timings(t: &[Timing]) {
    for t in t {
        println!("  GPU {:>9.3} ms  {}", t.ms, t.label);
    }
}

fn run(cli: Cli) -> Result<()> {
    match &cli.command {
        Command::Info { input } => {
            let map = load_input(input)?;
            let s = map.stats();
            println!("file:      {}", input.input);
            println!("mapping:   {}", map.mapping.name());
            println!(
                "size:      {} x {} x {} layer(s)",
                map.width,
                map.height,
                map.layers()
            );
            println!("channels:  RGB (linear float)");
            println!("min:       {:?}", s.min);
            println!(
                "max:       {:?}  (max luminance {:.6e})",
                s.max, s.max_luminance
            );
            println!(
                "mean:      [{:.6e}, {:.6e}, {:.6e}]  (solid-angle weighted)",
                s.mean[0], s.mean[1], s.mean[2]
            );
            println!("nan:       {}", s.nan);
            println!("inf:       {}", s.inf);
            println!("negative:  {}", s.negative);
            println!(
                "power:     [{:.6e}, {:.6e}, {:.6e}]  (sum of L * solid angle, W/m^2 per unit radiance)",
                s.power[0], s.power[1], s.power[2]
            );
        }
        Command::Convert {
            input,
            orient,
            output,
            to,
            size,
            supersample,
            png,
            exposure,
        } => {
            if *size == 0 || *size > 16384 {
                bail!("--size must be between 1 and 16384 (got {size})");
            }
            let to = parse_mapping(to)?;
            let map = load_input(input)?;
            let ctx = context(&cli)?;
            let pb = spinner("converting on the GPU");
            let src = GpuEnvMap::upload(&ctx, &map)?;
            let conv = Converter::new(&ctx)?;
            let opts = ConvertOptions {
                to,
                size: *size,
                orientation: Orientation {
                    flip_u: orient.flip_u,
                    flip_v: orient.flip_v,
                    rotate_y_degrees: orient.rotate_y,
                },
                supersample: *supersample,
            };
            let (dst, timings) = conv.run(&src, &opts)?;
            let out = dst.download(&ctx)?;
            pb.finish_and_clear();
            io::save_exr(&out, output)?;
            println!("wrote {}", output.display());
            if *png {
                let p = output.with_extension("png");
                let tm = ToneMap {
                    exposure: *exposure,
                };
                envlight::preview::preview(&out, tm)
                    .save(&p)
                    .with_context(|| p.display().to_string())?;
                println!("wrote {} ({})", p.display(), tm.describe());
            }
            print_timings(&timings);
        }
        Command::Sh {
            input,
            orient,
            order,
            output,
        } => {
            let map = load_input(input)?;
            let ctx = context(&cli)?;
            let pb = spinner("projecting onto SH on the GPU");
            let proj = ShProjector::new(&ctx, Subgroups::Auto)?;
            let g = GpuEnvMap::upload(&ctx, &map)?;
            let o = Orientation {
                flip_u: orient.flip_u,
                flip_v: orient.flip_v,
                rotate_y_degrees: orient.rotate_y,
            };
            let (coeffs, timings) = proj.run_oriented(&g, *order, &o)?;
            pb.finish_and_clear();
            let text = serde_json::to_string_pretty(&coeffs.to_json())?;
            std::fs::write(output, text).with_context(|| output.display().to_string())?;
            println!(
                "wrote {} ({} coefficients per channel)",
                output.display(),
                coeffs.coeffs.len()
            );
            print_timings(&timings);
        }
        Command::Irradiance {
            input,
            orient,
            method,
            order,
            window,
            lambda,
            out: dest,
        } => {
            let map = load_input(input)?;
            let ctx = context(&cli)?;
            let g = GpuEnvMap::upload(&ctx, &map)?;
            let target = dest.target()?;
            let o = orientation(orient);
            let (out, timings) = match method.as_str() {
                "brute" => {
                    let pb = spinner("brute-force irradiance on the GPU");
                    let r = BruteFilter::new(&ctx)?.run(&g, &o, Kernel::Cosine, target)?;
                    pb.finish_and_clear();
                    r
                }
                "sh" => {
                    let (c, mut timings) =
                        ShProjector::new(&ctx, Subgroups::Auto)?.run_oriented(&g, *order, &o)?;
                    let dirs = envlight::math::synth::fibonacci_sphere(20_000);
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
                    let w = match window.as_str() {
                        "none" => Window::None,
                        "hanning" => Window::Hanning {
                            width: lambda.unwrap_or(2.0 * (*order as f64 + 1.0)),
                        },
                        "sloan" => Window::Sloan {
                            lambda: lambda.context("--window sloan needs --lambda")?,
                        },
                        "auto" => Window::Sloan {
                            lambda: sh::smallest_nonnegative_window(&c.coeffs, &dirs),
                        },
                        other => bail!("unknown window {other:?} (none, hanning, sloan, auto)"),
                    };
                    if w != Window::None {
                        let n = sh::negativity(&sh::irradiance_coeffs(&w.apply(&c.coeffs)), &dirs);
                        println!(
                            "window {w:?}: negative on {:.1}% of the sphere",
                            100.0 * n.fraction
                        );
                    }
                    let irr = sh::irradiance_coeffs(&w.apply(&c.coeffs));
                    let (out, t) = ShEvaluator::new(&ctx)?.run(&irr, target)?;
                    timings.extend(t);
                    (out, timings)
                }
                other => bail!("unknown method {other:?} (sh or brute)"),
            };
            write_map(&ctx, &out, &dest.output, dest.png)?;
            print_timings(&timings);
        }
        Command::Prefilter {
            input,
            orient,
            phong,
            out: dest,
        } => {
            let map = load_input(input)?;
            let ctx = context(&cli)?;
            let g = GpuEnvMap::upload(&ctx, &map)?;
            let target = dest.target()?;
            let pb = spinner("brute-force Phong prefiltering on the GPU");
            let (out, timings) = BruteFilter::new(&ctx)?.run(
                &g,
                &orientation(orient),
                Kernel::Phong { n: *phong },
                target,
            )?;
            pb.finish_and_clear();
            write_map(&ctx, &out, &dest.output, dest.png)?;
            print_timings(&timings);
        }
        Command::Accuracy {
            what: AccuracyWhat::Sh { inputs, out, size },
        } => accuracy_sh(&cli, inputs, out, *size)?,
        Command::Demo { input, out, size } => demo(&cli, input, out, *size)?,
        Command::Render { scene, output } => render_scene(&cli, scene, output)?,
        Command::Plan { scene } => {
            let sc = envlight::scene::Scene::load(scene)?;
            let base = scene.parent().unwrap_or(Path::new("."));
            let path = base.join(&sc.environment.file);
            let mapping = match &sc.environment.mapping {
                Some(m) => Mapping::parse(m)
                    .with_context(|| format!("{}: unknown mapping '{m}'", scene.display()))?,
                None => envlight::render::load_environment(&sc, base)?.mapping,
            };
            let plan = envlight::scene::plan(&sc, mapping);
            println!(
                "{} ({}, {})",
                scene.display(),
                path.display(),
                mapping.name()
            );
            for (k, p) in plan.passes.iter().enumerate() {
                println!("{:>2}. {:<16} {}", k + 1, p.kind.name(), p.why);
            }
            for n in &plan.notes {
                println!("    note: {n}");
            }
        }
        Command::Devices => {
            let ctx = context(&cli)?;
            let i = ctx.info();
            println!(
                "envlight uses: {} ({:?}), driver {}",
                i.name, i.device_type, i.driver
            );
            println!(
                "timestamp period {} ns, {} valid bits",
                i.timestamp_period, i.timestamp_valid_bits
            );
        }
        Command::SynthSky { output, width } => {
            let w = (*width).max(2);
            let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 8, |d| {
                Sky::default().radiance(d)
            });
            io::save_exr(&map, output)?;
            let s = map.stats();
            println!(
                "wrote {} ({} x {}, max luminance {:.3e})",
                output.display(),
                w,
                w / 2,
                s.max_luminance
            );
        }
        Command::Bench {
            what:
                Bench::Fis {
                    maps,
                    sizes,
                    fis,
                    mc,
                    reference,
                    biases,
                    out,
                },
        } => bench_fis(&cli, maps, sizes, fis, mc, *reference, biases, out)?,
        Command::Bench {
            what: Bench::Convert { sizes, reps },
        } => bench_convert(&cli, sizes, *reps)?,
        Command::Bench {
            what:
                Bench::Irradiance {
                    sizes,
                    source,
                    reps,
                },
        } => bench_irradiance(&cli, sizes, *source, *reps)?,
        Command::Bench {
            what: Bench::Sh { sizes, reps },
        } => bench_sh(&cli, sizes, *reps)?,
    }
    Ok(())
}

fn demo(cli: &Cli, input: &Path, out: &Path, size: u32) -> Result<()> {
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
        let opts = ConvertOptions {
            to,
            size: n.max(1),
            orientation: Orientation::default(),
            supersample: None,
        };
        let (dst, timings) = conv.run(&src, &opts)?;
        let result = dst.download(&ctx)?;
        let exr = out.join(format!("sky_{}.exr", to.name()));
        let png = out.join(format!("sky_{}.png", to.name()));
        io::save_exr(&result, &exr)?;
        let p = envlight::preview::preview(&result, tm);
        p.save(&png).with_context(|| png.display().to_string())?;
        previews.push(p);
        let pin = map.power();
        let pout = result.power();
        rows.push((to, exr, png, timings, (pout[1] / pin[1] - 1.0) * 100.0));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let sheet = out.join("contact_sheet.png");
    envlight::preview::contact_sheet(&previews, 256)
        .save(&sheet)
        .with_context(|| sheet.display().to_string())?;
    println!("\nPreviews: {}", tm.describe());
    for (to, exr, png, timings, dp) in &rows {
        let ms: f64 = timings.iter().map(|t| t.ms).sum();
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
fn demo_scene(cli: &Cli, out: &Path) -> Result<()> {
    let scene = Path::new("assets/scenes/materials.toml");
    println!("\nevery material side by side ({}):", scene.display());
    render_scene(cli, scene, &out.join("materials.exr"))
}

fn render_scene(cli: &Cli, scene: &Path, output: &Path) -> Result<()> {
    let sc = envlight::scene::Scene::load(scene)?;
    let base = scene.parent().unwrap_or(Path::new("."));
    let env = envlight::render::load_environment(&sc, base)?;
    let ctx = context(cli)?;
    let t0 = std::time::Instant::now();
    let r = envlight::render::render(&ctx, &sc, &env)?;
    let wall = t0.elapsed().as_secs_f64();
    if let Some(dir) = output.parent() {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    }
    envlight::io::save_exr(&r.frame, output)?;
    let png = output.with_extension("png");
    let tm = ToneMap::default();
    envlight::preview::preview(&r.frame, tm)
        .save(&png)
        .with_context(|| png.display().to_string())?;
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
    if let Some((n, e)) = r.mc {
        match e {
            Some(e) => println!("monte carlo: {n} samples per pixel, relative error {e:.2e}"),
            None => println!("monte carlo: {n} samples per pixel"),
        }
    }
    println!("tone map: {tm:?} (PNG only; the EXR is linear)");
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn bench_fis(
    cli: &Cli,
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
        let m = envlight::io::load(p, &Default::default())?;
        let name = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        loaded.push((name, m));
    }
    let cfg = envlight::fisbench::FisBench {
        sizes: sizes.to_vec(),
        fis: fis.to_vec(),
        mc: mc.to_vec(),
        reference,
        biases: biases.to_vec(),
        bias_at: vec![16, 64],
        bias: envlight::scene::DEFAULT_FIS_BIAS,
    };
    let bar = indicatif::ProgressBar::new_spinner();
    let rows = envlight::fisbench::run(&ctx, &loaded, &cfg, |m| bar.set_message(m.to_string()))?;
    bar.finish_and_clear();
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver);
    std::fs::write(out.join("fis_vs_mc.csv"), envlight::fisbench::csv(&rows))?;
    let md = envlight::fisbench::markdown(&rows, &device);
    std::fs::write(out.join("fis_vs_mc.md"), &md)?;
    let png = out.join("fis_vs_mc.png");
    envlight::fisbench::plot(&rows)
        .save(&png)
        .with_context(|| png.display().to_string())?;
    println!("{md}");
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bench_convert(cli: &Cli, sizes: &[u32], reps: usize) -> Result<()> {
    let ctx = context(cli)?;
    println!("device: {} ({})", ctx.info().name, ctx.info().driver.trim());
    println!(
        "GPU time from timestamps, median of {reps} runs. 'copy' reads and writes every source texel \
         once: the floor. Source: the analytic sky (sun ~1e5 x zenith) as a lat-long.\n"
    );
    println!("| source | conversion | output | ss | copy ms | convert ms | ratio to copy | power error |");
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
            copy_ms.push(copy.run(&src)?.1.iter().map(|t| t.ms).sum());
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
            let opts = ConvertOptions {
                to,
                size,
                orientation: Orientation::default(),
                supersample,
            };
            let (ow, oh) = to.extent_for_size(size);
            let ss = supersample.unwrap_or_else(|| {
                Converter::supersampling((Mapping::LatLong, w, w / 2), (to, ow, oh))
            });
            conv.run(&src, &opts)?;
            let mut ms = Vec::new();
            let mut power = 0.0;
            for r in 0..reps {
                let (out, t) = conv.run(&src, &opts)?;
                ms.push(t.iter().map(|t| t.ms).sum());
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

fn bench_irradiance(cli: &Cli, sizes: &[u32], source: u32, reps: usize) -> Result<()> {
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
    let total = |t: &[Timing]| t.iter().map(|t| t.ms).sum::<f64>();
    for &n in sizes {
        let target = FilterTarget {
            to: Mapping::Angular,
            size: n,
        };
        brute.run(&src, &o, Kernel::Cosine, target)?;
        let mut b = Vec::new();
        for _ in 0..reps {
            b.push(total(&brute.run(&src, &o, Kernel::Cosine, target)?.1));
        }
        let b = median(b);
        for order in [2u32, 8] {
            let (c, _) = proj.run(&src, order)?;
            let irr = sh::irradiance_coeffs(&c.coeffs);
            eval.run(&irr, target)?;
            let (mut p, mut e) = (Vec::new(), Vec::new());
            for _ in 0..reps {
                p.push(total(&proj.run(&src, order)?.1));
                e.push(total(&eval.run(&irr, target)?.1));
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

fn bench_sh(cli: &Cli, sizes: &[u32], reps: usize) -> Result<()> {
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
            c.push(copy.run(&src)?.1.iter().map(|t| t.ms).sum());
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
                    ms.push(p.run(&src, lmax)?.1.iter().map(|t| t.ms).sum());
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
