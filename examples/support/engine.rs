//! A stand-in for an engine's own Vulkan setup, shared by the examples: an instance with the
//! validation layer and a messenger that counts warnings, one device with a graphics+compute
//! queue (Vulkan 1.3, synchronization2 and dynamic rendering), and teardown in reverse order.

use ash::vk;
use std::sync::atomic::{AtomicUsize, Ordering};

static WARNINGS: AtomicUsize = AtomicUsize::new(0);

unsafe extern "system" fn callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) {
        WARNINGS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the loader passes valid callback data for the duration of the call.
        if let Some(m) = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) } {
            eprintln!("[engine validation] {}", m.to_string_lossy());
        }
    }
    vk::FALSE
}

/// The engine's Vulkan objects.
pub struct Engine {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug: ash::ext::debug_utils::Instance,
    messenger: vk::DebugUtilsMessengerEXT,
    pub physical: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub family: u32,
}

impl Engine {
    /// Creates the instance, messenger and device.
    pub fn new() -> Result<Engine, Box<dyn std::error::Error>> {
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
        let debug = ash::ext::debug_utils::Instance::new(&entry, &instance);
        let mi = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
            )
            .pfn_user_callback(Some(callback));
        // SAFETY: valid instance and create info.
        let messenger = unsafe { debug.create_debug_utils_messenger(&mi, None)? };
        // SAFETY: valid instance.
        let physical = unsafe { instance.enumerate_physical_devices()? }[0];
        // SAFETY: valid physical device.
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
        // SAFETY: the device has this queue.
        let queue = unsafe { device.get_device_queue(family, 0) };
        Ok(Engine {
            entry,
            instance,
            debug,
            messenger,
            physical,
            device,
            queue,
            family,
        })
    }

    /// Validation warnings and errors seen so far.
    pub fn warnings(&self) -> usize {
        WARNINGS.load(Ordering::SeqCst)
    }

    /// A memory type of `bits` with `flags`.
    pub fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Option<u32> {
        // SAFETY: valid physical device.
        let props = unsafe {
            self.instance
                .get_physical_device_memory_properties(self.physical)
        };
        (0..props.memory_type_count).find(|&i| {
            bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    }
}

impl Drop for Engine {
    fn drop(&mut self) {
        // SAFETY: the engine's own objects, destroyed children first after the device idles.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
            self.debug
                .destroy_debug_utils_messenger(self.messenger, None);
            self.instance.destroy_instance(None);
        }
    }
}
