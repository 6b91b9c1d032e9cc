//! Passes that exist to test the plumbing and the shader library, not for users: the GLSL
//! mapping functions exposed to the float64 oracles, a plain copy (the benchmark floor), and
//! a costly dispatch after a draw (timestamps). Hidden from the documentation: not part of
//! the public API, and free to change.

pub mod copy;
pub mod diagnostics;
pub mod probe;
