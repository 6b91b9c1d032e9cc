//! Embedding envlight in an engine that owns its Vulkan instance, device and queue.
//!
//! The "engine" below creates its objects with ash (validation on), hands them to
//! `Context::adopt`, converts a map, drops the envlight context, and then keeps using its device:
//! envlight destroyed only what it created. `tests/adopt.rs` runs this same code.

#[path = "support/engine.rs"]
#[allow(dead_code)]
pub mod engine;

use ash::vk;
use envlight::gpu::{total_ms, AdoptInfo, Context, Timed};
use envlight::passes::{ConvertOptions, Converter};
use envlight::GpuEnvMap;
use envlight::{EnvMap, Mapping};

/// Runs the example; returns the number of validation warnings the engine saw.
pub fn run() -> Result<usize, Box<dyn std::error::Error>> {
    // --- The engine's own setup (any engine does this its own way). ---
    let engine = engine::Engine::new()?;
    let device = engine.device.clone();

    // --- envlight on the engine's objects. ---
    {
        // SAFETY: the handles are valid and outlive the context (dropped at the end of this block).
        let ctx = unsafe {
            Context::adopt(AdoptInfo {
                entry: engine.entry.clone(),
                instance: engine.instance.clone(),
                physical_device: engine.physical,
                device: device.clone(),
                queue: engine.queue,
                queue_family_index: engine.family,
                debug_utils: true,
            })?
        };
        // A sky brighter towards +Y with a warm lobe (any function of the direction will do).
        let map = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| {
            let lobe = (4.0 * (d.dot(glam::DVec3::new(0.3, 0.5, -0.8).normalize()) - 1.0)).exp();
            let base = 1.0 + 0.4 * d.y;
            [
                base + 0.8 * lobe,
                0.7 * base + 1.2 * lobe,
                0.5 * base + 0.4 * lobe + 0.3,
            ]
        });
        let gpu = GpuEnvMap::upload(&ctx, &map)?;
        let conv = Converter::new(&ctx)?;
        let opts = ConvertOptions::new(Mapping::Cube, 16);
        let Timed {
            value: cube,
            timings,
        } = conv.run(&gpu, &opts)?;
        let back = cube.download(&ctx)?;
        println!(
            "converted on the engine's device: {} ({:.3} ms GPU)",
            back.mapping.name(),
            total_ms(&timings)
        );
        drop((gpu, cube, conv));
        assert_eq!(ctx.live_objects(), 0, "envlight left objects behind");
    }

    // --- The engine carries on with its device, then tears it down itself. ---
    let bi = vk::BufferCreateInfo::default()
        .size(256)
        .usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: the device is still alive: envlight did not destroy it.
    unsafe {
        let b = device.create_buffer(&bi, None)?;
        device.destroy_buffer(b, None);
    }
    // Counted after the device and instance are gone: leaks are reported as they go.
    let warnings = engine.finish();
    Ok(warnings)
}

#[allow(dead_code)]
fn main() {
    match run() {
        Ok(0) => println!("adopt example: clean"),
        Ok(n) => {
            eprintln!("adopt example: {n} validation warnings");
            std::process::exit(1);
        }
        Err(e) => {
            eprintln!("adopt example failed: {e}");
            std::process::exit(1);
        }
    }
}
