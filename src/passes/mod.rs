//! GPU passes, one file each. A pass is built once and run many times; each run records
//! timestamps and returns what it cost.

pub mod convert;
pub mod copy;
pub mod diagnostics;
pub mod filter;
pub mod gbuffer;
pub mod mc;
pub mod mip;
pub mod probe;
pub mod sh_project;
pub mod shade;

pub use convert::{ConvertOptions, Converter};
