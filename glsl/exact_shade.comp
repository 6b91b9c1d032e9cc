#version 460
// The exact reference on the GPU (float64 twin: src/math/exact.rs, ExactFilter::shade): per
// query (a surface's frame, the view and the lobe's axis and scale, prepared on the host as the
// twin prepares them) the radiance one BRDF reflects, unshadowed, as the sum over every texel
// of L·∫ f·cos dω, each texel by the twin's rule: one node at its centre where it is small
// next to the lobe's scale there (α at the axis, a fraction of the chord in the tail, a
// quarter of it where the horizon crosses the texel), s × s cells of 2 × 2 Gauss points
// weighted by the mapping's footprint density elsewhere. Nothing is sampled: no noise.
//
// Each invocation sums `run` texels, lane-interleaved so that neighbouring lanes read
// neighbouring texels, with Kahan compensation (a sun 1e5 times the sky does not swamp the
// sky); the workgroup adds its lanes in a shared-memory tree and writes one partial sum for
// its query; the host adds a query's partials in float64 (passes::exact). `run` is sized on
// the host so that no invocation runs more loop iterations than llvmpipe allows (its texels
// each with the most cells the batch's lobes can ask).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "generated.glsl"
#include "mappings.glsl"
#include "brdf.glsl"

#define WG EXACT_WORKGROUP
layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_EXACT_MAP) uniform sampler2DArray map;
layout(std430, set = 0, binding = BINDING_EXACT_OMEGA) readonly buffer Omega { float omega[]; };
layout(std430, set = 0, binding = BINDING_EXACT_QUERIES) readonly buffer Queries { vec4 queries[]; };
layout(std430, set = 0, binding = BINDING_EXACT_PARTIALS) writeonly buffer Partials { vec4 partials[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ExactShadePush

shared vec3 tree[WG];

// A query's lobe in the map's file frame (passes::exact::query_words).
struct Lobe {
    vec3 t, b, n;  // the surface's frame
    vec3 wo;       // the view in that frame
    vec3 axis;     // the lobe's axis
    float a;       // its scale, squeezed at grazing views
};

Lobe read_lobe(uint q) {
    uint o = EXACT_QUERY_VEC4S * q;
    Lobe l;
    l.t = queries[o].xyz;
    l.b = queries[o + 1u].xyz;
    l.n = queries[o + 2u].xyz;
    l.wo = queries[o + 3u].xyz;
    l.axis = queries[o + 4u].xyz;
    l.a = queries[o + 4u].w;
    return l;
}

float f_cos(Lobe l, Brdf br, vec3 d) {
    return brdf_eval_cos(br, l.wo, vec3(dot(l.t, d), dot(l.b, d), dot(l.n, d)));
}

// ∫_t f·cos dω over texel p of `layer` (centre direction `dir`, solid angle `om`): the twin's
// shade_weight.
float texel_weight(Lobe l, Brdf br, uint layer, ivec2 p, vec3 dir, float om) {
    float rho = sqrt(om);
    vec3 e = dir - l.axis;
    float chord2 = dot(e, e);
    float horizon = dot(l.n, dir);
    float reach = EXACT_HORIZON_REACH * horizon;
    float tail = LIGHT_TAIL_FRACTION * LIGHT_TAIL_FRACTION * min(chord2, reach * reach);
    float w2 = max(l.a * l.a, tail);
    // The horizon crosses the texel: f·cos kinks there; a quarter of the scale.
    if (abs(horizon) < rho) w2 /= EXACT_HORIZON_SHRINK * EXACT_HORIZON_SHRINK;
    float size = pc.per_width * rho;
    if (size * size < LIGHT_CENTRE_BELOW * LIGHT_CENTRE_BELOW * w2) return f_cos(l, br, dir) * om;
    uint s = uint(min(ceil(size / sqrt(w2)), EXACT_MAX_CELLS_PER_WIDTH * pc.per_width));
    const float g = GAUSS2_OFFSET;  // 0.5 / √3: a cell's 2-point Gauss nodes
    float kw = 0.0, ww = 0.0;
    vec2 inv = 1.0 / vec2(pc.size);
    for (uint cell = 0u; cell < s * s; cell++) {
        vec2 corner = vec2(p) + vec2(cell % s, cell / s) / float(s);
        [[unroll]] for (int k = 0; k < 4; k++) {
            vec2 off = vec2((k & 1) == 0 ? -g : g, (k & 2) == 0 ? -g : g);
            vec2 uv = (corner + (0.5 + off) / float(s)) * inv;
            float wt = footprint_weight(pc.mapping, uv);
            kw += wt * f_cos(l, br, coord_to_dir(pc.mapping, Coord(layer, uv)));
            ww += wt;
        }
    }
    return ww > 0.0 ? kw / ww * om : f_cos(l, br, dir) * om;
}

void main() {
    uint q = pc.first + gl_WorkGroupID.y;
    Lobe l = read_lobe(q);
    Brdf br = Brdf(pc.brdf, pc.p0, pc.p1);
    uint lane = gl_LocalInvocationID.x;
    uint base = gl_WorkGroupID.x * WG * pc.run;
    uint layer_texels = pc.size.x * pc.size.y;
    precise vec3 sum = vec3(0.0);
    precise vec3 comp = vec3(0.0);
    for (uint k = 0u; k < pc.run; k++) {
        uint t = base + k * WG + lane;
        if (t >= pc.texels) break;
        uvec2 lr = div_rem(t, layer_texels);
        uvec2 ji = div_rem(lr.y, pc.size.x);
        uint layer = lr.x;
        ivec2 p = ivec2(ji.y, ji.x);
        float om = omega[pc.mapping == MAPPING_LATLONG ? ji.x : lr.y];
        if (om <= 0.0 && !texel_in_domain(pc.mapping, pc.size, p)) continue;
        ivec2 src = integration_source(pc.mapping, pc.size, p);
        if (src.x < 0) continue;
        vec3 dir = coord_to_dir(pc.mapping, Coord(layer, (vec2(p) + 0.5) / vec2(pc.size)));
        vec3 radiance = finite_or_zero(texelFetch(map, ivec3(src, int(layer)), 0).rgb);
        precise vec3 y = texel_weight(l, br, layer, p, dir, om) * radiance - comp;
        precise vec3 next = sum + y;
        comp = (next - sum) - y;
        sum = next;
    }
    tree[lane] = sum;
    barrier();
    for (uint s = WG / 2u; s > 0u; s >>= 1u) {
        if (lane < s) tree[lane] += tree[lane + s];
        barrier();
    }
    if (lane == 0u) partials[q * pc.groups + gl_WorkGroupID.x] = vec4(tree[0], 0.0);
}
