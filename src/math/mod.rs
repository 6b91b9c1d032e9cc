//! Pure float64 math: mappings, solid angles, quadrature and analytic test environments.
//!
//! Nothing here knows about Vulkan; these functions are the oracles the GPU passes are tested
//! against.

pub mod brdf;
pub mod camera;
pub mod convert;
pub mod envmap;
pub mod envsample;
pub mod exact;
pub mod filter;
pub mod fis;
pub mod footprint;
pub mod light_tree;
pub mod lights;
pub mod mapping;
pub mod mc;
pub mod mip;
pub mod moments;
pub mod quadrature;
pub mod sequence;
pub mod sh;
pub mod sh_brdf;
pub mod sh_rotate;
pub mod split_sum;
pub mod synth;

pub use mapping::{Coord, Mapping, Orientation};
