//! Thin Vulkan plumbing: context, RAII resources, barriers from declared usages, pipelines,
//! the recorder and timing. It knows the shader table (`crate::abi`) and nothing of passes
//! or maths.

pub(crate) mod barrier;
pub(crate) mod context;
pub(crate) mod pipeline;
pub mod pipeline_cache;
pub(crate) mod recorder;
pub(crate) mod resources;
pub(crate) mod shaders;
pub(crate) mod timing;

pub use barrier::Usage;
pub use context::{
    parse_uuid, uuid_text, AdoptInfo, Context, ContextOptions, DeviceInfo, DeviceSelector, Startup,
    ValidationLog, ValidationRecord,
};
pub use pipeline::FrameCache;
pub(crate) use pipeline::{Bind, Pipeline};
pub use recorder::{InFlight, Recorded, Recorder};
pub use resources::{Buffer, Image, ImageDesc, Sampler};
pub use timing::{total_ms, Timed, Timing};

/// Number of workgroups of `size` needed to cover `n` items.
pub(crate) fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}

/// Workgroups of `crate::abi::WORKGROUP_2D` covering `w` × `h` items on each of `layers`
/// layers: a 2D pass's dispatch.
pub(crate) fn groups_2d(w: u32, h: u32, layers: u32) -> [u32; 3] {
    let [x, y] = crate::abi::WORKGROUP_2D;
    [groups(w, x), groups(h, y), layers]
}

/// A 3×3 matrix as the three rows of `vec4 m[3]` in a push-constant block (w unused).
pub(crate) fn mat3_rows(m: glam::DMat3) -> [[f32; 4]; 3] {
    [0, 1, 2].map(|r| {
        let v = m.row(r);
        [v.x as f32, v.y as f32, v.z as f32, 0.0]
    })
}
