//! Thin Vulkan plumbing: context, RAII resources, barriers, pipelines, timing.

pub mod barrier;
pub mod context;
pub mod envmap;
pub mod layout;
pub mod pipeline;
pub mod resources;
pub mod shaders;
pub mod timing;

pub use context::{AdoptInfo, Context, ContextOptions, DeviceInfo, DeviceSelector};
pub use envmap::GpuEnvMap;
pub use resources::{Buffer, Image, ImageDesc, Sampler};
pub use timing::{GpuTimer, Timing};

/// Number of workgroups of `size` needed to cover `n` items.
pub fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}
