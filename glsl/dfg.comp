#version 460
// The split-sum DFG table (Karis 2013), twin of math::split_sum::dfg: entry (i, j) holds
// (A, B) = ∫ f/F·cos·(1 − Fc, Fc) dωᵢ for GGX α = x(j)² seen at n·v = x(i), Fc = (1 − v·h)⁵,
// with x(i) = i/(size − 1) (endpoints) or (i + ½)/size (texel centres, pc.centres; the twin's
// DfgAxes), as a sum over the GGX sampler's unit square with the rule of sh_brdf.comp
// (graded panels of the first uniform, SH_BRDF_PANELS uniform ones of the second, 4 × 4
// Gauss–Legendre nodes a panel). One dispatch adds one panel of the first uniform (the first
// writes): llvmpipe cuts a loop after 65535 iterations per invocation.
#extension GL_GOOGLE_include_directive : require

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;

#include "mappings.glsl"
#include "brdf.glsl"
#include "graded.glsl"

layout(std430, set = 0, binding = BINDING_DFG_TABLE) buffer Table { vec2 table[]; };

// The push block, generated from src/abi/push.rs.
PUSH_DfgPush

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= pc.size * pc.size) return;
    float last = float(max(pc.size, 2u) - 1u);
    vec2 ij = vec2(float(id % pc.size), float(id / pc.size));
    vec2 x = pc.centres != 0u ? (ij + 0.5) / float(pc.size) : ij / last;
    float mu = clamp(x.x, DFG_MU_MIN, 1.0);
    float r = x.y;
    vec3 wo = vec3(sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu);
    Brdf b = Brdf(BRDF_GGX, r * r, float(pc.correlated));
    const float h = 1.0 / float(SH_BRDF_PANELS);
    vec2 a = graded_panel(pc.panel);
    vec2 acc = vec2(0.0);
    for (uint pb = 0u; pb < SH_BRDF_PANELS; pb++) {
        for (uint xa = 0u; xa < SH_BRDF_GL_NODES; xa++) {
            for (uint xb = 0u; xb < SH_BRDF_GL_NODES; xb++) {
                vec2 u = vec2(a.x + (a.y - a.x) * 0.5 * (SH_BRDF_GL_X[xa] + 1.0),
                              (float(pb) + 0.5 * (SH_BRDF_GL_X[xb] + 1.0)) * h);
                vec3 wi = brdf_sample(b, wo, u);
                float w = brdf_weight(b, wo, wi);
                if (w == 0.0) continue;
                vec3 hv = wo + wi;
                float hl = length(hv);
                float vh = hl > 0.0 ? clamp(dot(wo, hv) / hl, 0.0, 1.0) : 0.0;
                float x = 1.0 - vh, x2 = x * x;
                float fc = x2 * x2 * x;
                float k = 0.25 * SH_BRDF_GL_W[xa] * SH_BRDF_GL_W[xb] * (a.y - a.x) * h * w;
                acc += k * vec2(1.0 - fc, fc);
            }
        }
    }
    uint at = pc.offset / 2u + id;
    if (pc.panel == 0u) {
        table[at] = acc;
    } else {
        table[at] += acc;
    }
}
