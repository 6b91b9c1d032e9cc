#version 460
// A map clamped in place at luminance τ: every texel of the mapping's domain whose luminance
// Y exceeds τ keeps L·τ/Y, chroma kept: the residual of a light extraction by the clamp rule,
// whose excess over τ the light records hold. A bake clamps its source this way after the
// passes that read the whole map. Float64 twin:
// math::lights::clamp_residual.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_CLAMP_MAP, rgba32f) uniform image2DArray map;
// The push block, generated from src/abi/push.rs.
PUSH_ClampPush

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.size))) return;
    if (!texel_in_domain(pc.mapping, pc.size, ivec2(id.xy))) return;
    vec4 l = imageLoad(map, ivec3(id));
    float y = dot(LUMINANCE, l.rgb);
    if (y > pc.threshold) {
        imageStore(map, ivec3(id), vec4(l.rgb * (pc.threshold / y), l.a));
    }
}
