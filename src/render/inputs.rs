//! The inputs stage: the GPU resources a plan's passes write, and the one submission that
//! records every pass before the shading (uploads, SH projection, SH-BRDF tables, the
//! paraboloid and its chain, split-sum, prefiltered maps, the G-buffer).

use super::lights::Lit;
use super::plan::{PassKind, Plan};
use super::records::Marks;
use super::Job;
use crate::error::Result;
use crate::gpu::{Buffer, Context, Recorder, Usage};
use crate::math::brdf::Brdf;
use crate::math::filter::Kernel;
use crate::math::sh::Window;
use crate::math::Mapping;
use crate::passes::gbuffer::GBuffer;
use crate::passes::sh_pack::{irradiance_entries, windowed_entries, PackEntry};
use crate::passes::{
    BruteFilter, ConvertOptions, ConvertPlan, Converter, GBufferPass, GpuEnvMap, LevelLayers,
    MipChain, PrefilterOptions, ShBrdfProjector, ShPacker, ShProjector, SplitSum,
};
use crate::scene::{Technique, DEFAULT_FIS_BIAS};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// The passes a plan runs, built once per renderer.
pub(super) struct Passes<'r> {
    pub sh: Option<(&'r ShProjector, &'r ShPacker)>,
    pub dp: Option<(&'r Converter, &'r MipChain)>,
    pub brute: Option<&'r BruteFilter>,
    pub gbuffer: &'r GBufferPass,
    pub sh_brdf: Option<&'r ShBrdfProjector>,
    pub split: Option<&'r SplitSum>,
}

/// A prefiltered map: its kernel, its image, its offset in the concatenated maps (texels),
/// and whether it is of a residual (the lights added per pixel).
pub(super) struct PrefilteredMap {
    kernel: Kernel,
    map: GpuEnvMap,
    offset: u32,
    lit: bool,
}

/// The GPU resources the passes write and the shading reads (the environment itself is the
/// caller's: uploaded by the host path, the engine's own image on the resident path).
pub(super) struct Inputs {
    /// The map's radiance SH coefficients (the projection's output, on the GPU).
    pub sh_out: Option<Buffer>,
    /// The sets the shade pass reads, packed from them on the GPU, and their entries.
    pub sh_packed: Option<Buffer>,
    pub sh_entries: Vec<PackEntry>,
    /// The light texels' radiance coefficients, subtracted for the residual's irradiance.
    pub sh_minus: Option<Buffer>,
    /// A host copy of the radiance coefficients, read after the frame for its notes (where an
    /// SH-BRDF object's lighting may ring).
    pub sh_host: Option<Buffer>,
    /// The SH-BRDF tables.
    pub tables: Option<Buffer>,
    /// The FIS dual paraboloid with its MIP chain.
    pub dp: Option<GpuEnvMap>,
    /// Prefiltered maps, one per distinct (kernel, size, of a residual or not).
    pub pre: Vec<PrefilteredMap>,
    /// Each object's prefiltered map's offset (texels; 0 for others).
    pub pre_offsets: Vec<u32>,
    /// The prefiltered maps concatenated, as the shader reads them.
    pub pre_buffer: Option<Buffer>,
    /// The split-sum chain and its DFG tables.
    pub split: Option<(GpuEnvMap, Buffer)>,
}

impl Inputs {
    /// The resources of `job`'s plan, given what the lights stage found and where the SH
    /// objects' sets go.
    pub fn new(job: &Job<'_>, lit: &Lit, sh: &ShLayout) -> Result<Inputs> {
        let (ctx, plan) = (job.ctx, job.plan);
        let storage =
            |name, bytes: u64, usage| Buffer::new(ctx, name, bytes, usage, MemoryLocation::GpuOnly);
        let tables = match plan.runs(PassKind::ShBrdfTable) {
            true => Some(storage(
                "sh brdf tables",
                plan.table_floats().max(4) as u64 * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?),
            false => None,
        };
        let projects = plan.runs(PassKind::ShProjection);
        // The resident path's diffuse residual projects into a second half.
        let halves = 1 + lit.sh_residual_at.is_some() as u64;
        let sh_out = match projects {
            true => Some(storage(
                "sh coefficients",
                halves * ShProjector::output_bytes(plan.lmax),
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
            )?),
            false => None,
        };
        let sh_packed = match projects && !sh.entries.is_empty() {
            true => Some(storage(
                "sh packed coefficients",
                ShPacker::output_bytes(sh.entries.len()),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?),
            false => None,
        };
        let sh_minus = match (&lit.sh_coeffs, projects) {
            (Some(c), true) => {
                let quads: Vec<[f32; 4]> = c
                    .iter()
                    .map(|v| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0])
                    .collect();
                Some(Buffer::storage(
                    ctx,
                    "light texels' sh coefficients",
                    &quads,
                )?)
            }
            _ => None,
        };
        let rings = plan
            .objects
            .iter()
            .any(|o| matches!(o.technique, Technique::ShBrdf { .. }));
        let sh_host = match projects && rings {
            true => Some(Buffer::new(
                ctx,
                "sh coefficients (host copy)",
                ShProjector::output_bytes(plan.lmax),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?),
            false => None,
        };
        let dp = match &plan.dp {
            Some(opts) => {
                let (w, h) = Mapping::DualParaboloid.extent_for_size(opts.size);
                let m = Mapping::DualParaboloid;
                Some(GpuEnvMap::with_mips(ctx, "fis paraboloid", m, w, h)?)
            }
            None => None,
        };
        let (pre, pre_offsets, pre_texels) = prefiltered_maps(ctx, plan, lit)?;
        let pre_buffer = match plan.runs(PassKind::Prefilter) {
            true => Some(storage(
                "prefiltered maps",
                (pre_texels.max(1) as u64) * 16,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            )?),
            false => None,
        };
        let split = match &plan.split {
            Some(sp) => {
                let ss = &job.scene.split_sum;
                let chain = SplitSum::chain(ctx, sp.size, ss.levels)?;
                let floats = sp.forms.len() * SplitSum::dfg_floats(ss.dfg_size);
                let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
                Some((chain, storage("dfg tables", floats as u64 * 4, usage)?))
            }
            None => None,
        };
        Ok(Inputs {
            sh_out,
            sh_packed,
            sh_entries: sh.entries.clone(),
            sh_minus,
            sh_host,
            tables,
            dp,
            pre,
            pre_offsets,
            pre_buffer,
            split,
        })
    }
}

/// The prefiltered maps of `plan`, one per distinct (kernel, size, of a residual or not),
/// each object's offset, and the texels in all.
fn prefiltered_maps(
    ctx: &Context,
    plan: &Plan,
    lit: &Lit,
) -> Result<(Vec<PrefilteredMap>, Vec<u32>, u32)> {
    let mut offsets = vec![0u32; plan.objects.len()];
    let mut maps: Vec<PrefilteredMap> = Vec::new();
    let mut texels = 0u32;
    if !plan.runs(PassKind::Prefilter) {
        return Ok((maps, offsets, texels));
    }
    let mut made: Vec<(u64, u32, bool, u32)> = Vec::new();
    for (k, o) in plan.objects.iter().enumerate() {
        let Technique::Prefiltered { size } = o.technique else {
            continue;
        };
        let kernel = match o.brdf {
            Brdf::Phong { n } => Kernel::Phong { n },
            _ => Kernel::Cosine,
        };
        let key = match kernel {
            Kernel::Phong { n } => n.to_bits(),
            Kernel::Cosine => u64::MAX,
        };
        // Maps of the residual where the lights are added per pixel.
        let of_residual = (lit.prefiltered && o.diffuse_prefiltered()) || lit.phong[k];
        if let Some(&(.., off)) = made
            .iter()
            .find(|m| m.0 == key && m.1 == size && m.2 == of_residual)
        {
            offsets[k] = off;
            continue;
        }
        let (w, h) = Mapping::LatLong.extent_for_size(size);
        let map = GpuEnvMap::new(ctx, "prefiltered", Mapping::LatLong, w, h)?;
        made.push((key, size, of_residual, texels));
        offsets[k] = texels;
        maps.push(PrefilteredMap {
            kernel,
            map,
            offset: texels,
            lit: of_residual,
        });
        texels += w * h;
    }
    Ok((maps, offsets, texels))
}

/// Records the tables no environment changes into `rec`: the SH-BRDF tables and split-sum's
/// DFG tables, their GPU time marked in `marks`. The host path records them with every
/// render (each where its pass runs); the resident path once, when it is prepared.
pub(super) fn record_tables(
    rec: &mut Recorder,
    marks: &mut Marks,
    job: &Job<'_>,
    passes: &Passes<'_>,
    inputs: &Inputs,
) -> Result<()> {
    record_sh_brdf_tables(rec, marks, job, passes, inputs)?;
    record_dfg_tables(rec, marks, job, passes, inputs)
}

/// The SH-BRDF tables ([`record_tables`]).
fn record_sh_brdf_tables(
    rec: &mut Recorder,
    marks: &mut Marks,
    job: &Job<'_>,
    passes: &Passes<'_>,
    inputs: &Inputs,
) -> Result<()> {
    if let (Some(p), Some(buf)) = (passes.sh_brdf, &inputs.tables) {
        for t in &job.plan.tables {
            marks.record(rec, PassKind::ShBrdfTable, |rec| {
                p.record(rec, &t.brdf, t.order, t.grid, buf, t.offset)
            })?;
        }
    }
    Ok(())
}

/// Split-sum's DFG tables ([`record_tables`]).
fn record_dfg_tables(
    rec: &mut Recorder,
    marks: &mut Marks,
    job: &Job<'_>,
    passes: &Passes<'_>,
    inputs: &Inputs,
) -> Result<()> {
    if let (Some(p), Some((_, tables)), Some(sp)) = (passes.split, &inputs.split, &job.plan.split) {
        let size = job.scene.split_sum.dfg_size;
        marks.record(rec, PassKind::SplitSum, |rec| {
            for (i, &correlated) in sp.forms.iter().enumerate() {
                let off = (i * SplitSum::dfg_floats(size)) as u32;
                p.record_dfg(rec, size, correlated, tables, off)?;
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// What a recording of the inputs covers beyond the passes every frame runs.
pub(super) struct Work<'a> {
    /// The environment-independent tables ([`record_tables`]).
    pub tables: bool,
    /// The split-sum chain's units this frame refilters (`None`: every level).
    pub split: Option<Vec<LevelLayers>>,
    /// The diffuse residual on the GPU (the resident path's extraction), which prefiltered
    /// irradiance maps of a residual filter.
    pub diffuse_residual: Option<&'a GpuEnvMap>,
    /// The chain's residual on the GPU (the resident path's extraction), which the paraboloid
    /// converts where it holds the residual and prefiltered Phong maps of a residual filter.
    pub chain_residual: Option<&'a GpuEnvMap>,
    /// The paraboloid's conversion planned for the source it converts (the resident path's,
    /// made once); where it does not serve that source, the conversion runs unplanned.
    pub dp_plan: Option<&'a ConvertPlan>,
    /// The SH output already holds this frame's projection of the map (the resident path's
    /// lights read its band 0 first): only the packing is recorded.
    pub sh_projected: bool,
}

impl Work<'static> {
    /// Everything: the host path's one render.
    pub const ALL: Work<'static> = Work {
        tables: true,
        split: None,
        diffuse_residual: None,
        chain_residual: None,
        dp_plan: None,
        sh_projected: false,
    };
}

/// Records everything before the shading into `rec`, reading the environment `env`: the
/// residuals' uploads, then each pass the plan runs, its GPU time marked in `marks`; the
/// tables and the split-sum levels as `work` says. `convert_built` waits for the paraboloid's
/// conversion pipelines, built on another thread meanwhile.
#[allow(clippy::too_many_arguments)]
pub(super) fn record(
    rec: &mut Recorder,
    marks: &mut Marks,
    job: &Job<'_>,
    passes: &Passes<'_>,
    (inputs, lit, gbuf): (&Inputs, &Lit, &GBuffer),
    env: &GpuEnvMap,
    work: &Work<'_>,
    convert_built: impl FnOnce() -> Result<()>,
) -> Result<()> {
    let (plan, orientation) = (job.plan, &job.orientation);
    if let (Some((p, pack)), Some(out)) = (passes.sh, &inputs.sh_out) {
        marks.record(rec, PassKind::ShProjection, |rec| {
            if !work.sh_projected {
                p.record_into(rec, env, plan.lmax, orientation, out)?;
            }
            // Each object's set, from the coefficients where they are: no readback.
            if let Some(packed) = &inputs.sh_packed {
                let minus = inputs.sh_minus.as_ref();
                pack.record(rec, out, &inputs.sh_entries, minus, packed)?;
            }
            Ok(())
        })?;
        if let Some(host) = &inputs.sh_host {
            rec.copy_buffer(out, host, ShProjector::output_bytes(plan.lmax));
            rec.use_buffer(host, Usage::HostRead);
        }
    }
    if let (Some(ex), Some(map)) = (&lit.chain, &lit.chain_residual) {
        map.record_upload(rec, &ex.residual)?;
    }
    if let Some((map, gpu)) = &lit.dp_source {
        gpu.record_upload(rec, map)?;
    }
    if let (Some(ex), Some(map)) = (&lit.diffuse, &lit.diffuse_residual) {
        map.record_upload(rec, &ex.residual)?;
    }
    if work.tables {
        record_sh_brdf_tables(rec, marks, job, passes, inputs)?;
    }
    if passes.dp.is_some() && inputs.dp.is_some() && plan.dp.is_some() {
        // After the uploads' staging copies, which this thread makes meanwhile.
        convert_built()?;
        record_chain(rec, marks, job, passes, (inputs, lit), env, work)?;
    }
    if let (Some(b), Some(buf)) = (passes.brute, &inputs.pre_buffer) {
        for m in &inputs.pre {
            let residual = match m.kernel {
                Kernel::Cosine => work.diffuse_residual.or(lit.diffuse_residual.as_ref()),
                Kernel::Phong { .. } => work.chain_residual.or(lit.chain_residual.as_ref()),
            };
            let source = match residual {
                Some(res) if m.lit => res,
                _ => env,
            };
            marks.record(rec, PassKind::Prefilter, |rec| {
                b.record(rec, source, orientation, m.kernel, &m.map)
            })?;
            rec.copy_image_to_buffer(&m.map.image, 0, buf, m.offset as u64 * 16);
        }
    }
    marks.record(rec, PassKind::GBuffer, |rec| {
        passes.gbuffer.record(rec, &job.scene.camera, gbuf)
    })
}

/// The paraboloid's conversion options as `lit` leaves them: from a residual a sampled
/// conversion may take the chain's rate (as predicted for the pipeline built meanwhile, unless the lobes were too narrow for
/// the lights found, which leaves them in the chain: then the general rate).
pub(super) fn dp_convert_options(opts: &ConvertOptions, lit: &Lit) -> ConvertOptions {
    let residual = lit.dp || lit.below_threshold;
    match residual {
        true => *opts,
        false => opts.with_supersample(None),
    }
}

/// Records the paraboloid's conversion (from `env` or its residual), its MIP chain and the
/// split-sum chain filtered from it.
fn record_chain(
    rec: &mut Recorder,
    marks: &mut Marks,
    job: &Job<'_>,
    passes: &Passes<'_>,
    (inputs, lit): (&Inputs, &Lit),
    env: &GpuEnvMap,
    work: &Work<'_>,
) -> Result<()> {
    let (Some((conv, mip)), Some(map), Some(opts)) = (passes.dp, &inputs.dp, &job.plan.dp) else {
        return Ok(());
    };
    let source = match (&lit.dp_source, &lit.chain_residual) {
        (Some((_, gpu)), _) => gpu,
        (None, Some(res)) if lit.dp => res,
        (None, None) if lit.dp => work.chain_residual.unwrap_or(env),
        _ => env,
    };
    let opts = dp_convert_options(opts, lit);
    let shape = (source.mapping, source.width, source.height);
    marks.record(rec, PassKind::DualParaboloid, |rec| {
        match work.dp_plan.filter(|p| p.serves(shape, &opts)) {
            Some(plan) => conv.record_planned(rec, source, map, plan),
            None => conv.record(rec, source, map, &opts),
        }
    })?;
    marks.record(rec, PassKind::MipChain, |rec| mip.record(rec, map))?;
    let (Some(p), Some((chain, _))) = (passes.split, &inputs.split) else {
        return Ok(());
    };
    if work.tables {
        record_dfg_tables(rec, marks, job, passes, inputs)?;
    }
    let ss = &job.scene.split_sum;
    marks.record(rec, PassKind::SplitSum, |rec| {
        let opts = PrefilterOptions {
            samples: ss.samples,
            rough_boost: ss.rough_boost,
            bias: ss.bias.unwrap_or(DEFAULT_FIS_BIAS),
            ..PrefilterOptions::new(ss.levels)
        };
        match &work.split {
            Some(units) => p.record_prefilter_slice(rec, map, chain, &opts, units),
            None => p.record_prefilter(rec, map, chain, &opts),
        }
    })
}

/// Where each SH or SH-BRDF object's set sits in the packed coefficients the shade pass reads,
/// and the entries that pack them from the projection's output on the GPU
/// ([`crate::passes::ShPacker`]).
pub(super) struct ShLayout {
    /// Per object: the offset of its set (in coefficients) and whether it is the diffuse
    /// residual's (the shader then adds the light clusters).
    pub offsets: Vec<super::records::ShOffset>,
    /// The packer's entries, every object's set in turn.
    pub entries: Vec<PackEntry>,
}

/// The packed sets of `job`'s SH objects: irradiance (Â_l folded in) of the map less its
/// light texels' where the lights stage extracted them, SH-BRDF objects' windowed radiance.
pub(super) fn sh_layout(job: &Job<'_>, lit: &Lit) -> ShLayout {
    let residual = lit.sh_coeffs.is_some();
    let shift = |mut e: Vec<PackEntry>| {
        for x in &mut e {
            x.source += lit.sh_residual_at.unwrap_or(0);
        }
        e
    };
    let mut layout = ShLayout {
        offsets: Vec::new(),
        entries: Vec::new(),
    };
    for p in &job.plan.objects {
        let offset = layout.entries.len() as u32;
        let (entries, of_residual) = match p.technique {
            Technique::Sh { order } if lit.sh_residual_at.is_some() => {
                (shift(irradiance_entries(order, false)), true)
            }
            Technique::Sh { order } => (irradiance_entries(order, residual), residual),
            Technique::ShBrdf { order, window, .. } => {
                (windowed_entries(order, window_of(window)), false)
            }
            _ => {
                layout.offsets.push(None);
                continue;
            }
        };
        layout.entries.extend(entries);
        layout.offsets.push(Some((offset, of_residual)));
    }
    layout
}

/// An SH-BRDF object's window.
pub(super) fn window_of(width: Option<f64>) -> Window {
    match width {
        Some(width) => Window::Hanning { width },
        None => Window::None,
    }
}
