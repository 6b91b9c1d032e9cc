//! envlight: environment-map lighting on explicit Vulkan passes.
//!
//! The crate is split as `DESIGN.md` asks: [`math`] is pure float64 (mappings, solid angles,
//! analytic environments) and knows nothing of Vulkan; [`gpu`] is thin Vulkan plumbing (a
//! context that creates or adopts a device, RAII resources, barriers, timing); [`passes`] holds
//! one file per GPU pass; [`io`] reads and writes maps.

#![warn(missing_docs)]

pub mod accuracy;
pub mod envmap;
pub mod error;
pub mod fisbench;
pub mod gpu;
pub mod io;
pub mod math;
pub mod passes;
pub mod preview;
pub mod render;
pub mod scene;

pub use envmap::EnvMap;
pub use error::{Error, Result};
pub use math::{Mapping, Orientation};
