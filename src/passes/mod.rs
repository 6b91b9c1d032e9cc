//! GPU passes, one file each, named as their shader and their float64 twin. A pass is built
//! once from its context (its pipelines made then, or on first use where the input decides
//! which) and records many times: `record(&mut rec, inputs…, outputs…, options)` records its
//! dispatches into a [`crate::gpu::Recorder`] the caller owns, with timed spans, and never
//! submits. Each pass also has a `run` helper that allocates its outputs and records through
//! [`crate::gpu::Context::run`], for the CLI, tests and one-off jobs.

pub mod brute;
pub mod convert;
pub mod exact;
pub mod extract;
pub mod gbuffer;
pub mod lights;
pub mod map;
pub mod mc;
pub mod mip;
pub mod sh_brdf;
pub mod sh_eval;
pub mod sh_pack;
pub mod sh_project;
pub mod shade;
pub mod split_sum;
#[cfg(feature = "test-hooks")]
pub mod testing;
#[cfg(not(feature = "test-hooks"))]
#[allow(dead_code)]
pub(crate) mod testing;

pub use brute::{BruteFilter, FilterTarget};
pub use convert::{ConvertOptions, ConvertPlan, Converter};
pub use exact::{ExactInputs, ExactShader};
pub use extract::{Extractor, GpuExtraction};
pub use gbuffer::{GBuffer, GBufferPass};
pub use lights::{GpuLights, LightsPass};
pub use map::GpuEnvMap;
pub use mc::MonteCarlo;
pub use mip::MipChain;
pub use sh_brdf::{ShBrdfProjector, ShRotator};
pub use sh_eval::ShEvaluator;
pub use sh_pack::ShPacker;
pub use sh_project::{ShCoefficients, ShProjector, ShReadback, Subgroups};
pub use shade::Shade;
pub use split_sum::{time_slices, LevelLayers, LevelSamples, PrefilterOptions, SplitSum};
