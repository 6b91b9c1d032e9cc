//! Irradiance and Phong-prefiltered environment maps by brute-force convolution of every
//! source texel (Miller & Hoffman 1984, `glsl/brute.comp`, float64 twin
//! [`crate::math::filter`]).

use super::map::GpuEnvMap;
use crate::abi::{
    binding, constants, push::BrutePush, ShaderId, BRUTE_TILE, WORKGROUP_1D, WORKGROUP_2D,
};
use crate::error::{Error, Result};
use crate::gpu::{
    groups, mat3_rows, Bind, Buffer, Context, Image, ImageDesc, Pipeline, Recorder, Sampler, Timing,
};
use crate::math::filter::{self, Kernel};
use crate::math::moments;
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
    /// Per source mapping, specialised on it.
    moments: [OnceLock<Pipeline>; 4],
    /// Per (source, destination) mapping pair, source kind (texels or a moment level), walk
    /// structure ([`BruteFilter::set_cells_walk`]) and lanes per output
    /// ([`BruteFilter::set_texel_lanes`]), specialised on all five ([`pipeline_slot`]).
    brute: [OnceLock<Pipeline>; PIPELINE_SLOTS],
    /// Per destination mapping.
    resolve: [OnceLock<Pipeline>; 4],
    sampler: Sampler,
    target_invocations: u32,
    /// Whether texels that take Gauss cells are summed in a second walk (glsl/brute.comp,
    /// CELLS_WALK): on CPU devices.
    cells_walk: bool,
    /// Invocations per output texel, each summing every `texel_lanes`-th slot of a tile
    /// (glsl/brute.comp, TEXEL_LANES): the subgroup size on CPU devices, 1 elsewhere.
    texel_lanes: u32,
    /// Whether one-level convolutions take the visit floor ([`BruteFilter::set_visit_floor`]).
    visit_floor: bool,
}

/// Largest lane count per output texel ([`BruteFilter::set_texel_lanes`]).
pub const MAX_TEXEL_LANES: u32 = 32;

/// Lane counts (powers of two up to [`MAX_TEXEL_LANES`]) times the 64 other variants, with
/// the rule or the visit floor.
const PIPELINE_SLOTS: usize = 2 * 64 * (MAX_TEXEL_LANES.trailing_zeros() as usize + 1);

/// The brute pipeline's slot for source and destination mapping ids, source kind, walk
/// structure, lanes per output (a power of two) and the visit floor.
fn pipeline_slot(
    from: u32,
    to: u32,
    moment: bool,
    cells_walk: bool,
    lanes: u32,
    visit_floor: bool,
) -> usize {
    (PIPELINE_SLOTS / 2) * visit_floor as usize
        + 64 * lanes.trailing_zeros() as usize
        + 4 * (4 * from + to) as usize
        + 2 * cells_walk as usize
        + moment as usize
}

/// The lanes per output a device takes by default: its subgroup size (a power of two at
/// most [`MAX_TEXEL_LANES`]) on CPU devices, whose subgroups are SIMD lanes of neighbouring
/// invocations, so that one output's lanes run as one group; 1 elsewhere.
fn default_texel_lanes(info: &crate::gpu::DeviceInfo) -> u32 {
    if info.device_type != vk::PhysicalDeviceType::CPU || info.subgroup_size < 2 {
        return 1;
    }
    lane_count(info.subgroup_size)
}

/// `lanes` clamped to 1 … [`MAX_TEXEL_LANES`] and rounded down to a power of two (the
/// pipelines are cached per power).
fn lane_count(lanes: u32) -> u32 {
    1 << (31 - lanes.clamp(1, MAX_TEXEL_LANES).leading_zeros())
}

/// Invocations a convolution keeps busy by default: outputs smaller than this (the coarse
/// Phong levels: 6 texels at 1²) split the source among parts, each summed by its own
/// invocation, then added per texel. An H100 holds ~270 000 resident invocations; beyond
/// 65 536 the coarse levels measured no faster.
pub const DEFAULT_TARGET_INVOCATIONS: u32 = 1 << 16;

impl BruteFilter {
    /// Builds the tile pipeline; the others are built, specialised, when a run needs them.
    pub fn new(ctx: &Context) -> Result<BruteFilter> {
        Ok(BruteFilter {
            ctx: ctx.clone(),
            prepare: Default::default(),
            tiles: Pipeline::compute(ctx, ShaderId::BruteTiles, &[WORKGROUP_1D])?,
            moments: Default::default(),
            brute: std::array::from_fn(|_| OnceLock::new()),
            resolve: Default::default(),
            sampler: Sampler::linear_clamp(ctx, "brute sampler")?,
            target_invocations: DEFAULT_TARGET_INVOCATIONS,
            cells_walk: ctx.info().device_type == vk::PhysicalDeviceType::CPU,
            texel_lanes: default_texel_lanes(ctx.info()),
            visit_floor: false,
        })
    }

    /// Sums the texels that take Gauss cells in a second walk over the source (`true`, the
    /// default on CPU devices, which run every branch of a loop's body, so that the cells' nodes
    /// leave the first walk's loop) or in the one walk (the default elsewhere). The sums differ
    /// by float rounding only.
    pub fn set_cells_walk(&mut self, on: bool) {
        self.cells_walk = on;
    }

    /// Sets how many invocations sum each output texel, each taking every `lanes`-th source
    /// slot (rounded down to a power of two, 1 to [`MAX_TEXEL_LANES`]); with more than one,
    /// a lat-long source is walked row by row over the lobe's reach only. On CPU devices the
    /// default is the SIMD width: one output per SIMD group, so the group walks only that
    /// output's texels. 1, the default elsewhere, gives each invocation its own output and
    /// every tile. The sums differ by float rounding only.
    pub fn set_texel_lanes(&mut self, lanes: u32) {
        self.texel_lanes = lane_count(lanes);
    }

    /// Makes one-level convolutions ([`BruteFilter::record`], [`BruteFilter::run`]) a benchmark
    /// instrument instead (`true`): each output texel gets Σ L·Ω over the source texels its
    /// walk visits (the same rows or tiles, the same lanes and chunks), read once each,
    /// without the rule, so that its time is what visiting the exact sum's texels costs
    /// (`envlight bench peers`). Not a filtered map; [`BruteFilter::record_levels`] refuses it.
    pub fn set_visit_floor(&mut self, on: bool) {
        self.visit_floor = on;
    }

    /// Sets how many invocations a convolution aims to keep busy by splitting the source among
    /// parts where the output has fewer texels (default [`DEFAULT_TARGET_INVOCATIONS`]; 1
    /// never splits). The parts' sums differ from one sum by float rounding only.
    pub fn set_target_invocations(&mut self, invocations: u32) {
        self.target_invocations = invocations.max(1);
    }

    /// Records the convolution of `src` (oriented by `orientation`) with `kernel` into
    /// `dst`, in the world frame, over every source texel: irradiance E(n) for
    /// [`Kernel::Cosine`], the normalised Phong prefilter indexed by the reflection direction
    /// for [`Kernel::Phong`]. Spans: "brute prepare", "brute tiles", then "brute irradiance" or
    /// "brute phong".
    pub fn record(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
        dst: &GpuEnvMap,
    ) -> Result<()> {
        let prep = self.prepare(rec, src, orientation, kernel)?;
        self.convolve(rec, &prep, None, kernel, dst)?;
        rec.keep(prep);
        Ok(())
    }

    /// Records one convolution per `(kernel, dst)` pair, each from the source level of the
    /// power-moment pyramid that [`moments::level_for`] picks for its lobe (level 0, every
    /// source texel, for the sharpest lobes; coarse levels for wide ones, descending to the
    /// source texels wherever the rule cannot take a coarse texel whole). Returns the levels.
    /// Spans: "brute prepare", "brute tiles", "brute moments" per level built, then one
    /// "brute phong" per output.
    pub fn record_levels(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        orientation: &Orientation,
        outputs: &[(Kernel, &GpuEnvMap)],
    ) -> Result<Vec<u32>> {
        if self.visit_floor {
            return Err(Error::Invalid(
                "the visit floor measures one-level convolutions, not Phong levels".into(),
            ));
        }
        let Some(sharpest) = outputs
            .iter()
            .map(|o| o.0)
            .max_by(|a, b| a.exponent().total_cmp(&b.exponent()))
        else {
            return Ok(Vec::new());
        };
        let prep = self.prepare(rec, src, orientation, sharpest)?;
        let mut levels: Vec<(u32, CoarseLevel)> = Vec::new();
        let mut chosen = Vec::new();
        for &(kernel, dst) in outputs {
            let s = moments::level_for(kernel, src.mapping, src.width, src.height);
            chosen.push(s);
            if s > 0 && !levels.iter().any(|l| l.0 == s) {
                let level = self.build_level(rec, &prep, s)?;
                levels.push((s, level));
            }
            let coarse = levels.iter().find(|l| l.0 == s).map(|l| &l.1);
            self.convolve(rec, &prep, coarse, kernel, dst)?;
        }
        rec.keep((prep, levels));
        Ok(chosen)
    }

    /// Checks the kernel and records the per-texel preparation and its tiles.
    fn prepare(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
    ) -> Result<PreparedSource> {
        check_kernel(kernel)?;
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
        let texels = src.width * src.height * src.mapping.layers();
        let ctx = rec.context().clone();
        let (w, h, layers) = (src.width, src.height, src.mapping.layers());
        let cones = texel_image(&ctx, "brute cones", w, h, layers)?;
        let rad = texel_image(&ctx, "brute radiance", w, h, layers)?;
        let shapes = texel_image(&ctx, "brute shapes", w, h, 3 * layers)?;
        let push = BrutePush {
            file_to_world: mat3_rows(orientation.checked_world_to_file()?.transpose()),
            src_size: [src.width, src.height],
            dst_size: [0, 0],
            src_mapping: src.mapping.id(),
            dst_mapping: 0,
            texels,
            exponent: 0.0,
            chunk_begin: 0,
            chunk_end: 0,
            src_layers: src.mapping.layers(),
            src_level: 0,
            parts: [1, 1],
            part_slots: 0,
            pad: 0,
        };
        let from = src.mapping.id();
        // Prepare reads only the source mapping (constant 3 is unused there).
        let prepare = Pipeline::compute_once(
            &self.prepare[from as usize],
            &self.ctx,
            ShaderId::BrutePrepare,
            &[WORKGROUP_1D, 1, from, 0],
        )?;
        rec.span("brute prepare", |rec| {
            rec.dispatch(
                prepare,
                &[
                    (
                        binding::BRUTE_PREP_SRC,
                        Bind::Sampled(&src.image, &self.sampler, false),
                    ),
                    (binding::BRUTE_PREP_CONES, Bind::Storage(&cones)),
                    (binding::BRUTE_PREP_RADIANCE, Bind::Storage(&rad)),
                    (binding::BRUTE_PREP_SHAPES, Bind::Storage(&shapes)),
                ],
                &push,
                grid_1d(&ctx, texels),
            )
        })?;
        let tiles = self.record_tiles(rec, &cones, &push)?;
        Ok(PreparedSource {
            cones,
            rad,
            shapes,
            tiles,
            push,
            mapping: src.mapping,
            size: (src.width, src.height),
        })
    }

    /// Records the tiles' bounding cones over `cones` (a map of `push.src_size`).
    fn record_tiles(&self, rec: &mut Recorder, cones: &Image, push: &BrutePush) -> Result<Buffer> {
        let ctx = rec.context().clone();
        let tile_count = tile_count(push);
        let tiles = scratch(&ctx, "brute tiles", tile_count as u64 * 16)?;
        rec.span("brute tiles", |rec| {
            rec.dispatch(
                &self.tiles,
                &[
                    (binding::BRUTE_TILE_CONES, Bind::Storage(cones)),
                    (binding::BRUTE_TILE_OUT, Bind::Buffer(&tiles)),
                ],
                push,
                grid_1d(&ctx, tile_count),
            )
        })?;
        Ok(tiles)
    }

    /// Records level `s` of the moment pyramid of a prepared source, and its tiles.
    fn build_level(
        &self,
        rec: &mut Recorder,
        prep: &PreparedSource,
        s: u32,
    ) -> Result<CoarseLevel> {
        let ctx = rec.context().clone();
        let (w, h) = (prep.size.0 >> s, prep.size.1 >> s);
        let texels = w * h * prep.mapping.layers();
        let layers = prep.mapping.layers();
        let cones = texel_image(&ctx, "brute level cones", w, h, layers)?;
        let light = texel_image(&ctx, "brute level light", w, h, 9 * layers)?;
        let push = BrutePush {
            src_size: [w, h],
            texels,
            src_level: s,
            ..prep.push
        };
        let from = prep.mapping.id();
        let pipeline = Pipeline::compute_once(
            &self.moments[from as usize],
            &self.ctx,
            ShaderId::BruteMoments,
            &[WORKGROUP_1D, 1, from, 0],
        )?;
        rec.span("brute moments", |rec| {
            rec.dispatch(
                pipeline,
                &[
                    (binding::BRUTE_MOM_RADIANCE, Bind::Storage(&prep.rad)),
                    (binding::BRUTE_MOM_SHAPES, Bind::Storage(&prep.shapes)),
                    (binding::BRUTE_MOM_CONES, Bind::Storage(&cones)),
                    (binding::BRUTE_MOM_LIGHT, Bind::Storage(&light)),
                ],
                &push,
                grid_1d(&ctx, texels),
            )
        })?;
        let tiles = self.record_tiles(rec, &cones, &push)?;
        Ok(CoarseLevel {
            cones,
            light,
            tiles,
            push,
        })
    }

    /// Records the sum into `dst` over the prepared texels, or over a level of the pyramid.
    fn convolve(
        &self,
        rec: &mut Recorder,
        prep: &PreparedSource,
        coarse: Option<&CoarseLevel>,
        kernel: Kernel,
        dst: &GpuEnvMap,
    ) -> Result<()> {
        let exponent = check_kernel(kernel)?;
        let ctx = rec.context().clone();
        let (w, h) = (dst.width, dst.height);
        let base = coarse.map_or(prep.push, |c| c.push);
        // A coarse texel may descend to all of its 4^s prepared texels.
        let descent = coarse.map_or(1, |c| 1u32 << (2 * c.push.src_level));
        let outputs = w * h * dst.mapping.layers();
        // Slots: the texels of tiles (walk), or with lanes on a lat-long source its texels,
        // row-major (walk_rows).
        let split_for = |lanes: u32| {
            let rows = lanes > 1 && prep.mapping == Mapping::LatLong;
            let slots = if rows {
                base.src_size[0] * base.src_size[1]
            } else {
                tile_count(&base) * BRUTE_TILE * BRUTE_TILE
            };
            let row = rows.then_some(base.src_size[0]);
            let chunk = self.chunk_size(prep, kernel, descent, lanes, row);
            let target = self.target_invocations.div_ceil(lanes);
            // A row's reach is walked whole in a chunk's first and last row: a chunk must
            // hold a row, or the loop limit could cut it short.
            let fits = row.is_none_or(|w| chunk >= w);
            (
                lanes,
                slots,
                Split::new(outputs, slots, chunk, target),
                fits,
            )
        };
        // Lanes share a part's slots: where the parts are shorter than the lanes (the
        // coarsest Phong levels, a few outputs split into parts of a slot or two), most lanes
        // would idle, and the parts alone fill the device (cube 1: 93 -> 258 ms with 8).
        let (lanes, slots, split, _) = match split_for(self.texel_lanes) {
            (lanes, _, split, fits) if split.part_slots < lanes || !fits => split_for(1),
            chosen => chosen,
        };
        let partials = scratch(
            &ctx,
            "brute partial sums",
            outputs as u64 * split.parts() as u64 * lanes as u64 * 32,
        )?;
        let push = BrutePush {
            dst_size: [w, h],
            dst_mapping: dst.mapping.id(),
            exponent,
            parts: split.grid,
            part_slots: split.part_slots,
            ..base
        };
        let (from, to) = (prep.mapping.id(), dst.mapping.id());
        let moment = coarse.is_some();
        let brute = Pipeline::compute_once(
            &self.brute[pipeline_slot(from, to, moment, self.cells_walk, lanes, self.visit_floor)],
            &self.ctx,
            if self.visit_floor {
                ShaderId::BruteVisits
            } else if matches!(prep.mapping, Mapping::Angular | Mapping::DualParaboloid) {
                ShaderId::BruteDisc
            } else {
                ShaderId::Brute
            },
            &[
                WORKGROUP_2D[0],
                WORKGROUP_2D[1],
                from,
                to,
                moment as u32,
                self.cells_walk as u32,
                lanes,
            ],
        )?;
        // The resolve reads only the destination mapping (constant 2 is unused there).
        let resolve = Pipeline::compute_once(
            &self.resolve[to as usize],
            &self.ctx,
            ShaderId::BruteResolve,
            &[WORKGROUP_2D[0], WORKGROUP_2D[1], 0, to],
        )?;
        let label = match kernel {
            Kernel::Cosine => "brute irradiance",
            Kernel::Phong { .. } => "brute phong",
        };
        let tiles = coarse.map_or(&prep.tiles, |c| &c.tiles);
        // Without a moment source, the level bindings are not read: bind the fine buffers.
        let (coarse_cones, light) =
            coarse.map_or((&prep.cones, &prep.shapes), |c| (&c.cones, &c.light));
        let per_dispatch = split.parts() * split.part_slots;
        rec.discard(&dst.image);
        rec.span(label, |rec| {
            // The first chunk starts the sums (its shader run sees chunk_begin = 0).
            let mut begin = 0;
            while begin < slots {
                let end = slots.min(begin.saturating_add(per_dispatch));
                rec.dispatch(
                    brute,
                    &[
                        (binding::BRUTE_CONES, Bind::Storage(&prep.cones)),
                        (binding::BRUTE_RADIANCE, Bind::Storage(&prep.rad)),
                        (binding::BRUTE_PARTIALS, Bind::Buffer(&partials)),
                        (binding::BRUTE_TILES, Bind::Buffer(tiles)),
                        (binding::BRUTE_SHAPES, Bind::Storage(&prep.shapes)),
                        (binding::BRUTE_COARSE_CONES, Bind::Storage(coarse_cones)),
                        (binding::BRUTE_LIGHT, Bind::Storage(light)),
                    ],
                    &BrutePush {
                        chunk_begin: begin,
                        chunk_end: end,
                        ..push
                    },
                    [
                        groups(w * split.grid[0] * lanes, WORKGROUP_2D[0]),
                        groups(h * split.grid[1], WORKGROUP_2D[1]),
                        dst.mapping.layers(),
                    ],
                )?;
                begin = end;
            }
            // Each part's lanes are parts of their own to the resolve.
            rec.dispatch(
                resolve,
                &[
                    (binding::BRUTE_RESOLVE_PARTIALS, Bind::Buffer(&partials)),
                    (binding::BRUTE_RESOLVE_DST, Bind::Storage(&dst.image)),
                ],
                &BrutePush {
                    parts: [split.grid[0] * lanes, split.grid[1]],
                    ..push
                },
                [
                    groups(w, WORKGROUP_2D[0]),
                    groups(h, WORKGROUP_2D[1]),
                    dst.mapping.layers(),
                ],
            )
        })?;
        rec.keep(partials);
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

    /// Prefilters `src` into one map per level of `levels` (level k: the lobe of
    /// [`PhongLevels::exponent`], the target size halved k times, at least 1) and waits
    /// (see [`BruteFilter::record_levels`]); returns the maps, each level's source level and
    /// the GPU times.
    pub fn run_levels(
        &self,
        src: &GpuEnvMap,
        orientation: &Orientation,
        levels: &PhongLevels,
        target: FilterTarget,
    ) -> Result<(Vec<GpuEnvMap>, Vec<u32>, Vec<Timing>)> {
        let mut maps = Vec::new();
        for k in 0..levels.count {
            let size = (target.size >> k).max(1);
            let (w, h) = target.to.extent_for_size(size);
            maps.push(GpuEnvMap::new(
                &self.ctx,
                "prefiltered level",
                target.to,
                w,
                h,
            )?);
        }
        let outputs: Vec<_> = maps
            .iter()
            .enumerate()
            .map(|(k, m)| {
                (
                    Kernel::Phong {
                        n: levels.exponent(k as u32),
                    },
                    m,
                )
            })
            .collect();
        let (chosen, t) = self.ctx.run("prefiltered levels", |rec| {
            self.record_levels(rec, src, orientation, &outputs)
        })?;
        Ok((maps, chosen, t))
    }
}

/// One Phong lobe per MIP level, by cmft's rule: level k of `count` has the exponent
/// 2^(scale·(1 − k/(count − 1)) + bias) + 1 (gloss 1 at level 0, 0 at the last; a single
/// level has gloss 1). cmft's `--glossScale 10 --glossBias 1` gives 2049 at level 0 and 3 at
/// the last.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongLevels {
    /// Levels, at least 1.
    pub count: u32,
    /// cmft's glossScale.
    pub scale: f64,
    /// cmft's glossBias.
    pub bias: f64,
}

impl PhongLevels {
    /// The exponent of level `k`.
    pub fn exponent(&self, k: u32) -> f64 {
        let gloss = if self.count > 1 {
            1.0 - k as f64 / (self.count - 1) as f64
        } else {
            1.0
        };
        (self.scale * gloss + self.bias).exp2() + 1.0
    }
}

/// The exponent the shader takes (0 for the cosine), or the error for one out of range.
fn check_kernel(kernel: Kernel) -> Result<f32> {
    let (lo, hi) = constants::PHONG_EXPONENT_RANGE;
    match kernel {
        Kernel::Cosine => Ok(0.0),
        Kernel::Phong { n } if (lo..=hi).contains(&n) => Ok(n as f32),
        Kernel::Phong { n } => Err(Error::Invalid(format!(
            "Phong exponent {n} is outside {lo} to {hi:e}"
        ))),
    }
}

/// An rgba32f storage image of `layers` `w` × `h` layers for per-texel data.
fn texel_image(ctx: &Context, name: &str, w: u32, h: u32, layers: u32) -> Result<Image> {
    Image::new(
        ctx,
        name,
        ImageDesc {
            width: w,
            height: h,
            layers,
            format: vk::Format::R32G32B32A32_SFLOAT,
            usage: vk::ImageUsageFlags::STORAGE,
            cube: false,
            mips: 1,
        },
    )
}

fn scratch(ctx: &Context, name: &str, bytes: u64) -> Result<Buffer> {
    Buffer::new(
        ctx,
        name,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuOnly,
    )
}

/// Tiles of BRUTE_TILE² texels over a map of `push.src_size` and `push.src_layers`.
fn tile_count(push: &BrutePush) -> u32 {
    push.src_size[0].div_ceil(BRUTE_TILE) * push.src_size[1].div_ceil(BRUTE_TILE) * push.src_layers
}

/// Workgroups for one invocation per item, folded into y past the x limit.
fn grid_1d(ctx: &Context, items: u32) -> [u32; 3] {
    let groups = items.div_ceil(WORKGROUP_1D);
    let gx = groups.min(ctx.info().max_workgroup_count.min(65535)).max(1);
    [gx, groups.div_ceil(gx), 1]
}

/// How one convolution splits its source slots among parts, each summed by its own invocation
/// per output texel: as many parts as bring the invocations to the target, at least one slot
/// each, and no part longer than the device's loop chunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Split {
    /// Parts per dispatch, as a grid of output-sized blocks.
    grid: [u32; 2],
    /// Slots each part sums in one dispatch.
    part_slots: u32,
}

impl Split {
    fn new(texels: u32, slots: u32, chunk: u32, target: u32) -> Split {
        let slots = slots.max(1);
        let want = target.div_ceil(texels.max(1)).clamp(1, slots);
        let part_slots = slots.div_ceil(want).min(chunk).max(1);
        let parts = want.min(slots.div_ceil(part_slots));
        let gx = (parts as f64).sqrt().ceil() as u32;
        Split {
            grid: [gx, parts.div_ceil(gx)],
            part_slots,
        }
    }

    fn parts(&self) -> u32 {
        self.grid[0] * self.grid[1]
    }
}

/// The source prepared for the sums: per-texel cones, radiance and shapes, and the tiles.
struct PreparedSource {
    cones: Image,
    rad: Image,
    shapes: Image,
    tiles: Buffer,
    push: BrutePush,
    mapping: Mapping,
    size: (u32, u32),
}

/// One level of the moment pyramid: its cones, light and tiles, and its push block.
struct CoarseLevel {
    cones: Image,
    light: Image,
    tiles: Buffer,
    push: BrutePush,
}

impl BruteFilter {
    /// Source slots per dispatch: all, or where the device cuts long loops short
    /// ([`crate::gpu::DeviceInfo::loop_iteration_limit`]), as many as keep every invocation's
    /// loop iterations within 90% of the limit: one for the texel loop, two where the cells
    /// rule's texels are summed in a second walk over the same slots ([`Self::set_cells_walk`]),
    /// plus, per texel, at most s² cell iterations (s from the rule for the source's widest
    /// texel) or ~130 for a clipped rim texel of an angular or paraboloid source, `descent`
    /// texels a slot (4^s for a coarse level's, which may descend to its prepared texels).
    /// llvmpipe counts the iterations of all loops together. With `lanes` invocations an
    /// output, each takes S/L of a chunk's S slots plus, per group the chunk touches (a tile,
    /// or with `row` a source row of that many texels, walk_rows), one more per piece and
    /// the group loop's own iterations.
    fn chunk_size(
        &self,
        src: &PreparedSource,
        kernel: Kernel,
        descent: u32,
        lanes: u32,
        row: Option<u32>,
    ) -> u32 {
        let Some(limit) = self.ctx.info().loop_iteration_limit else {
            return u32::MAX;
        };

        let (w, h) = src.size;
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
        let walks = if self.cells_walk { 2.0 } else { 1.0 };
        let per_slot = descent as f64 * (walks + (s * s).max(rim));
        let budget = 0.9 * limit as f64;
        // Every slot on one lane: right for one lane, and a bound for few slots on many.
        let whole = ((budget / per_slot) as u32).max(1);
        if lanes == 1 {
            return whole;
        }
        let lanes = lanes as f64;
        if let Some(w) = row {
            // Rows touched R ≤ S/w + 2, each ≤ w/L + 1 iterations (the first and last row's
            // whole reach, not only the chunk's part): ≤ S/L + S/w + 2w/L + 2 in all.
            let w = w as f64;
            let shared = (budget - per_slot * (2.0 * w / lanes + 2.0) - 2.0 * walks)
                / (per_slot / lanes + (per_slot + walks) / w);
            return (shared.max(0.0) as u32).max(1);
        }
        let tile = (BRUTE_TILE * BRUTE_TILE) as f64;
        let shared = (budget - 2.0 * per_slot - 6.0 * walks)
            / (per_slot / lanes + (per_slot + 3.0 * walks) / tile);
        whole.max(shared as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::Split;

    /// Every slot is summed once: the parts of all dispatches cover the slots, no part runs
    /// longer than the loop chunk, and the invocations come within a factor of two of the
    /// target (parts of whole slots round it down, the grid rounds it up).
    #[test]
    fn split_covers_the_slots_within_the_chunk() {
        for (texels, slots, chunk, target) in [
            (6, 8192, u32::MAX, 65536),
            (6, 8192, 1000, 65536),
            (24576, 524288, u32::MAX, 65536),
            (24576, 524288, 1180, 65536),
            (393216, 524288, u32::MAX, 65536),
            (1, 1, u32::MAX, 65536),
            (6, 3, 1, 65536),
            (96, 131072, 7, 1),
        ] {
            let s = Split::new(texels, slots, chunk, target);
            let per_dispatch = s.parts() * s.part_slots;
            assert!(s.part_slots >= 1 && s.part_slots <= chunk, "{s:?}");
            let dispatches = slots.div_ceil(per_dispatch);
            assert!(dispatches * per_dispatch >= slots, "{s:?}");
            if chunk == u32::MAX {
                assert_eq!(dispatches, 1, "{s:?}");
            }
            let invocations = texels as u64 * s.parts() as u64;
            let wanted = (target as u64)
                .max(texels as u64)
                .min(texels as u64 * slots as u64);
            assert!(invocations <= 2 * wanted.max(texels as u64), "{s:?}");
            if chunk == u32::MAX {
                assert!(2 * invocations >= wanted, "{s:?}");
            }
        }
    }
}
