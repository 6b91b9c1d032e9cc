#version 460
// One roughness level of the split-sum prefiltered chain (Karis 2013), twin of
// math::split_sum::prefilter: texel t of a dual paraboloid (directions continued past the
// rim) or of a cube (bakes) holds P(r, α) = Σ w·L / Σ w over N Hammersley samples of GGX α with n = v = r, w the
// sampler's weight f·cos/pdf, each sample read from the source chain at
// lod = ½·log2(Ωs/Ωp) + bias (filtered importance sampling, as shade.frag's fis()).
#extension GL_GOOGLE_include_directive : require

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;

#include "mappings.glsl"
#include "brdf.glsl"
#include "sequence.glsl"
#include "fis.glsl"

layout(set = 0, binding = BINDING_PREFILTER_GGX_SRC) uniform sampler2DArray src;
layout(rgba32f, set = 0, binding = BINDING_PREFILTER_GGX_DST) uniform writeonly image2DArray dst;

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
        Brdf b = Brdf(BRDF_GGX, pc.alpha, 0.0);
        const vec3 wo = vec3(0.0, 0.0, 1.0);
        vec3 sum = vec3(0.0);
        float total = 0.0;
        for (uint i = 0u; i < pc.samples; i++) {
            vec3 wi = brdf_sample(b, wo, hammersley(i, pc.samples));
            if (wi.z <= 0.0) continue;
            float w = brdf_weight(b, wo, wi);
            float pdf = brdf_pdf(b, wo, wi);
            vec3 d = normalize(t * wi.x + bt * wi.y + r * wi.z);
            float lod = fis_lod(pdf, pc.samples, d, pc.src_size, pc.bias, pc.src_max_lod);
            sum += w * src_lookup(d, lod);
            total += w;
        }
        color = total > 0.0 ? sum / total : vec3(0.0);
    }
    imageStore(dst, ivec3(id), vec4(color, 1.0));
}
