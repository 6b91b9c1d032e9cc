//! A stand-in for an engine's own Vulkan setup, shared by the examples: an instance with the
//! validation layer and a messenger that counts warnings, one device with a graphics+compute
//! queue (Vulkan 1.3, synchronization2 and dynamic rendering), and teardown in reverse order.
//! The count includes what the layer reports while the device and the instance are destroyed
//! (objects leaked on them): [`Engine::finish`] reads it after both are gone.

use ash::vk;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Counts the messages into the engine's counter, which `user` points at.
unsafe extern "system" fn callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) {
        // SAFETY: `user` is the engine's boxed counter, which outlives its instance.
        if let Some(count) = unsafe { (user as *const AtomicUsize).as_ref() } {
            count.fetch_add(1, Ordering::SeqCst);
        }
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
    /// The warnings and errors seen, boxed so that the messengers can point at it.
    warnings: Box<AtomicUsize>,
    /// Whether the device and instance are still alive.
    alive: bool,
}

impl Engine {
    /// Creates the instance, messenger and device.
    pub fn new() -> Result<Engine, Box<dyn std::error::Error>> {
        // SAFETY: loads the system loader.
        let entry = unsafe { ash::Entry::load()? };
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
        let exts = [ash::ext::debug_utils::NAME.as_ptr()];
        let warnings = Box::new(AtomicUsize::new(0));
        let user = &*warnings as *const AtomicUsize as *mut std::ffi::c_void;
        let messenger_info = || {
            vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
                )
                .pfn_user_callback(Some(callback))
                .user_data(user)
        };
        // Chained to the instance's create info, the messenger also hears what the layer says
        // while the instance is created and destroyed (objects leaked on it).
        let mut during_instance = messenger_info();
        let ci = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&exts)
            .push_next(&mut during_instance);
        // SAFETY: valid create info.
        let instance = unsafe { entry.create_instance(&ci, None)? };
        let debug = ash::ext::debug_utils::Instance::new(&entry, &instance);
        let mi = messenger_info();
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
            warnings,
            alive: true,
        })
    }

    /// Validation warnings and errors seen so far (teardown's come with [`Engine::finish`]).
    pub fn warnings(&self) -> usize {
        self.warnings.load(Ordering::SeqCst)
    }

    /// Tears the engine down (device, messenger, instance) and returns every validation
    /// warning and error seen, those reported while the device and instance were destroyed
    /// (leaked objects) included.
    pub fn finish(mut self) -> usize {
        self.teardown();
        self.warnings()
    }

    /// Destroys the device, the messenger and the instance, children first after the device
    /// idles.
    fn teardown(&mut self) {
        if !std::mem::replace(&mut self.alive, false) {
            return;
        }
        // SAFETY: the engine's own objects, destroyed once (`alive` says whether they are).
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
            self.debug
                .destroy_debug_utils_messenger(self.messenger, None);
            self.instance.destroy_instance(None);
        }
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
        self.teardown();
    }
}
