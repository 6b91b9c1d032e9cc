//! Embedding envlight in an engine that owns its Vulkan instance, device and queue.
//!
//! The "engine" below creates its objects with ash (validation on), hands them to
//! `Context::adopt`, converts a map, drops the envlight context, and then keeps using its device:
//! envlight destroyed only what it created. `tests/adopt.rs` runs this same code.

use ash::vk;
use envlight::gpu::{AdoptInfo, Context};
use envlight::math::synth::smooth_env;
use envlight::passes::{ConvertOptions, Converter};
use envlight::GpuEnvMap;
use envlight::{EnvMap, Mapping};
use std::sync::atomic::{AtomicUsize, Ordering};

static ENGINE_WARNINGS: AtomicUsize = AtomicUsize::new(0);

unsafe extern "system" fn engine_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) {
        ENGINE_WARNINGS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the loader passes valid callback data for the duration of the call.
        if let Some(m) = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) } {
            eprintln!("[engine validation] {}", m.to_string_lossy());
        }
    }
    vk::FALSE
}

/// Runs the example; returns the number of validation warnings the engine saw.
pub fn run() -> Result<usize, Box<dyn std::error::Error>> {
    // --- The engine's own setup (any engine does this its own way). ---
    // SAFETY: loads the system loader.
    let entry = unsafe { ash::Entry::load()? };
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
    let exts = [ash::ext::debug_utils::NAME.as_ptr()];
    let ci = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&exts);
    // SAFETY: valid create info.
    let instance = unsafe { entry.create_instance(&ci, None)? };
    let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
    let mi = vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
        )
        .pfn_user_callback(Some(engine_callback));
    // SAFETY: valid instance and create info.
    let messenger = unsafe { du.create_debug_utils_messenger(&mi, None)? };
    // SAFETY: valid instance.
    let physical = unsafe { instance.enumerate_physical_devices()? }[0];
    let family = unsafe { instance.get_physical_device_queue_family_properties(physical) }
        .iter()
        .position(|f| {
            f.queue_flags
                .contains(vk::QueueFlags::COMPUTE | vk::QueueFlags::GRAPHICS)
        })
        .ok_or("no graphics+compute queue")? as u32;
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
        .synchronization2(true)
        .dynamic_rendering(true);
    let prio = [1.0];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family)
        .queue_priorities(&prio)];
    let dci = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .push_next(&mut f13);
    // SAFETY: valid physical device and create info.
    let device = unsafe { instance.create_device(physical, &dci, None)? };
    let queue = unsafe { device.get_device_queue(family, 0) };

    // --- envlight on the engine's objects. ---
    {
        // SAFETY: the handles are valid and outlive the context (dropped at the end of this block).
        let ctx = unsafe {
            Context::adopt(AdoptInfo {
                entry: entry.clone(),
                instance: instance.clone(),
                physical_device: physical,
                device: device.clone(),
                queue,
                queue_family_index: family,
                debug_utils: true,
            })?
        };
        let map = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, smooth_env);
        let gpu = GpuEnvMap::upload(&ctx, &map)?;
        let conv = Converter::new(&ctx)?;
        let opts = ConvertOptions {
            to: Mapping::Cube,
            size: 16,
            orientation: Default::default(),
            supersample: None,
        };
        let (cube, timings) = conv.run(&gpu, &opts)?;
        let back = cube.download(&ctx)?;
        println!(
            "converted on the engine's device: {} ({:.3} ms GPU)",
            back.mapping.name(),
            timings.iter().map(|t| t.ms).sum::<f64>()
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
        device.device_wait_idle()?;
        device.destroy_device(None);
        du.destroy_debug_utils_messenger(messenger, None);
        instance.destroy_instance(None);
    }
    Ok(ENGINE_WARNINGS.load(Ordering::SeqCst))
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
