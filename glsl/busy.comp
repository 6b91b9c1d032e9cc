#version 460
// A deliberately costly dispatch, for testing that timestamps bracket the work they time.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_BUSY_OUT) writeonly buffer Out { float values[]; };
// The push block, generated from src/abi/push.rs.
PUSH_BusyPush

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    float x = float(i) * 1e-3;
    for (uint k = 0u; k < pc.iterations; k++) {
        x = sin(x) * 0.999 + cos(x * 1.0001) * 0.001 + 1e-7;
    }
    values[i] = x;
}
