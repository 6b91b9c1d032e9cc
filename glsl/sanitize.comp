#version 460
// The resident path's first pass: an engine's map copied into envlight's own image, every
// texel that is not a finite, non-negative radiance set to zero and counted (an engine's
// frame may hold NaN, infinities or negative values that a host map would have been refused
// for). Float64 twin: EnvMap::sanitized.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_SANITIZE_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_SANITIZE_DST, rgba32f) uniform writeonly image2DArray dst;
layout(std430, set = 0, binding = BINDING_SANITIZE_COUNT) buffer Count { uint zeroed; };
// The push block, generated from src/abi/push.rs.
PUSH_SanitizePush

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.size))) return;
    vec3 l = texelFetch(src, ivec3(id), 0).rgb;
    // NaN fails every comparison; +∞ is not below the largest float.
    bool radiance = all(greaterThanEqual(l, vec3(0.0))) && all(lessThan(l, vec3(FLOAT_INF)));
    if (!radiance) {
        atomicAdd(zeroed, 1u);
        l = vec3(0.0);
    }
    imageStore(dst, ivec3(id), vec4(l, 1.0));
}
