//! What only the tests call (feature `test-hooks`, which the crate's own tests turn on):
//! passes that test the plumbing and the shader library (the GLSL mapping functions exposed
//! to the float64 oracles, a plain copy that is the benchmark floor, a costly dispatch after a
//! draw for timestamps) and hooks into the passes' internals. Not part of the API an
//! embedder builds on, and free to change.

pub mod copy;
pub mod diagnostics;
pub mod poison;
pub mod probe;

use crate::gpu::Context;
use crate::passes::BruteFilter;

/// The shader module name of every pipeline created on `ctx` so far, in order.
pub fn pipelines_created(ctx: &Context) -> Vec<&'static str> {
    ctx.pipelines_created()
}

/// [`BruteFilter`]'s visit floor: each output texel sums L·Ω over the texels its walk visits,
/// without the rule (what `cargo xtask lab peers` times as the floor of the exact sum).
pub fn set_visit_floor(filter: &mut BruteFilter, on: bool) {
    filter.set_visit_floor(on);
}
