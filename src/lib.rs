//! envlight: environment-map lighting on explicit Vulkan passes.
//!
//! # Layers
//! Imports go one way: [`abi`]/[`error`] ← [`math`] ← [`io`] ← [`gpu`] ← [`passes`] ←
//! [`scene`] ← [`render`]/[`bake`] ← the `envlight` binary (feature `cli`, the only user of
//! clap, indicatif and anyhow), with no cycle among modules (`tests/layering.rs` derives the
//! graph from the paths the sources name).
//! - [`abi`] (std only) holds everything GLSL and Rust share: binding numbers and access,
//!   workgroup sizes, ids, tuning parameters, push blocks, and the shader table. The GLSL
//!   header `glsl/include/generated.glsl` is written from it.
//! - [`math`] is pure float64 (mappings, solid angles, SH, BRDFs, sequences, the twins of every
//!   pass) and knows nothing of Vulkan.
//! - [`gpu`] is thin Vulkan plumbing: a [`gpu::Context`] that creates or adopts a device, RAII
//!   resources, barriers from declared usages, pipelines, the [`gpu::Recorder`] and timestamps.
//! - [`passes`] holds one file per GPU pass. A pass is built once and *records* into a command
//!   buffer its caller owns; it never submits. [`gpu::Context::run`] is the one place that
//!   submits and waits, for the CLI, tests and one-off jobs.
//! - [`scene`] is the scene file's model and its validation; [`render`] resolves a scene into
//!   a [`render::Plan`] once and runs it stage by stage.
//!
//! # Embedding
//! An engine adopts its device ([`gpu::Context::adopt`]), builds the passes it needs once, and
//! each frame records them into its own command buffer, on images it may own
//! ([`gpu::Image::from_raw`]). Barriers between passes come from what each command declares;
//! the engine keeps the [`gpu::Recorded`] until its fence signals. `examples/frame.rs` is the
//! whole program, run by `tests/frame.rs`.
//!
//! ```no_run
//! use ash::vk;
//! use envlight::gpu::{Context, Image, Recorder, Usage};
//! use envlight::passes::map::{full_mips, map_desc};
//! use envlight::passes::{ConvertOptions, Converter, GpuEnvMap, MipChain};
//! use envlight::{EnvMap, Mapping, Orientation};
//!
//! /// Records a dual-paraboloid MIP chain of `env` into the engine's image `raw` (created as
//! /// `map_desc(DualParaboloid, 256, 256, full_mips(256, 256))` says) inside `cmd`.
//! fn record_probe(
//!     ctx: &Context,
//!     cmd: vk::CommandBuffer,
//!     raw: vk::Image,
//!     env: &EnvMap,
//! ) -> envlight::Result<envlight::gpu::Recorded> {
//!     let desc = map_desc(Mapping::DualParaboloid, 256, 256, full_mips(256, 256));
//!     // SAFETY: `raw` was created from `desc` on ctx's device and outlives the frame.
//!     let image = unsafe { Image::from_raw(ctx, "probe", raw, desc, Usage::Undefined)? };
//!     let dp = GpuEnvMap::from_image(image, Mapping::DualParaboloid);
//!     // Built once in a real engine, kept across frames.
//!     let (converter, mip) = (Converter::new(ctx)?, MipChain::new(ctx)?);
//!     let source = GpuEnvMap::new(ctx, "env", env.mapping, env.width, env.height)?;
//!     // SAFETY: cmd is recording, outside a render pass, for ctx's queue family; the
//!     // returned Recorded (and `source`, `dp`) are kept until the engine's fence signals.
//!     let mut rec = unsafe { Recorder::begin(ctx, cmd, true) };
//!     source.record_upload(&mut rec, env)?;
//!     let opts = ConvertOptions {
//!         to: Mapping::DualParaboloid,
//!         size: 256,
//!         orientation: Orientation::default(),
//!         supersample: None,
//!         nearest: false,
//!         edge_points: None,
//!     };
//!     converter.record(&mut rec, &source, &dp, &opts)?;
//!     mip.record(&mut rec, &dp)?;
//!     // Hand the image back in the layout the engine samples it in.
//!     rec.use_image(&dp.image, Usage::FragmentSampled);
//!     rec.keep((source, dp, converter, mip));
//!     Ok(rec.finish())
//! }
//! ```

#![warn(missing_docs)]

pub mod abi;
pub mod bake;
pub mod error;
pub mod gpu;
pub mod io;
pub mod math;
pub mod passes;
pub mod render;
pub mod scene;

pub use error::{Error, Result};
pub use math::envmap::EnvMap;
pub use math::{Mapping, Orientation};
pub use passes::GpuEnvMap;
