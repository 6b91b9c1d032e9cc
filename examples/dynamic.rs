//! An engine's loop with an environment that changes every frame: a minimal ash application
//! renders its own sky, its sun moving, into its own cube image with its own compute shader
//! (`support/sky.comp`), and records into the same command buffer envlight's resident render of
//! a scene lit by that image (diffuse by SH, GGX by FIS and by split-sum:
//! `assets/scenes/dynamic.toml`) and its own copies of the frame and the sky to the host. One
//! submission a frame, the engine's; envlight reads nothing back, submits nothing, and after
//! the first frame creates nothing (its descriptor sets are kept by the prepared render).
//!
//! `cargo run --release --example dynamic [FRAMES]` writes `out/dynamic/frame_K.exr` and the
//! sky it was lit by, `sky_K.exr`; `tests/dynamic.rs` runs the same code and compares each
//! frame with `envlight render` of that frame's sky.

#[path = "support/engine.rs"]
#[allow(dead_code)]
mod engine;

use ash::vk;
use engine::{Engine, EngineImage, HostBuffer};
use envlight::gpu::{Context, Image, Recorder, Usage};
use envlight::passes::map::map_desc;
use envlight::passes::GpuEnvMap;
use envlight::render::{MapShape, Renderer};
use envlight::scene::Scene;
use envlight::{EnvMap, Mapping};
use std::path::Path;

type Error = Box<dyn std::error::Error>;

/// Face side of the engine's sky cube.
pub const SKY_SIZE: u32 = 32;

/// The sun's direction in frame `k`: 25° up, swinging from 40° left of the camera's back to
/// 40° right over the frames (behind the camera, so that the spheres show its highlight).
pub fn sun_dir(k: usize, frames: usize) -> [f32; 3] {
    let t = if frames > 1 {
        k as f32 / (frames - 1) as f32
    } else {
        0.5
    };
    let (el, az) = (25f32.to_radians(), (-40.0 + 80.0 * t).to_radians());
    [az.sin() * el.cos(), el.sin(), az.cos() * el.cos()]
}

/// What a run produced.
pub struct Run {
    /// Each frame, linear RGB, as the engine read it back.
    pub frames: Vec<EnvMap>,
    /// The sky each frame was lit by, as the engine read it back.
    pub skies: Vec<EnvMap>,
    /// Submissions the engine made in its loop (one a frame).
    pub engine_submissions: usize,
    /// Submissions envlight made during the loop (none: it only records).
    pub envlight_submissions: u64,
    /// Vulkan objects envlight created in frames after the first.
    pub created_after_first: u64,
    /// Validation warnings and errors the engine saw.
    pub warnings: usize,
    /// envlight objects still alive after everything was dropped (must be 0).
    pub leaked: i64,
}

/// The engine's sky pipeline: its shader, layouts, the view and set it writes the cube with.
struct SkyPipeline {
    module: vk::ShaderModule,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    view: vk::ImageView,
}

/// The sky shader's push constants (std430: vec4, uint, padded to 32 bytes).
#[repr(C)]
#[derive(Clone, Copy)]
struct SkyPush {
    sun: [f32; 4],
    size: u32,
    pad: [u32; 3],
}

impl SkyPipeline {
    fn new(e: &Engine, sky: vk::Image) -> Result<SkyPipeline, Error> {
        let words = ash::util::read_spv(&mut std::io::Cursor::new(
            &include_bytes!("support/sky.spv")[..],
        ))?;
        let d = &e.device;
        // SAFETY: valid device and create infos throughout; every object is destroyed once in
        // `destroy`, after the GPU is done.
        unsafe {
            let module =
                d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)?;
            let bindings = [vk::DescriptorSetLayoutBinding::default()
                .binding(0)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)];
            let set_layout = d.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .size(std::mem::size_of::<SkyPush>() as u32)];
            let set_layouts = [set_layout];
            let layout = d.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&set_layouts)
                    .push_constant_ranges(&ranges),
                None,
            )?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let info = vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(layout);
            let pipeline = d
                .create_compute_pipelines(vk::PipelineCache::null(), &[info], None)
                .map_err(|(_, r)| r)?[0];
            let sizes = [vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_IMAGE,
                descriptor_count: 1,
            }];
            let pool = d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes),
                None,
            )?;
            let set = d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&set_layouts),
            )?[0];
            let view = d.create_image_view(
                &vk::ImageViewCreateInfo::default()
                    .image(sky)
                    .view_type(vk::ImageViewType::TYPE_2D_ARRAY)
                    .format(envlight::passes::map::FORMAT)
                    .subresource_range(
                        vk::ImageSubresourceRange::default()
                            .aspect_mask(vk::ImageAspectFlags::COLOR)
                            .level_count(1)
                            .layer_count(6),
                    ),
                None,
            )?;
            let image_info = [vk::DescriptorImageInfo::default()
                .image_view(view)
                .image_layout(vk::ImageLayout::GENERAL)];
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .image_info(&image_info);
            d.update_descriptor_sets(&[write], &[]);
            Ok(SkyPipeline {
                module,
                set_layout,
                layout,
                pipeline,
                pool,
                set,
                view,
            })
        }
    }

    /// Records the sky with its sun along `sun` into the cube (in layout GENERAL).
    fn record(&self, e: &Engine, cmd: vk::CommandBuffer, sun: [f32; 3]) {
        let push = SkyPush {
            sun: [sun[0], sun[1], sun[2], 1.0e4],
            size: SKY_SIZE,
            pad: [0; 3],
        };
        // SAFETY: plain old data of the push range's size.
        let bytes = unsafe {
            std::slice::from_raw_parts(
                (&push as *const SkyPush).cast::<u8>(),
                std::mem::size_of::<SkyPush>(),
            )
        };
        let groups = SKY_SIZE.div_ceil(8);
        // SAFETY: cmd is recording outside a render pass; the pipeline, layout and set are
        // live and match.
        unsafe {
            let d = &e.device;
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.set],
                &[],
            );
            d.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, bytes);
            d.cmd_dispatch(cmd, groups, groups, 6);
        }
    }

    fn destroy(self, e: &Engine) {
        let d = &e.device;
        // SAFETY: the GPU is done with every object; each is destroyed once.
        unsafe {
            d.destroy_image_view(self.view, None);
            d.destroy_descriptor_pool(self.pool, None);
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
            d.destroy_shader_module(self.module, None);
        }
    }
}

/// Records the engine's copy of every layer of `image` (left in TRANSFER_SRC_OPTIMAL) into
/// `dst`, and the barrier that makes it visible to the host.
fn record_copy(e: &Engine, cmd: vk::CommandBuffer, image: &Image, dst: &HostBuffer) {
    let desc = image.desc();
    let region = vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .layer_count(desc.layers),
        )
        .image_extent(vk::Extent3D {
            width: desc.width,
            height: desc.height,
            depth: 1,
        });
    let barrier = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::HOST)
        .dst_access_mask(vk::AccessFlags2::HOST_READ)];
    // SAFETY: cmd is recording outside a render pass; the image is in TRANSFER_SRC_OPTIMAL
    // (declared to envlight's recorder just before) and the buffer holds every layer.
    unsafe {
        e.device.cmd_copy_image_to_buffer(
            cmd,
            image.raw(),
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            dst.raw,
            &[region],
        );
        e.device.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().memory_barriers(&barrier),
        );
    }
}

/// The map `buffer` holds: `layers` layers of `width` × `height` RGBA32F texels.
fn map_of(buffer: &HostBuffer, mapping: Mapping, width: u32, height: u32) -> EnvMap {
    let rgb = buffer
        .texels()
        .into_iter()
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    EnvMap::new(mapping, width, height, rgb)
}

/// Runs the engine's loop for `frames` frames over `scene_path`'s scene.
pub fn run(scene_path: &Path, frames: usize) -> Result<Run, Error> {
    let scene = Scene::load(scene_path)?;
    let engine = Engine::new()?;
    let (pool, cmd) = engine.command_buffer()?;

    // The engine's sky: its cube image, its pipeline, and the buffers it reads frames into.
    let sky_desc = map_desc(Mapping::Cube, SKY_SIZE, SKY_SIZE, 1);
    let sky_raw = EngineImage::new(&engine, &sky_desc)?;
    let sky_pipeline = SkyPipeline::new(&engine, sky_raw.raw)?;
    let (fw, fh) = (scene.camera.width, scene.camera.height);
    let frame_buffer = HostBuffer::new(&engine, fw as u64 * fh as u64 * 16)?;
    let sky_buffer = HostBuffer::new(&engine, 6 * (SKY_SIZE * SKY_SIZE) as u64 * 16)?;

    let mut run = Run {
        frames: Vec::new(),
        skies: Vec::new(),
        engine_submissions: 0,
        envlight_submissions: 0,
        created_after_first: 0,
        warnings: 0,
        leaked: 0,
    };
    let leaked = {
        // SAFETY: the engine's handles are valid and outlive the context (this block).
        let ctx = unsafe { Context::adopt(engine.adopt_info())? };
        // SAFETY: the cube was created above as its description says, and is destroyed by
        // the engine only after every envlight object using it is gone.
        let sky = GpuEnvMap::from_image(
            unsafe {
                Image::from_raw(&ctx, "engine sky", sky_raw.raw, sky_desc, Usage::Undefined)?
            },
            Mapping::Cube,
        );
        // Made once: the renderer's passes and the scene's resources for this sky's shape.
        let renderer = Renderer::new(&ctx);
        let shape = MapShape {
            mapping: Mapping::Cube,
            width: SKY_SIZE,
            height: SKY_SIZE,
        };
        let prepared = renderer.resident(&scene, shape)?;
        let submissions = ctx.submissions();
        let mut created = 0;
        for k in 0..frames {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: the command buffer's previous submission has completed (waited on).
            unsafe { engine.device.begin_command_buffer(cmd, &begin)? };
            // SAFETY: cmd is recording, outside a render pass, for the context's queue family;
            // `recorded` and every resource live until the submission below has completed.
            let mut rec = unsafe { Recorder::begin(&ctx, cmd, false) };
            // The engine writes its sky: envlight's recorder places the barrier from the
            // last frame's reads, and knows the image was written when its passes read it.
            rec.use_image(&sky.image, Usage::ComputeWrite);
            sky_pipeline.record(&engine, cmd, sun_dir(k, frames));
            renderer.record_resident(&mut rec, &prepared, &sky)?;
            rec.use_image(&prepared.frame().image, Usage::TransferSrc);
            record_copy(&engine, cmd, &prepared.frame().image, &frame_buffer);
            rec.use_image(&sky.image, Usage::TransferSrc);
            record_copy(&engine, cmd, &sky.image, &sky_buffer);
            let recorded = rec.finish();
            // SAFETY: cmd is recording on the engine's device.
            unsafe { engine.submit_and_wait(cmd)? };
            drop(recorded);
            if k == 0 {
                created = ctx.objects_created();
            }
            run.frames
                .push(map_of(&frame_buffer, Mapping::LatLong, fw, fh));
            run.skies
                .push(map_of(&sky_buffer, Mapping::Cube, SKY_SIZE, SKY_SIZE));
        }
        run.created_after_first = ctx.objects_created() - created;
        run.envlight_submissions = ctx.submissions() - submissions;
        drop((prepared, renderer, sky));
        ctx.live_objects()
    };
    run.engine_submissions = engine.submissions();
    sky_pipeline.destroy(&engine);
    sky_raw.destroy(&engine);
    frame_buffer.destroy(&engine);
    sky_buffer.destroy(&engine);
    // SAFETY: the command buffer's work completed; the pool is the engine's.
    unsafe { engine.device.destroy_command_pool(pool, None) };
    run.warnings = engine.finish();
    run.leaked = leaked;
    Ok(run)
}

#[allow(dead_code)]
fn main() {
    let frames = std::env::args()
        .nth(1)
        .and_then(|n| n.parse().ok())
        .unwrap_or(8);
    let result = run(Path::new("assets/scenes/dynamic.toml"), frames).and_then(|r| {
        let out = Path::new("out/dynamic");
        std::fs::create_dir_all(out)?;
        for (k, (frame, sky)) in r.frames.iter().zip(&r.skies).enumerate() {
            envlight::io::save_exr(frame, out.join(format!("frame_{k}.exr")))?;
            envlight::io::save_exr(sky, out.join(format!("sky_{k}.exr")))?;
        }
        Ok(r)
    });
    match result {
        Ok(r) => {
            println!(
                "wrote {} frames to out/dynamic/: {} submissions (the engine's), {} by envlight, \
                 {} objects created after frame 1, {} validation warnings, {} envlight objects \
                 left",
                r.frames.len(),
                r.engine_submissions,
                r.envlight_submissions,
                r.created_after_first,
                r.warnings,
                r.leaked
            );
            if r.warnings > 0 || r.leaked != 0 || r.envlight_submissions > 0 {
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("dynamic example failed: {e}");
            std::process::exit(1);
        }
    }
}
