//! Extracted light texels added to a cube level (`glsl/lights.comp`, float64 twin
//! `crate::math::light_tree::LightTree::sum`): the bake's irradiance (cosine) and specular (GGX at
//! n = v = r) cubes get their lights this way, on top of what the residual map gives.

use super::map::GpuEnvMap;
use crate::abi::lights::{KERNEL_CLUSTERS, KERNEL_COSINE, KERNEL_GGX, TREE_BUDGET};
use crate::abi::{binding, push::LightsPush, ShaderId, WORKGROUP_2D};
use crate::error::{Error, Result};
use crate::gpu::{groups_2d, Bind, Buffer, Context, Pipeline, Recorder};
use crate::math::light_tree::LightTree;
use crate::math::lights::{
    cells_for_rho, cells_of_nodes, cluster_list, clusters, clusters_of, coarse_offset, gpu_list,
    largest_light_rho, prepare, prepare_local, CLUSTER_GRID,
};
pub use crate::math::lights::{
    Cluster, ExtractOptions, Extraction, LightKernel, LightTexel, PreparedLight,
};
use crate::math::split_sum::chain_norm;
use crate::passes::testing::poison::{self, PassId};
use crate::EnvMap;
use crate::Mapping;

/// The light texels on the GPU, uploaded once per map, and the clusters diffuse techniques
/// sum ([`crate::math::lights::Cluster`]) after them in the same buffer.
pub struct GpuLights {
    buffer: Buffer,
    count: u32,
    nodes: u32,
    clusters: u32,
    tree_nodes: u32,
    /// Where the texels' coarser quadratures start, in vec4s (0: none kept).
    coarse_at: u32,
    /// Whether the lights pass reads the buffer through its texel view (it has one).
    view: bool,
}

/// A light buffer of `vec4s` vec4s: storage, and a texel view where the device's
/// maxTexelBufferElements allows (the lights pass reads it so, faster on llvmpipe).
fn light_buffer(
    ctx: &Context,
    name: &str,
    vec4s: u64,
    extra: ash::vk::BufferUsageFlags,
    location: gpu_allocator::MemoryLocation,
) -> Result<(Buffer, bool)> {
    use ash::vk::BufferUsageFlags as U;
    let view = vec4s.max(1) <= ctx.info().max_texel_buffer_elements;
    let usage = U::STORAGE_BUFFER | extra;
    let usage = match view {
        true => usage | U::UNIFORM_TEXEL_BUFFER,
        false => usage,
    };
    Ok((
        Buffer::new(ctx, name, vec4s.max(1) * 16, usage, location)?,
        view,
    ))
}

impl GpuLights {
    /// Uploads `lights` (all with the same number of nodes).
    pub fn upload(ctx: &Context, lights: &[PreparedLight]) -> Result<GpuLights> {
        Self::upload_with_clusters(ctx, lights, &[])
    }

    /// Uploads `lights` (all with the same number of nodes) in the order of their tree
    /// (`LightTree`), then `clusters`, then the tree's nodes.
    pub fn upload_with_clusters(
        ctx: &Context,
        lights: &[PreparedLight],
        clusters: &[Cluster],
    ) -> Result<GpuLights> {
        Self::upload_owned(ctx, lights.to_vec(), clusters)
    }

    /// [`GpuLights::upload_with_clusters`] of lights it may reorder in place.
    fn upload_owned(
        ctx: &Context,
        lights: Vec<PreparedLight>,
        clusters: &[Cluster],
    ) -> Result<GpuLights> {
        let nodes = lights.first().map_or(0, |t| t.nodes.len()) as u32;
        if lights.iter().any(|t| t.nodes.len() as u32 != nodes) {
            return Err(Error::Invalid(
                "light texels with different node counts".into(),
            ));
        }
        let coarse = lights.first().map_or(0, |t| t.coarse.len());
        if lights.iter().any(|t| t.coarse.len() != coarse) {
            return Err(Error::Invalid(
                "light texels with different coarser quadratures".into(),
            ));
        }
        let count = lights.len() as u32;
        let tree = LightTree::new(lights);
        let mut list = gpu_list(&tree.lights);
        list.extend(cluster_list(clusters));
        // The clusters in use (shade.frag's loop bound; the GPU's fill fewer than their room).
        list.push([clusters.len() as f32, 0.0, 0.0, 0.0]);
        list.extend(tree.gpu_nodes());
        // shade.frag's walk step loads a texel's header and STEP_NODES quadrature nodes from
        // any item, so from the last node it reads past its TREE_VEC4S: zeros there.
        use crate::abi::lights::{HEADER_VEC4S, STEP_NODES, TREE_VEC4S};
        let pad = (HEADER_VEC4S + STEP_NODES)
            .saturating_sub(TREE_VEC4S)
            .max(1);
        list.extend(std::iter::repeat_n([0.0; 4], pad as usize));
        // The coarser quadratures last, in the texels' (tree) order: only the lights pass
        // reads them.
        let coarse_at = match coarse {
            0 => 0,
            _ => list.len() as u32,
        };
        for t in &tree.lights {
            list.extend(t.coarse.iter().map(|&(d, w)| {
                let d = d.as_vec3();
                [d.x, d.y, d.z, w as f32]
            }));
        }
        let (mut buffer, view) = light_buffer(
            ctx,
            "light texels",
            list.len() as u64,
            ash::vk::BufferUsageFlags::empty(),
            gpu_allocator::MemoryLocation::CpuToGpu,
        )?;
        buffer.write(&list);
        Ok(GpuLights {
            buffer,
            count,
            nodes,
            clusters: clusters.len() as u32,
            tree_nodes: tree.nodes.len() as u32,
            coarse_at,
            view,
        })
    }

    /// Lights of clusters alone, room for `cells` of them, written on the GPU with the count
    /// in use after them (`super::Extractor::record_clusters` at vec4
    /// [`GpuLights::cluster_at`]): no light texels, no tree. The resident path's diffuse
    /// lights.
    pub fn clusters_on_gpu(ctx: &Context, cells: u32) -> Result<GpuLights> {
        let vec4s = (cells * crate::abi::lights::CLUSTER_VEC4S + 1) as u64;
        let (buffer, view) = light_buffer(
            ctx,
            "light clusters",
            vec4s,
            ash::vk::BufferUsageFlags::empty(),
            gpu_allocator::MemoryLocation::GpuOnly,
        )?;
        Ok(GpuLights {
            buffer,
            count: 0,
            nodes: 0,
            clusters: cells,
            tree_nodes: 0,
            coarse_at: 0,
            view,
        })
    }

    /// Room for `room` light texels of `nodes` quadrature nodes each, the tree over them
    /// ([`GpuLights::tree_room`] nodes) and `cells` clusters, all written on the GPU
    /// (`super::Extractor::record_prepare`, `super::Extractor::record_clusters`): the
    /// resident path's lights, where FIS, split-sum, Phong maps or footprint lookups add the
    /// light texels (and SH or prefiltered irradiance the clusters) of each frame's map.
    pub fn on_gpu(ctx: &Context, room: u32, nodes: u32, cells: u32) -> Result<GpuLights> {
        Self::on_gpu_with(ctx, room, nodes, cells, false)
    }

    /// [`GpuLights::on_gpu`] with room for each texel's coarser quadratures too (those of
    /// 1 … c − 1 cells, `nodes` being (2c)²; `super::Extractor::record_prepare` writes them,
    /// as `crate::math::lights::prepare_local` does on the host): the lights pass then gives
    /// each texel only as many nodes as the kernel's scale at it asks, 4 in GGX's tail
    /// instead of `nodes`. For lights a chain's levels add (`LightsPass`); shade passes
    /// read the texels' own quadratures alone. Where the coarser quadratures would take the
    /// buffer past the device's `maxStorageBufferRange`, it is made without them
    /// ([`GpuLights::coarse_at`] 0): the lights pass's sums are the same, only slower.
    pub fn on_gpu_local(ctx: &Context, room: u32, nodes: u32, cells: u32) -> Result<GpuLights> {
        Self::on_gpu_with(ctx, room, nodes, cells, true)
    }

    fn on_gpu_with(
        ctx: &Context,
        room: u32,
        nodes: u32,
        cells: u32,
        coarse: bool,
    ) -> Result<GpuLights> {
        use crate::abi::lights::{CLUSTER_VEC4S, HEADER_VEC4S, STEP_NODES, TREE_VEC4S};
        if room == 0 {
            return Self::clusters_on_gpu(ctx, cells);
        }
        let pad = (HEADER_VEC4S + STEP_NODES)
            .saturating_sub(TREE_VEC4S)
            .max(1) as u64;
        let before = room as u64 * (HEADER_VEC4S + nodes) as u64
            + cells as u64 * CLUSTER_VEC4S as u64
            + 1
            + Self::tree_room(room) as u64 * TREE_VEC4S as u64
            + pad;
        // The coarser quadratures only speed the lights pass up: where they would take the
        // buffer past the device's storage range (a coarse map's largest cells for 16384
        // texels), the texels keep their own alone.
        let per_texel = match coarse {
            true => coarse_offset(cells_of_nodes(nodes)) as u64,
            false => 0,
        };
        let fits = (before + room as u64 * per_texel) * 16 <= ctx.info().max_storage_buffer_range;
        let per_texel = if fits { per_texel } else { 0 };
        // (Within the storage range, which is a u32 of bytes, a vec4 offset fits a u32.)
        let coarse_at = if per_texel == 0 { 0 } else { before as u32 };
        let vec4s = before + room as u64 * per_texel;
        let (buffer, view) = light_buffer(
            ctx,
            "light texels and clusters",
            vec4s,
            ash::vk::BufferUsageFlags::TRANSFER_SRC | ash::vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuOnly,
        )?;
        Ok(GpuLights {
            buffer,
            count: room,
            nodes,
            clusters: cells,
            tree_nodes: Self::tree_room(room),
            coarse_at,
            view,
        })
    }

    /// Where the texels' coarser quadratures start in the buffer, in vec4s (0: none kept).
    pub fn coarse_at(&self) -> u32 {
        self.coarse_at
    }

    /// Nodes of the tree the GPU builds over at most `room` texels
    /// (`crate::math::light_tree::LightTree::implicit`): 2·⌈room / LEAF_TEXELS⌉ − 1, and the
    /// end node.
    pub fn tree_room(room: u32) -> u32 {
        2 * room.div_ceil(crate::abi::lights::LEAF_TEXELS)
    }

    /// Nodes of the light texels' tree.
    pub fn tree_nodes(&self) -> u32 {
        self.tree_nodes
    }

    /// Where the tree's nodes start in the buffer, in vec4s: after the clusters and the
    /// count of those in use.
    pub fn tree_at(&self) -> u32 {
        self.cluster_at() + self.clusters * crate::abi::lights::CLUSTER_VEC4S + 1
    }

    /// The lights of `map` on the GPU, or `None` where neither extraction is given: the
    /// light texels of `texels` (`prepare`d for lobes down to `finest`) and the clusters
    /// of `diffuse` (`clusters` on `CLUSTER_GRID`), file directions turned to the world
    /// by `file_to_world`.
    pub fn of_extractions(
        ctx: &Context,
        map: &EnvMap,
        texels: Option<&Extraction>,
        diffuse: Option<&Extraction>,
        file_to_world: glam::DMat3,
        finest: f64,
    ) -> Result<Option<GpuLights>> {
        if texels.is_none() && diffuse.is_none() {
            return Ok(None);
        }
        let t = texels.map(|ex| prepare(map, ex, file_to_world, finest));
        let c = diffuse.map(|ex| clusters(ex, file_to_world, CLUSTER_GRID));
        Self::upload_owned(ctx, t.unwrap_or_default(), &c.unwrap_or_default()).map(Some)
    }

    /// [`GpuLights::of_extractions`] of light texel lists (the extractions' `lights`), each
    /// texel with its coarser quadratures (`crate::math::lights::prepare_local`): the
    /// lights pass then gives each texel only as many nodes as the kernel's scale at it asks.
    pub fn of_lights(
        ctx: &Context,
        map: &EnvMap,
        texels: Option<&[LightTexel]>,
        diffuse: Option<&[LightTexel]>,
        file_to_world: glam::DMat3,
        finest: f64,
    ) -> Result<Option<GpuLights>> {
        if texels.is_none() && diffuse.is_none() {
            return Ok(None);
        }
        let t = texels.map(|l| {
            let cells = cells_for_rho(largest_light_rho(l), finest);
            prepare_local(map, l, file_to_world, cells)
        });
        let c = diffuse.map(|l| clusters_of(l, file_to_world, CLUSTER_GRID));
        Self::upload_owned(ctx, t.unwrap_or_default(), &c.unwrap_or_default()).map(Some)
    }

    /// Clusters held.
    pub fn clusters(&self) -> u32 {
        self.clusters
    }

    /// Where the clusters start in the buffer, in vec4s.
    pub fn cluster_at(&self) -> u32 {
        self.count * self.stride()
    }

    /// Light texels held.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// vec4s per light texel in the buffer.
    pub fn stride(&self) -> u32 {
        crate::abi::lights::HEADER_VEC4S + self.nodes
    }

    /// The buffer (`crate::math::lights::gpu_list`'s layout for the texels, in tree order).
    pub fn buffer(&self) -> &Buffer {
        &self.buffer
    }

    /// The same lights, which the lights pass reads as a storage buffer (as it does lists
    /// beyond the device's maxTexelBufferElements): what tests of that path take.
    #[cfg(feature = "test-hooks")]
    pub fn read_as_storage(mut self) -> GpuLights {
        self.view = false;
        self
    }
}

// shade.frag's walk step and lights.comp's tree walk hand their kernels the STEP_NODES
// directions as one mat4x3.
const _: () = assert!(crate::abi::lights::STEP_NODES == 4, "walk_step's mat4x3");

/// The lights pass.
pub struct LightsPass {
    ctx: Context,
    /// Reading the light list through its texel view.
    view: Pipeline,
    /// Reading it as a storage buffer (built at its first use).
    storage: std::sync::OnceLock<Pipeline>,
}

impl LightsPass {
    /// Builds the pipeline that reads light lists through their texel views (the one that
    /// reads them as storage buffers is built when a list without a view first needs it).
    pub fn new(ctx: &Context) -> Result<LightsPass> {
        Ok(LightsPass {
            ctx: ctx.clone(),
            view: Pipeline::compute(ctx, ShaderId::LightsView, &WORKGROUP_2D)?,
            storage: std::sync::OnceLock::new(),
        })
    }

    /// Records the addition of `lights` filtered by `kernel` — divided by ∫K dω for GGX
    /// (`chain_norm`), as is for the cosine (irradiance) — to level `level` of the cube
    /// `dst`, summed through the lights' tree (`crate::math::light_tree::LightTree::sum`,
    /// each texel's estimate what `dst` holds before the lights). Span: "lights".
    pub fn record(
        &self,
        rec: &mut Recorder,
        lights: &GpuLights,
        kernel: LightKernel,
        dst: &GpuEnvMap,
        level: u32,
    ) -> Result<()> {
        self.record_faces(rec, lights, kernel, dst, level, 0..6)
    }

    /// As [`LightsPass::record`], to the faces `faces` of the level only (a time slice of a
    /// chain, `super::time_slices`), the others left as they were. Faces beyond the cube's
    /// six, or none, are refused.
    pub fn record_faces(
        &self,
        rec: &mut Recorder,
        lights: &GpuLights,
        kernel: LightKernel,
        dst: &GpuEnvMap,
        level: u32,
        faces: std::ops::Range<u32>,
    ) -> Result<()> {
        let (kind, alpha, inv_norm) = match kernel {
            LightKernel::Cosine => (KERNEL_COSINE, 0.0, 1.0),
            LightKernel::Ggx { alpha } => (KERNEL_GGX, alpha, 1.0 / chain_norm(alpha)),
        };
        let push = LightsPush {
            size: 0,
            count: lights.count,
            nodes: lights.nodes,
            kernel: kind,
            alpha: alpha as f32,
            inv_norm: inv_norm as f32,
            at: 0,
            coarse_at: lights.coarse_at,
            cells: cells_of_nodes(lights.nodes),
            tree_at: lights.tree_at(),
            tree_nodes: lights.tree_nodes,
            budget: (TREE_BUDGET / inv_norm) as f32,
            layer: 0,
        };
        self.dispatch(rec, "lights", lights, push, dst, (level, faces))
    }

    /// Records the addition of `lights`' clusters' irradiance
    /// (`crate::math::lights::cluster_irradiance`) to level `level` of the cube `dst`.
    /// Span: "light clusters".
    pub fn record_clusters(
        &self,
        rec: &mut Recorder,
        lights: &GpuLights,
        dst: &GpuEnvMap,
        level: u32,
    ) -> Result<()> {
        let push = LightsPush {
            size: 0,
            count: lights.clusters,
            nodes: 0,
            kernel: KERNEL_CLUSTERS,
            alpha: 0.0,
            inv_norm: 1.0,
            at: lights.cluster_at(),
            coarse_at: 0,
            cells: 0,
            tree_at: 0,
            tree_nodes: 0,
            budget: 0.0,
            layer: 0,
        };
        self.dispatch(rec, "light clusters", lights, push, dst, (level, 0..6))
    }

    /// One dispatch over the faces `faces` of level `level` of the cube `dst` (nothing where
    /// `push.count` is 0), `push`'s size and first face set here.
    fn dispatch(
        &self,
        rec: &mut Recorder,
        span: &str,
        lights: &GpuLights,
        mut push: LightsPush,
        dst: &GpuEnvMap,
        (level, faces): (u32, std::ops::Range<u32>),
    ) -> Result<()> {
        if dst.mapping != Mapping::Cube || level >= dst.mips() {
            return Err(Error::Invalid(format!(
                "{span}: level {level} of a {} map with {} levels (a cube's level expected)",
                dst.mapping.name(),
                dst.mips()
            )));
        }
        if faces.start >= faces.end || faces.end > 6 {
            return Err(Error::Invalid(format!(
                "{span}: faces {faces:?} of a cube's six"
            )));
        }
        if push.count == 0 {
            return Ok(());
        }
        let size = dst.level_size(level).0;
        push.size = size;
        push.layer = faces.start;
        let (pipeline, list) = match lights.view {
            true => (&self.view, Bind::Texels(&lights.buffer)),
            false => (
                Pipeline::compute_once(&self.storage, &self.ctx, ShaderId::Lights, &WORKGROUP_2D)?,
                Bind::Buffer(&lights.buffer),
            ),
        };
        rec.span(span, |rec| {
            rec.dispatch(
                pipeline,
                &[
                    (binding::LIGHTS_TEXELS, list),
                    (binding::LIGHTS_DST, Bind::StorageLevel(&dst.image, level)),
                ],
                &push,
                groups_2d(size, size, faces.end - faces.start),
            )
        })?;
        poison::image(rec, PassId::Lights, &dst.image, level..level + 1)
    }
}
