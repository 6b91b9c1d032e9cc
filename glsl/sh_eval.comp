#version 460
// Irradiance from SH coefficients at the centre of every texel of a map (R&H 2001 eq. 7 with
// the general A_l): E(n) = Σ_lm c_lm·f_lm·Y_lm(n), c_lm in a coefficient's rgb and a factor
// f_lm in its alpha: 1 where the caller folded Â_l and any window into c_lm, Â_l where the
// radiance coefficients were copied in on the GPU; minus coefficients d_lm stored after them
// (zero unless the caller subtracts the SH of extracted lights, leaving the residual's).
// Negative values (ringing) are clamped to 0
// here; the CPU reports where they were.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "sh.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_SH_EVAL_COEFFS) readonly buffer Coeffs { vec4 coeffs[]; };
layout(set = 0, binding = BINDING_SH_EVAL_DST, rgba32f) uniform writeonly image2DArray dst;

// The push block, generated from src/abi/push.rs.
PUSH_ShEvalPush

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    if (pc.dst_mapping == MAPPING_ANGULAR && !texel_in_domain(pc.dst_mapping, pc.dst_size, ivec2(id.xy))) {
        imageStore(dst, ivec3(id), vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    Coord c;
    c.layer = id.z;
    c.uv = (vec2(id.xy) + 0.5) / vec2(pc.dst_size);
    float y[SH_MAX_COEFFS];
    sh_basis(pc.lmax, coord_to_dir(pc.dst_mapping, c), y);
    vec3 e = vec3(0.0);
    uint n = (pc.lmax + 1u) * (pc.lmax + 1u);
    // coeffs[n + k].rgb: what to subtract (a map's light texels' irradiance coefficients).
    for (uint k = 0u; k < n; k++) e += (coeffs[k].rgb * coeffs[k].a - coeffs[n + k].rgb) * y[k];
    imageStore(dst, ivec3(id), vec4(max(e, vec3(0.0)), 1.0));
}
