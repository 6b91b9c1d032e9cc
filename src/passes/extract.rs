//! Light extraction on the GPU (`glsl/extract.comp`, float64 twin
//! `crate::math::lights::extract`): the light texels of a map that lives on the GPU — an
//! engine's own image that changes every frame — found, capped and compacted into a bounded
//! record buffer with an indirect-dispatch count, and the residual map written beside them,
//! with nothing read back and nothing waited for.
//!
//! The rule is the host's: a texel position holding part of the sphere is a light texel when its
//! luminance Y exceeds τ = `ratio` × the map's mean luminance, the threshold raised where needed
//! so that at most `max_texels` pass (it becomes the (max+1)-th brightest luminance, found
//! exactly by a two-level radix select over Y's float bits). The mean is the SH projection's
//! L00 × Y00, so the pass reads the coefficients a frame projects anyway (band 0 is enough,
//! [`super::ShProjector::record_into`]). Residual plus lights equal the map to float32 rounding;
//! texels above τ that the cap leaves out stay in the residual and are counted
//! ([`ExtractStats::candidates`] − [`ExtractStats::kept`]). Texels with a NaN or infinite
//! channel are zero in the residual and counted, so a broken frame leaves finite lights and a
//! finite residual, and the next frame starts afresh.
//!
//! The residual is clamped at the threshold ([`GpuExtraction::new`]) or, as the host's chain
//! extraction does by default, filled ([`GpuExtraction::with_fill`]): the light set grows by
//! rings of neighbours while the cap has room for each ring's records, and the residual under
//! it continues its surroundings, settled round by round from the set's edge inwards.
//!
//! Light records are in no particular order (an atomic compaction). Steps, one pipeline:
//! histogram of the top 16 bits of Y above τ; one workgroup selects the bin the cap falls in;
//! an indirect dispatch (no workgroups unless the cap binds) histograms that bin's low bits; one
//! workgroup selects the exact threshold; where filled, the set's ring 0 is listed, each ring
//! grows from the last, one invocation decides which rings fit and one workgroup runs the
//! fill's rounds; the compaction writes records and residual. A clamped extraction's histogram
//! pass writes its records and residual at τ as it goes, so that its compaction, an indirect
//! dispatch, runs over the map only where the cap binds: one pass over the map where it does
//! not, two where it does.

use crate::abi::lights::{
    clusters_mode, prepare_mode, CLUSTER_SORT_CELL_ARRAYS, CLUSTER_SORT_RECORD_ARRAYS,
    CLUSTER_VEC4S, KERNEL_COSINE, KERNEL_GGX, TREE_BUCKET_BITS, TREE_SORT_BUCKET_ARRAYS,
    TREE_SORT_RECORD_ARRAYS,
};
use crate::abi::lights::{
    extract_mode as mode, extract_word as word, EXTRACT_HEADER_WORDS, EXTRACT_LOW_BINS,
    EXTRACT_RECORD_VEC4S, EXTRACT_TOP_BINS, FILL_MAX_RINGS, FILL_RING_GROUPS, FILL_SLOT_ARRAYS,
    FILL_SLOT_BITS,
};
use crate::abi::push::{ExtractAddPush, ExtractClustersPush, ExtractPreparePush};
use crate::abi::{binding, push::ExtractPush, ShaderId, WORKGROUP_1D, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{
    groups, groups_2d, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timed, Usage,
};
use crate::math::envmap::{luminance, EnvMap};
use crate::math::lights::{ExtractOptions, LightKernel};
use crate::math::{Mapping, Orientation};
use crate::passes::split_sum::LevelLayers;
use crate::passes::testing::poison::{self, PassId};
use crate::passes::{GpuEnvMap, ShProjector};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// What one extraction found, from its header.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtractStats {
    /// τ: the ratio times the mean luminance (infinite where the mean is not positive).
    pub tau: f32,
    /// The threshold the light texels exceed: τ, or higher where the cap binds.
    pub threshold: f32,
    /// Texel positions above τ.
    pub candidates: u32,
    /// Light texels kept (at most the cap; the rest stay in the residual).
    pub kept: u32,
    /// Texels with a NaN or infinite channel, zero in the residual.
    pub nonfinite: u32,
    /// Filled extractions: the rings the light set grew by (0 otherwise).
    pub grown: u32,
    /// Filled extractions: the light set's texels (0 otherwise).
    pub members: u32,
    /// Filled extractions: the fill's rounds, the set's depth from its edge plus one (0
    /// otherwise).
    pub rounds: u32,
    /// The indirect arguments for a pass over the records ([`GpuExtraction::light_args`]):
    /// workgroups of `EXTRACT_LIGHT_GROUP` (64) invocations covering `kept`, then 1, 1.
    pub light_groups: [u32; 3],
}

/// One light record as the pass writes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuLightTexel {
    /// Layer, column and row of the texel position.
    pub texel: [u32; 3],
    /// Its centre direction (file frame).
    pub dir: [f32; 3],
    /// Its solid angle.
    pub omega: f32,
    /// Its excess radiance over the residual's clamp.
    pub excess: [f32; 3],
    /// The luminance of the value standing for it.
    pub luminance: f32,
}

/// What [`Extractor::run`] reads back.
#[derive(Clone, Debug)]
pub struct Extracted {
    /// The header's figures.
    pub stats: ExtractStats,
    /// The light records, in the order the GPU wrote them.
    pub lights: Vec<GpuLightTexel>,
    /// The residual map.
    pub residual: EnvMap,
}

impl Extracted {
    /// Luminous power Σ Y·ω of the residual plus the lights' excess: the map's, to float32
    /// rounding (texels the extraction counted as non-finite aside).
    pub fn power(&self) -> f64 {
        let lights: f64 = self
            .lights
            .iter()
            .map(|l| luminance(l.excess.map(f64::from)) * l.omega as f64)
            .sum();
        luminance(self.residual.power()) + lights
    }
}

/// The GPU resources of an extraction, made once for a map's mapping and size and a cap and
/// reused every frame: the state buffer (header, histograms, indirect arguments), the light
/// records and the residual map.
pub struct GpuExtraction {
    state: Buffer,
    lights: Buffer,
    residual: GpuEnvMap,
    max: u32,
    /// Rings the light set grows by where the residual is filled (`None`: clamped).
    fill: Option<u32>,
    /// The light set of a filled extraction (a word per texel, four per slot), a
    /// placeholder otherwise.
    set: Buffer,
}

impl GpuExtraction {
    /// Resources for maps of `mapping`, `width` × `height`, keeping at most `max` light texels,
    /// the residual clamped at the threshold.
    pub fn new(
        ctx: &Context,
        mapping: Mapping,
        width: u32,
        height: u32,
        max: u32,
    ) -> Result<GpuExtraction> {
        Self::with_fill(ctx, mapping, width, height, max, None)
    }

    /// [`GpuExtraction::new`] with the residual under the lights filled from around them
    /// where `fill` is given, the light set grown by up to that many rings of texels
    /// (`crate::math::lights::ExtractOptions::fill`, at most
    /// `crate::abi::lights::FILL_MAX_RINGS`).
    pub fn with_fill(
        ctx: &Context,
        mapping: Mapping,
        width: u32,
        height: u32,
        max: u32,
        fill: Option<u32>,
    ) -> Result<GpuExtraction> {
        if max == 0 {
            return Err(Error::Invalid(
                "a GPU light extraction needs room for at least one light texel".into(),
            ));
        }
        if let Some(rings) = fill {
            if rings > FILL_MAX_RINGS || max >= 1 << FILL_SLOT_BITS {
                return Err(Error::Invalid(format!(
                    "a filled GPU light extraction grows by at most {FILL_MAX_RINGS} rings and \
                     keeps fewer than 2^{FILL_SLOT_BITS} light texels (asked: {rings} rings, \
                     {max} texels)"
                )));
            }
        }
        let texels = width as u64 * height as u64 * mapping.layers() as u64;
        let set_words = match fill {
            Some(_) => texels + FILL_SLOT_ARRAYS as u64 * max as u64,
            None => 4,
        };
        let set = Buffer::new(
            ctx,
            "extraction light set",
            set_words * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let words = (EXTRACT_HEADER_WORDS + EXTRACT_TOP_BINS + EXTRACT_LOW_BINS) as u64;
        let state = Buffer::new(
            ctx,
            "extraction state",
            words * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::INDIRECT_BUFFER,
            MemoryLocation::GpuOnly,
        )?;
        let lights = Buffer::new(
            ctx,
            "extracted lights",
            Self::record_bytes(max),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let residual = GpuEnvMap::new(ctx, "extracted residual", mapping, width, height)?;
        Ok(GpuExtraction {
            state,
            lights,
            residual,
            max,
            fill,
            set,
        })
    }

    /// Rings the light set grows by where the residual is filled; `None` where it is clamped.
    pub fn fill(&self) -> Option<u32> {
        self.fill
    }

    /// Bytes of `max` light records.
    pub fn record_bytes(max: u32) -> u64 {
        max as u64 * EXTRACT_RECORD_VEC4S as u64 * 16
    }

    /// The state buffer: header words (`crate::abi::lights::extract_word`), then the
    /// histograms. [`GpuExtraction::light_args`] is where an indirect dispatch over the
    /// records reads its workgroup counts.
    pub fn state(&self) -> &Buffer {
        &self.state
    }

    /// Byte offset in [`GpuExtraction::state`] of the indirect arguments (x, 1, 1) for a
    /// dispatch of 64-invocation workgroups over the kept light records.
    pub fn light_args() -> u64 {
        word::LIGHT_ARGS as u64 * 4
    }

    /// The light records (`EXTRACT_RECORD_VEC4S` vec4s each, see [`GpuLightTexel`]); the
    /// count is the header's `KEPT` word.
    pub fn lights(&self) -> &Buffer {
        &self.lights
    }

    /// The residual map.
    pub fn residual(&self) -> &GpuEnvMap {
        &self.residual
    }

    /// The most light texels kept.
    pub fn max(&self) -> u32 {
        self.max
    }

    /// Whether these resources serve `map`.
    pub fn fits(&self, map: &GpuEnvMap) -> bool {
        (
            self.residual.mapping,
            self.residual.width,
            self.residual.height,
        ) == (map.mapping, map.width, map.height)
    }
}

/// The extraction pass, and the addition of its lights to a cube level.
pub struct Extractor {
    ctx: Context,
    /// The per-texel steps, one pipeline per mapping and per clamped or filled extraction
    /// (specialised: index 2 × mapping + filled), built on first use.
    pipelines: [std::sync::OnceLock<Pipeline>; 8],
    /// A filled extraction's steps over lists, one pipeline per mapping, built on first use.
    grow: [std::sync::OnceLock<Pipeline>; 4],
    select: Pipeline,
    add: Pipeline,
    clusters: Pipeline,
    prepare: Pipeline,
    sampler: Sampler,
}

impl Extractor {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Extractor> {
        Ok(Extractor {
            ctx: ctx.clone(),
            pipelines: Default::default(),
            grow: Default::default(),
            select: Pipeline::compute(ctx, ShaderId::ExtractSelect, &WORKGROUP_2D)?,
            add: Pipeline::compute(ctx, ShaderId::ExtractAdd, &WORKGROUP_2D)?,
            clusters: Pipeline::compute(ctx, ShaderId::ExtractClusters, &[WORKGROUP_1D])?,
            prepare: Pipeline::compute(ctx, ShaderId::ExtractPrepare, &[WORKGROUP_1D])?,
            sampler: Sampler::linear_clamp(ctx, "extraction")?,
        })
    }

    /// Records the extraction of `map` by `ratio` (over the mean luminance, which `sh` —
    /// the SH projection's output of this map, at least band 0 — gives) into `out`, keeping at
    /// most `out.max()` light texels. Refused, naming the image, where `map` cannot be sampled
    /// or `out` was made for another mapping or size. Span: "extract lights".
    pub fn record(
        &self,
        rec: &mut Recorder,
        map: &GpuEnvMap,
        sh: &Buffer,
        ratio: f64,
        out: &GpuExtraction,
    ) -> Result<()> {
        check_inputs(map, sh, ratio, out)?;
        let size = [map.width, map.height];
        let binds = [
            (
                binding::EXTRACT_MAP,
                Bind::Sampled(&map.image, &self.sampler, false),
            ),
            (binding::EXTRACT_SH, Bind::Buffer(sh)),
            (binding::EXTRACT_STATE, Bind::Buffer(&out.state)),
            (binding::EXTRACT_LIGHTS, Bind::Buffer(&out.lights)),
            (
                binding::EXTRACT_RESIDUAL,
                Bind::Storage(&out.residual.image),
            ),
            (binding::EXTRACT_FILL, Bind::Buffer(&out.set)),
        ];
        let push = |m, grow| ExtractPush {
            size,
            mapping: map.mapping.id(),
            mode: m,
            max: out.max,
            ratio: ratio as f32,
            fill: u32::from(out.fill.is_some()),
            grow,
        };
        let per_texel = groups_2d(map.width, map.height, map.mapping.layers());
        let id = map.mapping.id();
        let filled = u32::from(out.fill.is_some());
        let pipeline = Pipeline::compute_once(
            &self.pipelines[(2 * id + filled) as usize],
            &self.ctx,
            ShaderId::Extract,
            &[WORKGROUP_2D[0], WORKGROUP_2D[1], id, filled],
        )?;
        rec.span("extract lights", |rec| {
            rec.fill_buffer(&out.state, out.state.size(), 0);
            rec.discard(&out.residual.image);
            rec.dispatch(pipeline, &binds, &push(mode::HISTOGRAM, 0), per_texel)?;
            rec.dispatch(&self.select, &binds, &push(mode::SELECT_TOP, 0), [1, 1, 1])?;
            let low = (&out.state, word::LOW_ARGS as u64 * 4);
            rec.dispatch_indirect(pipeline, &binds, &push(mode::HISTOGRAM_LOW, 0), low)?;
            rec.dispatch(&self.select, &binds, &push(mode::SELECT_LOW, 0), [1, 1, 1])?;
            if let Some(rings) = out.fill {
                let grow = Pipeline::compute_once(
                    &self.grow[id as usize],
                    &self.ctx,
                    ShaderId::ExtractGrow,
                    &[WORKGROUP_2D[0], WORKGROUP_2D[1], id],
                )?;
                let labels = map.width as u64 * map.height as u64 * map.mapping.layers() as u64;
                rec.fill_buffer(&out.set, labels * 4, u32::MAX);
                let args = |w: u32| (&out.state, w as u64 * 4);
                let list = push(mode::MARK_LIST, 0);
                rec.dispatch_indirect(grow, &binds, &list, args(word::MARK_LIST_ARGS))?;
                let every = push(mode::MARK, 0);
                rec.dispatch_indirect(pipeline, &binds, &every, args(word::MARK_ARGS))?;
                for ring in 1..=rings {
                    let groups = [FILL_RING_GROUPS, 1, 1];
                    rec.dispatch(grow, &binds, &push(mode::RING, ring), groups)?;
                }
                // Only an angular map's rim positions read another texel.
                if map.mapping == Mapping::Angular {
                    rec.dispatch(pipeline, &binds, &push(mode::RIMS, 0), per_texel)?;
                }
                rec.dispatch(&self.select, &binds, &push(mode::DECIDE, rings), [1, 1, 1])?;
                rec.dispatch(&self.select, &binds, &push(mode::FILL, rings), [1, 1, 1])?;
            }
            let compact = push(mode::COMPACT, 0);
            if out.fill.is_some() {
                rec.dispatch(pipeline, &binds, &compact, per_texel)
            } else {
                // HISTOGRAM wrote the records and residual at τ; this rewrites them where
                // the cap binds (no workgroups elsewhere).
                let args = (&out.state, word::COMPACT_ARGS as u64 * 4);
                rec.dispatch_indirect(pipeline, &binds, &compact, args)
            }
        })?;
        poison::image(rec, PassId::Extract, &out.residual.image, 0..1)?;
        // Excess radiance scaled; the direction's x and the excess's red negated by the mirror.
        let floats = poison::Floats {
            first: 0,
            count: out.max * RECORD_WORDS as u32,
            stride: RECORD_WORDS as u32,
            scale_mask: 0b111_0000,
            mirror_mask: 0b1_0001,
            sh: None,
        };
        poison::buffer(rec, PassId::Extract, &out.lights, floats)
    }

    /// Records the addition of `from`'s kept lights (an extraction recorded earlier, of a map
    /// whose file directions reach the world through `file_to_world`) filtered by `kernel` —
    /// divided by ∫K dω for GGX (`chain_norm`, `norm` here so that a frame computes it once),
    /// as is for the cosine — to level `level` of the cube `dst`. The count is read on the GPU.
    /// Span: "add lights".
    #[allow(clippy::too_many_arguments)]
    pub fn record_add(
        &self,
        rec: &mut Recorder,
        from: &GpuExtraction,
        file_to_world: glam::DMat3,
        kernel: LightKernel,
        norm: f64,
        dst: &GpuEnvMap,
        level: u32,
    ) -> Result<()> {
        let unit = LevelLayers {
            level,
            layers: 0..6,
        };
        self.record_add_to(rec, from, file_to_world, kernel, norm, dst, &unit)
    }

    /// [`Extractor::record_add`] to some faces of a level only (`unit`): what a time slice
    /// of the chain refilters ([`crate::passes::split_sum::time_slices`]). Span: "add lights".
    #[allow(clippy::too_many_arguments)]
    pub fn record_add_to(
        &self,
        rec: &mut Recorder,
        from: &GpuExtraction,
        file_to_world: glam::DMat3,
        kernel: LightKernel,
        norm: f64,
        dst: &GpuEnvMap,
        unit: &LevelLayers,
    ) -> Result<()> {
        let (level, faces) = (unit.level, unit.layers.clone());
        if dst.mapping != Mapping::Cube
            || level >= dst.mips()
            || faces.start >= faces.end
            || faces.end > 6
        {
            return Err(Error::Invalid(format!(
                "adding lights: level {level} faces {faces:?} of the {} map '{}' with {} levels \
                 (a cube's level and faces expected)",
                dst.mapping.name(),
                dst.image.name(),
                dst.mips()
            )));
        }
        let (kind, alpha) = match kernel {
            LightKernel::Cosine => (KERNEL_COSINE, 0.0),
            LightKernel::Ggx { alpha } => (KERNEL_GGX, alpha),
        };
        let size = dst.level_size(level).0;
        let r = &from.residual;
        let push = ExtractAddPush {
            file_to_world: crate::gpu::mat3_rows(file_to_world),
            map_size: [r.width, r.height],
            mapping: r.mapping.id(),
            size,
            kernel: kind,
            alpha: alpha as f32,
            inv_norm: (1.0 / norm) as f32,
            layer: faces.start,
        };
        rec.span("add lights", |rec| {
            rec.dispatch(
                &self.add,
                &[
                    (binding::EXTRACT_ADD_STATE, Bind::Buffer(&from.state)),
                    (binding::EXTRACT_ADD_LIGHTS, Bind::Buffer(&from.lights)),
                    (
                        binding::EXTRACT_ADD_DST,
                        Bind::StorageLevel(&dst.image, level),
                    ),
                ],
                &push,
                groups_2d(size, size, faces.len() as u32),
            )
        })?;
        poison::image(rec, PassId::Extract, &dst.image, level..level + 1)
    }

    /// Records the gathering of `from`'s kept lights (an extraction recorded earlier, of a map
    /// whose file directions reach the world through `file_to_world`) into the clusters of a
    /// `grid` × `grid`/2 lat-long grid (`math::lights::clusters`' rule: the non-empty cells,
    /// row-major) at vec4 `at` of `out`, `CLUSTER_VEC4S` vec4s a cell, their count (as a
    /// float in x) after the room for every cell: what SH irradiance and prefiltered
    /// irradiance maps add per pixel. The records' count is read on the GPU; a scratch buffer of the recorder's holds the counting sort. Span: "light
    /// clusters (gpu)".
    pub fn record_clusters(
        &self,
        rec: &mut Recorder,
        from: &GpuExtraction,
        file_to_world: glam::DMat3,
        grid: u32,
        out: &Buffer,
        at: u32,
    ) -> Result<()> {
        let cells = grid as u64 * (grid as u64 / 2).max(1);
        if grid == 0 || out.size() < (at as u64 + cells * CLUSTER_VEC4S as u64 + 1) * 16 {
            return Err(Error::Invalid(format!(
                "light clusters: {cells} cells from vec4 {at} do not fit a buffer of {} bytes",
                out.size()
            )));
        }
        let words = CLUSTER_SORT_CELL_ARRAYS as u64 * cells
            + CLUSTER_SORT_RECORD_ARRAYS as u64 * from.max as u64;
        let sort = rec.scratch(
            "light clusters sort",
            words * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        )?;
        let push = |m| ExtractClustersPush {
            file_to_world: crate::gpu::mat3_rows(file_to_world),
            mode: m,
            grid,
            at,
            max: from.max,
        };
        let binds = [
            (binding::CLUSTERS_STATE, Bind::Buffer(&from.state)),
            (binding::CLUSTERS_LIGHTS, Bind::Buffer(&from.lights)),
            (binding::CLUSTERS_SORT, Bind::Buffer(&sort)),
            (binding::CLUSTERS_OUT, Bind::Buffer(out)),
        ];
        let records = (&from.state, GpuExtraction::light_args());
        let p = &self.clusters;
        rec.span("light clusters (gpu)", |rec| {
            rec.fill_buffer(&sort, cells * 4, 0);
            rec.dispatch_indirect(p, &binds, &push(clusters_mode::COUNT), records)?;
            rec.dispatch(p, &binds, &push(clusters_mode::SCAN), [1, 1, 1])?;
            rec.dispatch_indirect(p, &binds, &push(clusters_mode::SCATTER), records)?;
            let groups = groups(cells as u32, WORKGROUP_1D);
            rec.dispatch(p, &binds, &push(clusters_mode::SUM), [groups, 1, 1])
        })
    }

    /// Records the preparation of `from`'s kept light records (an extraction recorded
    /// earlier, of a map whose file directions reach the world through `file_to_world`) for
    /// the shade pass's light walk, into `out` (made by [`super::GpuLights::on_gpu`] with room
    /// for `from.max()` texels): the records ordered by a spatial key, each texel's header
    /// and quadrature of (2·cells)² nodes in that order, the tree over them
    /// (`crate::math::light_tree::LightTree::implicit`), and where `out` keeps them
    /// ([`super::GpuLights::on_gpu_local`]) each texel's coarser quadratures
    /// (`crate::math::lights::prepare_local`'s). The count is read on the GPU; a
    /// scratch buffer of the recorder's holds the sort. Span: "prepare lights (gpu)".
    pub fn record_prepare(
        &self,
        rec: &mut Recorder,
        from: &GpuExtraction,
        file_to_world: glam::DMat3,
        out: &super::GpuLights,
    ) -> Result<()> {
        let nodes = out.stride() - crate::abi::lights::HEADER_VEC4S;
        let cells = (nodes as f64).sqrt() as u32 / 2;
        let room = super::GpuLights::tree_room(from.max);
        if out.count() != from.max || out.tree_nodes() != room || 4 * cells * cells != nodes {
            return Err(Error::Invalid(format!(
                "prepare lights: a lights buffer with room for {} texels of {nodes} nodes and \
                 {} tree nodes cannot hold an extraction of {} (room for each texel, an even \
                 square of nodes, and {room} tree nodes)",
                out.count(),
                out.tree_nodes(),
                from.max
            )));
        }
        let buckets = 1u64 << TREE_BUCKET_BITS;
        let words = TREE_SORT_BUCKET_ARRAYS as u64 * buckets
            + TREE_SORT_RECORD_ARRAYS as u64 * from.max as u64;
        let sort = rec.scratch(
            "light tree sort",
            words * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        )?;
        let r = &from.residual;
        let push = |mode| ExtractPreparePush {
            file_to_world: crate::gpu::mat3_rows(file_to_world),
            map_size: [r.width, r.height],
            mapping: r.mapping.id(),
            cells,
            stride: out.stride(),
            tree_at: out.tree_at(),
            max: from.max,
            mode,
            tree_room: room,
            coarse_at: out.coarse_at(),
            pad: [0; 2],
        };
        let binds = [
            (binding::PREPARE_STATE, Bind::Buffer(&from.state)),
            (binding::PREPARE_LIGHTS, Bind::Buffer(&from.lights)),
            (binding::PREPARE_OUT, Bind::Buffer(out.buffer())),
            (binding::PREPARE_SORT, Bind::Buffer(&sort)),
        ];
        let p = &self.prepare;
        // The passes over the records take the extraction's own workgroup count (a dispatch
        // sized by the cap would start its workgroups for nothing: 256 of them at the chain's
        // 16384).
        let records = (&from.state, GpuExtraction::light_args());
        rec.span("prepare lights (gpu)", |rec| {
            rec.fill_buffer(&sort, buckets * 4, 0);
            rec.dispatch_indirect(p, &binds, &push(prepare_mode::KEYS), records)?;
            rec.dispatch(p, &binds, &push(prepare_mode::SCAN), [1, 1, 1])?;
            rec.dispatch_indirect(p, &binds, &push(prepare_mode::SCATTER), records)?;
            rec.dispatch_indirect(p, &binds, &push(prepare_mode::TEXELS), records)?;
            rec.dispatch_indirect(p, &binds, &push(prepare_mode::NODES), records)
        })
    }

    /// Uploads `map`, projects its band 0, extracts by `opts` (no `fill`), gathers the lights
    /// into the clusters of a `grid` × `grid`/2 grid (file frame = world) and reads back those
    /// in use, row-major, waiting (for tests).
    pub fn run_clusters(
        &self,
        map: &EnvMap,
        opts: &ExtractOptions,
        grid: u32,
    ) -> Result<Vec<[[f32; 3]; 3]>> {
        let gpu = GpuEnvMap::upload(&self.ctx, map)?;
        let max = u32::try_from(opts.max_texels)
            .map_err(|_| Error::Invalid(format!("{} light texels", opts.max_texels)))?;
        let out = GpuExtraction::new(&self.ctx, map.mapping, map.width, map.height, max)?;
        let projector = ShProjector::new(&self.ctx, crate::passes::Subgroups::Auto)?;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        let sh = Buffer::new(
            &self.ctx,
            "extraction L00",
            ShProjector::output_bytes(0),
            usage,
            MemoryLocation::GpuOnly,
        )?;
        let cells = (grid * (grid / 2).max(1)) as usize;
        let bytes = ((cells * CLUSTER_VEC4S as usize + 1) * 16) as u64;
        let clusters = Buffer::new(
            &self.ctx,
            "clusters",
            bytes,
            usage | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let host = Buffer::new(
            &self.ctx,
            "clusters (host)",
            bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        self.ctx.run_untimed("light clusters", |rec| {
            projector.record_into(rec, &gpu, 0, &Orientation::default(), &sh)?;
            self.record(rec, &gpu, &sh, opts.ratio, &out)?;
            self.record_clusters(rec, &out, glam::DMat3::IDENTITY, grid, &clusters, 0)?;
            rec.copy_buffer(&clusters, &host, bytes);
            rec.use_buffer(&host, Usage::HostRead);
            Ok(())
        })?;
        let v: Vec<[f32; 4]> = host.read(cells * CLUSTER_VEC4S as usize + 1);
        let used = v[cells * CLUSTER_VEC4S as usize][0] as usize;
        Ok(v[..used.min(cells) * CLUSTER_VEC4S as usize]
            .chunks_exact(CLUSTER_VEC4S as usize)
            .map(|c| [0, 1, 2].map(|ch| [c[ch][0], c[ch][1], c[ch][2]]))
            .collect())
    }

    /// Uploads `map`, projects its band 0, extracts by `opts` and reads everything
    /// back, waiting (for tests and one-off jobs).
    pub fn run(&self, map: &EnvMap, opts: &ExtractOptions) -> Result<Timed<Extracted>> {
        let gpu = GpuEnvMap::upload(&self.ctx, map)?;
        self.run_on(&gpu, opts)
    }

    /// [`Extractor::run`] on a map already on the GPU.
    pub fn run_on(&self, gpu: &GpuEnvMap, opts: &ExtractOptions) -> Result<Timed<Extracted>> {
        self.run_then(gpu, opts, |_, _| Ok(()))
    }

    /// [`Extractor::run`], then the records prepared into `lights`
    /// ([`Extractor::record_prepare`], `file_to_world` turning their directions) in the same
    /// submission; returns the extraction and `lights`' whole buffer, waiting (for tests).
    pub fn run_prepared(
        &self,
        map: &EnvMap,
        opts: &ExtractOptions,
        file_to_world: glam::DMat3,
        lights: &super::GpuLights,
    ) -> Result<(Extracted, Vec<[f32; 4]>)> {
        let gpu = GpuEnvMap::upload(&self.ctx, map)?;
        let bytes = lights.buffer().size();
        let host = Buffer::new(
            &self.ctx,
            "prepared lights (host)",
            bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let Timed { value: ex, .. } = self.run_then(&gpu, opts, |rec, out| {
            self.record_prepare(rec, out, file_to_world, lights)?;
            rec.copy_buffer(lights.buffer(), &host, bytes);
            rec.use_buffer(&host, Usage::HostRead);
            Ok(())
        })?;
        Ok((ex, host.read((bytes / 16) as usize)))
    }

    /// [`Extractor::run_on`], `then` recorded after the extraction in the same submission.
    fn run_then(
        &self,
        gpu: &GpuEnvMap,
        opts: &ExtractOptions,
        then: impl FnOnce(&mut Recorder, &GpuExtraction) -> Result<()>,
    ) -> Result<Timed<Extracted>> {
        let max = u32::try_from(opts.max_texels)
            .map_err(|_| Error::Invalid(format!("{} light texels", opts.max_texels)))?;
        let out = GpuExtraction::with_fill(
            &self.ctx,
            gpu.mapping,
            gpu.width,
            gpu.height,
            max,
            opts.fill,
        )?;
        let projector = ShProjector::new(&self.ctx, crate::passes::Subgroups::Auto)?;
        let sh = Buffer::new(
            &self.ctx,
            "extraction L00",
            ShProjector::output_bytes(0),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let words = EXTRACT_HEADER_WORDS as usize;
        let host = |name, bytes| {
            Buffer::new(
                &self.ctx,
                name,
                bytes,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )
        };
        let header = host("extraction header", words as u64 * 4)?;
        let records = host("extraction records", out.lights.size())?;
        let Timed {
            value: (residual, ()),
            timings: t,
        } = self.ctx.run("extracting lights", |rec| {
            projector.record_into(rec, gpu, 0, &Orientation::default(), &sh)?;
            self.record(rec, gpu, &sh, opts.ratio, &out)?;
            rec.copy_buffer(&out.state, &header, words as u64 * 4);
            rec.copy_buffer(&out.lights, &records, out.lights.size());
            rec.use_buffer(&header, Usage::HostRead);
            rec.use_buffer(&records, Usage::HostRead);
            then(rec, &out)?;
            Ok((out.residual.record_download(rec, 0)?, ()))
        })?;
        let h: Vec<u32> = header.read(words);
        let stats = ExtractStats {
            tau: f32::from_bits(h[word::TAU as usize]),
            threshold: f32::from_bits(h[word::THRESHOLD as usize]),
            candidates: h[word::CANDIDATES as usize],
            kept: h[word::KEPT as usize],
            nonfinite: h[word::NONFINITE as usize],
            grown: h[word::GROWN as usize],
            members: h[word::ACCEPTED as usize],
            rounds: h[word::ROUNDS as usize],
            light_groups: {
                let a = word::LIGHT_ARGS as usize;
                [h[a], h[a + 1], h[a + 2]]
            },
        };
        let written = h[word::COUNTER as usize].min(max) as usize;
        let raw: Vec<[u32; RECORD_WORDS]> = records.read(written);
        let lights = raw.iter().map(record_of).collect();
        let texels = residual.read();
        let residual = EnvMap::new(
            gpu.mapping,
            gpu.width,
            gpu.height,
            texels.into_iter().map(|t| [t[0], t[1], t[2]]).collect(),
        );
        Ok(Timed::new(
            Extracted {
                stats,
                lights,
                residual,
            },
            t,
        ))
    }
}

/// Words of a light record.
const RECORD_WORDS: usize = EXTRACT_RECORD_VEC4S as usize * 4;

/// A record from its words.
fn record_of(r: &[u32; RECORD_WORDS]) -> GpuLightTexel {
    let f = |k: usize| f32::from_bits(r[k]);
    GpuLightTexel {
        dir: [f(0), f(1), f(2)],
        omega: f(3),
        excess: [f(4), f(5), f(6)],
        luminance: f(7),
        texel: [r[8], r[9], r[10]],
    }
}

/// The checks [`Extractor::record`] makes before recording anything.
fn check_inputs(map: &GpuEnvMap, sh: &Buffer, ratio: f64, out: &GpuExtraction) -> Result<()> {
    let name = map.image.name();
    if !map
        .image
        .desc()
        .usage
        .contains(vk::ImageUsageFlags::SAMPLED)
    {
        return Err(Error::Invalid(format!(
            "light extraction: the image '{name}' was made without SAMPLED usage, which the \
             extraction reads it through"
        )));
    }
    if !out.fits(map) {
        let r = &out.residual;
        return Err(Error::Invalid(format!(
            "light extraction: the image '{name}' is a {} x {} {} map, but the extraction's \
             resources were made for {} x {} {} maps",
            map.width,
            map.height,
            map.mapping.name(),
            r.width,
            r.height,
            r.mapping.name()
        )));
    }
    if sh.size() < ShProjector::output_bytes(0) {
        return Err(Error::Invalid(
            "light extraction: the SH buffer holds no band-0 coefficient".into(),
        ));
    }
    if !(ratio.is_finite() && ratio > 0.0) {
        return Err(Error::Invalid(format!(
            "light extraction: the ratio {ratio} is not a positive number"
        )));
    }
    Ok(())
}
