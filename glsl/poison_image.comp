#version 460
// A test hook (feature test-hooks): corrupts, in place, one level of a map a pass has just
// written (one NaN, a scale, or the layers mirrored left to right), so that the tests show
// their comparisons catch a wrong output (tests/mutation.rs). Recorded only when a test asks.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_POISON_IMAGE, rgba32f) uniform image2DArray img;
// The push block, generated from src/abi/push.rs.
PUSH_PoisonPush

const uint NAN_MODE = 0u;
const uint SCALE_MODE = 1u;

float quiet_nan() {
    return uintBitsToFloat(0x7fc00000u);
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (id.x >= pc.width || id.y >= pc.height || id.z >= pc.layers) return;
    ivec3 p = ivec3(id);
    if (pc.mode == NAN_MODE) {
        if ((id.z * pc.height + id.y) * pc.width + id.x != pc.nan_at) return;
        vec4 t = imageLoad(img, p);
        imageStore(img, p, vec4(vec3(quiet_nan()), t.a));
    } else if (pc.mode == SCALE_MODE) {
        vec4 t = imageLoad(img, p);
        imageStore(img, p, vec4(t.rgb * pc.factor, t.a));
    } else {
        // Mirrored left to right: each pair of columns swapped once, the middle one kept.
        uint mirrored = pc.width - 1u - id.x;
        if (id.x >= mirrored) return;
        ivec3 q = ivec3(int(mirrored), p.yz);
        vec4 a = imageLoad(img, p);
        vec4 b = imageLoad(img, q);
        imageStore(img, p, b);
        imageStore(img, q, a);
    }
}
