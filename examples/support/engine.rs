//! A stand-in for an engine's own Vulkan setup, shared by the examples: an instance with the
//! validation layer and a messenger that counts warnings, one device with a graphics+compute
//! queue (Vulkan 1.3, synchronization2 and dynamic rendering), and teardown in reverse order.
//! The count includes what the layer reports while the device and the instance are destroyed
//! (objects leaked on them): [`Engine::finish`] reads it after both are gone.

use ash::vk;
use std::sync::atomic::{AtomicUsize, Ordering};

type Error = Box<dyn std::error::Error>;

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
    /// Submissions made.
    submissions: AtomicUsize,
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
            submissions: AtomicUsize::new(0),
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

    /// Ends `cmd`, submits it once and waits on a fence of its own; counts the submission.
    ///
    /// # Safety
    /// `cmd` is recording, on this device, for its queue family.
    pub unsafe fn submit_and_wait(&self, cmd: vk::CommandBuffer) -> Result<(), Error> {
        // SAFETY: as the caller promises; the fence is made and destroyed here.
        unsafe {
            self.device.end_command_buffer(cmd)?;
            let fence = self
                .device
                .create_fence(&vk::FenceCreateInfo::default(), None)?;
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            self.device.queue_submit(self.queue, &[submit], fence)?;
            self.device.wait_for_fences(&[fence], true, u64::MAX)?;
            self.device.destroy_fence(fence, None);
        }
        self.submissions.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }

    /// Submissions made through [`Engine::submit_and_wait`].
    pub fn submissions(&self) -> usize {
        self.submissions.load(Ordering::SeqCst)
    }

    /// What envlight needs to adopt the engine's device (`envlight::gpu::Context::adopt`).
    pub fn adopt_info(&self) -> envlight::gpu::AdoptInfo {
        envlight::gpu::AdoptInfo {
            entry: self.entry.clone(),
            instance: self.instance.clone(),
            physical_device: self.physical,
            device: self.device.clone(),
            queue: self.queue,
            queue_family_index: self.family,
            debug_utils: true,
        }
    }

    /// A command pool of the queue's family (its buffers resettable) and one primary command
    /// buffer from it; the caller destroys the pool.
    pub fn command_buffer(&self) -> Result<(vk::CommandPool, vk::CommandBuffer), Error> {
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(self.family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device and create info.
        let pool = unsafe { self.device.create_command_pool(&pool_info, None)? };
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is the engine's.
        let cmd = unsafe { self.device.allocate_command_buffers(&alloc)? }[0];
        Ok((pool, cmd))
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

/// An image the engine creates and binds to memory of its own.
pub struct EngineImage {
    pub raw: vk::Image,
    memory: vk::DeviceMemory,
}

impl EngineImage {
    pub fn new(e: &Engine, desc: &envlight::gpu::ImageDesc) -> Result<EngineImage, Error> {
        // The create info envlight expects of an image it is handed.
        let info = desc.create_info();
        // SAFETY: valid device and create info.
        let raw = unsafe { e.device.create_image(&info, None)? };
        // SAFETY: raw is a live image of this device.
        let req = unsafe { e.device.get_image_memory_requirements(raw) };
        let ty = e
            .memory_type(req.memory_type_bits, vk::MemoryPropertyFlags::DEVICE_LOCAL)
            .ok_or("no device-local memory")?;
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(ty);
        // SAFETY: valid allocation info; the memory is bound once and freed after the image.
        let memory = unsafe { e.device.allocate_memory(&alloc, None)? };
        unsafe { e.device.bind_image_memory(raw, memory, 0)? };
        Ok(EngineImage { raw, memory })
    }

    /// Destroys the image and frees its memory (after the GPU is done with it).
    pub fn destroy(self, e: &Engine) {
        // SAFETY: no pending work uses the image; envlight's views of it are gone.
        unsafe {
            e.device.destroy_image(self.raw, None);
            e.device.free_memory(self.memory, None);
        }
    }
}

/// A host-visible, coherent buffer the engine reads its frames back through.
pub struct HostBuffer {
    pub raw: vk::Buffer,
    memory: vk::DeviceMemory,
    ptr: *const u8,
    size: u64,
}

impl HostBuffer {
    /// A buffer of `size` bytes, a transfer destination, mapped for reading.
    pub fn new(e: &Engine, size: u64) -> Result<HostBuffer, Error> {
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(vk::BufferUsageFlags::TRANSFER_DST);
        // SAFETY: valid device and create info.
        let raw = unsafe { e.device.create_buffer(&info, None)? };
        // SAFETY: raw is a live buffer of this device.
        let req = unsafe { e.device.get_buffer_memory_requirements(raw) };
        let flags = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
        let ty = e
            .memory_type(req.memory_type_bits, flags)
            .ok_or("no host-visible coherent memory")?;
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(ty);
        // SAFETY: valid allocation info; bound once, mapped whole, freed after the buffer.
        let memory = unsafe { e.device.allocate_memory(&alloc, None)? };
        let ptr = unsafe {
            e.device.bind_buffer_memory(raw, memory, 0)?;
            e.device
                .map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())?
        } as *const u8;
        Ok(HostBuffer {
            raw,
            memory,
            ptr,
            size,
        })
    }

    /// Its contents as RGBA32F texels (after the copies into it have completed).
    pub fn texels(&self) -> Vec<[f32; 4]> {
        // SAFETY: the mapping covers `size` bytes and the GPU is done writing them.
        let bytes = unsafe { std::slice::from_raw_parts(self.ptr, self.size as usize) };
        bytes
            .chunks_exact(16)
            .map(|c| {
                std::array::from_fn(|i| {
                    f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])
                })
            })
            .collect()
    }

    /// Destroys the buffer and frees its memory (after the GPU is done with it).
    pub fn destroy(self, e: &Engine) {
        // SAFETY: no pending work uses the buffer.
        unsafe {
            e.device.destroy_buffer(self.raw, None);
            e.device.free_memory(self.memory, None);
        }
    }
}
