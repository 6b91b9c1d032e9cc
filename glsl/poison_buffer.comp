#version 460
// A test hook (feature test-hooks): corrupts, in place, floats a pass has just written (one
// NaN, a scale, or the mirror of SH coefficients or of marked floats), so that the tests show
// their comparisons catch a wrong output (tests/mutation.rs). Recorded only when a test asks.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_POISON_BUFFER, std430) buffer Values { float v[]; };
// The push block, generated from src/abi/push.rs.
PUSH_PoisonPush

const uint NAN_MODE = 0u;
const uint SCALE_MODE = 1u;

float quiet_nan() {
    return uintBitsToFloat(0x7fc00000u);
}

// The sign a mirror x → −x gives real SH coefficient k (m > 0 carries cos(mφ), m < 0
// sin(|m|φ), with φ measured from +x).
float sh_mirror_sign(uint k) {
    int l = int(floor(sqrt(float(k)) + 1e-3));
    int m = int(k) - l * l - l;
    int odd = abs(m) & 1;
    if (m > 0) return odd == 1 ? -1.0 : 1.0;
    if (m < 0) return odd == 1 ? 1.0 : -1.0;
    return 1.0;
}

void main() {
    uint f = gl_GlobalInvocationID.x;
    if (f >= pc.width) return;
    uint at = pc.first + f;
    if (pc.mode == NAN_MODE) {
        if (f == pc.nan_at) v[at] = quiet_nan();
    } else if (pc.mode == SCALE_MODE) {
        if (((pc.scale_mask >> (f % pc.stride)) & 1u) != 0u) v[at] *= pc.factor;
    } else if (pc.sh_channels != 0u) {
        v[at] *= sh_mirror_sign((f / pc.sh_channels) % pc.sh_count);
    } else if (((pc.mirror_mask >> (f % pc.stride)) & 1u) != 0u) {
        v[at] = -v[at];
    }
}
