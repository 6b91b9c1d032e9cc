//! The Monte Carlo reference (`glsl/mc.comp`, float64 twin `crate::math::mc`): progressive
//! frames of BRDF × environment samples combined by MIS, accumulated per pixel with the
//! luminance's second moment, so that every frame can say how far it still is from converged.

use super::gbuffer::GBuffer;
use super::map::GpuEnvMap;
use super::{ConvertOptions, Converter};
use crate::abi::{binding, push::McPush, ShaderId, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups_2d, mat3_rows, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timed};
use crate::math::envmap::luminance;
pub use crate::math::envsample::EnvSampler;
use crate::math::{Mapping, Orientation};
use crate::passes::testing::poison::{self, PassId};
use crate::EnvMap;

/// The environment as the Monte Carlo pass reads it: the full-resolution lat-long map and its
/// sampling tables.
pub struct McEnv {
    /// The map on the GPU.
    pub map: GpuEnvMap,
    /// Its tables on the GPU.
    pub tables: Buffer,
    /// The same tables in float64 (the CPU estimator's).
    pub sampler: EnvSampler,
    /// How the file is oriented.
    pub orientation: Orientation,
}

impl McEnv {
    /// Uploads a lat-long map and its sampling tables.
    pub fn new(ctx: &Context, map: &EnvMap, orientation: &Orientation) -> Result<McEnv> {
        let sampler = EnvSampler::new(map, orientation)?;
        let data = sampler.tables_f32();
        let tables = Buffer::storage(ctx, "environment sampling tables", &data)?;
        Ok(McEnv {
            map: GpuEnvMap::upload(ctx, map)?,
            tables,
            sampler,
            orientation: *orientation,
        })
    }
}

impl McEnv {
    /// The environment for any map: a lat-long map is read as it is; another is first
    /// converted on the GPU (`gpu` is `map` uploaded) to a world-frame lat-long with about as
    /// many texels, and the conversion's timings are returned.
    pub fn for_map(
        ctx: &Context,
        converter: &Converter,
        map: &EnvMap,
        gpu: &GpuEnvMap,
        orientation: &Orientation,
    ) -> Result<Timed<McEnv>> {
        if map.mapping == Mapping::LatLong {
            return Ok(Timed::new(McEnv::new(ctx, map, orientation)?, Vec::new()));
        }
        let n = map.width as f64 * map.height as f64 * map.layers() as f64;
        let width = (((2.0 * n).sqrt() as u32).max(8) / 2 * 2).min(8192);
        let Timed {
            value: ll,
            timings: t,
        } = converter.run(
            gpu,
            &ConvertOptions::new(Mapping::LatLong, width).with_orientation(*orientation),
        )?;
        Ok(Timed::new(
            McEnv::new(ctx, &ll.download(ctx)?, &Orientation::default())?,
            t,
        ))
    }
}

/// Per-run options: [`McOptions::new`] or [`Default`], then the fields that differ.
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct McOptions {
    /// Most samples per pixel.
    pub samples: u32,
    /// Stop early once the relative error estimate ([`relative_error`]) is below this.
    pub target_error: Option<f64>,
    /// Combine BRDF and environment sampling.
    pub mis: bool,
    /// Random seed.
    pub seed: u32,
    /// Trace shadow rays.
    pub shadows: bool,
    /// Samples per pixel per dispatch (lowered where the driver cuts long loops).
    pub per_frame: u32,
}

/// Monte Carlo samples per pixel by default.
pub const DEFAULT_SAMPLES: u32 = 1024;
/// Monte Carlo samples per pixel per dispatch by default.
pub const DEFAULT_PER_FRAME: u32 = 64;
/// The default Monte Carlo seed.
pub const DEFAULT_SEED: u32 = 1;

impl McOptions {
    /// At most `samples` samples per pixel, the other options at their defaults (MIS on, no
    /// shadows, the default seed and samples per frame, no early stop).
    pub fn new(samples: u32) -> Self {
        McOptions {
            samples,
            ..Default::default()
        }
    }
}

impl Default for McOptions {
    fn default() -> Self {
        McOptions {
            samples: DEFAULT_SAMPLES,
            target_error: None,
            mis: true,
            seed: DEFAULT_SEED,
            shadows: false,
            per_frame: DEFAULT_PER_FRAME,
        }
    }
}

/// The accumulation after a run.
pub struct McResult {
    /// rgb: Σ of estimates, a: Σ of their luminance², per pixel (0 where no MC material).
    pub accum: GpuEnvMap,
    /// Samples per pixel accumulated.
    pub samples: u32,
    /// The relative error estimate when the run stopped (when one was asked for).
    pub error: Option<f64>,
}

/// Mean and variance of the mean's luminance of one accumulated pixel.
pub fn pixel_stats(t: [f32; 4], samples: u32) -> ([f64; 3], f64) {
    let n = samples as f64;
    let mean = [t[0] as f64 / n, t[1] as f64 / n, t[2] as f64 / n];
    let ml = luminance(mean);
    let var = if samples > 1 {
        ((t[3] as f64 / n - ml * ml) * n / (n - 1.0)).max(0.0) / n
    } else {
        f64::INFINITY
    };
    (mean, var)
}

/// The image's relative error estimate: RMS over pixels with light of the standard error of
/// their mean luminance, over the mean luminance of those pixels.
pub fn relative_error(accum: &[[f32; 4]], samples: u32) -> f64 {
    let (mut var, mut lum, mut n) = (0.0, 0.0, 0usize);
    for &t in accum {
        if t[0] == 0.0 && t[1] == 0.0 && t[2] == 0.0 && t[3] == 0.0 {
            continue;
        }
        let (m, v) = pixel_stats(t, samples);
        var += v;
        lum += luminance(m);
        n += 1;
    }
    if n == 0 || lum <= 0.0 {
        return 0.0;
    }
    (var / n as f64).sqrt() / (lum / n as f64)
}

/// The Monte Carlo pass.
pub struct MonteCarlo {
    ctx: Context,
    pipeline: Pipeline,
    sampler: Sampler,
}

impl MonteCarlo {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<MonteCarlo> {
        Ok(MonteCarlo {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::Mc, &WORKGROUP_2D)?,
            sampler: Sampler::linear_clamp(ctx, "mc sampler")?,
        })
    }

    /// Samples per pixel one dispatch may take: `wanted`, or fewer where the driver cuts
    /// loops after a fixed number of iterations (lavapipe's 65535), counting the table
    /// searches and shadow rays of each sample.
    pub fn frame_samples(&self, env: &McEnv, objects: u32, shadows: bool, wanted: u32) -> u32 {
        let (w, h) = env.sampler.size();
        let per_sample = 8
            + (32 - w.leading_zeros())
            + (32 - h.leading_zeros())
            + if shadows { 2 * objects } else { 0 };
        match self.ctx.info().loop_iteration_limit {
            Some(limit) => wanted.min(limit / 2 / per_sample).max(1),
            None => wanted.max(1),
        }
    }

    /// Records `samples` more samples per pixel into `accum` (an rgba32f storage map of the
    /// G-buffer's size), for every pixel of `gbuf` whose material asks for MC, in frames of
    /// at most [`MonteCarlo::frame_samples`]. `first` is the index of the first new sample:
    /// 0 clears the accumulation first. Spans: "mc frame k" from `frame`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        rec: &mut Recorder,
        gbuf: &GBuffer,
        env: &McEnv,
        opts: &McOptions,
        accum: &GpuEnvMap,
        first: u32,
        samples: u32,
        frame: u32,
    ) -> Result<()> {
        assert_eq!((accum.width, accum.height), (gbuf.width, gbuf.height));
        let per_frame = self.frame_samples(env, gbuf.count, opts.shadows, opts.per_frame);
        if first == 0 {
            rec.clear(&accum.image, [0.0; 4]);
        }
        let mut done = first;
        let mut k = frame;
        while done < first + samples {
            let n = per_frame.min(first + samples - done);
            let push = McPush {
                world_to_file: mat3_rows(env.orientation.checked_world_to_file()?),
                env_size: [env.map.width, env.map.height],
                count: gbuf.count,
                shadows: opts.shadows as u32,
                size: [gbuf.width, gbuf.height],
                first: done,
                samples: n,
                seed: opts.seed,
                mis: opts.mis as u32,
                pad: [0; 2],
            };
            rec.span(&format!("mc frame {k}"), |rec| {
                rec.dispatch(
                    &self.pipeline,
                    &[
                        (
                            binding::MC_NORMAL,
                            Bind::Sampled(&gbuf.normal.image, &self.sampler, false),
                        ),
                        (
                            binding::MC_VIEW,
                            Bind::Sampled(&gbuf.view.image, &self.sampler, false),
                        ),
                        (
                            binding::MC_POSITION,
                            Bind::Sampled(&gbuf.position.image, &self.sampler, false),
                        ),
                        (binding::MC_OBJECTS, Bind::Buffer(&gbuf.objects)),
                        (
                            binding::MC_ENV,
                            Bind::Sampled(&env.map.image, &self.sampler, false),
                        ),
                        (binding::MC_TABLES, Bind::Buffer(&env.tables)),
                        (binding::MC_ACCUM, Bind::Storage(&accum.image)),
                    ],
                    &push,
                    groups_2d(gbuf.width, gbuf.height, 1),
                )
            })?;
            done += n;
            k += 1;
        }
        poison::image(rec, PassId::Mc, &accum.image, 0..1)
    }

    /// Accumulates samples for every pixel of `gbuf` whose material asks for MC, until
    /// `opts.samples` or `opts.target_error`, submitting a batch at a time (an error target
    /// needs the estimate read back between batches). Timings are labelled "mc frame k".
    pub fn run(&self, gbuf: &GBuffer, env: &McEnv, opts: &McOptions) -> Result<Timed<McResult>> {
        if opts.samples == 0 {
            return Err(Error::Invalid(
                "Monte Carlo needs at least one sample".into(),
            ));
        }
        let accum = GpuEnvMap::new(
            &self.ctx,
            "mc accumulation",
            Mapping::LatLong,
            gbuf.width,
            gbuf.height,
        )?;
        let per_frame = self.frame_samples(env, gbuf.count, opts.shadows, opts.per_frame);
        let mut timings = Vec::new();
        let mut done = 0u32;
        let mut error = None;
        let mut frame = 0u32;
        // With an error target, check after every batch of this many samples.
        let batch = if opts.target_error.is_some() {
            (per_frame * 4).max(256)
        } else {
            opts.samples
        };
        while done < opts.samples {
            let this_batch = batch.min(opts.samples - done);
            let t = self
                .ctx
                .run("Monte Carlo frames", |rec| {
                    self.record(rec, gbuf, env, opts, &accum, done, this_batch, frame)
                })?
                .timings;
            frame += this_batch.div_ceil(per_frame);
            done += this_batch;
            timings.extend(t);
            if let Some(target) = opts.target_error {
                let e = relative_error(&accum.download_level(&self.ctx, 0)?, done);
                error = Some(e);
                if e <= target {
                    break;
                }
            }
        }
        Ok(Timed::new(
            McResult {
                accum,
                samples: done,
                error,
            },
            timings,
        ))
    }
}
