//! What refiltering an environment that changes every frame costs.
//! Each frame's map is an image already on the GPU (as an engine renders its sky or a
//! reflection probe), its sun at another azimuth each frame; the whole refilter — SH 2 with
//! its 32² irradiance cube, light extraction, and the GGX chain of the residual (a 128² cube of 7
//! roughness levels filtered from a dual paraboloid and its MIP chain, level 0 from the
//! residual itself where that is no finer) — is recorded into one
//! command buffer per frame, one submission, nothing read back. Per-stage GPU times come from
//! timestamps, beside each stage's error and the frame's floor: a copy of the source and of
//! every output texel (each read once, written once, no arithmetic).

use super::floors::{copy_ms, rel_lum, spread_texels, worse, ERROR_TEXELS};
use super::{median, Report};
use crate::error::Result;
use crate::gpu::{Buffer, Context, Timing};
use crate::math::envmap::luminance;
use crate::math::exact::ExactFilter;
use crate::math::lights::{extract, ExtractOptions, LightKernel};
use crate::math::split_sum::level_alpha;
use crate::math::synth::Sky;
use crate::math::{Mapping, Orientation};
use crate::passes::extract::Extracted;
use crate::passes::testing::copy::CopyPass;
use crate::passes::{
    time_slices, ConvertOptions, ConvertPlan, Converter, Extractor, GpuExtraction, GpuLights,
    LevelLayers, LevelSamples, LightsPass, MipChain, PrefilterOptions, ShEvaluator, ShProjector,
    SplitSum, Subgroups,
};
use crate::{EnvMap, GpuEnvMap};
use ash::vk;
use glam::{DMat3, DVec3};
use gpu_allocator::MemoryLocation;

/// The frame's quality settings.
#[derive(Clone, Copy, Debug)]
pub struct FrameSettings {
    /// Side of the GGX chain's cube.
    pub chain: u32,
    /// Its roughness levels.
    pub levels: u32,
    /// FIS samples per chain texel.
    pub samples: u32,
    /// The most times `samples` the chain's roughest levels take
    /// (`PrefilterOptions::rough_boost`).
    pub rough_boost: u32,
    /// Frames the chain's rough levels are spread over (1: every level every frame).
    pub slices: u32,
    /// Side of the paraboloid the chain filters (its rough levels; level 0 too where the
    /// residual is finer than the chain, [`dynamic`] sets it per input).
    pub paraboloid: u32,
    /// Side of the irradiance cube.
    pub irradiance: u32,
    /// Light texels above this many times the mean luminance.
    pub ratio: f64,
    /// Most light texels.
    pub max_lights: u32,
    /// Each FIS sample reads the paraboloid's MIP level nearest its lod
    /// (`PrefilterOptions::nearest_mip`) rather than blending the two about it.
    pub nearest_mip: bool,
}

impl FrameSettings {
    /// FIS samples per chain texel by default: with [`FrameSettings::DEFAULT_ROUGH_BOOST`],
    /// every level's mean error within 1% of the exact prefilter on the sun sky.
    pub const DEFAULT_SAMPLES: u32 = 64;
    /// The most times the samples the chain's roughest levels take by default (without it,
    /// 64 samples leave α = 1 at 1.9%).
    pub const DEFAULT_ROUGH_BOOST: u32 = 8;

    /// The chain's samples per texel by level.
    pub fn level_samples(&self) -> LevelSamples {
        LevelSamples {
            base: self.samples,
            rough_boost: self.rough_boost,
        }
    }

    /// `samples` FIS samples per chain texel, up to `rough_boost` times that at its roughest
    /// levels, and the chain's rough levels over `slices` frames; the rest as an engine's frame
    /// would have it: 7 levels, each sample read from the MIP level nearest its lod, a 32²
    /// irradiance cube,
    /// lights above the diffuse ratio × the mean, at most as many as the chain extracts. The
    /// chain's side (and its paraboloid's) are set per run by [`dynamic`].
    pub fn new(samples: u32, rough_boost: u32, slices: u32) -> FrameSettings {
        FrameSettings {
            chain: 0,
            levels: 7,
            samples,
            rough_boost,
            slices,
            paraboloid: 0,
            irradiance: 32,
            ratio: crate::abi::lights::DIFFUSE_RATIO,
            max_lights: crate::abi::lights::CHAIN_MAX_TEXELS,
            nearest_mip: true,
        }
    }
}

/// The stages, by the span that times each.
const STAGES: [(&str, &str); 3] = [
    ("frame: lights", "light extraction (L00 + extract + tree)"),
    (
        "frame: sh",
        "irradiance cube: SH 2 of the residual + the lights",
    ),
    ("frame: chain", "GGX chain: the residual's + the lights"),
];

/// A frame's resources, made once and reused every frame.
struct Frame {
    l00: Buffer,
    sh: Buffer,
    irradiance: GpuEnvMap,
    lights: GpuExtraction,
    /// The frame's light texels prepared on the GPU for the chain (headers, quadratures,
    /// the coarser ones too, and the tree over them: `Extractor::record_prepare`).
    prepared: GpuLights,
    dp: GpuEnvMap,
    chain: GpuEnvMap,
    /// The residual's conversion to the paraboloid, planned once where it takes areas
    /// (`Converter::plan_pays`).
    plan: Option<ConvertPlan>,
}

/// The passes, built once.
struct Passes {
    proj: ShProjector,
    eval: ShEvaluator,
    extractor: Extractor,
    conv: Converter,
    mip: MipChain,
    split: SplitSum,
    lights: LightsPass,
}

/// The sun sky with its sun at `azimuth` degrees (10⁵ × the zenith, 1.5° across).
fn sky_at(mapping: Mapping, size: u32, azimuth: f64) -> EnvMap {
    let (el, az) = (30f64.to_radians(), azimuth.to_radians());
    let sky = Sky {
        sun_dir: DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos()),
        ..Sky::default()
    };
    let (w, h) = mapping.extent_for_size(size);
    EnvMap::from_fn(mapping, w, h, 2, move |d| sky.radiance(d))
}

/// The chain's (level, faces) frame `index` refilters: everything in frame 0 or without
/// slicing, else level 0 and slice (index − 1) mod `slices` (`time_slices`).
fn chain_units(s: &FrameSettings, index: usize) -> Vec<LevelLayers> {
    let all = |level| LevelLayers {
        level,
        layers: 0..6,
    };
    if s.slices <= 1 || index == 0 {
        return (0..s.levels).map(all).collect();
    }
    let slices = time_slices(s.chain, 6, s.levels, s.level_samples(), s.slices);
    let slice = &slices[(index - 1) % slices.len()];
    std::iter::once(all(0))
        .chain(slice.iter().cloned())
        .collect()
}

/// Records the refilter of frame `index` (of `env`) into `frame`, each stage in its span.
fn record_frame(
    rec: &mut crate::gpu::Recorder,
    p: &Passes,
    env: &GpuEnvMap,
    f: &Frame,
    s: &FrameSettings,
    index: usize,
) -> crate::error::Result<()> {
    let o = Orientation::default();
    let residual = f.lights.residual();
    rec.span(STAGES[0].0, |rec| {
        p.proj.record_into(rec, env, 0, &o, &f.l00)?;
        p.extractor.record(rec, env, &f.l00, s.ratio, &f.lights)?;
        p.extractor
            .record_prepare(rec, &f.lights, DMat3::IDENTITY, &f.prepared)
    })?;
    rec.span(STAGES[1].0, |rec| {
        p.proj.record_into(rec, residual, 2, &o, &f.sh)?;
        p.eval.record_irradiance(rec, &f.sh, 2, &f.irradiance)?;
        p.lights
            .record(rec, &f.prepared, LightKernel::Cosine, &f.irradiance, 0)
    })?;
    rec.span(STAGES[2].0, |rec| {
        let shape = (residual.mapping, residual.width, residual.height);
        let opts = chain_convert_options(shape, s.paraboloid);
        rec.span(PARABOLOID_SPAN, |rec| {
            match &f.plan {
                Some(plan) => p.conv.record_planned(rec, residual, &f.dp, plan)?,
                None => p.conv.record(rec, residual, &f.dp, &opts)?,
            }
            p.mip.record(rec, &f.dp)
        })?;
        let mut chain = PrefilterOptions::new(s.levels);
        (chain.samples, chain.rough_boost) = (s.samples, s.rough_boost);
        chain.nearest_mip = s.nearest_mip;
        for u in chain_units(s, index) {
            rec.span(&level_span(u.level), |rec| {
                // Level 0, the mirror, from the residual itself where that holds it whole
                // (mirror_direct), else from the paraboloid. Its lights are the records
                // themselves, which mirror lookups take directly (a GGX lobe at α → 0 would
                // need every light's finest nodes at every texel, more than the rest of the
                // frame).
                if u.level == 0 && mirror_direct(shape, s.chain) {
                    let opts =
                        ConvertOptions::new(Mapping::Cube, s.chain).with_supersample(Some(1));
                    return p.conv.record(rec, residual, &f.chain, &opts);
                }
                p.split.record_prefilter_slice(
                    rec,
                    &f.dp,
                    &f.chain,
                    &chain,
                    std::slice::from_ref(&u),
                )?;
                if u.level == 0 {
                    return Ok(());
                }
                let ggx = LightKernel::Ggx {
                    alpha: level_alpha(u.level, s.levels),
                };
                p.lights
                    .record_faces(rec, &f.prepared, ggx, &f.chain, u.level, u.layers.clone())
            })?;
        }
        Ok(())
    })
}

/// How the chain's samples read the paraboloid's MIP levels, in words.
fn mip_read_text(s: &FrameSettings) -> &'static str {
    match s.nearest_mip {
        true => "each sample read from the level nearest its lod (`PrefilterOptions::nearest_mip`: a bilinear read)",
        false => "each sample read trilinearly between the two levels about its lod",
    }
}

/// The rough levels' boost in words (`PrefilterOptions::rough_boost`), with each level's
/// samples for each chain side: empty without one.
fn boost_text(s: &FrameSettings, chains: &[u32]) -> String {
    if s.rough_boost <= 1 {
        return String::new();
    }
    let samples = s.level_samples();
    let per_chain: Vec<String> = chains
        .iter()
        .map(|&c| {
            let n: Vec<String> = (1..s.levels)
                .map(|k| samples.at(c, k).to_string())
                .collect();
            format!(
                "levels 1–{} of a {c}² chain take {}",
                s.levels - 1,
                n.join(", ")
            )
        })
        .collect();
    format!(
        " (up to {}× that at a level whose faces are 8² or smaller, `PrefilterOptions::rough_boost`: {})",
        s.rough_boost,
        per_chain.join("; ")
    )
}

/// The residual's conversion to the chain's paraboloid `size` a side, as the renderer's
/// (`ConvertOptions::for_residual_chain`).
fn chain_convert_options(src: (Mapping, u32, u32), size: u32) -> ConvertOptions {
    ConvertOptions::new(Mapping::DualParaboloid, size).for_residual_chain(src)
}

/// Whether the chain's level 0, the mirror, is converted from the residual (`src`) itself: where
/// it has no more texels than level 0 (a cube of the chain's side or smaller), so one
/// bilinear read a texel holds all of it (for a cube of the chain's side, its texels exactly).
/// The paraboloid then only feeds the rough levels' lobes, and the chain's side is enough
/// (their errors do not change). Finer sources would need several reads a texel here, more
/// than their level 0 costs read from a paraboloid of twice the chain's side.
fn mirror_direct(src: (Mapping, u32, u32), chain: u32) -> bool {
    Converter::ratio(src, (Mapping::Cube, chain, chain)) <= 1.0 + 1e-9
}

/// Side of the paraboloid the chain of side `chain` filters from `src`: the chain's where
/// level 0 comes from the source ([`mirror_direct`]), else twice it, so that level 0, read
/// from it, keeps the cube's resolution (a paraboloid's texels span twice the angle at its
/// centre as at its rim).
fn paraboloid_side(src: (Mapping, u32, u32), chain: u32) -> u32 {
    match mirror_direct(src, chain) {
        true => chain,
        false => 2 * chain,
    }
}

/// The span of the chain's conversion to the paraboloid and its MIP chain.
const PARABOLOID_SPAN: &str = "chain: paraboloid + mip";

/// The span of a chain level's refilter and its lights.
fn level_span(level: u32) -> String {
    format!("chain: level {level}")
}

/// The GPU milliseconds in `t` of the paraboloid, then of each of `levels` levels.
fn chain_parts_ms(t: &[Timing], levels: u32) -> Vec<f64> {
    let ms = |label: &str| t.iter().filter(|t| t.label == label).map(|t| t.ms).sum();
    std::iter::once(ms(PARABOLOID_SPAN))
        .chain((0..levels).map(|k| ms(&level_span(k))))
        .collect()
}

/// The GPU milliseconds of each stage in `t`.
fn stage_ms(t: &[Timing]) -> [f64; 3] {
    STAGES.map(|(label, _)| t.iter().filter(|t| t.label == label).map(|t| t.ms).sum())
}

/// The resources one frame's refilter writes, made once for `mapping` `w` × `h` inputs, and
/// the chain's conversion plan where it pays (with a note of its host time and size).
fn frame_resources(
    ctx: &Context,
    p: &Passes,
    (mapping, w, h): (Mapping, u32, u32),
    s: &FrameSettings,
) -> Result<(Frame, Option<String>)> {
    let frame = Frame {
        l00: Buffer::new(
            ctx,
            "frame L00",
            ShProjector::output_bytes(0),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?,
        sh: Buffer::new(
            ctx,
            "frame sh",
            ShProjector::output_bytes(2),
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?,
        irradiance: GpuEnvMap::new(
            ctx,
            "frame irradiance",
            Mapping::Cube,
            s.irradiance,
            s.irradiance,
        )?,
        lights: GpuExtraction::new(ctx, mapping, w, h, s.max_lights)?,
        prepared: {
            let rho = crate::math::lights::largest_rho(mapping, w, h);
            let cells = crate::math::lights::cells_for_rho(rho, level_alpha(1, s.levels));
            GpuLights::on_gpu_local(ctx, s.max_lights, 4 * cells * cells, 0)?
        },
        dp: GpuEnvMap::with_mips(
            ctx,
            "frame paraboloid",
            Mapping::DualParaboloid,
            s.paraboloid,
            s.paraboloid,
        )?,
        chain: SplitSum::cube_chain(ctx, s.chain, s.levels)?,
        plan: None,
    };
    let dp_opts = chain_convert_options((mapping, w, h), s.paraboloid);
    let started = std::time::Instant::now();
    let frame = Frame {
        plan: match p.conv.plan_pays((mapping, w, h), &dp_opts) {
            true => Some(p.conv.plan((mapping, w, h), &dp_opts)?),
            false => None,
        },
        ..frame
    };
    let to = format!("{} {w}x{h} to {}", mapping.name(), s.paraboloid);
    let plan_note = match (&frame.plan, p.conv.uses_area((mapping, w, h), &dp_opts)) {
        (Some(plan), _) => Some(format!(
            "{to}: {:.0} ms, {:.1} MB",
            started.elapsed().as_secs_f64() * 1e3,
            plan.bytes() as f64 / 1e6
        )),
        (None, true) => Some(format!(
            "{to}: not planned (its plan over `Converter::plan_pays`' budget): areas each frame"
        )),
        (None, false) => None,
    };
    Ok((frame, plan_note))
}

/// One input's rows: `frames` maps (the sun moving), each refiltered `reps` times after an
/// untimed frame; the median per stage; errors from the last frame. Also the chain's
/// conversion plan, where it has one: the host's time to make it and its size.
fn input_rows(
    ctx: &Context,
    p: &Passes,
    mapping: Mapping,
    size: u32,
    s: &FrameSettings,
    reps: usize,
) -> Result<(String, [f64; 3], String, Option<String>)> {
    let frames: Vec<EnvMap> = (0..3)
        .map(|k| sky_at(mapping, size, 40.0 + 25.0 * k as f64))
        .collect();
    let gpu: Vec<GpuEnvMap> = frames
        .iter()
        .map(|m| GpuEnvMap::upload(ctx, m))
        .collect::<crate::error::Result<_>>()?;
    let (w, h) = (gpu[0].width, gpu[0].height);
    let (frame, plan_note) = frame_resources(ctx, p, (mapping, w, h), s)?;
    let mut index = 0;
    let timed = time_frames(ctx, p, &gpu, &frame, s, reps, &mut index)?;
    let copy = CopyPass::new(ctx)?;
    let floor = copy_ms(ctx, &copy, mapping, w, h, reps)?
        + copy_ms(ctx, &copy, Mapping::Cube, s.chain, s.chain, reps)? * 4.0 / 3.0
        + copy_ms(ctx, &copy, Mapping::Cube, s.irradiance, s.irradiance, reps)?;
    let last = frames.last().unwrap_or_else(|| unreachable!());
    let (mut errors, level_errors) = frame_errors(ctx, p, last, &gpu[2], &frame, s)?;
    if s.slices > 1 {
        // As many frames again of the last map: every slice refiltered from it once.
        for _ in 0..s.slices {
            ctx.run_untimed("a frame's refilter", |rec| {
                record_frame(rec, p, &gpu[2], &frame, s, index)
            })?;
            index += 1;
        }
        let exact = ExactFilter::new(last, DMat3::IDENTITY);
        let caught = chain_error(ctx, &exact, &frame, s)?
            .into_iter()
            .fold(0.0, worse);
        errors[2] = format!(
            "{} (levels up to {} frames behind); {} frames later, its map unchanged: {caught:.1e}",
            errors[2],
            s.slices - 1,
            s.slices
        );
    }
    // Sliced, the same frames refiltered whole in the same run: the baseline beside it.
    let whole_base = match s.slices > 1 {
        true => {
            let every = FrameSettings { slices: 1, ..*s };
            Some(median(
                time_frames(ctx, p, &gpu, &frame, &every, reps, &mut 0)?.whole,
            ))
        }
        false => None,
    };
    let input = format!("{} {w}x{h}", mapping.name());
    let mut rows = String::new();
    let stage = timed.stages.map(median);
    for (k, (_, name)) in STAGES.iter().enumerate() {
        let name = name.replace("GGX chain", &format!("GGX chain {}²", s.chain));
        rows.push_str(&format!(
            "| {input} | {name} | {:.3} | | | {} |\n",
            stage[k], errors[k]
        ));
    }
    let most = timed.whole.iter().copied().fold(0.0, worse);
    let all = median(timed.whole);
    if let Some(base) = whole_base {
        rows.push_str(&format!(
            "| {input} | whole refilter, every level every frame (same run) | {base:.3} | \
             {floor:.3} | {:.1} | |\n",
            base / floor
        ));
        rows.push_str(&format!(
            "| {input} | slowest frame (one slice of {}) | {most:.3} | {floor:.3} | {:.1} | |\n",
            s.slices,
            most / floor
        ));
    }
    let what = match whole_base {
        Some(_) => "the median frame, time-sliced",
        None => "whole refilter",
    };
    rows.push_str(&format!(
        "| {input} | **{what} (chain {}²), one submission** | **{all:.3}** | {floor:.3} | \
         {:.1} | |\n",
        s.chain,
        all / floor
    ));
    let total: f64 = stage.iter().sum();
    let parts: Vec<f64> = timed.parts.into_iter().map(median).collect();
    let levels: Vec<String> = (0..s.levels as usize)
        .map(|k| match k {
            0 => format!("{:.1} (texel {:.1e})", parts[1], level_errors[0]),
            _ => format!("{:.1} ({:.1e})", parts[k + 1], level_errors[k]),
        })
        .collect();
    let level_row = format!("| {input} | {:.1} | {} |\n", parts[0], levels.join(" | "));
    Ok((rows, stage.map(|m| m / total), level_row, plan_note))
}

/// The GPU milliseconds of timed frames: per stage, whole, and per part of the chain (the
/// paraboloid, then each level), each a list over the frames.
struct FrameTimes {
    stages: [Vec<f64>; 3],
    whole: Vec<f64>,
    parts: Vec<Vec<f64>>,
}

/// Refilters each of `gpu`'s maps into `frame` for `reps` rounds after an untimed one, one
/// submission a frame (counted: an error otherwise), frame indices from `index` on.
fn time_frames(
    ctx: &Context,
    p: &Passes,
    gpu: &[GpuEnvMap],
    frame: &Frame,
    s: &FrameSettings,
    reps: usize,
    index: &mut usize,
) -> Result<FrameTimes> {
    let submissions = ctx.submissions();
    let mut timed = FrameTimes {
        stages: Default::default(),
        whole: Vec::new(),
        parts: vec![Vec::new(); s.levels as usize + 1],
    };
    for r in 0..=reps.max(1) {
        for env in gpu {
            let t = ctx
                .run("a frame's refilter", |rec| {
                    record_frame(rec, p, env, frame, s, *index)
                })?
                .timings;
            *index += 1;
            if r > 0 {
                let ms = stage_ms(&t);
                for (v, m) in timed.stages.iter_mut().zip(ms) {
                    v.push(m);
                }
                timed.whole.push(ms.iter().sum::<f64>());
                for (v, m) in timed.parts.iter_mut().zip(chain_parts_ms(&t, s.levels)) {
                    v.push(m);
                }
            }
        }
    }
    let runs = (reps.max(1) + 1) * gpu.len();
    let made = ctx.submissions() - submissions;
    if made as usize != runs {
        return Err(crate::Error::Invalid(format!(
            "{runs} frames took {made} submissions"
        )));
    }
    Ok(timed)
}

/// The chain's levels 1.. against the exact GGX prefilter (`exact`): each level's mean over
/// [`ERROR_TEXELS`] texels.
fn chain_error(
    ctx: &Context,
    exact: &ExactFilter,
    f: &Frame,
    s: &FrameSettings,
) -> Result<Vec<f64>> {
    let mut means = Vec::new();
    for k in 1..s.levels {
        let side = (s.chain >> k).max(1);
        let level = f.chain.download_level(ctx, k)?;
        let e: Vec<f64> = spread_texels(side, ERROR_TEXELS)
            .into_iter()
            .map(|(t, d)| rel_lum(level[t], exact.ggx(d, level_alpha(k, s.levels))))
            .collect();
        means.push(e.iter().sum::<f64>() / e.len() as f64);
    }
    Ok(means)
}

/// The chain's level 0, the mirror, against the host's residual (`residual`): the mean over
/// [`ERROR_TEXELS`] texels of the relative error against the residual's texel holding each
/// texel's centre (the exact prefilter's limit at α → 0, the map's texels taken as constant).
fn mirror_error(ctx: &Context, f: &Frame, s: &FrameSettings, residual: &EnvMap) -> Result<f64> {
    let level = f.chain.download_level(ctx, 0)?;
    let texels = spread_texels(s.chain, ERROR_TEXELS);
    let sum: f64 = texels
        .iter()
        .map(|&(t, d)| {
            let c = residual.coord(d);
            let i = ((c.u * residual.width as f64) as u32).min(residual.width - 1);
            let j = ((c.v * residual.height as f64) as u32).min(residual.height - 1);
            rel_lum(level[t], residual.texel(c.layer, i, j).map(f64::from))
        })
        .sum();
    Ok(sum / texels.len() as f64)
}

/// Each stage's error on the last frame: the extraction against the host's (count,
/// threshold, power); the irradiance cube against the exact irradiance of the map; the chain's
/// levels 1.. against the exact GGX prefilter of the map (mean over [`ERROR_TEXELS`] a level; the
/// worst level), and each level's mean, level 0's against the residual ([`mirror_error`]).
fn frame_errors(
    ctx: &Context,
    p: &Passes,
    map: &EnvMap,
    env: &GpuEnvMap,
    f: &Frame,
    s: &FrameSettings,
) -> Result<([String; 3], Vec<f64>)> {
    let irr = f.irradiance.download_level(ctx, 0)?;
    let exact = ExactFilter::new(map, DMat3::IDENTITY);
    let mut tech = Vec::new();
    for (t, d) in spread_texels(s.irradiance, ERROR_TEXELS) {
        tech.push(rel_lum(irr[t], exact.irradiance(d)));
    }
    let opts = ExtractOptions {
        ratio: s.ratio,
        max_texels: s.max_lights as usize,
        fill: None,
    };
    let got: Extracted = p.extractor.run_on(env, &opts)?.value;
    let want = extract(map, &opts);
    let split = got.power();
    let lights = format!(
        "{} texels (host {}), threshold {:.1e} of the host's, power {:.1e}",
        got.stats.kept,
        want.lights.len(),
        (got.stats.threshold as f64 / want.threshold - 1.0).abs(),
        (split / luminance(map.power()) - 1.0).abs()
    );
    let mut level_means = chain_error(ctx, &exact, f, s)?;
    let worst_mean = level_means.iter().copied().fold(0.0, worse);
    level_means.insert(0, mirror_error(ctx, f, s, &want.residual)?);
    let mean = tech.iter().sum::<f64>() / tech.len() as f64;
    let most = tech.into_iter().fold(0.0, worse);
    let strings = [
        lights,
        format!("exact irradiance: mean {mean:.1e}, worst {most:.1e} ({ERROR_TEXELS} texels)"),
        format!(
            "exact GGX prefilter, levels 1–{}: worst level's mean {worst_mean:.1e}",
            s.levels - 1
        ),
    ];
    Ok((strings, level_means))
}

/// Runs the benchmark: cube inputs of `cubes` sides and lat-long inputs of `widths`, each
/// refiltered with `s` into a chain of each side in `chains` (its paraboloid: `paraboloid_side`), in
/// `reps` timed rounds; `progress` hears of each input done. The report's job is "dynamic",
/// or "dynamic-sliced" where `s.slices` is above 1.
pub fn dynamic(
    ctx: &Context,
    cubes: &[u32],
    widths: &[u32],
    chains: &[u32],
    s: &FrameSettings,
    reps: usize,
    progress: &dyn Fn(&str),
) -> Result<Report> {
    let passes = Passes {
        proj: ShProjector::new(ctx, Subgroups::Auto)?,
        eval: ShEvaluator::new(ctx)?,
        extractor: Extractor::new(ctx)?,
        conv: Converter::new(ctx)?,
        mip: MipChain::new(ctx)?,
        split: SplitSum::new(ctx)?,
        lights: LightsPass::new(ctx)?,
    };
    let mut body = String::from(
        "| input | stage | GPU ms | floor ms | ratio | error |\n|---|---|---|---|---|---|\n",
    );
    let sliced = s.slices > 1;
    let inputs: Vec<(Mapping, u32)> = cubes
        .iter()
        .map(|&n| (Mapping::Cube, n))
        .chain(widths.iter().map(|&w| (Mapping::LatLong, w)))
        .collect();
    let mut shares = Vec::new();
    let mut plans = Vec::new();
    let mut level_rows = String::new();
    for (&c, &(mapping, size)) in chains
        .iter()
        .flat_map(|c| inputs.iter().map(move |i| (c, i)))
    {
        let (w, h) = mapping.extent_for_size(size);
        let s = &FrameSettings {
            chain: c,
            paraboloid: paraboloid_side((mapping, w, h), c),
            ..*s
        };
        let (rows, share, level_row, plan) = input_rows(ctx, &passes, mapping, size, s, reps)?;
        progress(&format!(
            "dynamic: {} {size}, chain {c}²: done",
            mapping.name()
        ));
        plans.extend(plan);
        body.push_str(&rows);
        level_rows.push_str(&level_row);
        shares.push(format!(
            "{} {size}, chain {c}²: {:.0}% / {:.0}% / {:.0}%",
            mapping.name(),
            100.0 * share[0],
            100.0 * share[1],
            100.0 * share[2]
        ));
    }
    if !sliced {
        let heads: Vec<String> = (0..s.levels)
            .map(|k| format!("level {k} (α {:.3})", level_alpha(k, s.levels)))
            .collect();
        body.push_str(&format!(
            "\nThe chain by part, GPU ms (the median frame) and, for the rough levels, the \
             level's mean error against the exact GGX prefilter ({ERROR_TEXELS} texels a \
             level, or all of a smaller one): the paraboloid (the residual's conversion and MIP \
             chain), level 0 (the mirror, converted from the residual; its mean error against \
             the residual's texel holding each texel's centre), then each rough level's FIS \
             refilter with its lights added.\n\n| input | \
             paraboloid + MIP | {} |\n|---|---|{}\n{level_rows}",
            heads.join(" | "),
            "---|".repeat(s.levels as usize)
        ));
    }
    body.push_str(&format!(
        "\nShare of the frame (lights / irradiance / chain): {}. The chain is the stage furthest \
         from the floor: {n} FIS samples for each of the 7 levels' texels{boost}{sliced}, each a \
         filtered read of the paraboloid, where the floor reads and writes each texel once. \
         A level's time goes as its texels times the samples (the reads, not the sampler's \
         arithmetic, are the cost), so level 1, with 3/4 of the rough levels' texels, takes \
         most of it, the lights added back there included (next to a sun the tree is walked \
         down to its texels' quadratures, the lobe at α 0.028 being narrower than the light \
         texels' spread). \
         The extraction stage is L00 (on a cube, per-texel Gauss–Legendre solid angles), \
         one pass over the map specialised to its mapping (the histogram's, which writes \
         the records and residual at τ; a second only where the cap binds), and the light texels' \
         preparation (sorted by a spatial key, their quadratures and the tree over them).\n",
        shares.join("; "),
        n = s.samples,
        boost = boost_text(s, chains),
        sliced = match sliced {
            true => format!(" (of the rough levels, one slice of {} a frame)", s.slices),
            false => String::new(),
        }
    ));
    if !plans.is_empty() {
        body.push_str(&format!(
            "\nA lat-long residual's conversion to the paraboloid is planned once per input \
             before its frames (`Converter::plan`: the exact areas' geometry in float64 on the \
             host; each frame then gathers its texels' weights), host time and size by input \
             and paraboloid side: {}. Cube \
             inputs convert by samples, 1.5 per source texel spacing and at least 2 per axis \
             (`Converter::chain_supersampling`), unplanned.\n",
            plans.join("; ")
        ));
    }
    let method = format!(
        "Three frames, the sun 25° further round each, as images already on the GPU; each \
         frame's refilter recorded into one command buffer and submitted once, nothing read \
         back (counted). GPU time from timestamps per stage, the median of {reps} rounds \
         after an untimed one. Settings: SH 2 and a {i}² irradiance cube; lights above \
         {ratio}× the mean luminance, at most {max}; a cube of {l} GGX levels ({c}² at \
         level 0) filtered by FIS, {n} samples a texel{boost}, from the residual converted to \
         a dual paraboloid with its MIP chain, {read}. Level 0, the mirror, is converted from the \
         residual itself where it has no more texels (a cube of the chain's side: a copy of its \
         texels; a smaller one: one bilinear read a texel), and the paraboloid is then of the chain's side; for \
         finer sources level 0 is read from a paraboloid of twice the chain's side, which \
         keeps the cube's resolution. Floor: copies of the source, of the chain's cube (its levels: 4/3 of \
         level 0) and of the irradiance cube, in the same run. Errors on the last frame, \
         against the map's exact irradiance and exact GGX prefilter (float64): the lights are \
         added through the tree the GPU builds over its records (`Extractor::record_prepare`, \
         `LightsPass`: a node taken whole where it is small next to the kernel's scale there or \
         its bound error is within 1% of the texel before the lights, a texel by as few of its \
         quadrature's nodes as the kernel's scale at it asks, its coarser quadratures kept, \
         `GpuLights::on_gpu_local`; `LightTree::sum`), the residual by SH 2 and by the chain.",
        i = s.irradiance,
        ratio = s.ratio,
        max = s.max_lights,
        c = chains
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join("² or "),
        l = s.levels,
        n = s.samples,
        boost = boost_text(s, chains),
        read = mip_read_text(s),
    );
    let method = match sliced {
        false => method,
        true => format!(
            "{method} Time-sliced: after a first frame that refilters everything, each frame \
             refilters the chain's level 0 and one of {n} slices of its rough levels' faces \
             (`passes::time_slices`, about equal cost; their lights added to those faces only), \
             so a level lags its map by up to {lag} frames: the errors are the last frame's \
             chain against the exact prefilter of that frame's map, the sun 25° further round \
             each frame. Beside it, the same frames refiltered whole in the same run.",
            n = s.slices,
            lag = s.slices - 1
        ),
    };
    Ok(Report {
        job: if sliced { "dynamic-sliced" } else { "dynamic" },
        title: if sliced {
            "An environment that changes every frame, its chain time-sliced"
        } else {
            "An environment that changes every frame"
        },
        method,
        body,
    })
}
