#version 460
// Lat-long to cube or dual paraboloid, conserving power: each output texel holds the mean of
// the source over the texel's footprint. In the equal-area plane (U, z) = (φ·W/2π, cos θ) lat-long texels are
// rectangles, each reconstructed as its value plus its limited slopes (convert_slopes.comp:
// second order on smooth maps, flat at extrema); the footprint is the polygon of points along
// the texel's edges (with the pole's line where a point sits on a pole or the texel holds
// one; a paraboloid texel's clipped to its half, z >= 0 or z <= 0, the rim being the equator),
// and its overlap with each source texel is integrated exactly, band of rows by band,
// along the polygon clipped to the band (Green's theorem); a paraboloid's chords inside its
// disc add their slivers (the parabolic segment between chord and curve, each to the source
// texel under the curve's midpoint: AREA_PARABOLOID_EDGE_STEPS). Neighbours share their edge points
// and split shared edges from a canonical endpoint order, so the polygons tile the plane and
// each source texel's power is counted once. Each footprint takes U from a column near it
// (local_u): at the map's own U, a column index in the thousands, float32 would round the
// points by ~1e-4 of a texel, and a sun's texels' areas with them; neighbours' shared points
// agree to ~1e-7 of a texel rather than bit for bit, except where the general walk keeps the
// map's own U (footprints on a pole or wide ones), as its neighbours there do. The float64
// twin is
// math::convert::latlong_area, step for step for the general walk; the cube's fast path (FAST,
// below) takes the same integrals over the same polygons without clipping.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "convert_area.glsl"
void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    general(id);
}
