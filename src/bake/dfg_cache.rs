//! The split-sum DFG table kept on disk between runs: it depends on its size, its Smith form
//! and axes, the shader that integrates it and the device, never on a probe, yet a 256² table
//! costs a bake on lavapipe more than its probe does. [`Baker::dfg_cached`] reads it from a
//! cache folder ([`default_dir`]) where an earlier run on the same device left it, else
//! computes it and leaves it there.

use super::Baker;
use crate::abi::{sh_brdf, ShaderId};
use crate::error::Result;
use crate::math::split_sum::DfgAxes;
use std::path::Path;

pub use crate::gpu::pipeline_cache::default_dir;

/// FNV-1a, 64 bits: a key and a checksum that stay the same across Rust versions.
fn fnv(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;
const MAGIC: &[u8; 8] = b"ENVLDFG1";

impl Baker {
    /// [`Baker::dfg_at`] through the cache in `dir` (`None`: computed every time). The file
    /// is named by everything the table depends on (size, Smith form, axes, the shader's
    /// SPIR-V, its dispatch panels, and the device: name, UUID, driver), and holds a
    /// checksum: a table from another device, another build of the shader or a damaged file
    /// is never read, and is computed again instead. A folder that cannot be written leaves
    /// the table computed and uncached.
    pub fn dfg_cached(
        &self,
        size: u32,
        correlated: bool,
        axes: DfgAxes,
        dir: Option<&Path>,
    ) -> Result<Vec<[f32; 2]>> {
        let Some(dir) = dir else {
            return self.dfg_at(size, correlated, axes);
        };
        let info = self.ctx.info();
        let mut key = fnv(crate::gpu::shaders::spirv(ShaderId::Dfg), FNV_START);
        key = fnv(&sh_brdf::GRADED_LEVELS.to_le_bytes(), key);
        key = fnv(info.name.as_bytes(), key);
        key = fnv(&info.uuid, key);
        key = fnv(info.driver.as_bytes(), key);
        let axes_name = match axes {
            DfgAxes::Endpoints => "endpoints",
            DfgAxes::Centres => "centres",
        };
        let smith = if correlated {
            "correlated"
        } else {
            "separable"
        };
        let path = dir.join(format!("dfg-{size}-{smith}-{axes_name}-{key:016x}.bin"));
        let entries = (size * size) as usize;
        if let Some(t) = read_table(&path, size, entries) {
            return Ok(t);
        }
        let t = self.dfg_at(size, correlated, axes)?;
        let mut bytes = Vec::with_capacity(24 + 8 * entries);
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&size.to_le_bytes());
        bytes.extend_from_slice(&[0; 4]);
        let payload: Vec<u8> = t.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        bytes.extend_from_slice(&fnv(&payload, FNV_START).to_le_bytes());
        bytes.extend_from_slice(&payload);
        // A cache is a convenience: a folder that cannot hold it costs the next run the table.
        let _ = std::fs::create_dir_all(dir).map(|_| crate::io::write_atomic(&path, &bytes));
        Ok(t)
    }
}

/// The table in `path` if it is one of `size` (`entries` entries) whose checksum holds.
fn read_table(path: &Path, size: u32, entries: usize) -> Option<Vec<[f32; 2]>> {
    let bytes = std::fs::read(path).ok()?;
    let (head, payload) = bytes.split_at_checked(24)?;
    let sum = u64::from_le_bytes(head[16..24].try_into().ok()?);
    let ok = &head[..8] == MAGIC
        && u32::from_le_bytes(head[8..12].try_into().ok()?) == size
        && payload.len() == 8 * entries
        && fnv(payload, FNV_START) == sum;
    ok.then(|| {
        payload
            .chunks_exact(8)
            .map(|c| {
                let f = |k: usize| f32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
                [f(0), f(4)]
            })
            .collect()
    })
}
