#version 460
// Rotates SH coefficient vectors by either construction of sh_rotate.glsl (tests and the
// rotation benchmark): record i of the input is a rotation's three rows (vec4 each) and
// (lmax+1)² coefficients; the output holds the rotated coefficients.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_SH_ROT_IN) readonly buffer In { float data[]; };
layout(std430, set = 0, binding = BINDING_SH_ROT_OUT) writeonly buffer Out { float result[]; };
layout(std430, set = 0, binding = BINDING_SH_ROT_X90) readonly buffer X90 { float x90[]; };
#define SH_X90(i) x90[i]
#include "sh_rotate.glsl"

// The push block, generated from src/abi/push.rs.
PUSH_ShRotatePush

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= pc.count) return;
    uint nc = (pc.lmax + 1u) * (pc.lmax + 1u);
    uint base = id * (SH_ROTATE_HEADER + nc);
    mat3 r;
    for (uint i = 0u; i < 3u; i++)
        for (uint j = 0u; j < 3u; j++) r[j][i] = data[base + 4u * i + j];
    float c[SH_MAX_COEFFS];
    for (uint k = 0u; k < SH_MAX_COEFFS; k++) c[k] = k < nc ? data[base + SH_ROTATE_HEADER + k] : 0.0;
    if (pc.method == SH_ROTATION_IVANIC) {
        sh_rotate_ivanic(r, pc.lmax, c);
    } else {
        sh_rotate_zxzxz(r, pc.lmax, c);
    }
    for (uint k = 0u; k < nc; k++) result[id * nc + k] = c[k];
}
