//! What a context is made from: the device to pick and its options ([`super::Context::new`]), or
//! an engine's own objects ([`super::Context::adopt`]).

use ash::vk;

/// Which physical device to use.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DeviceSelector {
    /// Prefer a discrete GPU, then an integrated one, then anything else, then a CPU device.
    #[default]
    Auto,
    /// A CPU implementation (Mesa's lavapipe).
    Cpu,
    /// The n-th device in the loader's enumeration order.
    Index(usize),
    /// The first device whose name contains this text (case-insensitive).
    Name(String),
    /// The device with this UUID (`VkPhysicalDeviceIDProperties::deviceUUID`; on NVIDIA the
    /// UUID `nvidia-smi -L` prints, as farms pin GPUs).
    Uuid([u8; 16]),
}

impl DeviceSelector {
    /// Reads `ENVLIGHT_DEVICE`: unset or `auto`; `cpu`, `lavapipe` or `llvmpipe`; a number; or
    /// part of a device name.
    pub fn from_env() -> DeviceSelector {
        match std::env::var("ENVLIGHT_DEVICE") {
            Ok(s) => DeviceSelector::parse(&s),
            Err(_) => DeviceSelector::Auto,
        }
    }

    /// Parses the same syntax as `ENVLIGHT_DEVICE` and `--device`.
    pub fn parse(s: &str) -> DeviceSelector {
        let t = s.trim();
        match t.to_ascii_lowercase().as_str() {
            "" | "auto" => DeviceSelector::Auto,
            "cpu" | "lavapipe" | "llvmpipe" => DeviceSelector::Cpu,
            _ => match (t.parse(), parse_uuid(t)) {
                (Ok(i), _) => DeviceSelector::Index(i),
                (_, Some(u)) => DeviceSelector::Uuid(u),
                _ => DeviceSelector::Name(t.to_string()),
            },
        }
    }
}

/// A device UUID as `nvidia-smi -L` prints it (`GPU-` and 32 hex digits in 8-4-4-4-12
/// groups), or the same without the prefix or dashes; `None` for anything else.
pub fn parse_uuid(s: &str) -> Option<[u8; 16]> {
    let t = s.trim();
    let t = match t.get(..4) {
        Some(p) if p.eq_ignore_ascii_case("gpu-") => &t[4..],
        _ => t,
    };
    let hex: String = t.chars().filter(|&c| c != '-').collect();
    if hex.len() != 32 || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let mut u = [0u8; 16];
    for (k, b) in u.iter_mut().enumerate() {
        *b = u8::from_str_radix(&hex[2 * k..2 * k + 2], 16).ok()?;
    }
    Some(u)
}

/// `uuid` as `nvidia-smi -L` prints it (without its `GPU-`): 8-4-4-4-12 lowercase hex.
pub fn uuid_text(uuid: &[u8; 16]) -> String {
    let h: String = uuid.iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &h[..8],
        &h[8..12],
        &h[12..16],
        &h[16..20],
        &h[20..]
    )
}

/// Options for [`super::Context::new`]: [`ContextOptions::new`] or [`Default`].
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ContextOptions {
    /// Enable the Khronos validation layer and record its messages (on in debug builds and
    /// whenever `ENVLIGHT_VALIDATION=1`).
    pub validation: bool,
    /// Which device.
    pub device: DeviceSelector,
    /// A folder where the driver's compiled pipelines are kept between runs (a file per
    /// device and driver version, `crate::gpu::pipeline_cache`; the command line uses
    /// [`crate::gpu::pipeline_cache::default_dir`]). `None`: nothing read or written.
    pub pipeline_cache: Option<std::path::PathBuf>,
}

impl ContextOptions {
    /// The device `device` picks, with validation as [`Default`] sets it (debug builds and
    /// `ENVLIGHT_VALIDATION=1`).
    pub fn new(device: DeviceSelector) -> Self {
        ContextOptions {
            device,
            ..Default::default()
        }
    }

    /// What a program's `--device` and `--validation` options ask for: the device `device`
    /// names ([`DeviceSelector::parse`]; absent, `ENVLIGHT_DEVICE`'s), validation where
    /// `validation` or [`Default`] turns it on, and compiled pipelines kept between runs
    /// (`crate::gpu::pipeline_cache::default_dir`, beside the bake's DFG tables).
    pub fn from_flags(device: Option<&str>, validation: bool) -> Self {
        let mut opts = ContextOptions::default();
        if let Some(d) = device {
            opts.device = DeviceSelector::parse(d);
        }
        opts.validation |= validation;
        opts.pipeline_cache = crate::gpu::pipeline_cache::default_dir();
        opts
    }
}

impl Default for ContextOptions {
    fn default() -> Self {
        ContextOptions {
            validation: cfg!(debug_assertions)
                || std::env::var("ENVLIGHT_VALIDATION").is_ok_and(|v| v == "1"),
            device: DeviceSelector::from_env(),
            pipeline_cache: None,
        }
    }
}

/// An engine's own Vulkan objects, for [`super::Context::adopt`].
pub struct AdoptInfo {
    /// The loader entry the engine uses.
    pub entry: ash::Entry,
    /// The engine's instance (API version 1.3 or later).
    pub instance: ash::Instance,
    /// The physical device behind `device`.
    pub physical_device: vk::PhysicalDevice,
    /// The engine's device, created with the Vulkan 1.3 features `synchronization2` and
    /// `dynamicRendering` enabled.
    pub device: ash::Device,
    /// A queue supporting compute and graphics.
    pub queue: vk::Queue,
    /// Its family.
    pub queue_family_index: u32,
    /// Whether the instance has `VK_EXT_debug_utils` enabled (then envlight names its objects).
    pub debug_utils: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flags pick the device and turn validation on; without them the environment's
    /// device and the default validation stand; both keep the pipeline cache.
    #[test]
    fn flags_give_the_options() {
        let o = ContextOptions::from_flags(Some("cpu"), true);
        assert_eq!(o.device, DeviceSelector::parse("cpu"));
        assert!(o.validation);
        assert_eq!(o.pipeline_cache, crate::gpu::pipeline_cache::default_dir());
        let d = ContextOptions::from_flags(None, false);
        assert_eq!(d.device, DeviceSelector::from_env());
        assert_eq!(d.validation, ContextOptions::default().validation);
    }
}
