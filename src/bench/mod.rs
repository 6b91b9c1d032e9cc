//! What envlight's passes cost on a device, each against its floor (a copy of its input,
//! measured in the same run) and with its error beside its time: GPU time from timestamp
//! queries, the median of repeated runs after an untimed one. `envlight bench` prints these
//! reports; the lab writes them into a device's performance page (`cargo xtask lab`).
//! Each benchmark builds its own passes and submits through [`Context::run`]; none is meant
//! for an engine's frame.

pub mod cubes;
mod dynamic;
mod floors;
pub mod pareto;
pub mod report;

pub use dynamic::{dynamic, FrameSettings};
pub use floors::floors;

use floors::time;

use crate::error::Result;
use crate::gpu::{Context, Timed};
use crate::math::filter::Kernel;
use crate::math::sh;
use crate::math::synth::Sky;
use crate::passes::sh_project::Subgroups;
use crate::passes::testing::copy::CopyPass;
use crate::passes::{
    BruteFilter, ConvertOptions, Converter, FilterTarget, ShEvaluator, ShProjector,
};
use crate::{EnvMap, GpuEnvMap, Mapping, Orientation};
use std::fmt::Write as _;

/// A benchmark's result: what it measured and how, and its tables (markdown).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Report {
    /// Its key on a performance page ("floors", "dynamic", …).
    pub job: &'static str,
    /// Its heading.
    pub title: &'static str,
    /// How it was measured: runs, medians, floors, what each error is against.
    pub method: String,
    /// Its tables and notes.
    pub body: String,
}

impl Report {
    /// The method, a blank line and the tables, as `envlight bench` prints them.
    pub fn text(&self) -> String {
        format!("{}\n\n{}", self.method, self.body)
    }
}

/// The median of `v` (the upper one of an even count).
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Each conversion of the analytic sky (sun ~10⁵ × the zenith) from a lat-long of each width
/// in `sizes` against a copy of the same source, the median of `reps` timed runs, with its
/// power error. The report's job is "convert".
pub fn convert(ctx: &Context, sizes: &[u32], reps: usize) -> Result<Report> {
    let mut body = String::new();
    let method = format!(
        "GPU time from timestamps, median of {reps} runs. 'copy' reads and writes every source texel \
         once: the floor. Source: the analytic sky (sun ~1e5 x zenith) as a lat-long."
    );
    let _ = writeln!(body, "| source | conversion | output | ss (or areas) | copy ms | convert ms | ratio to copy | power error |");
    let _ = writeln!(body, "|---|---|---|---|---|---|---|---|");
    let conv = Converter::new(ctx)?;
    let copy = CopyPass::new(ctx)?;
    for &w in sizes {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 2, |d| {
            Sky::default().radiance(d)
        });
        let pin = map.power()[1];
        let src = GpuEnvMap::upload(ctx, &map)?;
        // Each pass is timed after an untimed run: pipeline and driver warm-up.
        let floor = time(reps, || Ok(copy.run(&src)?.timings))?;
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
            let out = conv.run(&src, &opts)?.value;
            let power = out.download(ctx)?.power()[1] / pin - 1.0;
            let m = time(reps, || Ok(conv.run(&src, &opts)?.timings))?;
            let _ = writeln!(
                body,
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
    Ok(Report {
        job: "convert",
        title: "Conversions against a copy of their source",
        method,
        body,
    })
}

/// Brute-force irradiance against SH (projection + evaluation) at each angular output size in
/// `sizes`, from the analytic sky as a lat-long `source` texels wide, the median of `reps`
/// timed runs. The report's job is "irradiance".
pub fn irradiance(ctx: &Context, sizes: &[u32], source: u32, reps: usize) -> Result<Report> {
    let mut body = String::new();
    let w = source.max(4);
    let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 2, |d| {
        Sky::default().radiance(d)
    });
    let method = format!("source: the analytic sky, lat-long {w}x{}; GPU time from timestamps, median of {reps} runs after one untimed run.", w / 2);
    let _ = writeln!(body, "| output | brute ms | SH order | project ms | eval ms | brute / (project + eval) | brute / eval |");
    let _ = writeln!(body, "|---|---|---|---|---|---|---|");
    let src = GpuEnvMap::upload(ctx, &map)?;
    let brute = BruteFilter::new(ctx)?;
    let proj = ShProjector::new(ctx, Subgroups::Auto)?;
    let eval = ShEvaluator::new(ctx)?;
    let o = Orientation::default();
    for &n in sizes {
        let target = FilterTarget {
            to: Mapping::Angular,
            size: n,
        };
        let b = time(reps, || {
            Ok(brute.run(&src, &o, Kernel::Cosine, target)?.timings)
        })?;
        for order in [2u32, 8] {
            let Timed { value: c, .. } = proj.run(&src, order)?;
            let irr = sh::irradiance_coeffs(&c.coeffs);
            let p = time(reps, || Ok(proj.run(&src, order)?.timings))?;
            let e = time(reps, || Ok(eval.run(&irr, target)?.timings))?;
            let _ = writeln!(
                body,
                "| angular {n}x{n} | {b:.1} | {order} | {p:.3} | {e:.3} | {:.0}x | {:.0}x |",
                b / (p + e),
                b / e
            );
        }
    }
    Ok(Report {
        job: "irradiance",
        title: "Brute-force irradiance against SH",
        method,
        body,
    })
}

/// SH projection of orders 2 and 8 (by subgroups where the device has them, and by a shared
/// tree) of the analytic sky as lat-longs of each width in `sizes` against a copy of the same
/// map, the median of `reps` timed runs. The report's job is "sh".
pub fn sh(ctx: &Context, sizes: &[u32], reps: usize) -> Result<Report> {
    let mut body = String::new();
    let method = format!("GPU time from timestamps, median of {reps} runs after one untimed run; 'copy' reads and writes every texel once.");
    let _ = writeln!(
        body,
        "| map | reduction | lmax | copy ms | project + reduce ms | ratio to copy |"
    );
    let _ = writeln!(body, "|---|---|---|---|---|---|");
    let copy = CopyPass::new(ctx)?;
    let projectors = [
        ("subgroups", ShProjector::new(ctx, Subgroups::Auto)?),
        ("shared tree", ShProjector::new(ctx, Subgroups::Off)?),
    ];
    for &w in sizes {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 1, |d| {
            Sky::default().radiance(d)
        });
        let src = GpuEnvMap::upload(ctx, &map)?;
        let floor = time(reps, || Ok(copy.run(&src)?.timings))?;
        for (name, p) in &projectors {
            if *name == "subgroups" && !p.uses_subgroups() {
                continue;
            }
            for lmax in [2, 8] {
                let m = time(reps, || Ok(p.run(&src, lmax)?.timings))?;
                let _ = writeln!(
                    body,
                    "| latlong {w}x{} | {name} | {lmax} | {floor:.3} | {m:.3} | {:.1} |",
                    w / 2,
                    m / floor
                );
            }
        }
    }
    Ok(Report {
        job: "sh",
        title: "SH projection against a copy of its map",
        method,
        body,
    })
}
