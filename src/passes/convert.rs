//! Conversion of an environment map from any mapping to any other, at any resolution
//! (`glsl/convert.comp`, float64 twin `crate::math::convert`).

use super::map::GpuEnvMap;
use crate::abi::{area, binding, push::ConvertPush, ShaderId, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups, groups_2d, mat3_rows, Bind, Context, Pipeline, Recorder, Sampler, Timed};
use crate::math::{Mapping, Orientation};
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use std::sync::OnceLock;

mod planned;
pub use planned::{ConvertPlan, PLAN_BUDGET_BYTES};

/// Per-call options of [`Converter::run`] and [`Converter::record`]: start from
/// [`ConvertOptions::new`] (or [`Default`]) and change what differs with the `with_*` methods
/// or the fields; new options arrive with defaults that keep today's output.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct ConvertOptions {
    /// Output mapping.
    pub to: Mapping,
    /// Output size: lat-long width (height is half), angular side, cube face side, or
    /// paraboloid half side.
    pub size: u32,
    /// How the source file is oriented relative to the world frame.
    pub orientation: Orientation,
    /// Samples per axis per output texel; `None` picks it from the resolutions
    /// ([`Converter::supersampling`]).
    pub supersample: Option<u32>,
    /// Read the source's nearest texel at each sample instead of filtering bilinearly: the
    /// output texels are then the means of the source texels under them (a box
    /// reconstruction), and a bright texel stays within its own footprint.
    pub nearest: bool,
    /// Chords per edge of a dual-paraboloid texel's footprint polygon in the area conversion
    /// where both of the edge's ends lie in the disc away from the poles, each with its sliver
    /// (`area::PARABOLOID_EDGE_STEPS`, the default where `None`; 1 to `area::POLE_STEPS`).
    /// Power is kept at any count; more chords only place the slivers' areas more finely
    /// among the source texels, and cost time. Other conversions ignore it.
    pub edge_points: Option<u32>,
}

impl ConvertOptions {
    /// To `to` at `size`, the source taken as loaded ([`Orientation::default`]), samples per
    /// texel picked from the resolutions, bilinear reads, and the default points per
    /// paraboloid texel edge.
    pub fn new(to: Mapping, size: u32) -> Self {
        ConvertOptions {
            to,
            size,
            orientation: Orientation::default(),
            supersample: None,
            nearest: false,
            edge_points: None,
        }
    }

    /// The same, with the source oriented as `orientation`.
    pub fn with_orientation(self, orientation: Orientation) -> Self {
        ConvertOptions {
            orientation,
            ..self
        }
    }

    /// The same, with `supersample` samples per axis per output texel (`None`: picked from
    /// the resolutions).
    pub fn with_supersample(self, supersample: Option<u32>) -> Self {
        ConvertOptions {
            supersample,
            ..self
        }
    }

    /// The same, reading the source's nearest texel at each sample where `nearest` is true.
    pub fn with_nearest(self, nearest: bool) -> Self {
        ConvertOptions { nearest, ..self }
    }

    /// The same, with `edge_points` points per paraboloid texel edge (`None`: the default).
    pub fn with_edge_points(self, edge_points: Option<u32>) -> Self {
        ConvertOptions {
            edge_points,
            ..self
        }
    }

    /// The same, for a FIS chain's paraboloid (these options' size) converted from the
    /// light-free residual of a `src` map: unless a lat-long converts by exact areas, samples
    /// at the chain's rate ([`Converter::chain_supersampling`]). The chords per texel edge
    /// stay the default's, so that a plan made for the residual also serves the whole map
    /// where the lights found stay in it (a render's lobes too narrow for them).
    pub fn for_residual_chain(self, src: (Mapping, u32, u32)) -> Self {
        let size = self.size;
        match src.0 {
            Mapping::LatLong => self,
            _ => self.with_supersample(Some(Converter::chain_supersampling(src, size))),
        }
    }
}

impl Default for ConvertOptions {
    /// A 256² cube, with [`ConvertOptions::new`]'s defaults.
    fn default() -> Self {
        ConvertOptions::new(Mapping::Cube, 256)
    }
}

/// `opts`' points per paraboloid texel edge, checked: 1 to [`area::POLE_STEPS`].
fn edge_points(opts: &ConvertOptions) -> Result<u32> {
    let points = opts.edge_points.unwrap_or(area::PARABOLOID_EDGE_STEPS);
    match (1..=area::POLE_STEPS).contains(&points) {
        true => Ok(points),
        false => Err(Error::Invalid(format!(
            "{points} points per paraboloid texel edge: the conversion takes 1 to {}",
            area::POLE_STEPS
        ))),
    }
}

/// Invocations a workgroup of the general walk over a list of texels.
const LIST_GROUP: u32 = 64;

/// Texels that cover the sphere (those inside the disc for angular and paraboloid maps).
fn texels_on_sphere(m: Mapping, w: u32, h: u32) -> f64 {
    let n = w as f64 * h as f64;
    match m {
        Mapping::LatLong => n,
        Mapping::Angular => n * std::f64::consts::FRAC_PI_4,
        Mapping::Cube => 6.0 * n,
        Mapping::DualParaboloid => 2.0 * n * std::f64::consts::FRAC_PI_4,
    }
}

/// Bytes of each of a `w` × `h` lat-long map's two slope buffers, dL/dU and dL/dz (a vec4 a
/// texel each).
fn slope_buffer_bytes(w: u32, h: u32) -> u64 {
    w as u64 * h as u64 * 16
}

/// A lat-long source's limited slopes, [dL/dU, dL/dz], each in a buffer of its own (so that
/// each fits one storage buffer range where both together would not).
type Slopes = [std::sync::Arc<crate::gpu::Buffer>; 2];

/// The walks' binds of `slopes`: their texel views.
fn slope_texels(slopes: &Slopes) -> [(u32, Bind<'_>); 2] {
    [
        (binding::CONVERT_SLOPES_U, Bind::Texels(&slopes[0])),
        (binding::CONVERT_SLOPES_Z, Bind::Texels(&slopes[1])),
    ]
}

/// Whether an area conversion with `opts` from a lat-long `src_width` texels wide takes the
/// fast path and a list for the general walk: the fast path's windows sit where the poles are
/// for orientations that keep the Y axis (all that Orientation makes), and its angles from a
/// column's edge stay within 45° only where columns are narrow enough
/// (`area::FAST_MIN_SOURCE_WIDTH`).
fn split_area(opts: &ConvertOptions, src_width: u32) -> Result<bool> {
    Ok(matches!(opts.to, Mapping::Cube | Mapping::DualParaboloid)
        && src_width >= area::FAST_MIN_SOURCE_WIDTH
        && opts.orientation.checked_world_to_file()?.y_axis.abs() == glam::DVec3::Y)
}

/// The push block of a conversion of `src` with `opts` (its sample count picked from the
/// resolutions where `opts` gives none), clamping the residual's texels at `threshold` where
/// the conversion is split.
fn sampled_push(src: &GpuEnvMap, opts: &ConvertOptions, threshold: f64) -> Result<ConvertPush> {
    let (w, h) = opts.to.extent_for_size(opts.size);
    let ss = opts
        .supersample
        .unwrap_or_else(|| {
            Converter::supersampling((src.mapping, src.width, src.height), (opts.to, w, h))
        })
        .max(1);
    Ok(ConvertPush {
        world_to_file: mat3_rows(opts.orientation.checked_world_to_file()?),
        src_size: [src.width, src.height],
        dst_size: [w, h],
        src_mapping: src.mapping.id(),
        dst_mapping: opts.to.id(),
        ss,
        nearest: opts.nearest as u32,
        threshold: threshold as f32,
    })
}

/// Whether converting `src` into `dst` by `opts` reads each output texel's own source texel at
/// its centre and nothing else: a cube or lat-long to the same mapping at the same size, the
/// file's orientation the world's, one bilinear (or nearest) sample a texel. The texels are
/// then the source's, and the pass copies level 0 where both images allow a transfer and share
/// a format.
fn identity_copy(
    src: &GpuEnvMap,
    dst: &GpuEnvMap,
    opts: &ConvertOptions,
    push: &ConvertPush,
) -> bool {
    let (a, b) = (src.image.desc(), dst.image.desc());
    matches!(opts.to, Mapping::Cube | Mapping::LatLong)
        && src.mapping == opts.to
        && (src.width, src.height) == (dst.width, dst.height)
        && push.ss == 1
        && opts.orientation.checked_world_to_file().ok() == Some(glam::DMat3::IDENTITY)
        && a.format == b.format
        && a.usage.contains(vk::ImageUsageFlags::TRANSFER_SRC)
        && b.usage.contains(vk::ImageUsageFlags::TRANSFER_DST)
}

/// The conversion pass. Pipelines are built on first use, one per source kind.
pub struct Converter {
    ctx: Context,
    /// One pipeline per (source, destination) mapping pair, specialised on both.
    pipelines: [OnceLock<Pipeline>; 16],
    /// Lat-long to cube by exact footprint areas in one walk, and the source slopes they
    /// integrate.
    area_cube: OnceLock<Pipeline>,
    /// Lat-long to dual paraboloid by exact footprint areas, one per count of points per
    /// texel edge (`ConvertOptions::edge_points`, a specialisation constant; index count − 1).
    area_paraboloid: [OnceLock<Pipeline>; area::POLE_STEPS as usize],
    /// Lat-long to cube by areas in two dispatches: the fast path over the tiles holding its
    /// texels (`math::convert::area_tiles`), then the general walk over the texels it leaves
    /// (`math::convert::area_general_texels`).
    area_fast: OnceLock<Pipeline>,
    area_list: OnceLock<Pipeline>,
    /// The same to a dual paraboloid, one pair per count of points per texel edge.
    area_fast_paraboloid: [OnceLock<Pipeline>; area::POLE_STEPS as usize],
    area_list_paraboloid: [OnceLock<Pipeline>; area::POLE_STEPS as usize],
    /// A split paraboloid's texels outside its disc.
    area_rim: OnceLock<Pipeline>,
    slopes: OnceLock<Pipeline>,
    /// The gather of a [`ConvertPlan`].
    planned: OnceLock<Pipeline>,
    /// [`Converter::record_split`]'s, one per 2D source mapping.
    split: [OnceLock<Pipeline>; 4],
    sampler: Sampler,
}

impl Converter {
    /// Prepares the pass (no pipeline is built until a run needs it).
    pub fn new(ctx: &Context) -> Result<Converter> {
        Ok(Converter {
            ctx: ctx.clone(),
            pipelines: Default::default(),
            area_cube: OnceLock::new(),
            area_paraboloid: Default::default(),
            area_fast: OnceLock::new(),
            area_list: OnceLock::new(),
            area_fast_paraboloid: Default::default(),
            area_list_paraboloid: Default::default(),
            area_rim: OnceLock::new(),
            slopes: OnceLock::new(),
            planned: OnceLock::new(),
            split: Default::default(),
            sampler: Sampler::linear_clamp(ctx, "convert sampler")?,
        })
    }

    fn pipeline(&self, from: Mapping, to: Mapping) -> Result<&Pipeline> {
        let cell = &self.pipelines[(4 * from.id() + to.id()) as usize];
        let id = if from == Mapping::Cube {
            ShaderId::ConvertCube
        } else {
            ShaderId::Convert2d
        };
        let spec = [WORKGROUP_2D[0], WORKGROUP_2D[1], from.id(), to.id()];
        Pipeline::compute_once(cell, &self.ctx, id, &spec)
    }

    /// Builds the pipeline that converts `from` maps to `to` now rather than at the first
    /// [`Converter::record`] that needs it (from another thread while a map uploads, or
    /// before an engine's frame).
    pub fn prepare(&self, from: Mapping, to: Mapping) -> Result<()> {
        if from == Mapping::LatLong && matches!(to, Mapping::Cube | Mapping::DualParaboloid) {
            // The area pipeline, which serves lat-long to cube and dual paraboloid at all but
            // extreme minification (and, for the paraboloid, orientations that tilt its axis).
            return self.prepare_area(to, to == Mapping::Cube, area::PARABOLOID_EDGE_STEPS);
        }
        self.pipeline(from, to).map(|_| ())
    }

    /// Builds the pipeline that [`Converter::record_split`] of a `from` map (not a cube)
    /// takes now rather than at that record.
    pub fn prepare_split(&self, from: Mapping) -> Result<()> {
        self.split_pipeline(from).map(|_| ())
    }

    fn split_pipeline(&self, from: Mapping) -> Result<&Pipeline> {
        let to = Mapping::DualParaboloid;
        Pipeline::compute_once(
            &self.split[from.id() as usize],
            &self.ctx,
            ShaderId::ConvertSplit,
            &[WORKGROUP_2D[0], WORKGROUP_2D[1], from.id(), to.id()],
        )
    }

    /// Builds the pipelines that [`Converter::record`] of a `src` map (mapping, width,
    /// height) with `opts` takes, and no other, now rather than at that record.
    pub fn prepare_for(&self, src: (Mapping, u32, u32), opts: &ConvertOptions) -> Result<()> {
        if !self.uses_area(src, opts) {
            return self.pipeline(src.0, opts.to).map(|_| ());
        }
        self.prepare_area(opts.to, split_area(opts, src.1)?, edge_points(opts)?)
    }

    /// The slopes pipeline and the area pipelines to `to`: the cube's fast path and list
    /// where `split`, else the one walk (a paraboloid's with `points` per texel edge).
    fn prepare_area(&self, to: Mapping, split: bool, points: u32) -> Result<()> {
        self.slopes_pipeline()?;
        if split && to == Mapping::DualParaboloid {
            self.rim_pipeline()?;
        }
        match split {
            true => self.area_split_pipelines(to, points).map(|_| ()),
            false => self.area_pipeline(to, points).map(|_| ()),
        }
    }

    fn rim_pipeline(&self) -> Result<&Pipeline> {
        Pipeline::compute_once(
            &self.area_rim,
            &self.ctx,
            ShaderId::ConvertAreaRim,
            &WORKGROUP_2D,
        )
    }

    fn slopes_pipeline(&self) -> Result<&Pipeline> {
        Pipeline::compute_once(
            &self.slopes,
            &self.ctx,
            ShaderId::ConvertSlopes,
            &WORKGROUP_2D,
        )
    }

    /// The general walk to `to`, a cube or a dual paraboloid (a module each; the
    /// paraboloid's specialised on `points` per texel edge, 1 to [`area::POLE_STEPS`]).
    fn area_pipeline(&self, to: Mapping, points: u32) -> Result<&Pipeline> {
        match to {
            Mapping::DualParaboloid => Pipeline::compute_once(
                &self.area_paraboloid[points as usize - 1],
                &self.ctx,
                ShaderId::ConvertAreaParaboloid,
                &[WORKGROUP_2D[0], WORKGROUP_2D[1], points],
            ),
            _ => Pipeline::compute_once(
                &self.area_cube,
                &self.ctx,
                ShaderId::ConvertArea,
                &WORKGROUP_2D,
            ),
        }
    }

    /// The fast-path and list pipelines to `to` (a paraboloid's with `points` per texel
    /// edge), built side by side (llvmpipe takes ~20 ms for each).
    fn area_split_pipelines(&self, to: Mapping, points: u32) -> Result<(&Pipeline, &Pipeline)> {
        let (fast_cell, list_cell, fast_id, list_id) = match to {
            Mapping::DualParaboloid => (
                &self.area_fast_paraboloid[points as usize - 1],
                &self.area_list_paraboloid[points as usize - 1],
                ShaderId::ConvertAreaFastParaboloid,
                ShaderId::ConvertAreaListParaboloid,
            ),
            _ => (
                &self.area_fast,
                &self.area_list,
                ShaderId::ConvertAreaFast,
                ShaderId::ConvertAreaList,
            ),
        };
        if let (Some(fast), Some(list)) = (fast_cell.get(), list_cell.get()) {
            // Built: no thread to start (a bake records one conversion per probe).
            return Ok((fast, list));
        }
        let (fast, list) = std::thread::scope(|s| {
            let list = s.spawn(|| {
                Pipeline::compute_once(list_cell, &self.ctx, list_id, &[LIST_GROUP, 1, points])
            });
            let fast = Pipeline::compute_once(
                fast_cell,
                &self.ctx,
                fast_id,
                &[WORKGROUP_2D[0], WORKGROUP_2D[1], points],
            );
            (
                fast,
                list.join().unwrap_or_else(|p| std::panic::resume_unwind(p)),
            )
        });
        Ok((fast?, list?))
    }

    /// Whether converting a `src` map (mapping, width, height) with `opts` takes exact
    /// footprint areas, which conserves power, rather than `ss` × `ss` bilinear samples per
    /// texel: lat-long to cube, or to dual paraboloid where the orientation keeps the
    /// paraboloid's axis on the lat-long's, with no sample count or nearest reads asked for,
    /// not so strongly minified that the walks at the poles grow long
    /// (`math::convert::area_serves`), and a source each of whose slope buffers fits one
    /// storage buffer and one texel buffer view.
    pub fn uses_area(&self, src: (Mapping, u32, u32), opts: &ConvertOptions) -> bool {
        let Ok(world_to_file) = opts.orientation.checked_world_to_file() else {
            return false;
        };
        src.0 == Mapping::LatLong
            && opts.supersample.is_none()
            && !opts.nearest
            && crate::math::convert::area_serves(src.1, src.2, opts.to, opts.size, world_to_file)
            && slope_buffer_bytes(src.1, src.2) <= self.ctx.info().max_storage_buffer_range
            && slope_buffer_bytes(src.1, src.2) / 16 <= self.ctx.info().max_texel_buffer_elements
    }

    /// Samples per axis for an output texel: about two per source texel spacing, so that
    /// minification averages every source texel the footprint covers (1 when magnifying).
    pub fn supersampling(src: (Mapping, u32, u32), dst: (Mapping, u32, u32)) -> u32 {
        ((4.0 * Converter::ratio(src, dst)).ceil() as u32).clamp(1, 64)
    }

    /// Samples per axis for a texel of the dual paraboloid `dp_size` a side that feeds a FIS
    /// MIP chain (split-sum, FIS, the mirror level), converted from `src` by samples: 1.5 per
    /// source texel spacing, at least 2 — three eighths of [`Converter::supersampling`]'s 4.
    /// The chain's own filtering averages far more than a texel, so its levels' error against
    /// the exact prefilter does not depend on the rate. Level 0 does: at this rate a 256²
    /// paraboloid from a 256² cube is within ~0.1% a texel of a converged one on a map
    /// without a sun, but 2% rms with one, so renders take it for a light-free residual only.
    pub fn chain_supersampling(src: (Mapping, u32, u32), dp_size: u32) -> u32 {
        let (w, h) = Mapping::DualParaboloid.extent_for_size(dp_size);
        let r = Converter::ratio(src, (Mapping::DualParaboloid, w, h));
        ((1.5 * r).ceil() as u32).clamp(2, 64)
    }

    /// Source texel spacings per output texel spacing: √ of the ratio of the texels that
    /// cover the sphere.
    pub fn ratio(src: (Mapping, u32, u32), dst: (Mapping, u32, u32)) -> f64 {
        (texels_on_sphere(src.0, src.1, src.2) / texels_on_sphere(dst.0, dst.1, dst.2)).sqrt()
    }

    /// Records the conversion of `src` into `dst`, whose mapping and size must be
    /// `opts.to` at `opts.size`. `dst` may have MIP levels: only level 0 is written.
    pub fn record(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        opts: &ConvertOptions,
    ) -> Result<()> {
        let (w, h) = opts.to.extent_for_size(opts.size);
        assert_eq!(
            (dst.mapping, dst.width, dst.height),
            (opts.to, w, h),
            "the output does not match the options"
        );
        let push = sampled_push(src, opts, 0.0)?;
        let points = edge_points(opts)?;
        if identity_copy(src, dst, opts, &push) {
            let label = format!(
                "convert {} -> {} {w}x{h} (a copy)",
                src.mapping.name(),
                opts.to.name()
            );
            rec.span(&label, |rec| {
                rec.copy_image_level(&src.image, 0, &dst.image, 0);
                Ok(())
            })?;
            return poison::image(rec, PassId::Convert, &dst.image, 0..1);
        }
        if self.uses_area((src.mapping, src.width, src.height), opts) {
            let split = split_area(opts, src.width)?;
            self.record_area(rec, src, dst, &push, (w, h), (split, points))?;
            return poison::image(rec, PassId::Convert, &dst.image, 0..1);
        }
        let pipeline = self.pipeline(src.mapping, opts.to)?;
        let label = format!(
            "convert {} -> {} {w}x{h}",
            src.mapping.name(),
            opts.to.name()
        );
        self.record_sampled(rec, pipeline, src, &[dst], &push, &label)
    }

    /// Records the sampled conversion of a 2D `src` (lat-long, angular or paraboloid) into
    /// two dual paraboloids at once, reading the source once: into `whole` the map, into
    /// `residual` its residual, each source texel clamped at luminance `threshold` first (as
    /// [`crate::passes::map::LuminanceClamp`] would leave it). Both are written premultiplied
    /// as [`crate::passes::mip::MipChain`] keeps level 0, for
    /// [`crate::passes::mip::MipChain::record_premultiplied`] to finish. `opts` must convert
    /// to a dual paraboloid; its sample count is taken as [`Converter::record`] takes it, but
    /// never the area rule. Span: "convert {from} -> dual-paraboloid WxH, whole and residual".
    pub fn record_split(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        (whole, residual): (&GpuEnvMap, &GpuEnvMap),
        threshold: f64,
        opts: &ConvertOptions,
    ) -> Result<()> {
        let (w, h) = opts.to.extent_for_size(opts.size);
        if opts.to != Mapping::DualParaboloid || src.mapping == Mapping::Cube {
            return Err(Error::Invalid(format!(
                "a split conversion reads a 2D map into dual paraboloids, not {} into {}",
                src.mapping.name(),
                opts.to.name()
            )));
        }
        for dst in [whole, residual] {
            if (dst.mapping, dst.width, dst.height) != (opts.to, w, h) {
                return Err(Error::Invalid(format!(
                    "a split conversion's outputs are {w} x {h} dual paraboloids, not {} x {} {}",
                    dst.width,
                    dst.height,
                    dst.mapping.name()
                )));
            }
        }
        let push = sampled_push(src, opts, threshold)?;
        let pipeline = self.split_pipeline(src.mapping)?;
        let label = format!(
            "convert {} -> {} {w}x{h}, whole and residual",
            src.mapping.name(),
            opts.to.name()
        );
        self.record_sampled(rec, pipeline, src, &[whole, residual], &push, &label)
    }

    /// One dispatch of the sampled conversion into `dsts` (the destination, then, split, the
    /// residual's), level 0 of each.
    fn record_sampled(
        &self,
        rec: &mut Recorder,
        pipeline: &Pipeline,
        src: &GpuEnvMap,
        dsts: &[&GpuEnvMap],
        push: &ConvertPush,
        label: &str,
    ) -> Result<()> {
        let cube = src.mapping == Mapping::Cube;
        let mut binds = vec![(
            binding::CONVERT_SRC,
            Bind::Sampled(&src.image, &self.sampler, cube),
        )];
        let outputs = [binding::CONVERT_DST, binding::CONVERT_RESIDUAL];
        for (b, dst) in outputs.into_iter().zip(dsts) {
            rec.discard(&dst.image);
            binds.push((b, Bind::Storage(&dst.image)));
        }
        let [w, h] = push.dst_size;
        rec.span(label, |rec| {
            rec.dispatch(
                pipeline,
                &binds,
                push,
                groups_2d(w, h, dsts[0].mapping.layers()),
            )
        })?;
        for dst in dsts {
            poison::image(rec, PassId::Convert, &dst.image, 0..1)?;
        }
        Ok(())
    }

    /// Records the limited slopes of lat-long `src` into two scratch buffers, written as
    /// storage buffers and read through their texel views ([`slope_texels`]).
    fn record_slopes(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        push: &ConvertPush,
    ) -> Result<Slopes> {
        let usage =
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER;
        let bytes = slope_buffer_bytes(src.width, src.height);
        let slopes = [
            rec.scratch("convert slopes dL/dU", bytes, usage)?,
            rec.scratch("convert slopes dL/dz", bytes, usage)?,
        ];
        let pipeline = self.slopes_pipeline()?;
        rec.span("convert slopes", |rec| {
            rec.dispatch(
                pipeline,
                &[
                    (
                        binding::CONVERT_SRC,
                        Bind::Sampled(&src.image, &self.sampler, false),
                    ),
                    (binding::CONVERT_SLOPES_U, Bind::Buffer(&slopes[0])),
                    (binding::CONVERT_SLOPES_Z, Bind::Buffer(&slopes[1])),
                ],
                push,
                groups_2d(src.width, src.height, 1),
            )
        })?;
        Ok(slopes)
    }

    /// The lat-long to cube or dual-paraboloid conversion by exact footprint areas: the
    /// source's limited slopes, then the footprints' integrals (`split`: the cube's fast path
    /// and list; `points`: a paraboloid's per texel edge).
    fn record_area(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        push: &ConvertPush,
        (w, h): (u32, u32),
        (split, points): (bool, u32),
    ) -> Result<()> {
        let to = dst.mapping;
        let source = || {
            (
                binding::CONVERT_SRC,
                Bind::Sampled(&src.image, &self.sampler, false),
            )
        };
        rec.discard(&dst.image);
        let slopes = self.record_slopes(rec, src, push)?;
        let label = format!("convert latlong -> {} {w}x{h} (areas)", to.name());
        // One invocation per output texel: the whole walk.
        let over_map = |rec: &mut Recorder, pipeline: &Pipeline| {
            let [u, z] = slope_texels(&slopes);
            rec.dispatch(
                pipeline,
                &[
                    source(),
                    (binding::CONVERT_DST, Bind::Storage(&dst.image)),
                    u,
                    z,
                ],
                push,
                groups_2d(w, h, to.layers()),
            )
        };
        if !split {
            let area = self.area_pipeline(to, points)?;
            rec.span(&label, |rec| over_map(rec, area))?;
        } else {
            let (fast, general) = self.area_split_pipelines(to, points)?;
            let texels = crate::math::convert::area_general_texels(to, w);
            let (fast_tiles, rim_tiles) = crate::math::convert::area_tiles(to, w);
            let rim = match rim_tiles.is_empty() {
                true => None,
                false => Some(self.rim_pipeline()?),
            };
            // A paraboloid's texels outside its disc and the fast path's, one workgroup per
            // tile; then the general walk's texels, LIST_GROUP to a workgroup.
            // (pipeline, list, workgroups, whether it reads the slopes: the rim does not)
            let mut lists = Vec::new();
            for (pipeline, list, what, groups, slopes) in [
                (rim, &rim_tiles, "convert rim tiles", rim_tiles.len(), false),
                (
                    Some(fast),
                    &fast_tiles,
                    "convert fast tiles",
                    fast_tiles.len(),
                    true,
                ),
                (
                    Some(general),
                    &texels,
                    "convert general texels",
                    groups(texels.len() as u32, LIST_GROUP) as usize,
                    true,
                ),
            ] {
                if let Some(pipeline) = pipeline.filter(|_| groups > 0) {
                    lists.push((pipeline, rec.upload(what, list)?, groups as u32, slopes));
                }
            }
            rec.span(&label, |rec| {
                for (pipeline, list, groups, reads_slopes) in &lists {
                    let mut binds = vec![
                        source(),
                        (binding::CONVERT_DST, Bind::Storage(&dst.image)),
                        (binding::CONVERT_LIST, Bind::Buffer(list)),
                    ];
                    if *reads_slopes {
                        binds.extend(slope_texels(&slopes));
                    }
                    rec.dispatch(pipeline, &binds, push, [*groups, 1, 1])?;
                }
                Ok(())
            })?;
        }
        Ok(())
    }

    /// Converts `src` to `opts.to` at `opts.size`; returns the new map and the GPU time.
    pub fn run(&self, src: &GpuEnvMap, opts: &ConvertOptions) -> Result<Timed<GpuEnvMap>> {
        self.run_into(src, opts, false)
    }

    /// As [`Converter::run`], into a map with a full MIP chain of which only level 0 is
    /// written (for [`crate::passes::mip::MipChain`] to fill).
    pub fn run_mipped(&self, src: &GpuEnvMap, opts: &ConvertOptions) -> Result<Timed<GpuEnvMap>> {
        self.run_into(src, opts, true)
    }

    fn run_into(
        &self,
        src: &GpuEnvMap,
        opts: &ConvertOptions,
        mips: bool,
    ) -> Result<Timed<GpuEnvMap>> {
        let (w, h) = opts.to.extent_for_size(opts.size);
        let name = format!("{} {}", opts.to.name(), opts.size);
        let dst = if mips {
            GpuEnvMap::with_mips(&self.ctx, &name, opts.to, w, h)?
        } else {
            GpuEnvMap::new(&self.ctx, &name, opts.to, w, h)?
        };
        Ok(self
            .ctx
            .run("converting a map", |rec| self.record(rec, src, &dst, opts))?
            .map(|()| dst))
    }
}
