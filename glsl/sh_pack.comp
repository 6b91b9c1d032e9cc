#version 460
// SH coefficients packed for the shade pass on the GPU (twin: math::sh::pack): packed
// coefficient o is scale × (radiance coefficient `source` − coefficient `minus` of a second
// set, where there is one): an SH object's irradiance (Â_l folded in) of the map less its
// light texels', or an SH-BRDF object's windowed radiance. The projection's output never comes
// back to the host between projection and shading.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_SH_PACK_RADIANCE) readonly buffer Radiance { float radiance[]; };
layout(std430, set = 0, binding = BINDING_SH_PACK_ENTRIES) readonly buffer Entries { uvec4 entries[]; };
layout(std430, set = 0, binding = BINDING_SH_PACK_MINUS) readonly buffer Minus { vec4 minus[]; };
layout(std430, set = 0, binding = BINDING_SH_PACK_OUT) writeonly buffer Out { vec4 coeffs[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ShPackPush

void main() {
    uint o = gl_GlobalInvocationID.x;
    if (o >= pc.count) return;
    uvec4 e = entries[o];
    vec3 c = vec3(radiance[3u * e.x], radiance[3u * e.x + 1u], radiance[3u * e.x + 2u]);
    if (e.z != 0u) c -= minus[e.z - 1u].rgb;
    coeffs[o] = vec4(c * uintBitsToFloat(e.y), 0.0);
}
