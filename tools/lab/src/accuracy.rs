//! What SH irradiance costs in accuracy and time against the brute-force convolution
//! (`envlight-lab accuracy`): for each map, the RMS and max relative error of orders 0, 1, 2,
//! 4, 6 and 8 (without a window and with the smallest non-negative Sloan window) over a
//! uniform set of normals, and the GPU times of projection, evaluation and brute force.
//!
//! The normals are the texel centres of a cube map of `size`² per face, weighted by their
//! exact solid angles, so sums over them are integrals over the sphere. Relative errors are of
//! luminance, against the brute-force irradiance at the same normal.

use crate::common::{context, Global};
use anyhow::Context as _;
use envlight::error::Result;
use envlight::gpu::{total_ms, Context, Timed};
use envlight::io::{self, LoadOptions};
use envlight::math::envmap::{luminance, EnvMap};
use envlight::math::filter::Kernel;
use envlight::math::sh::{self, Window};
use envlight::math::synth::fibonacci_sphere;
use envlight::math::{Mapping, Orientation};
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::passes::{BruteFilter, FilterTarget, ShEvaluator};
use envlight::GpuEnvMap;
use indicatif::ProgressBar;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// SH orders the report covers.
pub const ORDERS: [u32; 6] = [0, 1, 2, 4, 6, 8];

/// One order (and window) of one map.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Row {
    /// Highest band.
    pub order: u32,
    /// Sloan window λ applied (0: none).
    pub lambda: f64,
    /// RMS relative error over the sphere.
    pub rms: f64,
    /// Largest relative error.
    pub max: f64,
    /// Fraction of the sphere where the unclamped SH irradiance is negative (before the
    /// evaluation pass clamps it).
    pub negative: f64,
    /// GPU time of the evaluation pass, ms.
    pub eval_ms: f64,
}

/// Everything measured on one map.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MapReport {
    /// The map's name.
    pub name: String,
    /// Texels of the source.
    pub texels: u64,
    /// Normals compared (6·size²).
    pub normals: u32,
    /// GPU time of the projection to order 8, ms.
    pub projection_ms: f64,
    /// GPU time of the brute-force irradiance at the same output size, ms.
    pub brute_ms: f64,
    /// Without a window, then with the smallest non-negative one, per order.
    pub rows: Vec<Row>,
}

/// The passes the report runs, built once.
pub struct Accuracy {
    ctx: Context,
    projector: ShProjector,
    eval: ShEvaluator,
    brute: BruteFilter,
}

impl Accuracy {
    /// Builds the passes.
    pub fn new(ctx: &Context) -> Result<Accuracy> {
        Ok(Accuracy {
            ctx: ctx.clone(),
            projector: ShProjector::new(ctx, Subgroups::Auto)?,
            eval: ShEvaluator::new(ctx)?,
            brute: BruteFilter::new(ctx)?,
        })
    }

    /// Measures one map at `size`² normals per cube face.
    pub fn run(&self, name: &str, map: &EnvMap, size: u32) -> Result<MapReport> {
        let g = GpuEnvMap::upload(&self.ctx, map)?;
        let target = FilterTarget {
            to: Mapping::Cube,
            size,
        };
        let Timed {
            value: bf,
            timings: t,
        } = self
            .brute
            .run(&g, &Orientation::default(), Kernel::Cosine, target)?;
        let brute_ms = total_ms(&t);
        let bf = bf.download(&self.ctx)?;
        let Timed {
            value: c,
            timings: t,
        } = self.projector.run(&g, 8)?;
        let projection_ms = total_ms(&t);
        let omega: Vec<f64> = (0..6 * size * size)
            .map(|k| {
                let r = k % (size * size);
                Mapping::Cube.texel_solid_angle(size, size, r % size, r / size)
            })
            .collect();
        let dirs = fibonacci_sphere(4000);
        let mut rows = Vec::new();
        for order in ORDERS {
            let radiance = &c.coeffs[..sh::count(order)];
            let lambda = sh::smallest_nonnegative_window(radiance, &dirs);
            let windows = if lambda > 0.0 {
                vec![0.0, lambda]
            } else {
                vec![0.0]
            };
            for lambda in windows {
                let irr = sh::irradiance_coeffs(&Window::Sloan { lambda }.apply(radiance));
                let negative = sh::negativity(&irr, &dirs).fraction;
                let Timed {
                    value: e,
                    timings: t,
                } = self.eval.run(&irr, target)?;
                let eval_ms = total_ms(&t);
                let e = e.download(&self.ctx)?;
                let (mut sum, mut wsum, mut max) = (0.0, 0.0, 0.0f64);
                for ((a, b), w) in e.texels.iter().zip(&bf.texels).zip(&omega) {
                    let la = luminance(a.map(f64::from));
                    let lb = luminance(b.map(f64::from));
                    let rel = (la - lb).abs() / lb.max(f64::MIN_POSITIVE);
                    sum += w * rel * rel;
                    wsum += w;
                    max = max.max(rel);
                }
                rows.push(Row {
                    order,
                    lambda,
                    rms: (sum / wsum).sqrt(),
                    max,
                    negative,
                    eval_ms,
                });
            }
        }
        Ok(MapReport {
            name: name.to_string(),
            texels: map.texels.len() as u64,
            normals: 6 * size * size,
            projection_ms,
            brute_ms,
            rows,
        })
    }
}

/// The reports as a markdown table.
pub fn markdown(reports: &[MapReport], device: &str) -> String {
    let mut s = format!(
        "SH irradiance against brute force ({device}). Relative error of luminance over a \
         uniform set of normals; `λ` is the smallest Sloan window that makes the irradiance \
         non-negative (rows without one are unwindowed); `neg` is the fraction of the sphere \
         where the unwindowed-or-windowed SH irradiance is negative before clamping. Times are \
         GPU timestamps.\n\n\
         | map | order | λ | RMS | max | neg | SH ms (proj + eval) | brute ms | brute / SH |\n\
         |---|---|---|---|---|---|---|---|---|\n"
    );
    for r in reports {
        for row in &r.rows {
            let sh_ms = r.projection_ms + row.eval_ms;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.2}% | {:.2}% | {:.1}% | {:.3} | {:.1} | {:.0}× |",
                r.name,
                row.order,
                if row.lambda > 0.0 {
                    format!("{:.3}", row.lambda)
                } else {
                    "–".into()
                },
                100.0 * row.rms,
                100.0 * row.max,
                100.0 * row.negative,
                sh_ms,
                r.brute_ms,
                r.brute_ms / sh_ms
            );
        }
    }
    s
}

/// The reports as CSV.
pub fn csv(reports: &[MapReport]) -> String {
    let mut s = String::from(
        "map,texels,normals,order,lambda,rms,max,negative,projection_ms,eval_ms,brute_ms\n",
    );
    for r in reports {
        for row in &r.rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{}",
                r.name,
                r.texels,
                r.normals,
                row.order,
                row.lambda,
                row.rms,
                row.max,
                row.negative,
                r.projection_ms,
                row.eval_ms,
                r.brute_ms
            );
        }
    }
    s
}

/// Colour of the i-th map's curve (also listed in the markdown beside the plot).
pub fn plot_colour(i: usize) -> [u8; 3] {
    const C: [[u8; 3]; 10] = [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [127, 127, 127],
        [188, 189, 34],
        [23, 190, 207],
    ];
    C[i % C.len()]
}

/// A plot of unwindowed RMS error (log scale, 1e-4 to 10, gridlines at each decade) against
/// SH order (0 to 8), one polyline per map in [`plot_colour`], with the seed's quoted 25%, 8%
/// and 1% at orders 0, 1, 2 as black squares.
pub fn plot(reports: &[MapReport]) -> image::RgbImage {
    let (w, h, m) = (640u32, 420u32, 40i32);
    let mut img = image::RgbImage::from_pixel(w, h, image::Rgb([255, 255, 255]));
    let x_of = |order: f64| m as f64 + order / 8.0 * (w as f64 - 2.0 * m as f64);
    let y_of = |err: f64| {
        let l = err.clamp(1e-4, 10.0).log10(); // -4..1
        m as f64 + (1.0 - l) / 5.0 * (h as f64 - 2.0 * m as f64)
    };
    let put = |img: &mut image::RgbImage, x: i32, y: i32, c: [u8; 3]| {
        if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
            img.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    };
    for dec in -1..=4 {
        let y = y_of(10f64.powi(-dec)) as i32;
        for x in m..(w as i32 - m) {
            put(&mut img, x, y, [210, 210, 210]);
        }
    }
    for o in 0..=8 {
        let x = x_of(o as f64) as i32;
        for y in m..(h as i32 - m) {
            put(&mut img, x, y, [235, 235, 235]);
        }
    }
    let line = |img: &mut image::RgbImage, a: (f64, f64), b: (f64, f64), c: [u8; 3]| {
        let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) as usize).max(1);
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            for dy in -1..=1 {
                put(img, x as i32, y as i32 + dy, c);
            }
        }
    };
    for (i, r) in reports.iter().enumerate() {
        let pts: Vec<(f64, f64)> = r
            .rows
            .iter()
            .filter(|row| row.lambda == 0.0)
            .map(|row| (x_of(row.order as f64), y_of(row.rms)))
            .collect();
        for p in pts.windows(2) {
            line(&mut img, p[0], p[1], plot_colour(i));
        }
    }
    for (order, err) in [(0.0, 0.25), (1.0, 0.08), (2.0, 0.01)] {
        let (x, y) = (x_of(order) as i32, y_of(err) as i32);
        for dx in -4..=4 {
            for dy in -4..=4 {
                put(&mut img, x + dx, y + dy, [0, 0, 0]);
            }
        }
    }
    img
}

/// `envlight-lab accuracy`: the report on every map, written to `out`.
pub fn accuracy_sh(cli: &Global, inputs: &[PathBuf], out: &Path, size: u32) -> anyhow::Result<()> {
    let mut files = Vec::new();
    for i in inputs {
        if i.is_dir() {
            files.extend(envlight::io::probes_in(i)?);
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
    let mut md = markdown(&reports, &device);
    md.push_str("\nPlot `accuracy.png`: unwindowed RMS error (log scale, 1e-4 to 10, a gridline per decade) against order 0–8; black squares are the seed's 25%, 8%, 1%. Curves:\n\n");
    for (i, r) in reports.iter().enumerate() {
        let [cr, cg, cb] = plot_colour(i);
        md.push_str(&format!("- rgb({cr}, {cg}, {cb}): {}\n", r.name));
    }
    print!("{md}");
    for (name, text) in [("accuracy.md", md), ("accuracy.csv", csv(&reports))] {
        let p = out.join(name);
        std::fs::write(&p, text).with_context(|| p.display().to_string())?;
    }
    let p = out.join("accuracy.png");
    plot(&reports)
        .save(&p)
        .with_context(|| p.display().to_string())?;
    println!("wrote {}", out.display());
    Ok(())
}
