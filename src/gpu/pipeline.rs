//! Pipelines built from a [`ShaderId`] and its interface, and transient descriptor sets.

use super::context::{Context, Shared};
use super::resources::{Buffer, Image, Sampler};
use super::shaders::{descriptor_type, spirv};
use crate::abi::{Kind, PushBlock, ShaderId};
use crate::error::{Result, VkContext};
use ash::vk;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

fn shader_module(shared: &Shared, id: ShaderId) -> Result<vk::ShaderModule> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv(id)))
        .map_err(|_| crate::Error::Invalid(format!("spirv/{}.spv is not SPIR-V", id.name())))?;
    let info = vk::ShaderModuleCreateInfo::default().code(&words);
    // SAFETY: valid device; the words are a SPIR-V module built for Vulkan 1.2.
    let m = unsafe { shared.device.create_shader_module(&info, None) }
        .vk("creating a shader module")?;
    shared.name(m, id.source().name);
    Ok(m)
}

/// A descriptor set layout, pipeline layout and pipeline.
pub struct Pipeline {
    shared: Arc<Shared>,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    pub(crate) set_layout: vk::DescriptorSetLayout,
    pub(crate) shader: ShaderId,
    /// Unique in the process (descriptor caches key by it).
    pub(crate) serial: u64,
    stages: vk::ShaderStageFlags,
}

impl Pipeline {
    fn layouts(
        shared: &Arc<Shared>,
        shader: ShaderId,
        stages: vk::ShaderStageFlags,
    ) -> Result<Pipeline> {
        let iface = shader.interface();
        let bindings: Vec<_> = iface
            .bindings
            .iter()
            .map(|&(b, kind, _)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(descriptor_type(kind))
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid device and create info.
        let set_layout = unsafe { shared.device.create_descriptor_set_layout(&info, None) }
            .vk("creating a descriptor set layout")?;
        shared.track();
        let mut p = Pipeline {
            shared: shared.clone(),
            pipeline: vk::Pipeline::null(),
            layout: vk::PipelineLayout::null(),
            set_layout,
            shader,
            serial: super::context::next_serial(),
            stages,
        };
        shared.name(set_layout, shader.name());
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(stages)
            .offset(0)
            .size(iface.push_size)];
        let set_layouts = [set_layout];
        let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if iface.push_size > 0 {
            info = info.push_constant_ranges(&ranges);
        }
        // SAFETY: valid device; the set layout is live.
        p.layout = unsafe { shared.device.create_pipeline_layout(&info, None) }
            .vk("creating a pipeline layout")?;
        shared.track();
        shared.name(p.layout, shader.name());
        Ok(p)
    }

    /// The compute pipeline in `cell`, built on first use with [`Pipeline::compute`]: passes
    /// keep one cell per specialisation they may need and build only those a run asks for.
    pub fn compute_once<'a>(
        cell: &'a std::sync::OnceLock<Pipeline>,
        ctx: &Context,
        shader: ShaderId,
        spec: &[u32],
    ) -> Result<&'a Pipeline> {
        if cell.get().is_none() {
            let _ = cell.set(Pipeline::compute(ctx, shader, spec)?);
        }
        Ok(cell.get().unwrap_or_else(|| unreachable!("set above")))
    }

    /// A compute pipeline; `spec` are the u32 specialization constants 0, 1, … (workgroup
    /// sizes from [`crate::abi::WORKGROUP_2D`] and its kin).
    pub fn compute(ctx: &Context, shader: ShaderId, spec: &[u32]) -> Result<Pipeline> {
        let shared = &ctx.shared;
        let mut p = Pipeline::layouts(shared, shader, vk::ShaderStageFlags::COMPUTE)?;
        let module = shader_module(shared, shader)?;
        let entries = spec_entries(spec);
        let data: &[u8] = bytemuck::cast_slice(spec);
        let spec_info = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(data);
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main")
            .specialization_info(&spec_info);
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(p.layout);
        // SAFETY: valid device, module and layout; the module is destroyed right after.
        let result = unsafe {
            shared
                .device
                .create_compute_pipelines(shared.pipeline_cache.cache, &[info], None)
        };
        unsafe { shared.device.destroy_shader_module(module, None) };
        p.pipeline = result
            .map_err(|(_, r)| r)
            .vk("creating a compute pipeline")?[0];
        shared.track();
        shared.name(p.pipeline, shader.name());
        if let Ok(mut log) = shared.pipelines.lock() {
            log.push(shader.name());
        }
        Ok(p)
    }

    /// A graphics pipeline drawing a fullscreen triangle into colour attachments of
    /// `formats` with dynamic rendering, viewport and scissor dynamic.
    pub fn fullscreen(
        ctx: &Context,
        vert: ShaderId,
        frag: ShaderId,
        formats: &[vk::Format],
    ) -> Result<Pipeline> {
        Pipeline::fullscreen_with(ctx, vert, frag, formats, &[])
    }

    /// [`Pipeline::fullscreen`] with the fragment shader's specialisation constants 0, 1, …
    /// set to `spec`.
    pub fn fullscreen_with(
        ctx: &Context,
        vert: ShaderId,
        frag: ShaderId,
        formats: &[vk::Format],
        spec: &[u32],
    ) -> Result<Pipeline> {
        let shared = &ctx.shared;
        assert!(vert.interface().bindings.is_empty() && vert.interface().push_size == 0);
        let mut p = Pipeline::layouts(shared, frag, vk::ShaderStageFlags::FRAGMENT)?;
        let vm = shader_module(shared, vert)?;
        let fm = match shader_module(shared, frag) {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: vm is unused.
                unsafe { shared.device.destroy_shader_module(vm, None) };
                return Err(e);
            }
        };
        let entries = spec_entries(spec);
        let spec_info = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(spec));
        let mut frag_stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(fm)
            .name(c"main");
        if !spec.is_empty() {
            frag_stage = frag_stage.specialization_info(&spec_info);
        }
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vm)
                .name(c"main"),
            frag_stage,
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let attachments: Vec<_> = formats
            .iter()
            .map(|_| {
                vk::PipelineColorBlendAttachmentState::default()
                    .color_write_mask(vk::ColorComponentFlags::RGBA)
            })
            .collect();
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering =
            vk::PipelineRenderingCreateInfo::default().color_attachment_formats(formats);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(p.layout)
            .push_next(&mut rendering);
        // SAFETY: valid device, modules and layout; the modules are destroyed right after.
        let result = unsafe {
            shared
                .device
                .create_graphics_pipelines(shared.pipeline_cache.cache, &[info], None)
        };
        unsafe {
            shared.device.destroy_shader_module(vm, None);
            shared.device.destroy_shader_module(fm, None);
        }
        p.pipeline = result
            .map_err(|(_, r)| r)
            .vk("creating a graphics pipeline")?[0];
        shared.track();
        shared.name(p.pipeline, frag.name());
        if let Ok(mut log) = shared.pipelines.lock() {
            log.push(frag.name());
        }
        Ok(p)
    }

    /// Whether it is a compute pipeline (else a fullscreen graphics one).
    pub fn is_compute(&self) -> bool {
        self.stages == vk::ShaderStageFlags::COMPUTE
    }

    /// The module its layout follows (the fragment shader of a graphics pipeline).
    pub fn shader(&self) -> ShaderId {
        self.shader
    }

    /// Binds the pipeline, its descriptor set (if any) and push constants.
    pub(crate) fn bind<P: PushBlock>(
        &self,
        cmd: vk::CommandBuffer,
        set: Option<&DescriptorSet>,
        push: &P,
    ) {
        let d = &self.shared.device;
        let point = if self.stages == vk::ShaderStageFlags::COMPUTE {
            vk::PipelineBindPoint::COMPUTE
        } else {
            vk::PipelineBindPoint::GRAPHICS
        };
        assert_eq!(
            std::mem::size_of::<P>() as u32,
            self.shader.interface().push_size,
            "push constant type does not match {:?}",
            self.shader
        );
        // SAFETY: cmd is recording; pipeline, layout and set are live and compatible.
        unsafe {
            d.cmd_bind_pipeline(cmd, point, self.pipeline);
            if let Some(s) = set {
                d.cmd_bind_descriptor_sets(cmd, point, self.layout, 0, &[s.set], &[]);
            }
            if std::mem::size_of::<P>() > 0 {
                d.cmd_push_constants(cmd, self.layout, self.stages, 0, push.bytes());
            }
        }
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        let d = &self.shared.device;
        // SAFETY: no pending work uses the pipeline (passes wait for their submissions).
        unsafe {
            if self.pipeline != vk::Pipeline::null() {
                d.destroy_pipeline(self.pipeline, None);
                self.shared.untrack();
            }
            if self.layout != vk::PipelineLayout::null() {
                d.destroy_pipeline_layout(self.layout, None);
                self.shared.untrack();
            }
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
        self.shared.untrack();
    }
}

/// What a binding points at.
pub enum Bind<'a> {
    /// An image read through a sampler: its array view, or its cube view when `cube`.
    Sampled(&'a Image, &'a Sampler, bool),
    /// A storage image (array view, layout GENERAL).
    Storage(&'a Image),
    /// One MIP level of an image as a storage image (layout GENERAL).
    StorageLevel(&'a Image, u32),
    /// A whole storage buffer.
    Buffer(&'a Buffer),
    /// A buffer's rgba32f texel view (one made with UNIFORM_TEXEL_BUFFER usage).
    Texels(&'a Buffer),
}

impl Bind<'_> {
    /// The image bound, if an image.
    pub(crate) fn image(&self) -> Option<&Image> {
        match self {
            Bind::Sampled(i, _, _) | Bind::Storage(i) | Bind::StorageLevel(i, _) => Some(i),
            Bind::Buffer(_) | Bind::Texels(_) => None,
        }
    }

    /// The buffer bound, if a buffer.
    pub(crate) fn buffer(&self) -> Option<&Buffer> {
        match self {
            Bind::Buffer(b) | Bind::Texels(b) => Some(b),
            _ => None,
        }
    }
}

impl Bind<'_> {
    /// What identifies this binding's descriptor: its kind, its resources' serials, its level.
    fn key(&self) -> [u64; 3] {
        match self {
            Bind::Sampled(i, s, cube) => [1 + *cube as u64, i.serial, s.serial],
            Bind::Storage(i) => [3, i.serial, 0],
            Bind::StorageLevel(i, level) => [4, i.serial, *level as u64],
            Bind::Buffer(b) => [5, b.serial, 0],
            Bind::Texels(b) => [6, b.serial, 0],
        }
    }
}

/// What a frame recorded again on the same resources would otherwise make anew, kept across
/// recordings: descriptor sets (one per pipeline and distinct bindings), buffers uploaded with
/// the same contents, and GPU-only scratch buffers and images (the k-th of each name and size
/// or description a recording asks for). A recorder uses one after [`super::Recorder::use_frame_cache`]; then a frame
/// recorded again allocates nothing (with timestamps off, whose query pools are per
/// recording). Keys are resources' serials, never reused, so a set is never bound to a
/// resource that replaced a destroyed one; what was made for resources since dropped stays
/// until the cache is dropped. An uploaded buffer is never rewritten (an earlier frame may
/// still read it); a scratch buffer is shared by successive recordings, whose barriers order
/// its uses when they are submitted in recording order. Cheap to clone: clones share.
#[derive(Clone, Default)]
pub struct FrameCache {
    inner: Arc<Mutex<CacheInner>>,
}

#[derive(Default)]
struct CacheInner {
    sets: HashMap<Vec<u64>, Arc<DescriptorSet>>,
    uploads: HashMap<(String, u64, usize), Arc<Buffer>>,
    scratch: HashMap<(String, u64, u32, usize), Arc<Buffer>>,
    images: HashMap<(String, [u32; 7], usize), Arc<super::Image>>,
}

impl FrameCache {
    /// An empty cache.
    pub fn new() -> FrameCache {
        FrameCache::default()
    }

    /// Descriptor sets and buffers made so far.
    pub fn len(&self) -> usize {
        self.inner.lock().map_or(0, |c| {
            c.sets.len() + c.uploads.len() + c.scratch.len() + c.images.len()
        })
    }

    /// Whether nothing was made yet.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, CacheInner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The set of `pipeline` with `binds`, written on first use.
    pub(crate) fn set(
        &self,
        ctx: &Context,
        pipeline: &Pipeline,
        binds: &[(u32, Bind<'_>)],
    ) -> Result<Arc<DescriptorSet>> {
        let mut key = vec![pipeline.serial];
        for (b, bind) in binds {
            key.push(*b as u64);
            key.extend(bind.key());
        }
        let mut c = self.lock();
        if let Some(s) = c.sets.get(&key) {
            return Ok(s.clone());
        }
        let set = Arc::new(DescriptorSet::new(ctx, pipeline, binds)?);
        c.sets.insert(key, set.clone());
        Ok(set)
    }

    /// A storage buffer named `name` holding `bytes`, made on first use.
    pub(crate) fn upload(&self, ctx: &Context, name: &str, bytes: &[u8]) -> Result<Arc<Buffer>> {
        let key = (
            name.to_string(),
            crate::abi::fnv1a_bytes(bytes),
            bytes.len(),
        );
        let mut c = self.lock();
        if let Some(b) = c.uploads.get(&key) {
            return Ok(b.clone());
        }
        let b = Arc::new(Buffer::storage(ctx, name, bytes)?);
        c.uploads.insert(key, b.clone());
        Ok(b)
    }

    /// The `k`-th GPU-only scratch buffer of `name`, `size` bytes and `usage` a recording
    /// asks for, made on first use.
    pub(crate) fn scratch(
        &self,
        ctx: &Context,
        (name, size, usage): (&str, u64, ash::vk::BufferUsageFlags),
        k: usize,
    ) -> Result<Arc<Buffer>> {
        let key = (name.to_string(), size, usage.as_raw(), k);
        let mut c = self.lock();
        if let Some(b) = c.scratch.get(&key) {
            return Ok(b.clone());
        }
        let location = gpu_allocator::MemoryLocation::GpuOnly;
        let b = Arc::new(Buffer::new(ctx, name, size, usage, location)?);
        c.scratch.insert(key, b.clone());
        Ok(b)
    }

    /// The `k`-th scratch image of `name` and `desc` a recording asks for, made on first use.
    pub(crate) fn image(
        &self,
        ctx: &Context,
        name: &str,
        desc: super::ImageDesc,
        k: usize,
    ) -> Result<Arc<super::Image>> {
        let key = (name.to_string(), image_key(&desc), k);
        let mut c = self.lock();
        if let Some(i) = c.images.get(&key) {
            return Ok(i.clone());
        }
        let i = Arc::new(super::Image::new(ctx, name, desc)?);
        c.images.insert(key, i.clone());
        Ok(i)
    }
}

/// What identifies an image description in a [`FrameCache`].
pub(crate) fn image_key(d: &super::ImageDesc) -> [u32; 7] {
    [
        d.width,
        d.height,
        d.layers,
        d.format.as_raw() as u32,
        d.usage.as_raw(),
        d.cube as u32,
        d.mips,
    ]
}

/// A descriptor set in a pool of its own, for one submission (or, in a [`FrameCache`],
/// for every recording on the same resources).
pub struct DescriptorSet {
    shared: Arc<Shared>,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
}

impl DescriptorSet {
    /// Allocates and writes a set for `pipeline`; `binds` must cover its interface exactly.
    pub fn new(
        ctx: &Context,
        pipeline: &Pipeline,
        binds: &[(u32, Bind<'_>)],
    ) -> Result<DescriptorSet> {
        let shared = &ctx.shared;
        let iface = pipeline.shader.interface();
        assert_eq!(
            binds.len(),
            iface.bindings.len(),
            "{:?}: wrong number of bindings",
            pipeline.shader
        );
        let sizes: Vec<_> = iface
            .bindings
            .iter()
            .map(|&(_, k, _)| vk::DescriptorPoolSize {
                ty: descriptor_type(k),
                descriptor_count: 1,
            })
            .collect();
        let info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid device and create info.
        let pool = unsafe { shared.device.create_descriptor_pool(&info, None) }
            .vk("creating a descriptor pool")?;
        shared.track();
        shared.name(pool, pipeline.shader.name());
        let mut ds = DescriptorSet {
            shared: shared.clone(),
            pool,
            set: vk::DescriptorSet::null(),
        };
        let layouts = [pipeline.set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool has room for exactly this set.
        ds.set = unsafe { shared.device.allocate_descriptor_sets(&alloc) }
            .vk("allocating a descriptor set")?[0];
        let mut image_infos = Vec::new();
        let mut buffer_infos = Vec::new();
        let mut texel_views = Vec::new();
        for (b, bind) in binds {
            let kind = iface
                .bindings
                .iter()
                .find(|(n, _, _)| n == b)
                .map(|&(_, k, _)| k)
                .unwrap_or_else(|| panic!("{:?} has no binding {b}", pipeline.shader));
            match (bind, kind) {
                (Bind::Sampled(img, smp, cube), Kind::Sampled) => image_infos.push((
                    *b,
                    kind,
                    vk::DescriptorImageInfo {
                        sampler: smp.raw,
                        image_view: if *cube { img.cube_view } else { img.view },
                        image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                    },
                )),
                (Bind::Storage(img), Kind::StorageImage) => image_infos.push((
                    *b,
                    kind,
                    vk::DescriptorImageInfo {
                        sampler: vk::Sampler::null(),
                        image_view: img.level_view(0),
                        image_layout: vk::ImageLayout::GENERAL,
                    },
                )),
                (Bind::StorageLevel(img, level), Kind::StorageImage) => image_infos.push((
                    *b,
                    kind,
                    vk::DescriptorImageInfo {
                        sampler: vk::Sampler::null(),
                        image_view: img.level_view(*level),
                        image_layout: vk::ImageLayout::GENERAL,
                    },
                )),
                (Bind::Buffer(buf), Kind::StorageBuffer) => buffer_infos.push((
                    *b,
                    vk::DescriptorBufferInfo {
                        buffer: buf.raw,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                )),
                (Bind::Texels(buf), Kind::TexelBuffer) => {
                    assert!(
                        buf.texel_view != vk::BufferView::null(),
                        "{:?}: binding {b}'s buffer has no texel view",
                        pipeline.shader
                    );
                    texel_views.push((*b, buf.texel_view));
                }
                _ => panic!("{:?}: binding {b} is a {kind:?}", pipeline.shader),
            }
        }
        let mut writes = Vec::new();
        for (b, kind, info) in &image_infos {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(ds.set)
                    .dst_binding(*b)
                    .descriptor_type(descriptor_type(*kind))
                    .image_info(std::slice::from_ref(info)),
            );
        }
        for (b, info) in &buffer_infos {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(ds.set)
                    .dst_binding(*b)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(std::slice::from_ref(info)),
            );
        }
        for (b, view) in &texel_views {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(ds.set)
                    .dst_binding(*b)
                    .descriptor_type(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                    .texel_buffer_view(std::slice::from_ref(view)),
            );
        }
        // SAFETY: the set and every resource written are live.
        unsafe { shared.device.update_descriptor_sets(&writes, &[]) };
        Ok(ds)
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        // SAFETY: the submission using the set has completed.
        unsafe { self.shared.device.destroy_descriptor_pool(self.pool, None) };
        self.shared.untrack();
    }
}

/// Map entries for specialisation constants 0, 1, … taken from consecutive u32s.
fn spec_entries(spec: &[u32]) -> Vec<vk::SpecializationMapEntry> {
    (0..spec.len() as u32)
        .map(|i| vk::SpecializationMapEntry {
            constant_id: i,
            offset: 4 * i,
            size: 4,
        })
        .collect()
}
