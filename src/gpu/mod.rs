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

/// A 3×3 matrix as the three rows of `vec4 m[3]` in a push-constant block (w unused).
pub fn mat3_rows(m: glam::DMat3) -> [[f32; 4]; 3] {
    [0, 1, 2].map(|r| {
        let v = m.row(r);
        [v.x as f32, v.y as f32, v.z as f32, 0.0]
    })
}
