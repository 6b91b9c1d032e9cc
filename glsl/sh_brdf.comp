#version 460
// SH projection of a BRDF slice per view (Kautz, Sloan & Snyder 2002), twin of
// src/math/sh_brdf.rs: invocation i computes c(ωₒ) = ∫ f(ωₒ, ωᵢ)·cos θᵢ·y(ωᵢ) dωᵢ for view i
// of the paraboloid-mapped grid, as a sum over the BRDF sampler's unit square of
// weight(ωₒ, ωᵢ)·y(ωᵢ): the first uniform in panels graded toward both ends, the second in
// SH_BRDF_PANELS uniform ones, 4 × 4 Gauss–Legendre nodes a panel. One dispatch adds one
// panel of the first uniform (the first writes): llvmpipe cuts a loop after 65535 iterations
// per invocation, and the whole rule at l = 8 would take 4096 × 81.
#extension GL_GOOGLE_include_directive : require

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
// The band (the basis loops unroll and the sums stay in registers) and the BRDF (the other
// BRDFs' branches vanish).
layout(constant_id = 1) const uint LMAX = 2u;
const uint NC = (LMAX + 1u) * (LMAX + 1u);
layout(constant_id = 2) const uint BRDF = 0u;

#define SH_SPEC_BASIS
#include "mappings.glsl"
#include "sh.glsl"
#include "brdf.glsl"
#include "graded.glsl"

layout(std430, set = 0, binding = BINDING_SH_BRDF_TABLE) buffer Table { float table[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ShBrdfPush

// The view at grid texel (i, j): upper paraboloid (s, t) = (x, y)/(1 + z), centres outside the
// disc pulled onto the rim, then lifted as local_view lifts views.
vec3 grid_view(uint i, uint j) {
    float g = float(pc.grid);
    vec2 st = (vec2(i, j) + 0.5) / g * 2.0 - 1.0;
    float r2 = dot(st, st);
    if (r2 > 1.0) st *= (1.0 - RIM_PULL_IN) / sqrt(r2);
    float q = dot(st, st);
    vec3 d = vec3(2.0 * st, 1.0 - q) / (1.0 + q);
    return local_view(d, vec3(1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0), vec3(0.0, 0.0, 1.0));
}

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= pc.grid * pc.grid) return;
    vec3 wo = grid_view(id % pc.grid, id / pc.grid);
    Brdf b = Brdf(BRDF, pc.p0, pc.p1);
    float acc[NC];
    for (uint k = 0u; k < NC; k++) acc[k] = 0.0;
    if (BRDF == BRDF_MIRROR) {
        // A delta: y(r), once (later panels add nothing).
        if (pc.panel == 0u) {
            sh_basis_spec(vec3(-wo.x, -wo.y, wo.z));
            for (uint k = 0u; k < NC; k++) acc[k] = sh_y[k];
        }
    } else {
        const float h = 1.0 / float(SH_BRDF_PANELS);
        vec2 a = graded_panel(pc.panel);
        for (uint pb = 0u; pb < SH_BRDF_PANELS; pb++) {
            for (uint xa = 0u; xa < SH_BRDF_GL_NODES; xa++) {
                for (uint xb = 0u; xb < SH_BRDF_GL_NODES; xb++) {
                    vec2 u = vec2(a.x + (a.y - a.x) * 0.5 * (SH_BRDF_GL_X[xa] + 1.0),
                                  (float(pb) + 0.5 * (SH_BRDF_GL_X[xb] + 1.0)) * h);
                    vec3 wi = brdf_sample(b, wo, u);
                    float w = brdf_weight(b, wo, wi);
                    if (w == 0.0) continue;
                    sh_basis_spec(wi);
                    float k = 0.25 * SH_BRDF_GL_W[xa] * SH_BRDF_GL_W[xb] * (a.y - a.x) * h * w;
                    for (uint c = 0u; c < NC; c++) acc[c] += k * sh_y[c];
                }
            }
        }
    }
    uint at = pc.offset + id * NC;
    if (pc.panel == 0u) {
        for (uint k = 0u; k < NC; k++) table[at + k] = acc[k];
    } else {
        for (uint k = 0u; k < NC; k++) table[at + k] += acc[k];
    }
}
