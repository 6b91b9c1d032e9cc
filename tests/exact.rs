//! The exact reference pass (`passes::exact`): the radiance a BRDF reflects, summed over every
//! texel on the GPU, against its float64 twin (`ExactFilter::shade`).

mod common;
#[path = "twins/exact.rs"]
mod twin;

/// Diffuse, Phong, GGX 0.05–0.6 and Ward at normals all round, head-on to grazing, on a sun
/// sky in three mappings (see the twin): within 1e-4 of the twin.
#[test]
fn sums_match_the_float64_twin() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}
