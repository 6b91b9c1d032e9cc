//! Split-sum shading's precomputation (Karis 2013): the DFG table (`glsl/dfg.comp`) and the
//! prefiltered GGX chain, one roughness a level, built by filtered importance sampling from
//! the dual-paraboloid MIP chain (`glsl/prefilter_ggx.comp`). Float64 twins in
//! `crate::math::split_sum`, which states the approximation (n = v = r) and the level rule.

use super::map::{map_desc, GpuEnvMap};
use crate::abi::push::{DfgPush, PrefilterGgxPush};
use crate::abi::{binding, sh_brdf, split_sum, ShaderId, WORKGROUP_1D, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{
    groups, groups_2d, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timed, Usage,
};
pub use crate::math::split_sum::DfgAxes;
pub use crate::math::split_sum::LevelSamples;
use crate::math::split_sum::{level_alpha, level_size};
use crate::math::Mapping;
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// How the prefiltered chain is built: [`PrefilterOptions::new`] or [`Default`] (8 levels),
/// then the fields that differ.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct PrefilterOptions {
    /// Roughness levels (level k holds α = (k/(levels − 1))²).
    pub levels: u32,
    /// FIS samples per texel.
    pub samples: u32,
    /// The most times `samples` the roughest levels take, whose texels are few
    /// ([`LevelSamples`]); 1, the default: `samples` at every level.
    pub rough_boost: u32,
    /// Lod bias of the FIS reads.
    pub bias: f64,
    /// Each sample reads the source chain's level nearest its lod (a bilinear read) instead
    /// of blending the two about it (trilinear, the default): one level's texels read a
    /// sample instead of two levels', the levels' errors against the exact prefilter within
    /// 1% either way (`envlight bench dynamic` publishes its time and errors). Twin:
    /// [`crate::math::split_sum::prefilter_read`].
    pub nearest_mip: bool,
}

impl PrefilterOptions {
    /// `levels` roughness levels, with the default samples per texel and lod bias (what
    /// `envlight bake` uses).
    pub fn new(levels: u32) -> Self {
        PrefilterOptions {
            levels,
            samples: split_sum::DEFAULT_SAMPLES,
            rough_boost: 1,
            bias: crate::math::fis::DEFAULT_BIAS,
            nearest_mip: false,
        }
    }

    /// Samples per texel by level: `samples`, boosted at the roughest levels by up to
    /// `rough_boost`.
    pub fn level_samples(&self) -> LevelSamples {
        LevelSamples {
            base: self.samples,
            rough_boost: self.rough_boost,
        }
    }
}

impl Default for PrefilterOptions {
    /// Eight levels, as [`PrefilterOptions::new`].
    fn default() -> Self {
        PrefilterOptions::new(8)
    }
}

/// Some layers of one level of a prefiltered chain: the unit a time slice refilters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LevelLayers {
    /// The level.
    pub level: u32,
    /// Its layers (cube faces, paraboloid halves) refiltered.
    pub layers: std::ops::Range<u32>,
}

/// The rough levels (1 to `levels` − 1) of a chain `size` a side at level 0 with `layers`
/// layers, dealt into `slices` time slices of about equal cost, as Unity spreads a probe's
/// refilter over frames: each (level, layer) lands in exactly one slice. A frame that records
/// slice `f mod slices` (after one that refilters everything) keeps every level at most
/// `slices` − 1 frames behind its map. Level 0, the mirror, is in no slice: one read a texel,
/// it is cheap and the sharpest, so a frame refilters it whole. The cost of a unit is its
/// texels times its level's `samples` ([`LevelSamples::at`]); units go, largest first, to the slice with the
/// least so far (ties: the lowest level and layer, the first slice), so no slice costs more
/// than the even share plus the largest unit. Each slice lists its units by level and layer,
/// a level's neighbouring layers merged.
pub fn time_slices(
    size: u32,
    layers: u32,
    levels: u32,
    samples: LevelSamples,
    slices: u32,
) -> Vec<Vec<LevelLayers>> {
    let slices = slices.max(1) as usize;
    let mut units: Vec<(u64, u32, u32)> = (1..levels)
        .flat_map(|k| {
            let side = level_size(size, k) as u64;
            let cost = side * side * u64::from(samples.at(size, k));
            (0..layers).map(move |l| (cost, k, l))
        })
        .collect();
    units.sort_by_key(|&(cost, k, l)| (std::cmp::Reverse(cost), k, l));
    let mut load = vec![0u64; slices];
    let mut dealt: Vec<Vec<(u32, u32)>> = vec![Vec::new(); slices];
    for (cost, k, l) in units {
        let i = (0..slices).min_by_key(|&i| (load[i], i)).unwrap_or(0);
        load[i] += cost;
        dealt[i].push((k, l));
    }
    dealt
        .into_iter()
        .map(|mut v| {
            v.sort_unstable();
            let mut out: Vec<LevelLayers> = Vec::new();
            for (k, l) in v {
                match out.last_mut() {
                    Some(u) if u.level == k && u.layers.end == l => u.layers.end = l + 1,
                    _ => out.push(LevelLayers {
                        level: k,
                        layers: l..l + 1,
                    }),
                }
            }
            out
        })
        .collect()
}

/// The split-sum passes.
pub struct SplitSum {
    ctx: Context,
    /// Built at the first DFG table (a bake that reads its table from a cache needs none).
    dfg: std::sync::OnceLock<Pipeline>,
    prefilter: Pipeline,
    trilinear: Sampler,
    /// The same, reading the level nearest the lod (`PrefilterOptions::nearest_mip`).
    nearest_mip: Sampler,
}

impl SplitSum {
    /// Builds the prefilter's pipeline (the DFG table's is built when a table is first
    /// recorded).
    pub fn new(ctx: &Context) -> Result<SplitSum> {
        Ok(SplitSum {
            ctx: ctx.clone(),
            dfg: std::sync::OnceLock::new(),
            prefilter: Pipeline::compute(ctx, ShaderId::PrefilterGgx, &WORKGROUP_2D)?,
            trilinear: Sampler::trilinear_border(ctx, "split-sum source sampler")?,
            nearest_mip: Sampler::nearest_mip_border(ctx, "split-sum nearest-level sampler")?,
        })
    }

    /// Floats one DFG table `size` a side takes ((A, B) per entry).
    pub fn dfg_floats(size: u32) -> usize {
        2 * (size * size) as usize
    }

    /// Records the DFG table of GGX with the given Smith form into `out` from float `offset`
    /// (even) on: row j (√α) after row, (A, B) per entry, entries at the axes' endpoints.
    /// Span: "dfg table".
    pub fn record_dfg(
        &self,
        rec: &mut Recorder,
        size: u32,
        correlated: bool,
        out: &Buffer,
        offset: u32,
    ) -> Result<()> {
        self.record_dfg_at(rec, size, correlated, DfgAxes::Endpoints, out, offset)
    }

    /// [`SplitSum::record_dfg`] with the entries where `axes` puts them.
    pub fn record_dfg_at(
        &self,
        rec: &mut Recorder,
        size: u32,
        correlated: bool,
        axes: DfgAxes,
        out: &Buffer,
        offset: u32,
    ) -> Result<()> {
        if !(2..=split_sum::MAX_DFG_SIZE).contains(&size) || !offset.is_multiple_of(2) {
            return Err(Error::Invalid(format!(
                "split-sum: DFG table size {size} outside 2 to {} (or odd offset {offset})",
                split_sum::MAX_DFG_SIZE
            )));
        }
        let need = (offset as u64 + Self::dfg_floats(size) as u64) * 4;
        assert!(need <= out.size(), "split-sum: the DFG buffer is too small");
        let pipeline =
            Pipeline::compute_once(&self.dfg, &self.ctx, ShaderId::Dfg, &[WORKGROUP_1D])?;
        rec.span("dfg table", |rec| {
            // One dispatch per panel of the first uniform (llvmpipe's loop limit).
            for panel in 0..2 * sh_brdf::GRADED_LEVELS {
                let push = DfgPush {
                    size,
                    correlated: correlated as u32,
                    offset,
                    panel,
                    centres: (axes == DfgAxes::Centres) as u32,
                };
                rec.dispatch(
                    pipeline,
                    &[(binding::DFG_TABLE, Bind::Buffer(out))],
                    &push,
                    [groups(size * size, WORKGROUP_1D), 1, 1],
                )?;
            }
            Ok(())
        })?;
        // (A, B) records: both scaled; the table has no frame to mirror (the chain has).
        let f = poison::Floats {
            first: offset,
            count: Self::dfg_floats(size) as u32,
            stride: 2,
            scale_mask: 0b11,
            mirror_mask: 0,
            sh: None,
        };
        poison::buffer(rec, PassId::SplitSum, out, f)
    }

    /// Computes one DFG table (at endpoints) and reads it back, with its GPU time.
    pub fn run_dfg(&self, size: u32, correlated: bool) -> Result<Timed<Vec<[f32; 2]>>> {
        self.run_dfg_at(size, correlated, DfgAxes::Endpoints)
    }

    /// [`SplitSum::run_dfg`] with the entries where `axes` puts them.
    pub fn run_dfg_at(
        &self,
        size: u32,
        correlated: bool,
        axes: DfgAxes,
    ) -> Result<Timed<Vec<[f32; 2]>>> {
        let n = Self::dfg_floats(size);
        let out = Buffer::new(
            &self.ctx,
            "dfg table",
            n as u64 * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        let t = self
            .ctx
            .run("computing a DFG table", |rec| {
                self.record_dfg_at(rec, size, correlated, axes, &out, 0)?;
                rec.use_buffer(&out, Usage::HostRead);
                Ok(())
            })?
            .timings;
        let flat: Vec<f32> = out.read(n);
        Ok(Timed::new(
            flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
            t,
        ))
    }

    /// A dual paraboloid `size` a side with exactly `levels` MIP levels, one roughness each
    /// (no level beyond the last, so a trilinear read at the last lod reads nothing unwritten).
    pub fn chain(ctx: &Context, size: u32, levels: u32) -> Result<GpuEnvMap> {
        if levels == 0 || level_size(size, levels - 1) < split_sum::MIN_LEVEL_SIZE.min(size) {
            return Err(Error::Invalid(format!(
                "split-sum: {levels} levels of a {size}² paraboloid leave the coarsest under {}²",
                split_sum::MIN_LEVEL_SIZE
            )));
        }
        let (w, h) = Mapping::DualParaboloid.extent_for_size(size);
        GpuEnvMap::create(
            ctx,
            "split-sum prefiltered chain",
            map_desc(Mapping::DualParaboloid, w, h, levels),
            Mapping::DualParaboloid,
        )
    }

    /// Records the first `opts.levels` levels of `dst` (from [`SplitSum::chain`]) from `src`,
    /// a dual paraboloid whose MIP chain is filled (premultiplied, as
    /// [`crate::passes::MipChain`] leaves it). Spans: "split-sum level k".
    pub fn record_prefilter(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        opts: &PrefilterOptions,
    ) -> Result<()> {
        self.record_prefilter_levels(rec, src, dst, opts, 0..opts.levels)
    }

    /// As [`SplitSum::record_prefilter`], for the levels in `levels` only (of a chain of
    /// `opts.levels`): a bake filters the mirror from the whole map and the rough levels
    /// from its residual after light extraction.
    pub fn record_prefilter_levels(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        opts: &PrefilterOptions,
        levels: std::ops::Range<u32>,
    ) -> Result<()> {
        let layers = dst.mapping.layers();
        let units: Vec<LevelLayers> = (levels.start..levels.end.min(opts.levels))
            .map(|level| LevelLayers {
                level,
                layers: 0..layers,
            })
            .collect();
        self.record_prefilter_slice(rec, src, dst, opts, &units)
    }

    /// As [`SplitSum::record_prefilter`], for the layers of the levels `units` names only:
    /// a time slice of the chain ([`time_slices`]), the rest of it left as it was. Units
    /// beyond `opts.levels` or the chain's layers are refused.
    pub fn record_prefilter_slice(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        dst: &GpuEnvMap,
        opts: &PrefilterOptions,
        units: &[LevelLayers],
    ) -> Result<()> {
        if src.mapping != Mapping::DualParaboloid
            || !matches!(dst.mapping, Mapping::DualParaboloid | Mapping::Cube)
        {
            return Err(Error::Invalid(
                "split-sum prefilters a dual paraboloid into a dual paraboloid or a cube".into(),
            ));
        }
        if opts.levels == 0
            || opts.levels > dst.mips()
            || opts.samples == 0
            || opts.rough_boost == 0
        {
            return Err(Error::Invalid(format!(
                "split-sum: {} levels of {} samples (rough levels up to {}×) into a chain of {} levels",
                opts.levels,
                opts.samples,
                opts.rough_boost,
                dst.mips()
            )));
        }
        let layers = dst.mapping.layers();
        if let Some(u) = units.iter().find(|u| {
            u.level >= opts.levels || u.layers.end > layers || u.layers.start >= u.layers.end
        }) {
            return Err(Error::Invalid(format!(
                "split-sum: level {} layers {:?} of a chain of {} levels, {layers} layers",
                u.level, u.layers, opts.levels
            )));
        }
        let sampler = match opts.nearest_mip {
            true => &self.nearest_mip,
            false => &self.trilinear,
        };
        let mut tables: Vec<(u32, std::sync::Arc<Buffer>, u32)> = Vec::new();
        for u in units {
            let k = u.level;
            let size = level_size(dst.width, k);
            let alpha = level_alpha(k, opts.levels);
            if !tables.iter().any(|t| t.0 == k) {
                let samples = opts.level_samples().at(dst.width, k);
                let (words, count) = sample_words(alpha, samples, opts.bias, src.width);
                tables.push((k, rec.upload("split-sum samples", &words)?, count));
            }
            let (_, table, count) = tables
                .iter()
                .find(|t| t.0 == k)
                .cloned()
                .unwrap_or_else(|| unreachable!("pushed above"));
            let push = PrefilterGgxPush {
                size,
                src_size: src.width,
                src_max_lod: (src.mips() - 1) as f32,
                alpha: alpha as f32,
                samples: count,
                dst_mapping: dst.mapping.id(),
                layer: u.layers.start,
            };
            let span = match u.layers.len() as u32 == layers {
                true => format!("split-sum level {k}"),
                false => format!("split-sum level {k} layers {:?}", u.layers),
            };
            rec.span(&span, |rec| {
                rec.dispatch(
                    &self.prefilter,
                    &[
                        (
                            binding::PREFILTER_GGX_SRC,
                            Bind::Sampled(&src.image, sampler, false),
                        ),
                        (
                            binding::PREFILTER_GGX_DST,
                            Bind::StorageLevel(&dst.image, k),
                        ),
                        (binding::PREFILTER_GGX_SAMPLES, Bind::Buffer(&table)),
                    ],
                    &push,
                    groups_2d(size, size, u.layers.len() as u32),
                )
            })?;
        }
        let lo = units.iter().map(|u| u.level).min().unwrap_or(0);
        let hi = units.iter().map(|u| u.level + 1).max().unwrap_or(0);
        poison::image(rec, PassId::SplitSum, &dst.image, lo..hi)
    }

    /// A cube `size` a side with exactly `levels` MIP levels, one roughness each (a bake's
    /// specular cube).
    pub fn cube_chain(ctx: &Context, size: u32, levels: u32) -> Result<GpuEnvMap> {
        if levels == 0 || levels > crate::passes::map::full_mips(size, size) {
            return Err(Error::Invalid(format!(
                "split-sum: {levels} levels do not fit a {size}² cube"
            )));
        }
        GpuEnvMap::create(
            ctx,
            "prefiltered GGX cube",
            map_desc(Mapping::Cube, size, size, levels),
            Mapping::Cube,
        )
    }
}

/// A level's samples ([`crate::math::split_sum::prefilter_samples`]) as
/// `glsl/prefilter_ggx.comp` reads them:
/// (wi, w) then (lod, 0, 0, 0), the pdf's +∞ lod as 1e30 (clamped to the chain's last level),
/// and their count. α = 0 reads none; the binding still takes a buffer.
fn sample_words(alpha: f64, samples: u32, bias: f64, src_size: u32) -> (Vec<[f32; 4]>, u32) {
    let table = match alpha > 0.0 {
        true => crate::math::split_sum::prefilter_samples(alpha, samples, bias, src_size),
        false => Vec::new(),
    };
    // One [f32; 4] pair a sample: the table's layout.
    const _: () = assert!(split_sum::PREFILTER_SAMPLE_VEC4S == 2);
    let mut words: Vec<[f32; 4]> = table
        .iter()
        .flat_map(|t| {
            [
                [t.wi.x as f32, t.wi.y as f32, t.wi.z as f32, t.weight as f32],
                [t.lod.min(1e30) as f32, 0.0, 0.0, 0.0],
            ]
        })
        .collect();
    let count = table.len() as u32;
    if words.is_empty() {
        words.resize(split_sum::PREFILTER_SAMPLE_VEC4S as usize, [0.0; 4]);
    }
    (words, count)
}

#[cfg(test)]
mod tests {
    use super::{time_slices, LevelLayers, LevelSamples};

    /// Every (level ≥ 1, layer) of the chain lands in exactly one slice, level 0 in none,
    /// and no slice costs more than the even share plus the largest unit; one slice holds
    /// every rough level whole.
    #[test]
    fn time_slices_deal_every_unit_once_evenly() {
        let boosted = LevelSamples {
            base: 64,
            rough_boost: 8,
        };
        let cases = [(128, 6, 7), (32, 2, 3), (256, 2, 8), (64, 6, 2)];
        for ((size, layers, levels), samples) in cases
            .into_iter()
            .flat_map(|c| [(c, LevelSamples::flat(64)), (c, boosted)])
        {
            for slices in 1..=8u32 {
                let dealt = time_slices(size, layers, levels, samples, slices);
                assert_eq!(dealt.len(), slices as usize);
                let mut seen = Vec::new();
                let cost = |u: &LevelLayers| {
                    let side = (size >> u.level).max(1) as u64;
                    side * side * u.layers.len() as u64 * u64::from(samples.at(size, u.level))
                };
                let loads: Vec<u64> = dealt.iter().map(|s| s.iter().map(cost).sum()).collect();
                for u in dealt.iter().flatten() {
                    assert!(u.level >= 1 && u.level < levels, "{u:?}");
                    seen.extend(u.layers.clone().map(|l| (u.level, l)));
                }
                seen.sort_unstable();
                let want: Vec<(u32, u32)> = (1..levels)
                    .flat_map(|k| (0..layers).map(move |l| (k, l)))
                    .collect();
                assert_eq!(seen, want, "{size} {layers} {levels} in {slices}");
                let total: u64 = loads.iter().sum();
                let largest = (1..levels)
                    .map(|k| ((size >> k).max(1) as u64).pow(2) * u64::from(samples.at(size, k)))
                    .max()
                    .unwrap_or(0);
                let most = loads.iter().copied().max().unwrap_or(0);
                assert!(
                    most <= total / slices as u64 + largest,
                    "{size} {layers} {levels} in {slices}: {loads:?}"
                );
            }
        }
        let one = time_slices(128, 6, 7, LevelSamples::flat(64), 1);
        assert_eq!(one[0].len(), 6);
        assert!(one[0].iter().all(|u| u.layers == (0..6)));
    }
}
