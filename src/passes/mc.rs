//! The Monte Carlo reference (`glsl/mc.comp`, float64 twin [`crate::math::mc`]): progressive
//! frames of BRDF × environment samples combined by MIS, accumulated per pixel with the
//! luminance's second moment, so that every frame can say how far it still is from converged.

use crate::envmap::luminance;
use crate::error::{Error, Result};
use crate::gpu::barrier::{
    cmd_image_barriers, cmd_memory_barrier, image_barrier, memory_barrier, Usage,
};
use crate::gpu::layout::{binding, WORKGROUP_2D};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{groups, mat3_rows, Buffer, Context, GpuEnvMap, Sampler, Timing};
use crate::math::envsample::EnvSampler;
use crate::math::{Mapping, Orientation};
use crate::passes::gbuffer::GBuffer;
use crate::passes::{ConvertOptions, Converter};
use crate::EnvMap;
use ash::vk;

/// Push constants of `glsl/mc.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct McPush {
    /// Rows of the world → file matrix.
    pub world_to_file: [[f32; 4]; 3],
    /// Lat-long size.
    pub env_size: [u32; 2],
    /// Number of objects.
    pub count: u32,
    /// 1: shadow rays.
    pub shadows: u32,
    /// Frame size.
    pub size: [u32; 2],
    /// Index of the frame's first sample.
    pub first: u32,
    /// Samples per pixel in this frame.
    pub samples: u32,
    /// Random seed.
    pub seed: u32,
    /// 1: MIS of BRDF and environment sampling; 0: BRDF sampling alone.
    pub mis: u32,
    /// Padding.
    pub pad: [u32; 2],
}

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
    ) -> Result<(McEnv, Vec<Timing>)> {
        if map.mapping == Mapping::LatLong {
            return Ok((McEnv::new(ctx, map, orientation)?, Vec::new()));
        }
        let n = map.width as f64 * map.height as f64 * map.layers() as f64;
        let width = (((2.0 * n).sqrt() as u32).max(8) / 2 * 2).min(8192);
        let (ll, t) = converter.run(
            gpu,
            &ConvertOptions {
                to: Mapping::LatLong,
                size: width,
                orientation: *orientation,
                supersample: None,
            },
        )?;
        Ok((
            McEnv::new(ctx, &ll.download(ctx)?, &Orientation::default())?,
            t,
        ))
    }
}

/// Per-run options.
#[derive(Clone, Copy, Debug)]
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

impl Default for McOptions {
    fn default() -> Self {
        McOptions {
            samples: 1024,
            target_error: None,
            mis: true,
            seed: 1,
            shadows: false,
            per_frame: 64,
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

    /// Accumulates samples for every pixel of `gbuf` whose material asks for MC, until
    /// `opts.samples` or `opts.target_error`. Timings are labelled "mc frame k".
    pub fn run(
        &self,
        gbuf: &GBuffer,
        env: &McEnv,
        opts: &McOptions,
    ) -> Result<(McResult, Vec<Timing>)> {
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
        let set = DescriptorSet::new(
            &self.ctx,
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
        )?;
        let per_frame = self.frame_samples(env, gbuf.count, opts.shadows, opts.per_frame);
        let d = self.ctx.device();
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
            let frames = this_batch.div_ceil(per_frame);
            let mut spans = Spans::new(&self.ctx, frames)?;
            let start = done;
            self.ctx.submit_and_wait("Monte Carlo frames", |cmd| {
                spans.reset(cmd);
                if start == 0 {
                    cmd_image_barriers(
                        d,
                        cmd,
                        &[image_barrier(
                            accum.image.raw,
                            1,
                            Usage::Undefined,
                            Usage::TransferDst,
                        )],
                    );
                    let range = vk::ImageSubresourceRange::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .level_count(1)
                        .layer_count(1);
                    // SAFETY: cmd is recording; the image is in TRANSFER_DST_OPTIMAL.
                    unsafe {
                        d.cmd_clear_color_image(
                            cmd,
                            accum.image.raw,
                            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                            &vk::ClearColorValue { float32: [0.0; 4] },
                            &[range],
                        )
                    };
                    cmd_image_barriers(
                        d,
                        cmd,
                        &[image_barrier(
                            accum.image.raw,
                            1,
                            Usage::TransferDst,
                            Usage::ComputeReadWrite,
                        )],
                    );
                } else {
                    cmd_image_barriers(
                        d,
                        cmd,
                        &[image_barrier(
                            accum.image.raw,
                            1,
                            Usage::ComputeSampled,
                            Usage::ComputeReadWrite,
                        )],
                    );
                }
                let mut first = start;
                for k in 0..frames {
                    let samples = per_frame.min(start + this_batch - first);
                    let push = McPush {
                        world_to_file: mat3_rows(env.orientation.world_to_file()),
                        env_size: [env.map.width, env.map.height],
                        count: gbuf.count,
                        shadows: opts.shadows as u32,
                        size: [gbuf.width, gbuf.height],
                        first,
                        samples,
                        seed: opts.seed,
                        mis: opts.mis as u32,
                        pad: [0; 2],
                    };
                    let span = spans.begin(cmd, &format!("mc frame {}", frame + k));
                    self.pipeline.bind(cmd, Some(&set), &push);
                    // SAFETY: cmd is recording with the compute pipeline bound.
                    unsafe {
                        d.cmd_dispatch(
                            cmd,
                            groups(gbuf.width, WORKGROUP_2D[0]),
                            groups(gbuf.height, WORKGROUP_2D[1]),
                            1,
                        )
                    };
                    spans.end(cmd, span);
                    cmd_memory_barrier(
                        d,
                        cmd,
                        memory_barrier(Usage::ComputeReadWrite, Usage::ComputeReadWrite),
                    );
                    first += samples;
                }
                cmd_image_barriers(
                    d,
                    cmd,
                    &[image_barrier(
                        accum.image.raw,
                        1,
                        Usage::ComputeReadWrite,
                        Usage::ComputeSampled,
                    )],
                );
                Ok(())
            })?;
            frame += frames;
            done += this_batch;
            timings.extend(spans.read()?);
            if let Some(target) = opts.target_error {
                let e = relative_error(&accum.download_level(&self.ctx, 0)?, done);
                error = Some(e);
                if e <= target {
                    break;
                }
            }
        }
        Ok((
            McResult {
                accum,
                samples: done,
                error,
            },
            timings,
        ))
    }
}
