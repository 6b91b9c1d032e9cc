#version 460
// Shades every G-buffer pixel by its material's technique and composites the frame:
// - LOOKUP: the mirror: the mean over the pixel's footprint from the dual-paraboloid chain
//   (plus the light texels it covers), or one nearest-texel lookup of the reflected direction;
// - SH: albedo·E(n)/π from SH irradiance coefficients (R&H 2001), clamped at 0;
// - PREFILTERED: a prefiltered lat-long map, irradiance by n or Phong by r, bilinear
//   (with lights extracted: of the residual, plus the light clusters' irradiance or the light
//   texels under the Phong BRDF);
// - FIS: filtered importance sampling (Colbert & Křivánek 2007): N Hammersley samples of the
//   BRDF, each read from the dual-paraboloid MIP chain at lod ½·log2(Ωs/Ωp) + bias;
// - MC: the mean the Monte Carlo pass accumulated;
// - SH_BRDF: Kautz et al. 2002: the BRDF's SH vector at the local view (bilinear over the view
//   grid), rotated to world space, dotted with the environment's radiance coefficients.
// Misses show the environment along the ray, footprint-filtered as mirrors are where asked. Shadows (V_em) apply to LOOKUP and FIS.
#extension GL_GOOGLE_include_directive : require
#ifdef USE_VOTE
#extension GL_KHR_shader_subgroup_vote : require
#endif
#include "generated.glsl"

// Which code this pipeline keeps (specialisation constant 0, set from what a render binds
// and draws: bit t for technique t, FOOTPRINT_CODE for footprint lookups, SHADOWS_CODE for
// shadow rays, bit BRDF_CODE_SHIFT + id for each BRDF its objects use): the others' branches
// fold away, so llvmpipe compiles a FIS-only shade in a fraction of the whole one's time,
// and a light tree walk's step (whose whole body llvmpipe runs) carries one BRDF, not six.
layout(constant_id = 0) const uint CODE = 0xffffffffu;
#define BRDF_KEPT(k) ((CODE & (1u << (BRDF_CODE_SHIFT + (k)))) != 0u)

bool has(uint bit) {
#ifdef LEAN
    // A variant for draws with neither footprint lookups nor shadow rays: their code is gone
    // before the driver sees it (a smaller module, which llvmpipe compiles and runs faster).
    bit &= ~(FOOTPRINT_CODE | SHADOWS_CODE);
#endif
    return (CODE & bit) != 0u;
}

bool has_tech(uint t) {
#ifdef ONLY_TECHS
    // A variant for scenes of one technique (with the background's lookup, and the one whose
    // inputs it reads): the others' code is gone before the driver sees it, which llvmpipe
    // builds 3x faster than the constant's fold. CODE still holds the BRDFs, footprint and
    // shadow bits.
    return t == TECH_LOOKUP || ((ONLY_TECHS) & (1u << t)) != 0u;
#else
    return has(1u << t);
#endif
}

#include "mappings.glsl"
#include "lights.glsl"
#include "sh.glsl"
#include "scene.glsl"
#include "sequence.glsl"
#include "brdf.glsl"
#include "fis.glsl"

// Whether every active lane of the subgroup has ended its light tree walk. llvmpipe leaves a
// loop early only on a subgroup-uniform break: lanes that break alone are masked, and the
// loop runs on to its bound (the tree's nodes plus texels, tens of thousands on a studio
// probe), whatever the walk's length. Without vote ops, the lane alone.
bool walk_done(bool done) {
#ifdef USE_VOTE
    return subgroupAll(done);
#else
    return done;
#endif
}

layout(set = 0, binding = BINDING_SHADE_NORMAL) uniform sampler2DArray gbuf_normal;
layout(set = 0, binding = BINDING_SHADE_VIEW) uniform sampler2DArray gbuf_view;
layout(std430, set = 0, binding = BINDING_SHADE_OBJECTS) readonly buffer Objects { Object objects[]; };
layout(std430, set = 0, binding = BINDING_SHADE_COEFFS) readonly buffer Coeffs { vec4 coeffs[]; };
layout(set = 0, binding = BINDING_SHADE_ENV) uniform sampler2DArray env;
layout(set = 0, binding = BINDING_SHADE_POSITION) uniform sampler2DArray gbuf_position;
layout(set = 0, binding = BINDING_SHADE_DP) uniform sampler2DArray dp;
layout(std430, set = 0, binding = BINDING_SHADE_PREFILTERED) readonly buffer Pre { vec4 pre[]; };
layout(set = 0, binding = BINDING_SHADE_MC) uniform sampler2DArray mc_accum;
layout(std430, set = 0, binding = BINDING_SHADE_BRDF_SH) readonly buffer BrdfSh { float brdf_sh[]; };
layout(std430, set = 0, binding = BINDING_SHADE_X90) readonly buffer X90 { float x90[]; };
layout(set = 0, binding = BINDING_SHADE_SPLIT) uniform sampler2DArray split_chain;
layout(std430, set = 0, binding = BINDING_SHADE_DFG) readonly buffer Dfg { vec2 dfg[]; };
layout(std430, set = 0, binding = BINDING_SHADE_LIGHTS) readonly buffer Lights { vec4 lights[]; };
layout(std430, set = 0, binding = BINDING_SHADE_CAMERA) readonly buffer Cam { vec4 cam[]; };
#define SH_X90(i) x90[i]
#include "sh_rotate.glsl"

// The push block, generated from src/abi/push.rs.
PUSH_ShadePush

layout(location = 0) out vec4 out_color;

vec3 env_lookup(vec3 d) {
    vec3 f = vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d), dot(pc.world_to_file[2].xyz, d));
    Coord c = dir_to_coord(pc.env_mapping, f);
    ivec2 texel = min(ivec2(c.uv * vec2(pc.env_size)), ivec2(pc.env_size) - 1);
    return texelFetch(env, ivec3(texel, int(c.layer)), 0).rgb;
}

bool occluded(vec3 o, vec3 d) {
    for (uint k = 0u; k < pc.count; k++) {
        vec3 n;
        if (object_hit(objects[k], o, d, n) > 0.0) return true;
    }
    return false;
}

vec3 dp_lookup(vec3 d, float lod) {
    return dp_chain_lookup(dp, d, lod, pc.dp_size, pc.max_lod);
}

#include "footprint.glsl"

// Bilinear lookup in a w x w/2 lat-long map stored at pre[off...], wrapping in u.
vec3 prefiltered_lookup(uint off, int w, vec3 d) {
    int h = w / 2;
    Coord c = dir_to_coord(MAPPING_LATLONG, d);
    vec2 p = c.uv * vec2(w, h) - 0.5;
    ivec2 i0 = ivec2(floor(p));
    vec2 t = p - vec2(i0);
    vec3 acc = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        ivec2 q = i0 + ivec2(k & 1, k >> 1);
        q.x += q.x < 0 ? w : (q.x >= w ? -w : 0);  // q.x in [-1, w]; no lane-by-lane remainder
        q.y = clamp(q.y, 0, h - 1);
        float wgt = ((k & 1) == 1 ? t.x : 1.0 - t.x) * ((k >> 1) == 1 ? t.y : 1.0 - t.y);
        acc += wgt * pre[off + uint(q.y * w + q.x)].rgb;
    }
    return acc;
}

#include "light_walk.glsl"

// Whether the scene's shadow rays are traced (and their code kept).
bool shadows_on() {
    return has(SHADOWS_CODE) && pc.shadows != 0u;
}

float brdf_eval_world(Brdf b, vec3 wo, vec3 t, vec3 bt, vec3 n, vec3 d) {
    return brdf_eval_cos(b, wo, vec3(dot(d, t), dot(d, bt), dot(d, n)));
}

// The light texels under the BRDF by their tree (math::light_tree::LightTree::sum_brdf): a
// node taken whole (light_tree_whole) by the BRDF's mean over its four sigma points, other
// leaves' texels one by one (math::lights::light_sum_brdf's rule); with `shadows`, a shadow
// ray along each texel's centre and each sigma point.
vec3 fis_lights(Brdf b, vec3 wo, vec3 t, vec3 bt, vec3 n, vec3 r, float scale, vec3 origin,
                float allowance, bool shadows) {
    vec3 sum = vec3(0.0);
    float fade = BRDF_HORIZON_FADE[b.id];
    Walk k = Walk(0u, 0u, 0u, 0u);
    for (uint step = 0u; step < walk_bound(); step++) {
        bool done = walk_over(k);
        if (walk_done(done)) break;
        if (done) continue;
        mat4x3 d;
        vec4 w;
        vec3 light, centre;
        if (!walk_step(k, r, scale, n, fade, allowance, d, w, light, centre)) continue;
        vec4 f = vec4(brdf_eval_world(b, wo, t, bt, n, d[0]), brdf_eval_world(b, wo, t, bt, n, d[1]),
                      brdf_eval_world(b, wo, t, bt, n, d[2]), brdf_eval_world(b, wo, t, bt, n, d[3]));
        if (shadows) {
            bool texel = centre != vec3(0.0);
            for (uint s = 0u; s < (texel ? 1u : 4u); s++) {
                if (occluded(origin, texel ? centre : d[s])) {
                    if (texel) {
                        w = vec4(0.0);
                    } else {
                        w[s] = 0.0;
                    }
                }
            }
        }
        sum += dot(f, w) * light;
    }
    return sum;
}

vec3 fis(Object ob, vec3 n, vec3 v, vec3 p, uvec2 pix) {
    Brdf b = Brdf(ob.brdf, ob.params[0], ob.params[1]);
    uint count = ob.samples;
    vec3 t, bt;
    shading_frame(n, t, bt);
    vec3 wo = local_view(v, t, bt, n);
    vec2 offset = (ob.flags & OBJECT_ROTATE) != 0u ? pixel_offset(pix) : vec2(0.0);
    vec3 origin = shadow_origin(p, n);
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < count; i++) {
        vec3 wi = brdf_sample(b, wo, rotate_sample(hammersley(i, count), offset));
        if (wi.z <= 0.0) continue;  // below the horizon: no light, still one of the N
        float w = brdf_weight(b, wo, wi);
        float pdf = brdf_pdf(b, wo, wi);
        vec3 d = normalize(t * wi.x + bt * wi.y + n * wi.z);
        float lod = fis_lod(pdf, count, d, pc.dp_size, ob.lod_bias, pc.max_lod);
        if (shadows_on() && occluded(origin, d)) continue;
        sum += w * dp_lookup(d, lod);
    }
    sum /= float(count);
    // With lights extracted the chain holds the residual; the light texels are added by the
    // BRDF itself (math::lights::light_sum_brdf's rule; ob.lobe the lobe's scale).
    // A tree node may err by TREE_BUDGET of the estimate so far (math::light_tree::brdf_slack).
    if ((ob.flags & OBJECT_LIGHTS) != 0u) {
        float allowance = LIGHT_TREE_BUDGET * dot(sum, LUMINANCE) * max(wo.z, ob.lobe);
        sum += fis_lights(b, wo, t, bt, n, 2.0 * dot(v, n) * n - v, ob.lobe, origin, allowance,
                          shadows_on());
    }
    return sum;
}

// Twin of math::sh_brdf::shade.
vec3 sh_brdf(Object ob, vec3 n, vec3 v) {
    uint grid = ob.grid, env_off = ob.data_offset, lmax = ob.size;
    uint table = ob.table_offset, nc = (lmax + 1u) * (lmax + 1u);
    vec3 t, bt;
    shading_frame(n, t, bt);
    vec3 wo = local_view(v, t, bt, n);
    float g = float(grid);
    vec2 p = clamp((wo.xy / (1.0 + wo.z) + 1.0) * 0.5 * g - 0.5, 0.0, g - 1.0);
    uvec2 i0 = min(uvec2(floor(p)), uvec2(max(grid, 2u) - 2u));
    vec2 f = p - vec2(i0);
    uvec2 i1 = min(i0 + 1u, uvec2(grid - 1u));
    uint v00 = table + (i0.y * grid + i0.x) * nc, v10 = table + (i0.y * grid + i1.x) * nc;
    uint v01 = table + (i1.y * grid + i0.x) * nc, v11 = table + (i1.y * grid + i1.x) * nc;
    float c[SH_MAX_COEFFS];
    for (uint k = 0u; k < SH_MAX_COEFFS; k++) {
        c[k] = k < nc ? mix(mix(brdf_sh[v00 + k], brdf_sh[v10 + k], f.x),
                            mix(brdf_sh[v01 + k], brdf_sh[v11 + k], f.x), f.y)
                      : 0.0;
    }
    mat3 frame = mat3(t, bt, n);
    if (pc.sh_rotation == SH_ROTATION_IVANIC) {
        sh_rotate_ivanic(frame, lmax, c);
    } else {
        sh_rotate_zxzxz(frame, lmax, c);
    }
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < nc; k++) sum += c[k] * coeffs[env_off + k].rgb;
    return max(sum, vec3(0.0));
}

// The chain along d at GGX α: lod √α·(levels − 1), ob.last_lod = levels − 1.
vec3 split_chain_read(Object ob, vec3 d, float alpha) {
    Coord c = dir_to_coord(MAPPING_DUAL_PARABOLOID, d);
    return textureLod(split_chain, vec3(c.uv, float(c.layer)), sqrt(clamp(alpha, 0.0, 1.0)) * ob.last_lod).rgb;
}

// Twin of math::split_sum::taps_mean: the chain read by `taps` points of the real GGX lobe
// for (n, v), Hammersley points through the visible-normal sampler, each at
// math::split_sum::tap_alpha, weighted by f·cos/pdf; their weighted mean.
vec3 split_taps(Object ob, vec3 wo, vec3 t, vec3 bt, vec3 n, uint taps) {
    Brdf b = Brdf(ob.brdf, ob.params[0], ob.params[1]);
    vec3 sum = vec3(0.0);
    float total = 0.0;
    for (uint i = 0u; i < taps; i++) {
        vec3 wi = brdf_sample(b, wo, hammersley(i, taps));
        if (wi.z <= 0.0) continue;
        float w = brdf_weight(b, wo, wi);
        float pdf = brdf_pdf(b, wo, wi);
        if (!(pdf > 0.0)) continue;
        float a = min(SPLIT_TAP_SCALE * sqrt(1.0 / (float(taps) * pdf * 4.0 * PI)), 1.0);
        sum += w * split_chain_read(ob, normalize(t * wi.x + bt * wi.y + n * wi.z), a);
        total += w;
    }
    return total > 0.0 ? sum / total : vec3(0.0);
}

// Twin of math::split_sum::shade (one tap) and shade_taps: the prefiltered chain at lod
// √α·(levels − 1) along r, or by the lobe's taps (ob.samples), times A + B (F = 1) read
// bilinearly at (n·v, √α) from the DFG table at ob.data_offset (entries), ob.size a side;
// with lights extracted, the light texels times ob.light_norm = 1/∫K; ob.params[0] = α.
vec3 split_sum(Object ob, vec3 n, vec3 v, vec3 r) {
    float ra = sqrt(clamp(ob.params[0], 0.0, 1.0));
    vec3 t, bt;
    shading_frame(n, t, bt);
    vec3 wo = local_view(v, t, bt, n);
    uint taps = ob.samples;
    float mu = clamp(wo.z, 0.0, 1.0);
    uint off = ob.data_offset, size = ob.size;
    vec2 q = vec2(mu, ra) * float(size - 1u);
    uvec2 i0 = min(uvec2(floor(q)), uvec2(max(size, 2u) - 2u));
    vec2 f = q - vec2(i0);
    uvec2 i1 = min(i0 + 1u, uvec2(size - 1u));
    vec2 ab = mix(mix(dfg[off + i0.y * size + i0.x], dfg[off + i0.y * size + i1.x], f.x),
                  mix(dfg[off + i1.y * size + i0.x], dfg[off + i1.y * size + i1.x], f.x), f.y);
    if (taps >= 2u) {
        vec3 e = split_taps(ob, wo, t, bt, n, taps) * (ab.x + ab.y);
        // Extracted lights under the BRDF itself, as FIS adds them (its allowance rule).
        if ((ob.flags & OBJECT_LIGHTS) != 0u) {
            Brdf b = Brdf(ob.brdf, ob.params[0], ob.params[1]);
            float scale = max(ob.params[0], GGX_ALPHA_MIN);
            float allowance = LIGHT_TREE_BUDGET * dot(e, LUMINANCE) * max(wo.z, scale);
            e += fis_lights(b, wo, t, bt, n, r, scale, vec3(0.0), allowance, false);
        }
        return e;
    }
    vec3 p = split_chain_read(ob, r, ob.params[0]);
    if ((ob.flags & OBJECT_LIGHTS) != 0u) {
        float a = max(ob.params[0], GGX_ALPHA_MIN);
        float a2 = a * a;
        vec3 sum = vec3(0.0);
        // The error a node may make, in the light sum's units: TREE_BUDGET of the chain's.
        float allowance = LIGHT_TREE_BUDGET * dot(p, LUMINANCE) / ob.light_norm;
        Walk k = Walk(0u, 0u, 0u, 0u);
        for (uint step = 0u; step < walk_bound(); step++) {
            bool done = walk_over(k);
            if (walk_done(done)) break;
            if (done) continue;
            mat4x3 d;
            vec4 w;
            vec3 light, centre;
            if (!walk_step(k, r, a, r, LIGHT_KERNEL_FADE, allowance, d, w, light, centre)) continue;
            vec3 e0 = r - d[0], e1 = r - d[1], e2 = r - d[2], e3 = r - d[3];
            vec4 f = vec4(chain_kernel(a2, 0.5 * dot(e0, e0)), chain_kernel(a2, 0.5 * dot(e1, e1)),
                          chain_kernel(a2, 0.5 * dot(e2, e2)), chain_kernel(a2, 0.5 * dot(e3, e3)));
            sum += dot(f, w) * light;
        }
        p += sum * ob.light_norm;
    }
    return p * (ab.x + ab.y);
}

// The light clusters' irradiance at normal n (math::lights::cluster_irradiance): per
// channel max(0, n·V), V = Σ L·Ω·ω over a cell's light texels. The clusters in use are
// counted after the room for pc.clusters (the GPU's extraction fills fewer).
vec3 lights_irradiance(vec3 n) {
    vec3 e = vec3(0.0);
    uint used = min(pc.clusters, uint(lights[pc.cluster_at + pc.clusters * LIGHT_CLUSTER_VEC4S].x));
    for (uint c = 0u; c < used; c++) {
        uint at = pc.cluster_at + c * LIGHT_CLUSTER_VEC4S;
        e += max(vec3(dot(n, lights[at].xyz), dot(n, lights[at + 1u].xyz), dot(n, lights[at + 2u].xyz)), vec3(0.0));
    }
    return e;
}

void main() {
    uvec2 pix = uvec2(gl_FragCoord.xy);
    ivec3 q = ivec3(pix, 0);
    vec4 nrm = texelFetch(gbuf_normal, q, 0);
    vec3 v = texelFetch(gbuf_view, q, 0).xyz;
    if (nrm.w < 0.0) {
        bool filtered = has(FOOTPRINT_CODE) && (pc.footprint & FOOTPRINT_BACKGROUND) != 0u;
        out_color = vec4(filtered ? footprint_radiance(q.xy, -1.0, -v) : env_lookup(-v), 1.0);
        return;
    }
    Object ob = objects[uint(nrm.w)];
    uint tech = ob.technique;
    vec3 n = normalize(nrm.xyz);
    vec3 p = texelFetch(gbuf_position, q, 0).xyz;
    vec3 r = 2.0 * dot(v, n) * n - v;
    vec3 color;
    if (has_tech(TECH_MC) && tech == TECH_MC) {
        color = texelFetch(mc_accum, q, 0).rgb / float(max(pc.mc_samples, 1u));
    } else if (has_tech(TECH_SH) && tech == TECH_SH) {
        float y[SH_MAX_COEFFS];
        uint lmax = ob.size, off = ob.data_offset;
        sh_basis(lmax, n, y);
        vec3 e = vec3(0.0);
        for (uint k = 0u; k < (lmax + 1u) * (lmax + 1u); k++) e += coeffs[off + k].rgb * y[k];
        e = max(e, vec3(0.0));
        // The residual's SH plus the light clusters' irradiance.
        if ((ob.flags & OBJECT_LIGHTS) != 0u) e += lights_irradiance(n);
        color = ob.albedo.rgb * e / PI;
    } else if (has_tech(TECH_PREFILTERED) && tech == TECH_PREFILTERED) {
        bool diffuse = ob.brdf == BRDF_LAMBERT;
        vec3 l = prefiltered_lookup(ob.data_offset, int(ob.size), diffuse ? n : r);
        if ((ob.flags & OBJECT_LIGHTS) != 0u) {
            if (diffuse) {
                // The residual's irradiance map plus the light clusters' irradiance.
                l += lights_irradiance(n);
            } else {
                // The residual's Phong map plus the light texels under the Phong BRDF itself
                // (its horizon clipped, unshadowed as the map is), a node allowed
                // TREE_BUDGET of the map's value (ob.lobe: the lobe's scale, 1/√n).
                Brdf b = Brdf(ob.brdf, ob.params[0], ob.params[1]);
                vec3 t, bt;
                shading_frame(n, t, bt);
                vec3 wo = local_view(v, t, bt, n);
                float allowance = LIGHT_TREE_BUDGET * dot(l, LUMINANCE) * max(wo.z, ob.lobe);
                l += fis_lights(b, wo, t, bt, n, r, ob.lobe, p, allowance, false);
            }
        }
        color = ob.albedo.rgb * (diffuse ? l / PI : l);
    } else if (has_tech(TECH_SPLIT_SUM) && tech == TECH_SPLIT_SUM) {
        color = ob.albedo.rgb * split_sum(ob, n, v, r);
    } else if (has_tech(TECH_SH_BRDF) && tech == TECH_SH_BRDF) {
        color = ob.albedo.rgb * sh_brdf(ob, n, v);
    } else if (tech == TECH_LOOKUP) {
        bool dark = shadows_on() && occluded(shadow_origin(p, n), r);
        bool filtered = has(FOOTPRINT_CODE) && (pc.footprint & FOOTPRINT_MIRROR) != 0u;
        vec3 l = filtered ? footprint_radiance(q.xy, nrm.w, r) : env_lookup(r);
        color = dark ? vec3(0.0) : ob.albedo.rgb * l;
    } else if (has_tech(TECH_FIS) && tech == TECH_FIS) {
        color = ob.albedo.rgb * fis(ob, n, v, p, pix);
    } else {
        color = vec3(0.0);
    }
    out_color = vec4(color, 1.0);
}
