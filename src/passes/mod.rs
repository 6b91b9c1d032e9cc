//! GPU passes.
