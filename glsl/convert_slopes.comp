#version 460
// Per texel of a lat-long map, the slopes of its linear reconstruction in the equal-area plane
// (U, z) = (φ·W/2π, cos θ): central differences (one-sided in the polar rows), limited
// (Barth–Jespersen) so that across the texel the reconstruction stays between the least and
// greatest of the texel and its four neighbours (no new extremum, never negative; a lone
// bright texel stays flat). convert_area.comp integrates it; the linear part integrates to
// zero over the texel, so power is unchanged. Twin: math::convert::area_slopes.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;

layout(set = 0, binding = BINDING_CONVERT_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_CONVERT_SLOPES_U, std430) writeonly buffer SlopesU {
    vec4 slopes_u[];  // per texel: (dL/dU rgb, 0)
};
layout(set = 0, binding = BINDING_CONVERT_SLOPES_Z, std430) writeonly buffer SlopesZ {
    vec4 slopes_z[];  // per texel: (dL/dz rgb, 0)
};

// The push block, generated from src/abi/push.rs (src_size only).
PUSH_ConvertPush

float zc(int r, int h) { return 0.5 * (latlong_band_edge(r, h) + latlong_band_edge(r + 1, h)); }

vec3 at(int c, int r) { return texelFetch(src, ivec3(c, r, 0), 0).rgb; }

void main() {
    int w = int(pc.src_size.x), h = int(pc.src_size.y);
    int c = int(gl_GlobalInvocationID.x), r = int(gl_GlobalInvocationID.y);
    if (c >= w || r >= h) return;
    vec3 l = at(c, r);
    vec3 left = at(c == 0 ? w - 1 : c - 1, r), right = at(c + 1 == w ? 0 : c + 1, r);
    vec3 gu = 0.5 * (right - left);
    vec3 lo = min(l, min(left, right)), hi = max(l, max(left, right));
    vec3 gz = vec3(0.0);
    bool has_up = r > 0, has_down = r + 1 < h;
    vec3 up = has_up ? at(c, r - 1) : l, down = has_down ? at(c, r + 1) : l;
    if (has_up && has_down) {
        gz = (up - down) / (zc(r - 1, h) - zc(r + 1, h));
    } else if (has_down) {
        gz = (l - down) / (zc(r, h) - zc(r + 1, h));
    } else if (has_up) {
        gz = (up - l) / (zc(r - 1, h) - zc(r, h));
    }
    lo = min(lo, min(up, down));
    hi = max(hi, max(up, down));
    float half_dz = 0.5 * (latlong_band_edge(r, h) - latlong_band_edge(r + 1, h));
    vec3 reach = 0.5 * abs(gu) + half_dz * abs(gz);
    vec3 phi = vec3(1.0);
    for (int k = 0; k < 3; k++) {
        if (reach[k] > 0.0) phi[k] = min(min((hi[k] - l[k]) / reach[k], (l[k] - lo[k]) / reach[k]), 1.0);
    }
    gu *= phi;
    gz *= phi;
    uint o = uint(r * w + c);
    slopes_u[o] = vec4(gu, 0.0);
    slopes_z[o] = vec4(gz, 0.0);
}
