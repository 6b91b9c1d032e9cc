//! Irradiance and Phong-prefiltered environment maps: the brute-force convolution of every
//! source texel (Miller & Hoffman 1984, `glsl/brute.comp`, float64 twin
//! [`crate::math::filter`]) and irradiance evaluated from SH coefficients
//! (Ramamoorthi & Hanrahan 2001, `glsl/sh_eval.comp`).

use crate::error::{Error, Result};
use crate::gpu::barrier::{
    cmd_image_barriers, cmd_memory_barrier, image_barrier, memory_barrier, Usage,
};
use crate::gpu::layout::{binding, SH_MAX_LMAX, WORKGROUP_1D, WORKGROUP_2D};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{groups, mat3_rows, Buffer, Context, GpuEnvMap, Sampler, Timing};
use crate::math::filter::{self, Kernel};
use crate::math::{sh, Mapping, Orientation};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Push constants of `glsl/brute.comp` (both variants).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BrutePush {
    /// Rows of the source file → world matrix.
    pub file_to_world: [[f32; 4]; 3],
    /// Source layer size.
    pub src_size: [u32; 2],
    /// Output layer size.
    pub dst_size: [u32; 2],
    /// Source mapping id.
    pub src_mapping: u32,
    /// Output mapping id.
    pub dst_mapping: u32,
    /// Source texels in all layers.
    pub texels: u32,
    /// 0 for the cosine, else the Phong exponent.
    pub exponent: f32,
    /// First source texel this dispatch sums.
    pub chunk_begin: u32,
    /// One past the last.
    pub chunk_end: u32,
    /// Padding.
    pub pad: [u32; 2],
}

/// Push constants of `glsl/sh_eval.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShEvalPush {
    /// Output layer size.
    pub dst_size: [u32; 2],
    /// Output mapping id.
    pub dst_mapping: u32,
    /// Highest band.
    pub lmax: u32,
}

/// Where a filtered map goes: its mapping and size (as `--size` means for conversion).
#[derive(Clone, Copy, Debug)]
pub struct FilterTarget {
    /// Output mapping.
    pub to: Mapping,
    /// Output size: lat-long width, or the side of a square layer.
    pub size: u32,
}

impl FilterTarget {
    /// Width and height of a layer.
    pub fn extent(&self) -> (u32, u32) {
        self.to.extent_for_size(self.size)
    }
}

/// The brute-force convolution pass.
pub struct BruteFilter {
    ctx: Context,
    prepare: Pipeline,
    brute: Pipeline,
    sampler: Sampler,
}

impl BruteFilter {
    /// Builds the two pipelines.
    pub fn new(ctx: &Context) -> Result<BruteFilter> {
        Ok(BruteFilter {
            ctx: ctx.clone(),
            prepare: Pipeline::compute(ctx, ShaderId::BrutePrepare, &[WORKGROUP_1D])?,
            brute: Pipeline::compute(ctx, ShaderId::Brute, &WORKGROUP_2D)?,
            sampler: Sampler::linear_clamp(ctx, "brute sampler")?,
        })
    }

    /// Convolves `src` (oriented by `orientation`) with `kernel` into a new map in the world
    /// frame: irradiance E(n) for [`Kernel::Cosine`], the normalised Phong prefilter indexed by
    /// the reflection direction for [`Kernel::Phong`]. Returns it and the GPU times of the two
    /// dispatches.
    pub fn run(
        &self,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
        target: FilterTarget,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let exponent = match kernel {
            Kernel::Cosine => 0.0,
            Kernel::Phong { n } if (1.0..=1e6).contains(&n) => n as f32,
            Kernel::Phong { n } => {
                return Err(Error::Invalid(format!(
                    "Phong exponent {n} is outside 1 to 1e6"
                )))
            }
        };
        let (w, h) = target.extent();
        let texels = src.width * src.height * src.mapping.layers();
        let bytes = texels as u64 * 16;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let cones = Buffer::new(
            &self.ctx,
            "brute cones",
            bytes,
            usage,
            MemoryLocation::GpuOnly,
        )?;
        let rad = Buffer::new(
            &self.ctx,
            "brute radiance",
            bytes,
            usage,
            MemoryLocation::GpuOnly,
        )?;
        let push = BrutePush {
            file_to_world: mat3_rows(orientation.world_to_file().transpose()),
            src_size: [src.width, src.height],
            dst_size: [w, h],
            src_mapping: src.mapping.id(),
            dst_mapping: target.to.id(),
            texels,
            exponent,
            chunk_begin: 0,
            chunk_end: texels,
            pad: [0; 2],
        };
        let prep_set = DescriptorSet::new(
            &self.ctx,
            &self.prepare,
            &[
                (
                    binding::BRUTE_PREP_SRC,
                    Bind::Sampled(&src.image, &self.sampler, false),
                ),
                (binding::BRUTE_PREP_CONES, Bind::Buffer(&cones)),
                (binding::BRUTE_PREP_RADIANCE, Bind::Buffer(&rad)),
            ],
        )?;
        let mut spans = Spans::new(&self.ctx, 1)?;
        let d = self.ctx.device();
        let prep_groups = texels.div_ceil(WORKGROUP_1D);
        let gx = prep_groups.min(self.ctx.info().max_workgroup_count.min(65535));
        let gy = prep_groups.div_ceil(gx);
        self.ctx
            .submit_and_wait("preparing a brute-force convolution", |cmd| {
                spans.reset(cmd);
                let span = spans.begin(cmd, "brute prepare");
                self.prepare.bind(cmd, Some(&prep_set), &push);
                // SAFETY: cmd is recording with the compute pipeline bound.
                unsafe { d.cmd_dispatch(cmd, gx, gy, 1) };
                spans.end(cmd, span);
                cmd_memory_barrier(
                    d,
                    cmd,
                    memory_barrier(Usage::ComputeWrite, Usage::ComputeRead),
                );
                Ok(())
            })?;
        let mut timings = spans.read()?;
        let dst = GpuEnvMap::new(&self.ctx, "brute-force filtered", target.to, w, h)?;
        let comp = Buffer::new(
            &self.ctx,
            "brute compensation",
            (w * h * target.to.layers()) as u64 * 16,
            usage,
            MemoryLocation::GpuOnly,
        )?;
        let set = DescriptorSet::new(
            &self.ctx,
            &self.brute,
            &[
                (binding::BRUTE_CONES, Bind::Buffer(&cones)),
                (binding::BRUTE_RADIANCE, Bind::Buffer(&rad)),
                (binding::BRUTE_DST, Bind::Storage(&dst.image)),
                (binding::BRUTE_COMP, Bind::Buffer(&comp)),
            ],
        )?;
        let label = match kernel {
            Kernel::Cosine => "brute irradiance",
            Kernel::Phong { .. } => "brute phong",
        };
        let chunk = self.chunk_size(src, kernel);
        let layers = target.to.layers();
        let mut spans = Spans::new(&self.ctx, 1)?;
        self.ctx.submit_and_wait("brute-force convolution", |cmd| {
            spans.reset(cmd);
            let img = dst.image.raw();
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    img,
                    layers,
                    Usage::Undefined,
                    Usage::ComputeReadWrite,
                )],
            );
            let span = spans.begin(cmd, label);
            let mut begin = 0;
            while begin < texels {
                let end = texels.min(begin.saturating_add(chunk));
                if begin > 0 {
                    cmd_memory_barrier(
                        d,
                        cmd,
                        memory_barrier(Usage::ComputeReadWrite, Usage::ComputeReadWrite),
                    );
                }
                let p = BrutePush {
                    chunk_begin: begin,
                    chunk_end: end,
                    ..push
                };
                self.brute.bind(cmd, Some(&set), &p);
                // SAFETY: cmd is recording with the compute pipeline bound.
                unsafe {
                    d.cmd_dispatch(
                        cmd,
                        groups(w, WORKGROUP_2D[0]),
                        groups(h, WORKGROUP_2D[1]),
                        layers,
                    )
                };
                begin = end;
            }
            spans.end(cmd, span);
            cmd_image_barriers(
                d,
                cmd,
                &[image_barrier(
                    img,
                    layers,
                    Usage::ComputeReadWrite,
                    Usage::ComputeSampled,
                )],
            );
            Ok(())
        })?;
        timings.extend(spans.read()?);
        Ok((dst, timings))
    }
}

impl BruteFilter {
    /// Source texels per dispatch: all of them, or where the device cuts long loops short
    /// ([`crate::gpu::DeviceInfo::loop_iteration_limit`]), as many as keep every invocation's
    /// loop iterations within 90% of the limit: one for the texel loop plus, per texel, at
    /// most s² cell iterations (s from the rule for the source's widest texel) or ~130 for a
    /// clipped rim texel of an angular or paraboloid source.
    fn chunk_size(&self, src: &GpuEnvMap, kernel: Kernel) -> u32 {
        let Some(limit) = self.ctx.info().loop_iteration_limit else {
            return u32::MAX;
        };
        let (w, h) = (src.width, src.height);
        let mut min_cos: f64 = 1.0;
        // Texel radii vary smoothly: a sparse sample of texels plus the corners suffices,
        // and the 25% margin in the radius already covers the spread between samples.
        let step_i = (w / 64).max(1);
        let step_j = (h / 64).max(1);
        for j in (0..h).step_by(step_j as usize).chain([h - 1]) {
            for i in (0..w).step_by(step_i as usize).chain([w - 1]) {
                min_cos = min_cos.min(filter::texel_cos_radius(src.mapping, w, h, 0, i, j));
            }
        }
        let s = (filter::CELLS_PER_WIDTH * (kernel.exponent() * 2.0 * (1.0 - min_cos)).sqrt())
            .ceil()
            .clamp(filter::EDGE_CELLS as f64, filter::MAX_CELLS as f64);
        let rim = if matches!(src.mapping, Mapping::Angular | Mapping::DualParaboloid) {
            130.0
        } else {
            0.0
        };
        let per_texel = 1.0 + (s * s).max(rim);
        ((0.9 * limit as f64 / per_texel) as u32).max(1)
    }
}

/// The SH evaluation pass: irradiance (or any zonal convolution whose per-band factors the
/// caller folds into the coefficients) at every texel centre of a map.
pub struct ShEvaluator {
    ctx: Context,
    pipeline: Pipeline,
}

impl ShEvaluator {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<ShEvaluator> {
        Ok(ShEvaluator {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::ShEval, &WORKGROUP_2D)?,
        })
    }

    /// Writes Σ c_lm·Y_lm(d) (clamped at 0) at every texel centre d of a new `target` map.
    /// For irradiance, pass [`sh::irradiance_coeffs`] of the radiance, windowed or not.
    pub fn run(
        &self,
        coeffs: &[[f64; 3]],
        target: FilterTarget,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let lmax = (coeffs.len() as f64).sqrt() as u32 - 1;
        if sh::count(lmax) != coeffs.len() || lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "{} SH coefficients are not a full set of bands up to {SH_MAX_LMAX}",
                coeffs.len()
            )));
        }
        let data: Vec<[f32; 4]> = coeffs
            .iter()
            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
            .collect();
        let buf = Buffer::storage(&self.ctx, "sh eval coefficients", &data)?;
        let (w, h) = target.extent();
        let dst = GpuEnvMap::new(&self.ctx, "sh irradiance", target.to, w, h)?;
        let set = DescriptorSet::new(
            &self.ctx,
            &self.pipeline,
            &[
                (binding::SH_EVAL_COEFFS, Bind::Buffer(&buf)),
                (binding::SH_EVAL_DST, Bind::Storage(&dst.image)),
            ],
        )?;
        let push = ShEvalPush {
            dst_size: [w, h],
            dst_mapping: target.to.id(),
            lmax,
        };
        let timings = dst.fill(
            &self.ctx,
            "evaluating SH irradiance",
            "sh eval",
            &self.pipeline,
            &set,
            &push,
        )?;
        Ok((dst, timings))
    }
}
