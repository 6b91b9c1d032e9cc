#version 460
// One progressive frame of the Monte Carlo reference, per pixel whose material asks for it:
// `samples` more estimates added to the accumulation (rgb sum, luminance² sum). Each estimate
// combines one BRDF sample and one environment sample (luminance × solid-angle CDF over the
// full-resolution lat-long map, uniform in solid angle inside the texel) by the balance
// heuristic (Veach & Guibas 1995); with mis = 0 it is plain BRDF sampling. No filtering: the
// map is read texel by texel. Shadows test visibility against the scene's objects.
// Twin of src/math/mc.rs.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "scene.glsl"
#include "sequence.glsl"
#include "brdf.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_MC_NORMAL) uniform sampler2DArray gbuf_normal;
layout(set = 0, binding = BINDING_MC_VIEW) uniform sampler2DArray gbuf_view;
layout(set = 0, binding = BINDING_MC_POSITION) uniform sampler2DArray gbuf_position;
layout(std430, set = 0, binding = BINDING_MC_OBJECTS) readonly buffer Objects { Object objects[]; };
layout(set = 0, binding = BINDING_MC_ENV) uniform sampler2DArray env;
layout(std430, set = 0, binding = BINDING_MC_TABLES) readonly buffer Tables { float tables[]; };
layout(set = 0, binding = BINDING_MC_ACCUM, rgba32f) uniform image2DArray accum;

// The push block, generated from src/abi/push.rs.
PUSH_McPush

vec3 to_file(vec3 d) {
    return vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d), dot(pc.world_to_file[2].xyz, d));
}

vec3 to_world(vec3 f) {
    return f.x * pc.world_to_file[0].xyz + f.y * pc.world_to_file[1].xyz + f.z * pc.world_to_file[2].xyz;
}

ivec2 env_texel(vec3 f) {
    Coord c = dir_to_coord(MAPPING_LATLONG, f);
    return min(ivec2(c.uv * vec2(pc.env_size)), ivec2(pc.env_size) - 1);
}

uint pdf_base() {
    return pc.env_size.y + pc.env_size.x * pc.env_size.y;
}

// First k in [0, n) whose CDF entry exceeds u.
uint search(uint base, uint n, float u) {
    uint lo = 0u, hi = n - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (tables[base + mid] > u) hi = mid; else lo = mid + 1u;
    }
    return lo;
}

bool occluded(vec3 o, vec3 d) {
    for (uint k = 0u; k < pc.count; k++) {
        vec3 n;
        if (object_hit(objects[k], o, d, n) > 0.0) return true;
    }
    return false;
}

// Radiance arriving along world direction d (0 when shadowed).
vec3 incoming(vec3 origin, vec3 d, ivec2 texel) {
    if (pc.shadows != 0u && occluded(origin, d)) return vec3(0.0);
    return texelFetch(env, ivec3(texel, 0), 0).rgb;
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(pix, pc.size))) return;
    ivec3 q = ivec3(pix, 0);
    vec4 nrm = texelFetch(gbuf_normal, q, 0);
    if (nrm.w < 0.0) return;
    Object ob = objects[uint(nrm.w)];
    if (ob.technique != TECH_MC) return;
    Brdf b = Brdf(ob.brdf, ob.params[0], ob.params[1]);
    vec3 n = normalize(nrm.xyz);
    vec3 v = texelFetch(gbuf_view, q, 0).xyz;
    vec3 origin = shadow_origin(texelFetch(gbuf_position, q, 0).xyz, n);
    vec3 t, bt;
    shading_frame(n, t, bt);
    vec3 wo = local_view(v, t, bt, n);
    uint w = pc.env_size.x, h = pc.env_size.y;
    vec3 sum = vec3(0.0);
    float sum2 = 0.0;
    for (uint s = 0u; s < pc.samples; s++) {
        uint state = rng_init(pix, pc.first + s, pc.seed);
        vec2 u = vec2(rng_next(state), rng_next(state));
        vec3 x = vec3(0.0);
        vec3 wi = brdf_sample(b, wo, u);
        if (wi.z > 0.0) {
            vec3 d = normalize(t * wi.x + bt * wi.y + n * wi.z);
            ivec2 texel = env_texel(to_file(d));
            float wt = b.id == BRDF_MIRROR ? 1.0 : brdf_weight(b, wo, wi);
            if (pc.mis != 0u && b.id != BRDF_MIRROR) {
                float pb = brdf_pdf(b, wo, wi);
                float pe = tables[pdf_base() + uint(texel.y) * w + uint(texel.x)];
                wt *= pb / (pb + pe);
            }
            if (wt > 0.0) x += wt * incoming(origin, d, texel);
        }
        vec4 ue = vec4(rng_next(state), rng_next(state), rng_next(state), rng_next(state));
        if (pc.mis != 0u && b.id != BRDF_MIRROR) {
            uint j = search(0u, h, ue.x);
            uint i = search(h + j * w, w, ue.y);
            float phi = TAU * (float(i) + ue.z) / float(w);
            float c0 = cos(PI * float(j) / float(h)), c1 = cos(PI * float(j + 1u) / float(h));
            float ct = c0 - ue.w * (c0 - c1);
            float st = sqrt(max(1.0 - ct * ct, 0.0));
            vec3 d = normalize(to_world(vec3(st * sin(phi), ct, -st * cos(phi))));
            vec3 wl = vec3(dot(d, t), dot(d, bt), dot(d, n));
            float pe = tables[pdf_base() + j * w + i];
            if (wl.z > 0.0 && pe > 0.0) {
                float f = brdf_eval_cos(b, wo, wl);
                float pb = brdf_pdf(b, wo, wl);
                if (f > 0.0) x += f / (pb + pe) * incoming(origin, d, ivec2(i, j));
            }
        }
        x *= ob.albedo.rgb;
        sum += x;
        float l = dot(x, LUMINANCE);
        sum2 += l * l;
    }
    imageStore(accum, q, imageLoad(accum, q) + vec4(sum, sum2));
}
