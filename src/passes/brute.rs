//! Irradiance and Phong-prefiltered environment maps by brute-force convolution of every
//! source texel (Miller & Hoffman 1984, `glsl/brute.comp`, float64 twin
//! [`crate::math::filter`]).

use super::map::GpuEnvMap;
use crate::abi::{
    binding, constants, push::BrutePush, ShaderId, BRUTE_TILE, WORKGROUP_1D, WORKGROUP_2D,
};
use crate::error::{Error, Result};
use crate::gpu::{groups, mat3_rows, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timing};
use crate::math::filter::{self, Kernel};
use crate::math::{Mapping, Orientation};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::OnceLock;

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
    /// Per source mapping, specialised on it.
    prepare: [OnceLock<Pipeline>; 4],
    tiles: Pipeline,
    /// Per (source, destination) mapping pair, specialised on both.
    brute: [OnceLock<Pipeline>; 16],
    sampler: Sampler,
}

impl BruteFilter {
    /// Builds the tile pipeline; the others are built, specialised, when a run needs them.
    pub fn new(ctx: &Context) -> Result<BruteFilter> {
        Ok(BruteFilter {
            ctx: ctx.clone(),
            prepare: Default::default(),
            tiles: Pipeline::compute(ctx, ShaderId::BruteTiles, &[WORKGROUP_1D])?,
            brute: Default::default(),
            sampler: Sampler::linear_clamp(ctx, "brute sampler")?,
        })
    }

    /// Records the convolution of `src` (oriented by `orientation`) with `kernel` into
    /// `dst`, in the world frame: irradiance E(n) for [`Kernel::Cosine`], the normalised
    /// Phong prefilter indexed by the reflection direction for [`Kernel::Phong`]. Spans:
    /// "brute prepare", "brute tiles", then "brute irradiance" or "brute phong".
    pub fn record(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
        dst: &GpuEnvMap,
    ) -> Result<()> {
        let (lo, hi) = constants::PHONG_EXPONENT_RANGE;
        let exponent = match kernel {
            Kernel::Cosine => 0.0,
            Kernel::Phong { n } if (lo..=hi).contains(&n) => n as f32,
            Kernel::Phong { n } => {
                return Err(Error::Invalid(format!(
                    "Phong exponent {n} is outside {lo} to {hi:e}"
                )))
            }
        };
        if let Some(worst) =
            crate::math::filter::unresolved(kernel, src.mapping, src.width, src.height)
        {
            return Err(Error::Invalid(format!(
                "the {kernel:?} lobe is too sharp for the {} x {} {} source: n·ρ² reaches \
                 {worst:.3e} where the per-texel rule resolves up to {} (ρ the texel's \
                 radius); convert the source to a larger one first (a cube resolves the back of an \
                 angular probe best: envlight convert --to cube --size N) or use a lower exponent",
                src.width,
                src.height,
                src.mapping.name(),
                crate::math::filter::RESOLVED_N_RHO2
            )));
        }
        let (w, h) = (dst.width, dst.height);
        let texels = src.width * src.height * src.mapping.layers();
        let bytes = texels as u64 * 16;
        let ctx = rec.context().clone();
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let scratch =
            |name: &str, bytes: u64| Buffer::new(&ctx, name, bytes, usage, MemoryLocation::GpuOnly);
        let cones = scratch("brute cones", bytes)?;
        let rad = scratch("brute radiance", bytes)?;
        let shapes = scratch("brute shapes", 3 * bytes)?;
        let comp = scratch(
            "brute compensation",
            (w * h * dst.mapping.layers()) as u64 * 16,
        )?;
        let push = BrutePush {
            file_to_world: mat3_rows(orientation.checked_world_to_file()?.transpose()),
            src_size: [src.width, src.height],
            dst_size: [w, h],
            src_mapping: src.mapping.id(),
            dst_mapping: dst.mapping.id(),
            texels,
            exponent,
            chunk_begin: 0,
            chunk_end: 0,
            src_layers: src.mapping.layers(),
            pad: 0,
        };
        let tile_count =
            src.width.div_ceil(BRUTE_TILE) * src.height.div_ceil(BRUTE_TILE) * src.mapping.layers();
        let slots = tile_count * BRUTE_TILE * BRUTE_TILE;
        let tiles = scratch("brute tiles", tile_count as u64 * 16)?;
        let prep_groups = texels.div_ceil(WORKGROUP_1D);
        let gx = prep_groups.min(ctx.info().max_workgroup_count.min(65535));
        let gy = prep_groups.div_ceil(gx);
        let (from, to) = (src.mapping.id(), dst.mapping.id());
        // Prepare reads only the source mapping (constant 1 is unused there).
        let prepare = Pipeline::compute_once(
            &self.prepare[from as usize],
            &self.ctx,
            ShaderId::BrutePrepare,
            &[WORKGROUP_1D, 1, from, 0],
        )?;
        let brute = Pipeline::compute_once(
            &self.brute[(4 * from + to) as usize],
            &self.ctx,
            ShaderId::Brute,
            &[WORKGROUP_2D[0], WORKGROUP_2D[1], from, to],
        )?;
        rec.span("brute prepare", |rec| {
            rec.dispatch(
                prepare,
                &[
                    (
                        binding::BRUTE_PREP_SRC,
                        Bind::Sampled(&src.image, &self.sampler, false),
                    ),
                    (binding::BRUTE_PREP_CONES, Bind::Buffer(&cones)),
                    (binding::BRUTE_PREP_RADIANCE, Bind::Buffer(&rad)),
                    (binding::BRUTE_PREP_SHAPES, Bind::Buffer(&shapes)),
                ],
                &push,
                [gx, gy, 1],
            )
        })?;
        let tile_groups = tile_count.div_ceil(WORKGROUP_1D);
        let tx = tile_groups.min(ctx.info().max_workgroup_count.min(65535));
        rec.span("brute tiles", |rec| {
            rec.dispatch(
                &self.tiles,
                &[
                    (binding::BRUTE_TILE_CONES, Bind::Buffer(&cones)),
                    (binding::BRUTE_TILE_OUT, Bind::Buffer(&tiles)),
                ],
                &push,
                [tx, tile_groups.div_ceil(tx), 1],
            )
        })?;
        let label = match kernel {
            Kernel::Cosine => "brute irradiance",
            Kernel::Phong { .. } => "brute phong",
        };
        let chunk = self.chunk_size(src, kernel);
        // The first chunk starts the sums (its shader run sees chunk_begin = 0).
        rec.discard(&dst.image);
        rec.span(label, |rec| {
            let mut begin = 0;
            while begin < slots {
                let end = slots.min(begin.saturating_add(chunk));
                rec.dispatch(
                    brute,
                    &[
                        (binding::BRUTE_CONES, Bind::Buffer(&cones)),
                        (binding::BRUTE_RADIANCE, Bind::Buffer(&rad)),
                        (binding::BRUTE_DST, Bind::Storage(&dst.image)),
                        (binding::BRUTE_COMP, Bind::Buffer(&comp)),
                        (binding::BRUTE_TILES, Bind::Buffer(&tiles)),
                        (binding::BRUTE_SHAPES, Bind::Buffer(&shapes)),
                    ],
                    &BrutePush {
                        chunk_begin: begin,
                        chunk_end: end,
                        ..push
                    },
                    [
                        groups(w, WORKGROUP_2D[0]),
                        groups(h, WORKGROUP_2D[1]),
                        dst.mapping.layers(),
                    ],
                )?;
                begin = end;
            }
            Ok(())
        })?;
        rec.keep((cones, rad, comp, tiles, shapes));
        Ok(())
    }

    /// Convolves `src` into a new `target` map and waits (see [`BruteFilter::record`]);
    /// returns it and the GPU times.
    pub fn run(
        &self,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
        target: FilterTarget,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let (w, h) = target.extent();
        let dst = GpuEnvMap::new(&self.ctx, "brute-force filtered", target.to, w, h)?;
        let ((), t) = self.ctx.run("brute-force convolution", |rec| {
            self.record(rec, src, orientation, kernel, &dst)
        })?;
        Ok((dst, t))
    }
}

impl BruteFilter {
    /// Source slots (tile-major texels) per dispatch: all, or where the device cuts long loops short
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
        let n = kernel.exponent();
        let rho = min_cos.clamp(-1.0, 1.0).acos();
        // Texels the horizon cuts take at least EDGE_CELLS a side, unless the lobe there is
        // below the cut-off for every texel: x_max ≤ sin ρ at the horizon.
        let straddlers_kept = n <= 1.0 || n * rho.sin().ln() >= filter::LOG_CUTOFF;
        let floor = if straddlers_kept {
            filter::EDGE_CELLS as f64
        } else {
            1.0
        };
        let s = (filter::CELLS_PER_WIDTH * (n * 2.0 * (1.0 - min_cos)).sqrt())
            .ceil()
            .clamp(floor, filter::MAX_CELLS as f64);
        let rim = if matches!(src.mapping, Mapping::Angular | Mapping::DualParaboloid) {
            130.0
        } else {
            0.0
        };
        let per_texel = 1.0 + (s * s).max(rim);
        ((0.9 * limit as f64 / per_texel) as u32).max(1)
    }
}
