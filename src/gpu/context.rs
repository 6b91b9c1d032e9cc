//! The Vulkan context: a headless instance and device that envlight creates, or an engine's own
//! that it adopts (and then destroys nothing it did not create).

use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use gpu_allocator::AllocationSizes;
use std::ffi::{c_void, CStr};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

const MB: u64 = 1 << 20;
/// Device memory blocks: gpu-allocator's default.
const DEVICE_BLOCK: u64 = 256 * MB;
/// Host memory blocks: the first of each memory type, doubling per block up to the default.
const HOST_BLOCK_MIN: u64 = 4 * MB;
/// See [`HOST_BLOCK_MIN`].
const HOST_BLOCK_MAX: u64 = 64 * MB;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Held while envlight creates or destroys an instance and device, so that no two contexts
/// do either at once in one process. The spec lets threads create and destroy devices
/// concurrently, but the Vulkan loader keeps every instance's devices on process-wide lists
/// that `vkCreateDevice` walks and `vkDestroyDevice` frees from without a common lock
/// (KhronosGroup/Vulkan-Loader#2018, present through 1.4.341; Debian 12 ships 1.3.239): one
/// thread's teardown can free a node another thread's device creation is reading, which
/// crashes the process. Contexts an engine adopts are its own to order.
static LIFECYCLE: Mutex<()> = Mutex::new(());

/// [`LIFECYCLE`], taken; a panic while it was held poisons nothing that it guards.
fn lifecycle() -> MutexGuard<'static, ()> {
    LIFECYCLE.lock().unwrap_or_else(|e| e.into_inner())
}

mod options;

pub use options::{parse_uuid, uuid_text, AdoptInfo, ContextOptions, DeviceSelector};

/// Validation messages at warning or above, kept for tests to assert on.
#[derive(Default)]
struct MessageSink {
    messages: Mutex<Vec<String>>,
    /// Set once the context's device and instance are destroyed.
    torn_down: std::sync::atomic::AtomicBool,
}

/// The validation messages of one context, readable after the context is gone: the layer
/// reports leaked objects while the device and instance are destroyed, so a test checks the
/// log after dropping the context (see [`Context::validation_log`]).
#[derive(Clone)]
pub struct ValidationLog(Arc<MessageSink>);

impl ValidationLog {
    /// Messages at warning or above so far.
    pub fn messages(&self) -> Vec<String> {
        self.0
            .messages
            .lock()
            .map(|m| m.clone())
            .unwrap_or_default()
    }

    /// Whether the context has been torn down (its last clone and resource dropped), so
    /// that the log is complete.
    pub fn complete(&self) -> bool {
        self.0.torn_down.load(Ordering::SeqCst)
    }
}

/// The validation logs of every context a program makes with validation on, readable after
/// the contexts are gone (the layer reports leaks at teardown): a program keeps one in a
/// static, makes its contexts through it, and fails where [`ValidationRecord::messages`] is
/// not empty at its end (`envlight` and the lab do).
pub struct ValidationRecord(Mutex<Vec<ValidationLog>>);

impl ValidationRecord {
    /// An empty record.
    pub const fn new() -> ValidationRecord {
        ValidationRecord(Mutex::new(Vec::new()))
    }

    /// A context made with `opts`, its log kept where validation is on.
    pub fn context(&self, opts: &ContextOptions) -> Result<Context> {
        let ctx = Context::new(opts)?;
        if opts.validation {
            if let Ok(mut logs) = self.0.lock() {
                logs.push(ctx.validation_log());
            }
        }
        Ok(ctx)
    }

    /// Every message the recorded contexts' layers reported, teardown included.
    pub fn messages(&self) -> Vec<String> {
        self.0
            .lock()
            .map(|logs| logs.iter().flat_map(|l| l.messages()).collect())
            .unwrap_or_default()
    }
}

impl Default for ValidationRecord {
    fn default() -> Self {
        ValidationRecord::new()
    }
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if !severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) {
        return vk::FALSE;
    }
    // SAFETY: the loader passes valid callback data for the duration of the call.
    let text = unsafe {
        data.as_ref()
            .and_then(|d| d.message_as_c_str())
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    eprintln!("[vulkan {severity:?}] {text}");
    // SAFETY: user data is the MessageSink boxed in Shared, which outlives the messenger.
    if let Some(sink) = unsafe { (user as *const MessageSink).as_ref() } {
        if let Ok(mut m) = sink.messages.lock() {
            m.push(format!("{severity:?}: {text}"));
        }
    }
    vk::FALSE
}

/// Device facts passes need.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    /// The device's name.
    pub name: String,
    /// Discrete, integrated, CPU…
    pub device_type: vk::PhysicalDeviceType,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period: f64,
    /// Valid bits of timestamps on the queue (0: no timestamps).
    pub timestamp_valid_bits: u32,
    /// Largest 2D image dimension.
    pub max_image_dimension_2d: u32,
    /// Largest cube image face.
    pub max_image_dimension_cube: u32,
    /// Largest storage buffer a descriptor may cover, bytes (128 MiB on lavapipe).
    pub max_storage_buffer_range: u64,
    /// Most texels a texel buffer view may address.
    pub max_texel_buffer_elements: u64,
    /// Driver name and version text.
    pub driver: String,
    /// `VkPhysicalDeviceIDProperties::deviceUUID` (what `--device` takes as a UUID).
    pub uuid: [u8; 16],
    /// Subgroup size of compute shaders.
    pub subgroup_size: u32,
    /// Whether compute shaders have subgroup arithmetic (subgroupAdd).
    pub subgroup_arithmetic: bool,
    /// Whether fragment shaders have subgroup vote operations (subgroupAll).
    pub fragment_vote: bool,
    /// Largest workgroup count in one dispatch dimension.
    pub max_workgroup_count: u32,
    /// Most loop iterations one shader invocation may run before the driver cuts its loops
    /// short: llvmpipe (lavapipe) stops any loop after 65535 iterations, counted over all of
    /// an invocation's passes through that loop. Passes with long loops split their work
    /// into dispatches under this budget. `None` where there is no such limit.
    pub loop_iteration_limit: Option<u32>,
}

pub(crate) struct Shared {
    pub(crate) entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) device: ash::Device,
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    pub(crate) info: DeviceInfo,
    debug_instance: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    debug_device: Option<ash::ext::debug_utils::Device>,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    command_pool: Mutex<vk::CommandPool>,
    live: AtomicI64,
    /// Objects created so far (never decremented): what a frame allocates.
    created: AtomicU64,
    owns_device: bool,
    sink: Arc<MessageSink>,
    /// The shader of every pipeline created, in order (what `envlight plan` is checked by).
    pub(crate) pipelines: Mutex<Vec<&'static str>>,
    /// The cache every pipeline is created through, and its file.
    pub(crate) pipeline_cache: super::pipeline_cache::DiskCache,
    /// Submissions made so far ([`Context::submissions`]).
    submissions: AtomicU64,
    /// What a test hook set on this context (feature `test-hooks`: `passes::testing`), opaque
    /// here.
    #[cfg(feature = "test-hooks")]
    pub(crate) test_hook: Mutex<Option<Arc<dyn std::any::Any + Send + Sync>>>,
}

/// A Vulkan device envlight runs its passes on. Cloning is cheap (shared ownership); the device
/// is torn down when the last clone and the last resource made from it are dropped.
#[derive(Clone)]
pub struct Context {
    pub(crate) shared: Arc<Shared>,
    startup: Option<Startup>,
}

/// What creating an owned context cost on the host, in milliseconds: the floor under every
/// job of a process, which the driver sets (see `envlight devices` and `cargo xtask lab peers`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Startup {
    /// Loading the Vulkan loader library.
    pub loader_ms: f64,
    /// Enumerating layers and extensions and vkCreateInstance (the loader opens every
    /// installed driver here).
    pub instance_ms: f64,
    /// Choosing the physical device and vkCreateDevice.
    pub device_ms: f64,
    /// The allocator, the command pool and the device's properties.
    pub rest_ms: f64,
}

fn no_device_help() -> &'static str {
    "install a Vulkan driver: `apt-get install mesa-vulkan-drivers` gives Mesa's lavapipe \
     (CPU), or run `cargo xtask setup`"
}

impl Context {
    /// Creates a headless instance and device.
    pub fn new(opts: &ContextOptions) -> Result<Context> {
        let mut clock = std::time::Instant::now();
        let mut lap = || {
            let now = std::time::Instant::now();
            let ms = 1e3 * (now - clock).as_secs_f64();
            clock = now;
            ms
        };
        // SAFETY: loading the system's Vulkan loader runs its initialisers; nothing else to uphold.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::NoLoader(e.to_string()))?;
        let loader_ms = lap();
        let _lifecycle = lifecycle();
        let sink = Arc::<MessageSink>::default();

        let mut layers = Vec::new();
        let mut extensions = Vec::new();
        // SAFETY: plain enumeration calls on a loaded entry.
        let available_layers = unsafe { entry.enumerate_instance_layer_properties() }
            .vk("enumerating instance layers")?;
        let available_ext = unsafe { entry.enumerate_instance_extension_properties(None) }
            .vk("enumerating instance extensions")?;
        let has_ext = |name: &CStr| {
            available_ext
                .iter()
                .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
        };
        if opts.validation {
            if !available_layers
                .iter()
                .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER))
            {
                return Err(Error::NoDevice(
                    "validation was requested but VK_LAYER_KHRONOS_validation is not installed: \
                     `apt-get install vulkan-validationlayers` (or `cargo xtask setup`)"
                        .into(),
                ));
            }
            layers.push(VALIDATION_LAYER.as_ptr());
        }
        // Synchronization validation (missing or wrong barriers) needs the layer's
        // VK_EXT_validation_features; older layers without it get core validation only.
        // SAFETY: plain enumeration call on a loaded entry.
        let sync_validation = opts.validation
            && unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
                .unwrap_or_default()
                .iter()
                .any(|e| {
                    e.extension_name_as_c_str()
                        .is_ok_and(|n| n == ash::ext::validation_features::NAME)
                });
        if sync_validation {
            extensions.push(ash::ext::validation_features::NAME.as_ptr());
        }
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        let debug_utils = has_ext(ash::ext::debug_utils::NAME);
        if debug_utils {
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let app = vk::ApplicationInfo::default()
            .application_name(c"envlight")
            .engine_name(c"envlight")
            .api_version(vk::API_VERSION_1_3);
        let severity = vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR;
        let types = vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
            | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE;
        let sink_ptr = Arc::as_ptr(&sink) as *mut c_void;
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(severity)
            .message_type(types)
            .pfn_user_callback(Some(debug_callback))
            .user_data(sink_ptr);
        let mut create = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if debug_utils && opts.validation {
            // Also catches messages from instance creation and destruction.
            create = create.push_next(&mut messenger_info);
        }
        if sync_validation {
            create = create.push_next(&mut features);
        }
        // SAFETY: the create info and everything it points to live across the call.
        let instance = unsafe { entry.create_instance(&create, None) }.map_err(|r| match r {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => Error::NoDevice(format!(
                "no Vulkan 1.3 driver found ({r}); {}",
                no_device_help()
            )),
            r => Error::Vulkan {
                what: "creating the instance",
                result: r,
            },
        })?;
        let instance_ms = lap();
        // From here on, a failure must destroy the instance: InstanceGuard does.
        let guard = InstanceGuard(Some(instance.clone()));
        let debug_instance = if debug_utils && opts.validation {
            let di = ash::ext::debug_utils::Instance::new(&entry, &instance);
            // SAFETY: valid instance; the sink outlives the messenger (destroyed in Shared::drop).
            let m = unsafe { di.create_debug_utils_messenger(&messenger_info, None) }
                .vk("creating the debug messenger")?;
            Some((di, m))
        } else {
            None
        };
        let result = (|| {
            let (physical, family) = pick_device(&instance, &opts.device)?;
            let device = create_device(&instance, physical, family)?;
            Ok((physical, family, device))
        })();
        let (physical, family, device) = match result {
            Ok(v) => v,
            Err(e) => {
                if let Some((di, m)) = &debug_instance {
                    // SAFETY: the messenger belongs to this instance and nothing uses it now.
                    unsafe { di.destroy_debug_utils_messenger(*m, None) };
                }
                drop(guard);
                return Err(e);
            }
        };
        std::mem::forget(guard);
        let device_ms = lap();
        // SAFETY: queue 0 of the family was requested at device creation.
        let queue = unsafe { device.get_device_queue(family, 0) };
        let mut ctx = Self::finish(
            entry,
            instance,
            physical,
            device,
            queue,
            family,
            debug_instance,
            debug_utils,
            (true, opts.pipeline_cache.as_deref()),
            sink,
        )?;
        ctx.startup = Some(Startup {
            loader_ms,
            instance_ms,
            device_ms,
            rest_ms: lap(),
        });
        Ok(ctx)
    }

    /// Adopts an engine's instance, device and queue. envlight creates its own allocator,
    /// command pool and resources on them and destroys only those.
    ///
    /// # Safety
    /// The handles must be valid, `device` must have been created from `physical_device` with
    /// the features [`AdoptInfo::device`] lists, and they must outlive this context and every
    /// resource made from it. Submissions to `queue` from elsewhere must be externally
    /// synchronised with envlight's (envlight waits for its own work before returning).
    pub unsafe fn adopt(info: AdoptInfo) -> Result<Context> {
        let AdoptInfo {
            entry,
            instance,
            physical_device,
            device,
            queue,
            queue_family_index,
            debug_utils,
        } = info;
        Self::finish(
            entry,
            instance,
            physical_device,
            device,
            queue,
            queue_family_index,
            None,
            debug_utils,
            (false, None),
            Arc::default(),
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn finish(
        entry: ash::Entry,
        instance: ash::Instance,
        physical: vk::PhysicalDevice,
        device: ash::Device,
        queue: vk::Queue,
        family: u32,
        debug_instance: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
        debug_utils: bool,
        (owns_device, cache_dir): (bool, Option<&std::path::Path>),
        sink: Arc<MessageSink>,
    ) -> Result<Context> {
        // SAFETY: valid physical device of this instance.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut id = vk::PhysicalDeviceIDProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut driver_props)
            .push_next(&mut subgroup)
            .push_next(&mut id);
        // SAFETY: valid physical device; props2 chain lives across the call.
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let info = DeviceInfo {
            name: props
                .device_name_as_c_str()
                .map(|c| c.to_string_lossy().into_owned())
                .unwrap_or_default(),
            device_type: props.device_type,
            uuid: id.device_uuid,
            timestamp_period: props.limits.timestamp_period as f64,
            timestamp_valid_bits: families
                .get(family as usize)
                .map(|f| f.timestamp_valid_bits)
                .unwrap_or(0),
            max_image_dimension_2d: props.limits.max_image_dimension2_d,
            max_image_dimension_cube: props.limits.max_image_dimension_cube,
            max_storage_buffer_range: props.limits.max_storage_buffer_range as u64,
            max_texel_buffer_elements: props.limits.max_texel_buffer_elements as u64,
            subgroup_size: subgroup.subgroup_size,
            subgroup_arithmetic: subgroup
                .supported_stages
                .contains(vk::ShaderStageFlags::COMPUTE)
                && subgroup.supported_operations.contains(
                    vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::ARITHMETIC,
                ),
            fragment_vote: subgroup
                .supported_stages
                .contains(vk::ShaderStageFlags::FRAGMENT)
                && subgroup
                    .supported_operations
                    .contains(vk::SubgroupFeatureFlags::VOTE),
            max_workgroup_count: props.limits.max_compute_work_group_count[0],
            loop_iteration_limit: (driver_props.driver_id == vk::DriverId::MESA_LLVMPIPE)
                .then_some(65535),
            driver: format!(
                "{} {}",
                driver_props
                    .driver_name_as_c_str()
                    .map(|c| c.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                driver_props
                    .driver_info_as_c_str()
                    .map(|c| c.to_string_lossy().into_owned())
                    .unwrap_or_default()
            ),
        };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            // Host-visible blocks start small and grow to the default 64 MB: allocating and
            // mapping a 64 MB block of host memory takes NVIDIA's driver milliseconds, which a
            // job reading back a few hundred bytes would pay whole.
            allocation_sizes: AllocationSizes::new(DEVICE_BLOCK, HOST_BLOCK_MIN)
                .with_max_host_memblock_size(HOST_BLOCK_MAX),
        })
        .map_err(|source| Error::Alloc {
            what: "the allocator".into(),
            source,
        })?;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid device; family index is the queue's.
        let command_pool = unsafe { device.create_command_pool(&pool_info, None) }
            .vk("creating a command pool")?;
        let debug_device =
            debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let pipeline_cache = super::pipeline_cache::DiskCache::open(&device, &props, cache_dir)?;
        let shared = Shared {
            entry,
            instance,
            physical,
            device,
            queue: Mutex::new(queue),
            queue_family: family,
            info,
            debug_instance,
            debug_device,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            command_pool: Mutex::new(command_pool),
            live: AtomicI64::new(0),
            created: AtomicU64::new(0),
            pipelines: Mutex::new(Vec::new()),
            pipeline_cache,
            submissions: AtomicU64::new(0),
            #[cfg(feature = "test-hooks")]
            test_hook: Mutex::new(None),
            owns_device,
            sink,
        };
        shared.name(command_pool, "envlight command pool");
        Ok(Context {
            shared: Arc::new(shared),
            startup: None,
        })
    }

    /// Bytes of compiled pipelines this context's cache started from
    /// ([`ContextOptions::pipeline_cache`]; 0: none there, or none asked for).
    pub fn pipeline_cache_loaded(&self) -> usize {
        self.shared.pipeline_cache.loaded
    }

    /// What creating this context cost, where envlight created it (None where it adopted
    /// an engine's device).
    pub fn startup(&self) -> Option<Startup> {
        self.startup
    }

    /// Facts about the device.
    pub fn info(&self) -> &DeviceInfo {
        &self.shared.info
    }

    /// The queue family envlight submits to.
    pub fn queue_family(&self) -> u32 {
        self.shared.queue_family
    }

    /// The ash device, for callers that record their own commands around envlight's.
    pub fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// Number of Vulkan objects envlight has created on this context and not yet destroyed
    /// (buffers, images, views, samplers, pipelines, layouts, pools, fences…).
    pub fn live_objects(&self) -> i64 {
        self.shared.live.load(Ordering::SeqCst)
    }

    /// How many Vulkan objects envlight has created on this context so far (resources, views,
    /// pipelines, descriptor pools, query pools; never decremented): a frame that creates
    /// none allocates nothing.
    pub fn objects_created(&self) -> u64 {
        self.shared.created.load(Ordering::SeqCst)
    }

    /// How many submissions envlight has made on this context so far ([`Context::run`] and
    /// [`Context::submit`]; work recorded into an engine's command buffers is not counted).
    pub fn submissions(&self) -> u64 {
        self.shared.submissions.load(Ordering::SeqCst)
    }

    /// The shader module name of every pipeline created on this context so far, in order.
    pub(crate) fn pipelines_created(&self) -> Vec<&'static str> {
        self.shared
            .pipelines
            .lock()
            .map(|p| p.clone())
            .unwrap_or_default()
    }

    /// A handle on this context's validation messages that stays readable after the context
    /// is dropped, to catch what the layer reports during teardown (leaked objects).
    pub fn validation_log(&self) -> ValidationLog {
        ValidationLog(self.shared.sink.clone())
    }

    /// Validation messages at warning or above recorded so far.
    pub fn validation_messages(&self) -> Vec<String> {
        self.shared
            .sink
            .messages
            .lock()
            .map(|m| m.clone())
            .unwrap_or_default()
    }
}

/// A number no other resource, sampler or pipeline of this process has had: what a
/// [`super::DescriptorCache`] keys its sets by (Vulkan may reuse a destroyed object's handle).
pub(crate) fn next_serial() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl Shared {
    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        // A poisoned lock only means another thread panicked mid-allocation; the allocator's
        // own state is still consistent, so keep going.
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(crate) fn track(&self) {
        self.live.fetch_add(1, Ordering::SeqCst);
        self.created.fetch_add(1, Ordering::SeqCst);
    }

    pub(crate) fn untrack(&self) {
        self.live.fetch_sub(1, Ordering::SeqCst);
    }

    /// Names an object for validation messages and debuggers (no-op without debug utils).
    pub(crate) fn name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(d) = &self.debug_device {
            let cname = std::ffi::CString::new(name.replace('\0', " ")).unwrap_or_default();
            let info = vk::DebugUtilsObjectNameInfoEXT::default()
                .object_handle(handle)
                .object_name(&cname);
            // SAFETY: the handle belongs to this device; the name lives across the call.
            let _ = unsafe { d.set_debug_utils_object_name(&info) };
        }
    }

    pub(crate) fn submit_and_wait(
        &self,
        what: &'static str,
        record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
    ) -> Result<()> {
        let (cmd, fence) = self.submit(what, record)?;
        self.retire(cmd, fence)
    }

    /// Allocates a command buffer and a fence, records with `record`, and submits; the
    /// caller must [`Shared::retire`] the pair. On an error nothing is left to retire.
    pub(crate) fn submit(
        &self,
        what: &'static str,
        record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
    ) -> Result<(vk::CommandBuffer, vk::Fence)> {
        let d = &self.device;
        let pool = self.command_pool.lock().unwrap_or_else(|e| e.into_inner());
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: pool is ours and externally synchronised by the mutex held while recording.
        let cmd =
            unsafe { d.allocate_command_buffers(&alloc) }.vk("allocating a command buffer")?[0];
        let fence_info = vk::FenceCreateInfo::default();
        let fence = match unsafe { d.create_fence(&fence_info, None) } {
            Ok(f) => f,
            Err(r) => {
                // SAFETY: cmd came from this pool and was never submitted.
                unsafe { d.free_command_buffers(*pool, &[cmd]) };
                return Err(Error::Vulkan {
                    what: "creating a fence",
                    result: r,
                });
            }
        };
        self.track();
        self.name(cmd, what);
        self.name(fence, what);
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: fresh command buffer from our pool.
            unsafe { d.begin_command_buffer(cmd, &begin) }.vk("beginning a command buffer")?;
            record(cmd)?;
            unsafe { d.end_command_buffer(cmd) }.vk("ending a command buffer")?;
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            let queue = self.queue.lock().unwrap_or_else(|e| e.into_inner());
            self.submissions.fetch_add(1, Ordering::SeqCst);
            // SAFETY: the queue is externally synchronised by its mutex.
            unsafe { d.queue_submit(*queue, &[submit], fence) }.vk(what)
        })();
        if let Err(e) = result {
            // SAFETY: nothing of this pair is pending (a failed submit leaves nothing queued;
            // the wait covers a device that failed mid-way).
            unsafe {
                let _ = d.device_wait_idle();
                d.destroy_fence(fence, None);
                d.free_command_buffers(*pool, &[cmd]);
            }
            self.untrack();
            return Err(e);
        }
        Ok((cmd, fence))
    }

    /// Waits for a pair [`Shared::submit`] returned, then frees both.
    pub(crate) fn retire(&self, cmd: vk::CommandBuffer, fence: vk::Fence) -> Result<()> {
        let d = &self.device;
        // SAFETY: the fence belongs to this device and was submitted with cmd.
        let result =
            unsafe { d.wait_for_fences(&[fence], true, u64::MAX) }.vk("waiting for the GPU");
        let pool = self.command_pool.lock().unwrap_or_else(|e| e.into_inner());
        // SAFETY: the work is finished (or the device lost, after which the idle wait
        // returns), so both can go; the pool is synchronised by its mutex.
        unsafe {
            if result.is_err() {
                let _ = d.device_wait_idle();
            }
            d.destroy_fence(fence, None);
            d.free_command_buffers(*pool, &[cmd]);
        }
        self.untrack();
        result
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        // SAFETY: every resource holds an Arc<Shared>, so none is alive now; after the wait
        // no work is pending. Destruction runs in reverse order of creation.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.pipeline_cache.close(&self.device);
            let pool = *self
                .command_pool
                .get_mut()
                .unwrap_or_else(|e| e.into_inner());
            self.device.destroy_command_pool(pool, None);
            ManuallyDrop::drop(&mut self.allocator);
            if self.owns_device {
                let _lifecycle = lifecycle();
                self.device.destroy_device(None);
                if let Some((di, m)) = self.debug_instance.take() {
                    di.destroy_debug_utils_messenger(m, None);
                }
                self.instance.destroy_instance(None);
            }
        }
        self.sink.torn_down.store(true, Ordering::SeqCst);
        let _ = &self.entry;
        let _ = self.physical;
    }
}

/// Destroys an instance if device creation fails half-way.
struct InstanceGuard(Option<ash::Instance>);

impl Drop for InstanceGuard {
    fn drop(&mut self) {
        if let Some(i) = self.0.take() {
            // SAFETY: no child object of the instance exists when the guard fires.
            unsafe { i.destroy_instance(None) };
        }
    }
}

fn pick_device(
    instance: &ash::Instance,
    selector: &DeviceSelector,
) -> Result<(vk::PhysicalDevice, u32)> {
    // SAFETY: valid instance.
    let devices = unsafe { instance.enumerate_physical_devices() }.vk("enumerating devices")?;
    if devices.is_empty() {
        return Err(Error::NoDevice(format!(
            "the Vulkan loader found no device; {}",
            no_device_help()
        )));
    }
    let mut candidates = Vec::new();
    let mut names = Vec::new();
    for (index, &pd) in devices.iter().enumerate() {
        // SAFETY: pd was just enumerated from this instance.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = props
            .device_name_as_c_str()
            .map(|c| c.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut id = vk::PhysicalDeviceIDProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut id);
        // SAFETY: as above; the chain lives across the call.
        unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
        let uuid = id.device_uuid;
        names.push(format!("{index}: {name} (UUID {})", uuid_text(&uuid)));
        if props.api_version < vk::API_VERSION_1_3 {
            continue;
        }
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let want = vk::QueueFlags::COMPUTE | vk::QueueFlags::GRAPHICS;
        let Some(family) = families.iter().position(|f| f.queue_flags.contains(want)) else {
            continue;
        };
        let rank = match props.device_type {
            vk::PhysicalDeviceType::DISCRETE_GPU => 0,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
            vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
            vk::PhysicalDeviceType::CPU => 4,
            _ => 3,
        };
        let ok = match selector {
            DeviceSelector::Auto => true,
            DeviceSelector::Cpu => props.device_type == vk::PhysicalDeviceType::CPU,
            DeviceSelector::Index(i) => *i == index,
            DeviceSelector::Name(n) => name.to_lowercase().contains(&n.to_lowercase()),
            DeviceSelector::Uuid(u) => *u == uuid,
        };
        if ok {
            candidates.push((rank, index, pd, family as u32));
        }
    }
    candidates.sort_by_key(|c| (c.0, c.1));
    candidates.first().map(|c| (c.2, c.3)).ok_or_else(|| {
        let wanted = match selector {
            DeviceSelector::Uuid(u) => format!("UUID {}", uuid_text(u)),
            other => format!("{other:?}"),
        };
        Error::NoDevice(format!(
            "no Vulkan 1.3 device with a graphics+compute queue matches {wanted} \
                 (devices: {}); {}",
            names.join(", "),
            no_device_help()
        ))
    })
}

fn create_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    family: u32,
) -> Result<ash::Device> {
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13);
    // SAFETY: valid physical device; the chain lives across the call.
    unsafe { instance.get_physical_device_features2(physical, &mut f2) };
    if f13.synchronization2 == vk::FALSE || f13.dynamic_rendering == vk::FALSE {
        return Err(Error::NoDevice(
            "the device lacks synchronization2 or dynamicRendering (Vulkan 1.3 core)".into(),
        ));
    }
    let mut enable13 = vk::PhysicalDeviceVulkan13Features::default()
        .synchronization2(true)
        .dynamic_rendering(true);
    let priorities = [1.0f32];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family)
        .queue_priorities(&priorities)];
    let create = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .push_next(&mut enable13);
    // SAFETY: valid physical device; the create info lives across the call.
    unsafe { instance.create_device(physical, &create, None) }.vk("creating the device")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;
    use std::time::Duration;

    /// How long a context's creation or teardown is given to show it waits for the lock: it
    /// takes tens of milliseconds on lavapipe, so one that ignored the lock would be done.
    const WAITS: Duration = Duration::from_millis(1500);

    fn validated() -> ContextOptions {
        let mut o = ContextOptions::new(DeviceSelector::from_env());
        o.validation = true;
        o
    }

    /// Creating a context and destroying one both wait while another thread holds
    /// [`LIFECYCLE`] (the loader's device lists are not safe to change from two threads at
    /// once), and go on once it is let go.
    #[test]
    fn contexts_are_created_and_destroyed_one_at_a_time() {
        let held = lifecycle();
        let (tx, rx) = mpsc::channel();
        let maker = std::thread::spawn(move || {
            let ctx = Context::new(&validated());
            let _ = tx.send(());
            ctx
        });
        // Let go of the lock before asserting, so that a failure unwinds without deadlock.
        let early = rx.recv_timeout(WAITS).is_ok();
        drop(held);
        assert!(!early, "a context was created while the lock was held");
        rx.recv_timeout(Duration::from_secs(120))
            .expect("creation went on once the lock was let go");
        let ctx = maker.join().unwrap().expect("a Vulkan context");
        let log = ctx.validation_log();

        let held = lifecycle();
        let (tx, rx) = mpsc::channel();
        let dropper = std::thread::spawn(move || {
            drop(ctx);
            let _ = tx.send(());
        });
        let early = rx.recv_timeout(WAITS).is_ok() || log.complete();
        drop(held);
        assert!(!early, "a context was destroyed while the lock was held");
        rx.recv_timeout(Duration::from_secs(120))
            .expect("teardown went on once the lock was let go");
        dropper.join().unwrap();
        assert!(log.complete());
        assert!(log.messages().is_empty(), "{:?}", log.messages());
    }
}
