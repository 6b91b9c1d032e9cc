//! The exact-area conversion from a plan ([`ConvertPlan`]): the geometry worked out once, in
//! float64, for a source size, an output mapping and size and an orientation; each conversion
//! then a gather of a few source texels and their slopes per output texel
//! (`glsl/convert_planned.comp`, twin `math::convert::apply_area_plan`).

use super::{edge_points, slope_texels, ConvertOptions, Converter};
use crate::abi::{binding, push::ConvertPush, ShaderId, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups_2d, mat3_rows, Bind, Buffer, Pipeline, Recorder, Timed};
use crate::math::convert::{area_plan, AreaPlan};
use crate::math::Mapping;
use crate::passes::map::GpuEnvMap;
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Mutex;

/// An exact-area conversion (lat-long to cube or dual paraboloid) planned for one source
/// size and one [`ConvertOptions`]: per output texel, the source texels its footprint
/// overlaps and their weights, on the GPU. [`Converter::record_planned`] converts any map of
/// that size with it as [`Converter::record`] does, but in a fraction of the time, which
/// suits an environment that changes every frame at a fixed size, or many probes of one size.
/// Made by [`Converter::plan`]; [`ConvertPlan::bytes`] says what it holds (about 16 bytes per
/// source texel an output texel overlaps).
pub struct ConvertPlan {
    src: (u32, u32),
    opts: ConvertOptions,
    texels: u32,
    offsets: Buffer,
    entries: Buffer,
    /// The host's copies, until the first recording that uses the plan copies them over.
    staging: Mutex<Option<(Buffer, Buffer)>>,
}

impl ConvertPlan {
    /// Bytes the plan holds on the GPU.
    pub fn bytes(&self) -> u64 {
        self.offsets.size() + self.entries.size()
    }

    /// Whether the plan converts a `src` map (mapping, width, height) as `opts` asks.
    pub fn serves(&self, src: (Mapping, u32, u32), opts: &ConvertOptions) -> bool {
        let same = |a: &ConvertOptions, b: &ConvertOptions| {
            (a.to, a.size, a.orientation) == (b.to, b.size, b.orientation)
                && edge_points(a).ok() == edge_points(b).ok()
        };
        src == (Mapping::LatLong, self.src.0, self.src.1) && same(&self.opts, opts)
    }
}

/// The most bytes a plan a frame loop makes may take ([`Converter::plan_pays`]): beyond it
/// the source is much finer than the output (a 4k map to a 256² paraboloid), the host's build
/// takes seconds (about 1 s per 40 MB on two cores) and the memory outweighs a frame's saving.
pub const PLAN_BUDGET_BYTES: u64 = 64 << 20;

/// A GPU-only storage buffer holding `data` and the host-visible buffer to copy it from.
fn staged(ctx: &crate::gpu::Context, name: &str, data: &[u8]) -> Result<(Buffer, Buffer)> {
    let size = (data.len() as u64).max(16);
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
    let gpu = Buffer::new(ctx, name, size, usage, MemoryLocation::GpuOnly)?;
    let src = vk::BufferUsageFlags::TRANSFER_SRC;
    let mut host = Buffer::new(ctx, name, size, src, MemoryLocation::CpuToGpu)?;
    host.write(data);
    Ok((gpu, host))
}

impl Converter {
    /// Plans the conversion of a `src` map (mapping, width, height) with `opts` (on the host,
    /// in float64, on every core: about as long as one unplanned conversion on lavapipe).
    /// Only conversions that take exact areas ([`Converter::uses_area`]) have a plan.
    pub fn plan(&self, src: (Mapping, u32, u32), opts: &ConvertOptions) -> Result<ConvertPlan> {
        if !self.uses_area(src, opts) {
            return Err(Error::Invalid(format!(
                "no plan for a {} {}x{} map to {} {}: only lat-long to cube or dual \
                 paraboloid by exact areas has one",
                src.0.name(),
                src.1,
                src.2,
                opts.to.name(),
                opts.size
            )));
        }
        let w2f = opts.orientation.checked_world_to_file()?;
        let points = edge_points(opts)?;
        let plan: AreaPlan = area_plan((src.1, src.2), opts.to, opts.size, w2f, points);
        let (offsets, staged_offsets) = staged(
            &self.ctx,
            "convert plan offsets",
            bytemuck::cast_slice(&plan.offsets),
        )?;
        let (entries, staged_entries) = staged(
            &self.ctx,
            "convert plan entries",
            bytemuck::cast_slice(&plan.entries),
        )?;
        Ok(ConvertPlan {
            src: (src.1, src.2),
            opts: *opts,
            texels: plan.offsets.len() as u32 - 1,
            offsets,
            entries,
            staging: Mutex::new(Some((staged_offsets, staged_entries))),
        })
    }

    /// About the bytes a plan of a `src` map (mapping, width, height) with `opts` takes:
    /// per output texel an offset and (r + 1)² entries, r the source texel spacings per
    /// output texel spacing (measured 4.1 entries at r = 1.1, 9.3 at r = 2.3).
    pub fn plan_bytes(src: (Mapping, u32, u32), opts: &ConvertOptions) -> u64 {
        let (w, h) = opts.to.extent_for_size(opts.size);
        let texels = (w * h * opts.to.layers()) as f64;
        let r = Converter::ratio(src, (opts.to, w, h));
        (texels * (4.0 + 16.0 * (r + 1.0) * (r + 1.0))) as u64
    }

    /// Whether a frame loop should convert a `src` map with `opts` from a plan: the conversion
    /// takes areas, and its plan is estimated ([`Converter::plan_bytes`]) within
    /// [`PLAN_BUDGET_BYTES`] and the device's largest storage buffer.
    pub fn plan_pays(&self, src: (Mapping, u32, u32), opts: &ConvertOptions) -> bool {
        let max = self
            .ctx
            .info()
            .max_storage_buffer_range
            .min(PLAN_BUDGET_BYTES);
        self.uses_area(src, opts) && Converter::plan_bytes(src, opts) <= max
    }

    fn planned_pipeline(&self) -> Result<&Pipeline> {
        Pipeline::compute_once(
            &self.planned,
            &self.ctx,
            ShaderId::ConvertPlanned,
            &WORKGROUP_2D,
        )
    }

    /// Records the conversion of `src` into `dst` with `plan`, which must serve `src` and
    /// `dst`'s mapping and size: the source's slopes, then each output texel's sum over its
    /// plan's entries. The first recording that uses a plan also copies it to the GPU:
    /// submit that one first (or alone).
    pub fn record_planned(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        plan: &ConvertPlan,
    ) -> Result<()> {
        let (w, h) = plan.opts.to.extent_for_size(plan.opts.size);
        if (src.mapping, src.width, src.height) != (Mapping::LatLong, plan.src.0, plan.src.1)
            || (dst.mapping, dst.width, dst.height) != (plan.opts.to, w, h)
        {
            return Err(Error::Invalid(format!(
                "a conversion plan for lat-long {}x{} to {} {w}x{h} was given {} {}x{} to {} \
                 {}x{}",
                plan.src.0,
                plan.src.1,
                plan.opts.to.name(),
                src.mapping.name(),
                src.width,
                src.height,
                dst.mapping.name(),
                dst.width,
                dst.height
            )));
        }
        let staging = plan.staging.lock().map(|mut s| s.take()).unwrap_or(None);
        if let Some((offsets, entries)) = staging {
            rec.copy_buffer(&offsets, &plan.offsets, offsets.size());
            rec.copy_buffer(&entries, &plan.entries, entries.size());
            rec.keep(offsets);
            rec.keep(entries);
        }
        let push = ConvertPush {
            world_to_file: mat3_rows(plan.opts.orientation.checked_world_to_file()?),
            src_size: [src.width, src.height],
            dst_size: [w, h],
            src_mapping: src.mapping.id(),
            dst_mapping: plan.opts.to.id(),
            ss: 1,
            nearest: 0,
            threshold: 0.0,
        };
        debug_assert_eq!(plan.texels, w * h * plan.opts.to.layers());
        let source = || {
            (
                binding::CONVERT_SRC,
                Bind::Sampled(&src.image, &self.sampler, false),
            )
        };
        let planned = self.planned_pipeline()?;
        rec.discard(&dst.image);
        let slopes = self.record_slopes(rec, src, &push)?;
        let [slopes_u, slopes_z] = slope_texels(&slopes);
        let label = format!(
            "convert latlong -> {} {w}x{h} (planned)",
            dst.mapping.name()
        );
        rec.span(&label, |rec| {
            rec.dispatch(
                planned,
                &[
                    source(),
                    (binding::CONVERT_DST, Bind::Storage(&dst.image)),
                    slopes_u,
                    slopes_z,
                    (binding::CONVERT_PLAN_OFFSETS, Bind::Buffer(&plan.offsets)),
                    (binding::CONVERT_PLAN_ENTRIES, Bind::Buffer(&plan.entries)),
                ],
                &push,
                groups_2d(w, h, plan.opts.to.layers()),
            )
        })?;
        poison::image(rec, PassId::Convert, &dst.image, 0..1)
    }

    /// Converts `src` with `plan` into a new map; returns it and the GPU time.
    pub fn run_planned(&self, src: &GpuEnvMap, plan: &ConvertPlan) -> Result<Timed<GpuEnvMap>> {
        let (to, size) = (plan.opts.to, plan.opts.size);
        let (w, h) = to.extent_for_size(size);
        let dst = GpuEnvMap::new(&self.ctx, &format!("{} {size}", to.name()), to, w, h)?;
        Ok(self
            .ctx
            .run("converting a map by its plan", |rec| {
                self.record_planned(rec, src, &dst, plan)
            })?
            .map(|()| dst))
    }
}
