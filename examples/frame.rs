//! An engine's frame with envlight's passes in it: a minimal ash application that owns its
//! device, its command buffer and its images (a dual-paraboloid MIP chain and the frame it
//! shades), records envlight's upload, dual-paraboloid conversion, MIP chain, G-buffer and
//! shading into that one command buffer, submits once and waits on its own fence.
//!
//! `cargo run --example frame [SCENE]` renders a scene of lookup and FIS materials (default
//! `assets/scenes/frame.toml`) to `out/frame.exr`; `tests/frame.rs` runs the same code and
//! compares the frame with `envlight render` of the same scene.

#[path = "support/engine.rs"]
#[allow(dead_code)]
mod engine;

use ash::vk;
use envlight::gpu::{Context, Image, ImageDesc, Recorder, Usage};
use envlight::passes::gbuffer::{GBuffer, ObjectRecord};
use envlight::passes::map::{full_mips, map_desc};
use envlight::passes::shade::ShadeInputs;
use envlight::passes::{ConvertOptions, Converter, GBufferPass, GpuEnvMap, MipChain, Shade};
use envlight::scene::{MapShape, Scene, Technique};
use envlight::{EnvMap, Mapping};
use std::path::Path;

type Error = Box<dyn std::error::Error>;

/// What a run produced.
pub struct Frame {
    /// The shaded frame, linear RGB.
    pub frame: EnvMap,
    /// Validation warnings the engine saw.
    pub warnings: usize,
    /// envlight objects still alive after everything was dropped (must be 0).
    pub leaked: i64,
    /// GPU time of each span of the one command buffer.
    pub timings: Vec<envlight::gpu::Timing>,
}

/// Renders `scene` (lookup and FIS materials only) in one command buffer of the engine's.
pub fn run(scene_path: &Path) -> Result<Frame, Error> {
    let scene = Scene::load(scene_path)?;
    let env = scene.load_environment(scene_path.parent().unwrap_or(Path::new(".")))?;
    if let Some(o) = scene.objects.iter().find(|o| {
        !matches!(
            o.material.technique(),
            Technique::Lookup | Technique::Fis { .. }
        )
    }) {
        return Err(format!(
            "this example shades lookup and FIS only, not {:?}",
            o.material
        )
        .into());
    }
    let engine = engine::Engine::new()?;

    // The engine's command pool and command buffer.
    let (pool, cmd) = engine.command_buffer()?;

    // The engine's images: the dual-paraboloid chain and the frame.
    let dp_size = scene.fis_dp_size(MapShape::of(&env));
    let (dw, dh) = Mapping::DualParaboloid.extent_for_size(dp_size);
    let dp_desc = map_desc(Mapping::DualParaboloid, dw, dh, full_mips(dw, dh));
    let (fw, fh) = (scene.camera.width, scene.camera.height);
    let frame_desc = ImageDesc {
        width: fw,
        height: fh,
        layers: 1,
        format: envlight::passes::gbuffer::FORMAT,
        usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_SRC,
        cube: false,
        mips: 1,
    };
    let dp_raw = engine::EngineImage::new(&engine, &dp_desc)?;
    let frame_raw = engine::EngineImage::new(&engine, &frame_desc)?;

    let (frame, timings, leaked) = {
        // SAFETY: the engine's handles are valid and outlive the context (this block).
        let ctx = unsafe { Context::adopt(engine.adopt_info())? };
        // SAFETY: both images were created above as their descriptions say, and are
        // destroyed by the engine only after every envlight object using them is gone.
        let dp = GpuEnvMap::from_image(
            unsafe {
                Image::from_raw(
                    &ctx,
                    "engine paraboloid",
                    dp_raw.raw,
                    dp_desc,
                    Usage::Undefined,
                )?
            },
            Mapping::DualParaboloid,
        );
        let target = GpuEnvMap::from_image(
            unsafe {
                Image::from_raw(
                    &ctx,
                    "engine frame",
                    frame_raw.raw,
                    frame_desc,
                    Usage::Undefined,
                )?
            },
            Mapping::LatLong,
        );
        // Passes are built once, before the frame.
        let converter = Converter::new(&ctx)?;
        let mip = MipChain::new(&ctx)?;
        let gbuffer = GBufferPass::new(&ctx)?;
        let shade = Shade::new(&ctx)?;
        let orientation = scene.environment.orientation();
        let env_gpu = GpuEnvMap::new(&ctx, "environment", env.mapping, env.width, env.height)?;
        let objects: Vec<ObjectRecord> = scene.objects.iter().map(|o| o.record(0)).collect();
        let mut gbuf = GBuffer::new(&ctx, fw, fh, &objects)?;
        // Footprint-filtered mirrors cast sub-pixel rays of this camera.
        gbuf.camera = Some(scene.camera);

        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: a fresh command buffer of the engine's pool.
        unsafe { engine.device.begin_command_buffer(cmd, &begin)? };
        // SAFETY: cmd is recording, outside a render pass, for this context's queue family;
        // `recorded` and every resource live until the fence below has signalled.
        let mut rec = unsafe { Recorder::begin(&ctx, cmd, true) };
        env_gpu.record_upload(&mut rec, &env)?;
        let opts = ConvertOptions::new(Mapping::DualParaboloid, dp_size)
            .with_orientation(orientation)
            .with_nearest(scene.chain_of_texel_means());
        converter.record(&mut rec, &env_gpu, &dp, &opts)?;
        mip.record(&mut rec, &dp)?;
        gbuffer.record(&mut rec, &scene.camera, &gbuf)?;
        let inputs = ShadeInputs {
            env: &env_gpu,
            orientation,
            sh: None,
            dp: Some(&dp),
            prefiltered: None,
            mc: None,
            brdf_sh: None,
            sh_rotation: envlight::passes::shade::Rotation::Zxzxz,
            split: None,
            shadows: scene.shadows,
            lights: None,
            footprint: scene.footprint(true, false),
        };
        shade.record(&mut rec, &gbuf, &inputs, &target)?;
        let readback = target.record_download(&mut rec, 0)?;
        let recorded = rec.finish();
        // SAFETY: cmd is recording on the engine's device.
        unsafe { engine.submit_and_wait(cmd)? };
        let timings = recorded.timings()?;
        let frame = EnvMap::new(
            Mapping::LatLong,
            fw,
            fh,
            readback
                .read()
                .into_iter()
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
        );
        drop((
            recorded, readback, dp, target, converter, mip, gbuffer, shade, env_gpu, gbuf,
        ));
        (frame, timings, ctx.live_objects())
    };

    // The engine tears down what it made.
    dp_raw.destroy(&engine);
    frame_raw.destroy(&engine);
    // SAFETY: the command buffer's work completed; the pool is the engine's.
    unsafe { engine.device.destroy_command_pool(pool, None) };
    // Counted after the device and instance are gone: leaks are reported as they go.
    let warnings = engine.finish();
    Ok(Frame {
        frame,
        warnings,
        leaked,
        timings,
    })
}

#[allow(dead_code)]
fn main() {
    let scene = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "assets/scenes/frame.toml".into());
    match run(Path::new(&scene)) {
        Ok(f) => {
            for t in &f.timings {
                println!("  GPU {:>9.3} ms  {}", t.ms, t.label);
            }
            let out = Path::new("out/frame.exr");
            if let Err(e) = std::fs::create_dir_all("out")
                .map_err(Error::from)
                .and_then(|_| envlight::io::save_exr(&f.frame, out).map_err(Error::from))
            {
                eprintln!("frame example: {e}");
                std::process::exit(1);
            }
            println!(
                "wrote {}; {} validation warnings, {} envlight objects left",
                out.display(),
                f.warnings,
                f.leaked
            );
            if f.warnings > 0 || f.leaked != 0 {
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("frame example failed: {e}");
            std::process::exit(1);
        }
    }
}
