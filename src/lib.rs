//! envlight: environment-map lighting on explicit Vulkan passes.
//!
//! # What is where
//! The crate root re-exports what an embedder names most: [`Context`] (create or adopt a
//! device), [`EnvMap`] and [`load`] (maps in memory and from files), [`GpuEnvMap`], the
//! passes ([`Converter`], [`MipChain`], [`ShProjector`], [`ShEvaluator`], [`BruteFilter`],
//! [`SplitSum`], [`LightsPass`], [`MonteCarlo`]) and their options, [`Recorder`] and
//! [`Recorded`], [`Error`].
//! - [`gpu`]: the context, RAII resources, usages (barriers come from what each command
//!   declares), the recorder and GPU timings.
//! - [`passes`]: one module per GPU pass. A pass is built once and *records* into a command
//!   buffer its caller owns; it never submits. [`Context::run`] is the one place that submits
//!   and waits, for the command line, tests and one-off jobs.
//! - [`io`]: EXR, HDR, PFM, PNG and KTX2 in and out. [`bake`]: SH, irradiance and GGX cubes
//!   for an engine, one probe or a whole set. [`scene`] and [`render`]: the reference
//!   renderer (a scene resolves into a [`render::Plan`] once and runs stage by stage).
//!   [`bench`](mod@bench): what each pass costs on a device against its floor, with its error.
//!
//! Features: `cli` (default) builds the `envlight` binary and is the only user of clap,
//! indicatif and anyhow; `reference` makes `math` public, the float64 reference
//! implementations every pass is tested against; `test-hooks` exposes
//! `passes::testing`, what only the tests call. The layout GLSL and Rust share (`src/abi`) is
//! private. Modules import one way (abi and error ← math ← io ← gpu ← passes ← scene ←
//! render and bake ← bench ← cli; `tests/layering.rs` checks it); `docs/design.md` has the rest.
//!
//! # Embedding
//! An engine adopts its device ([`Context::adopt`]), builds the passes it needs once, and
//! each frame records them into its own command buffer, on images it may own
//! ([`Image::from_raw`]). Barriers between passes come from what each command declares;
//! the engine keeps the [`Recorded`] until its fence signals. `examples/frame.rs` is the
//! whole program, run by `tests/frame.rs`.
//!
//! ```no_run
//! use ash::vk;
//! use envlight::passes::map::{full_mips, map_desc};
//! use envlight::{ConvertOptions, Context, Converter, EnvMap, GpuEnvMap, Image, Mapping};
//! use envlight::{MipChain, Recorded, Recorder, Usage};
//!
//! /// Records a dual-paraboloid MIP chain of `env` into the engine's image `raw` (created as
//! /// `map_desc(DualParaboloid, 256, 256, full_mips(256, 256))` says) inside `cmd`.
//! fn record_probe(
//!     ctx: &Context,
//!     cmd: vk::CommandBuffer,
//!     raw: vk::Image,
//!     env: &EnvMap,
//! ) -> envlight::Result<Recorded> {
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
//!     let opts = ConvertOptions::new(Mapping::DualParaboloid, 256);
//!     converter.record(&mut rec, &source, &dp, &opts)?;
//!     mip.record(&mut rec, &dp)?;
//!     // Hand the image back in the layout the engine samples it in.
//!     rec.use_image(&dp.image, Usage::FragmentSampled);
//!     rec.keep((source, dp, converter, mip));
//!     Ok(rec.finish())
//! }
//! ```

#![warn(missing_docs)]
#![warn(unnameable_types)]

// The layout GLSL and Rust share; tools/shaderc and tests/shaders.rs include it by path and
// use its generators, which the library itself does not call.
#[allow(dead_code, unused_imports)]
mod abi;
pub mod bake;
pub mod bench;
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod cli;
pub mod error;
pub mod gpu;
pub mod io;
/// The float64 reference implementations (feature `reference`): mappings, solid angles, SH,
/// BRDFs, sequences and the twin of every pass, which the tests hold the GPU passes to.
#[cfg(feature = "reference")]
pub mod math;
#[cfg(not(feature = "reference"))]
#[allow(dead_code, unused_imports)]
mod math;
pub mod passes;
pub mod render;
pub mod scene;

// The crate root: what an embedder names most.
pub use error::{Error, Result};
pub use gpu::{Context, ContextOptions, Image, Recorded, Recorder, Usage};
pub use io::{load, LoadOptions};
pub use math::brdf::Brdf;
pub use math::envmap::{EnvMap, Stats};
pub use math::mapping::Coord;
pub use math::{Mapping, Orientation};
pub use passes::{
    BruteFilter, ConvertOptions, Converter, FilterTarget, GpuEnvMap, LightsPass, MipChain,
    MonteCarlo, PrefilterOptions, ShCoefficients, ShEvaluator, ShProjector, SplitSum,
};
