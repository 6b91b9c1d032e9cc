//! The G-buffer pass (`passes::gbuffer`) against its float64 twin (`math::camera`): per pixel
//! the object hit, its normal, position and distance, and the direction to the eye, for
//! perspective and orthographic cameras at odd sizes, at grazing incidence on the plane.

mod common;
#[path = "twins/gbuffer.rs"]
mod twin;

/// Each pixel against the float64 ray cast through its centre. Pixels whose hit float32
/// cannot decide (margin under 1e-3: silhouettes, the disc's rim, near-ties) are left out and
/// counted; every other hit must be on the same object, with its normal within 1e-4 and its
/// position within 1e-4 · (1 + distance) of float64's: f32 intersections lose ~1e-7 relative
/// per operation, and a margin of 1e-3 bounds the amplification of a sphere's square root by
/// ~1/√margin ≈ 30, which leaves an order of magnitude to spare. Misses carry index −1 and
/// minus the ray's direction; every texel is finite.
#[test]
fn gbuffer_matches_the_float64_ray_cast() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}
