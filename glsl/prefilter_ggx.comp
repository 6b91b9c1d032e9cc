#version 460
// One roughness level of the split-sum prefiltered chain (Karis 2013), twin of
// math::split_sum::prefilter: texel t of a dual paraboloid (directions continued past the
// rim) or of a cube (bakes) holds P(r, α) = Σ w·L / Σ w over N Hammersley samples of GGX α with n = v = r, w the
// sampler's weight f·cos/pdf, each sample read from the source chain at
// lod = ½·log2(Ωs/Ωp) + bias (filtered importance sampling, as shade.frag's fis()). At n = v a
// sample's direction in the texel's frame, weight and Ωs are the level's alone: they come from
// the level's sample table (math::split_sum::prefilter_samples), leaving a texel the frame, Ωp
// and the reads.
#extension GL_GOOGLE_include_directive : require

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;

#include "mappings.glsl"
#include "brdf.glsl"
#include "fis.glsl"

layout(set = 0, binding = BINDING_PREFILTER_GGX_SRC) uniform sampler2DArray src;
layout(rgba32f, set = 0, binding = BINDING_PREFILTER_GGX_DST) uniform writeonly image2DArray dst;
// PREFILTER_SAMPLE_VEC4S (2) vec4s a sample: (wi, w), then (lod before the texel term, 0, 0, 0).
layout(std430, set = 0, binding = BINDING_PREFILTER_GGX_SAMPLES) readonly buffer Samples { vec4 table[]; };

// The push block, generated from src/abi/push.rs.
PUSH_PrefilterGgxPush

vec3 src_lookup(vec3 d, float lod) {
    return dp_chain_lookup(src, d, lod, pc.src_size, pc.src_max_lod);
}

void main() {
    uvec3 id = gl_GlobalInvocationID + uvec3(0u, 0u, pc.layer);
    if (id.x >= pc.size || id.y >= pc.size) return;
    Coord c;
    c.layer = id.z;
    c.uv = (vec2(id.xy) + 0.5) / float(pc.size);
    vec3 r = normalize(coord_to_dir(pc.dst_mapping, c));
    vec3 color;
    if (pc.alpha <= 0.0) {
        color = src_lookup(r, 0.0);
    } else {
        vec3 t, bt;
        shading_frame(r, t, bt);
        // Ωp = (1 + |d.y|)²·(2/size)²: its ½·log2 is log2(1 + |d.y|) past the tap's lod.
        vec3 sum = vec3(0.0);
        float total = 0.0;
        for (uint i = 0u; i < pc.samples; i++) {
            uint at = PREFILTER_SAMPLE_VEC4S * i;
            vec4 s = table[at];
            vec3 d = normalize(t * s.x + bt * s.y + r * s.z);
            float lod = clamp(table[at + 1u].x - log2(1.0 + abs(d.y)), 0.0, pc.src_max_lod);
            sum += s.w * src_lookup(d, lod);
            total += s.w;
        }
        color = total > 0.0 ? sum / total : vec3(0.0);
    }
    imageStore(dst, ivec3(id), vec4(color, 1.0));
}
