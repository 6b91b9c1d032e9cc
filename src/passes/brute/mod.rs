//! Irradiance and Phong-prefiltered environment maps by brute-force convolution of every
//! source texel (Miller & Hoffman 1984, `glsl/brute.comp`, float64 twin
//! `crate::math::filter`).

use super::map::GpuEnvMap;
use crate::abi::{constants, ShaderId, WORKGROUP_1D};
use crate::error::{Error, Result};
use crate::gpu::{Context, Pipeline, Recorder, Sampler, Timed};
pub use crate::math::filter::Kernel;
use crate::math::moments;
use crate::math::{Mapping, Orientation};
use ash::vk;
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

mod source;
mod sum;
mod variants;

use crate::passes::testing::poison::{self, PassId};
use source::CoarseLevel;
use variants::{default_texel_lanes, lane_count, PIPELINE_SLOTS};

/// Invocations a convolution keeps busy by default: outputs smaller than this (the coarse
/// Phong levels: 6 texels at 1²) split the source among parts, each summed by its own
/// invocation, then added per texel. 2¹⁶ fills current GPUs' cores several times over
/// (`cargo xtask lab peers` times the coarse Phong levels).
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
    /// (`cargo xtask lab peers`). Not a filtered map; [`BruteFilter::record_levels`] refuses it.
    pub(crate) fn set_visit_floor(&mut self, on: bool) {
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
        poison::image(rec, PassId::Brute, &dst.image, 0..1)
    }

    /// Records one convolution per `(kernel, dst)` pair, each from the source level of the
    /// power-moment pyramid that `moments::level_for` picks for its lobe (level 0, every
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
            poison::image(rec, PassId::Brute, &dst.image, 0..1)?;
        }
        rec.keep((prep, levels));
        Ok(chosen)
    }

    /// Convolves `src` into a new `target` map and waits (see [`BruteFilter::record`]);
    /// returns it and the GPU times.
    pub fn run(
        &self,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
        target: FilterTarget,
    ) -> Result<Timed<GpuEnvMap>> {
        let (w, h) = target.extent();
        let dst = GpuEnvMap::new(&self.ctx, "brute-force filtered", target.to, w, h)?;
        Ok(self
            .ctx
            .run("brute-force convolution", |rec| {
                self.record(rec, src, orientation, kernel, &dst)
            })?
            .map(|()| dst))
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
    ) -> Result<Timed<(Vec<GpuEnvMap>, Vec<u32>)>> {
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
        let Timed {
            value: chosen,
            timings: t,
        } = self.ctx.run("prefiltered levels", |rec| {
            self.record_levels(rec, src, orientation, &outputs)
        })?;
        Ok(Timed::new((maps, chosen), t))
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
pub(super) fn check_kernel(kernel: Kernel) -> Result<f32> {
    let (lo, hi) = constants::PHONG_EXPONENT_RANGE;
    match kernel {
        Kernel::Cosine => Ok(0.0),
        Kernel::Phong { n } if (lo..=hi).contains(&n) => Ok(n as f32),
        Kernel::Phong { n } => Err(Error::Invalid(format!(
            "Phong exponent {n} is outside {lo} to {hi:e}"
        ))),
    }
}
