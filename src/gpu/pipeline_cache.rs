//! The driver's compiled pipelines kept on disk between runs: a `VkPipelineCache` read from a
//! file at context creation and written back when the context is torn down, one file per
//! device, driver version and `pipelineCacheUUID`, so that a later process on the same
//! device and driver skips the compilations an earlier one made. A file from another device
//! or driver, or a damaged one, is never handed to the driver (its header is checked first)
//! and is replaced. How much a run saves is the driver's to say: NVIDIA's driver fills the
//! cache with its compiled code; lavapipe (Mesa 22.3) keeps only the 32-byte header, so its
//! runs compile every pipeline whatever the cache holds.

use crate::error::{Result, VkContext};
use ash::vk;
use std::path::{Path, PathBuf};

/// The cache folder: `ENVLIGHT_CACHE_DIR` (empty: no cache), else `$XDG_CACHE_HOME/envlight`,
/// else `~/.cache/envlight`; `None` where none of these is set.
pub fn default_dir() -> Option<PathBuf> {
    let var = |k: &str| std::env::var_os(k).map(PathBuf::from);
    match var("ENVLIGHT_CACHE_DIR") {
        Some(d) if d.as_os_str().is_empty() => None,
        Some(d) => Some(d),
        None => var("XDG_CACHE_HOME")
            .filter(|d| d.is_absolute())
            .map(|d| d.join("envlight"))
            .or_else(|| var("HOME").map(|h| h.join(".cache").join("envlight"))),
    }
}

/// A context's pipeline cache and the file it came from and goes back to.
pub(crate) struct DiskCache {
    pub(crate) cache: vk::PipelineCache,
    file: Option<PathBuf>,
    /// The bytes read from the file and handed to the driver (0: it started empty).
    pub(crate) loaded: usize,
}

/// The file for the device of `props` in `dir`.
pub(crate) fn file_for(dir: &Path, props: &vk::PhysicalDeviceProperties) -> PathBuf {
    let uuid: String = props
        .pipeline_cache_uuid
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    dir.join(format!(
        "pipelines-{:04x}-{:04x}-{:08x}-{uuid}.bin",
        props.vendor_id, props.device_id, props.driver_version
    ))
}

/// Whether `data` starts with the header `vkGetPipelineCacheData` writes for the device of
/// `props` (version one: length, version, vendor, device, pipelineCacheUUID).
pub(crate) fn header_matches(data: &[u8], props: &vk::PhysicalDeviceProperties) -> bool {
    let word = |k: usize| u32::from_le_bytes([data[k], data[k + 1], data[k + 2], data[k + 3]]);
    data.len() >= 32
        && word(0) >= 32
        && word(0) as usize <= data.len()
        && word(4) == vk::PipelineCacheHeaderVersion::ONE.as_raw() as u32
        && word(8) == props.vendor_id
        && word(12) == props.device_id
        && data[16..32] == props.pipeline_cache_uuid
}

impl DiskCache {
    /// The cache of `device`, started from its file in `dir` where that file is this
    /// device's and driver's; with no `dir`, an empty cache that is never written.
    pub(crate) fn open(
        device: &ash::Device,
        props: &vk::PhysicalDeviceProperties,
        dir: Option<&Path>,
    ) -> Result<DiskCache> {
        let file = dir.map(|d| file_for(d, props));
        let data = file
            .as_deref()
            .and_then(|f| std::fs::read(f).ok())
            .filter(|d| header_matches(d, props))
            .unwrap_or_default();
        let info = vk::PipelineCacheCreateInfo::default().initial_data(&data);
        // SAFETY: valid device; the initial data is this device's own cache data (checked
        // header), which the driver validates further.
        let cache =
            unsafe { device.create_pipeline_cache(&info, None) }.vk("creating a pipeline cache")?;
        Ok(DiskCache {
            cache,
            file,
            loaded: data.len(),
        })
    }

    /// Writes the cache back to its file (through a temporary file renamed over it, so that
    /// processes sharing the folder never read a partial file) and destroys it. Best effort:
    /// a folder that cannot be written leaves the next run to compile again.
    ///
    /// # Safety
    /// `device` is the cache's, and no pipeline creation is using the cache.
    pub(crate) unsafe fn close(&mut self, device: &ash::Device) {
        if let Some(file) = &self.file {
            // SAFETY: valid device and cache (the caller's contract).
            if let Ok(data) = unsafe { device.get_pipeline_cache_data(self.cache) } {
                let unchanged = std::fs::read(file).is_ok_and(|old| old == data);
                if !data.is_empty() && !unchanged {
                    let _ = write_atomically(file, &data);
                }
            }
        }
        // SAFETY: as above; nothing uses the cache after this.
        unsafe { device.destroy_pipeline_cache(self.cache, None) };
        self.cache = vk::PipelineCache::null();
    }
}

/// A temporary file beside `file`, named for this process and this call: two contexts of one
/// process closing at once each write their own before renaming.
fn temporary_beside(file: &Path) -> PathBuf {
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    file.with_extension(format!("tmp{}-{n}", std::process::id()))
}

fn write_atomically(file: &Path, data: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = file.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = temporary_beside(file);
    std::fs::write(&tmp, data)?;
    std::fs::rename(&tmp, file).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each write goes through a temporary file of its own, beside the cache file.
    #[test]
    fn each_write_has_its_own_temporary_file() {
        let file = Path::new("/cache/pipelines-1-2-3-abc.bin");
        let names: Vec<PathBuf> = (0..4).map(|_| temporary_beside(file)).collect();
        for (i, a) in names.iter().enumerate() {
            assert_eq!(a.parent(), file.parent(), "{a:?}");
            assert!(names[i + 1..].iter().all(|b| b != a), "{names:?}");
        }
    }
}
