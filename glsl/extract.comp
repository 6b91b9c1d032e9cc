#version 460
// Light texels found on the GPU (twin: math::lights::extract without fill; passes::extract).
// The rule is the host's: a texel position holding part of the sphere (its integration
// source's value standing for it) is a light texel when its luminance Y exceeds
// τ = ratio × the mean luminance, raised where needed so that at most `max` pass: the
// threshold is then the luminance of the (max+1)-th brightest, found exactly by a radix select
// over the float bits of Y (positive floats order as their bits): a histogram of the top 16
// bits, the bin the cap falls in, a histogram of that bin's low 16 bits (an indirect dispatch
// of no workgroups where the cap does not bind), the exact key. The mean comes from the SH
// projection's L00 (mean = L00 · Y00), so nothing is read back. A light keeps L·(1 − thr/Y),
// the residual L·thr/Y; texels with a NaN or infinite channel are zero in the residual and
// counted. Records are in no particular order (atomic compaction). Built twice: the per-texel
// steps, and with EXTRACT_SELECT the one-workgroup selects (their barriers and shared memory
// kept out of the per-texel steps).
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"
#include "mappings.glsl"
#include "extract.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
// The map's mapping, specialised per pipeline (the per-texel steps then compile one mapping's
// branches, not four; pc.mapping holds the same id).
layout(constant_id = 2) const uint MAPPING = 0u;
layout(set = 0, binding = BINDING_EXTRACT_MAP) uniform sampler2DArray map_;
layout(std430, set = 0, binding = BINDING_EXTRACT_SH) readonly buffer Sh { float sh[]; };
layout(std430, set = 0, binding = BINDING_EXTRACT_STATE) buffer State { uint state[]; };
layout(std430, set = 0, binding = BINDING_EXTRACT_LIGHTS) writeonly buffer Lights { Record records[]; };
layout(set = 0, binding = BINDING_EXTRACT_RESIDUAL, rgba32f) uniform writeonly image2DArray residual;

// The push block, generated from src/abi/push.rs.
PUSH_ExtractPush

const uint TOP = EXTRACT_HEADER_WORDS;
const uint LOW = EXTRACT_HEADER_WORDS + EXTRACT_TOP_BINS;
const uint NO_BIN = 0xffffffffu;
// Y00 = K00 (the generated SH_K table).


// τ, or +inf where the mean is not positive and finite (nothing is a light).
float tau() {
    float mean = dot(LUMINANCE, vec3(sh[0], sh[1], sh[2])) * SH_K[0];
    float t = pc.ratio * mean;
    return (t > 0.0 && !isinf(t)) ? t : FLOAT_INF;
}

// The value standing for texel position p of layer `layer` and whether p holds part of the
// sphere; `own`: p is its own source (the residual keeps a light's clamp there).
bool source_value(ivec2 p, uint layer, out vec3 l, out bool own) {
    ivec2 s = integration_source(MAPPING, pc.size, p);
    own = s == p;
    if (s.x < 0) return false;
    l = texelFetch(map_, ivec3(s, layer), 0).rgb;
    return true;
}

// The luminance of a value counted in the extraction: 0 where not finite.
float lum(vec3 l) {
    return finite3(l) ? dot(LUMINANCE, l) : 0.0;
}

// Per texel: the histograms (HISTOGRAM, HISTOGRAM_LOW) or the records and residual (COMPACT).
void per_texel() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.size)) || id.z >= mapping_layers(MAPPING)) return;
    ivec2 p = ivec2(id.xy);
    vec3 l = vec3(0.0);
    bool own;
    bool counted = source_value(p, id.z, l, own);
    bool good = finite3(l);
    float y = counted ? lum(l) : 0.0;
    float t = tau();
    if (pc.mode == EXTRACT_MODE_HISTOGRAM) {
        if (id == uvec3(0u)) state[EXTRACT_WORD_TAU] = floatBitsToUint(t);
        if (counted && own && !good) atomicAdd(state[EXTRACT_WORD_NONFINITE], 1u);
        if (y > t) {
            atomicAdd(state[EXTRACT_WORD_CANDIDATES], 1u);
            atomicAdd(state[TOP + (floatBitsToUint(y) >> 16)], 1u);
        }
        return;
    }
    if (pc.mode == EXTRACT_MODE_HISTOGRAM_LOW) {
        uint key = floatBitsToUint(y);
        if (y > t && (key >> 16) == state[EXTRACT_WORD_BIN]) {
            atomicAdd(state[LOW + (key & 0xffffu)], 1u);
        }
        return;
    }
    float thr = uintBitsToFloat(state[EXTRACT_WORD_THRESHOLD]);
    vec3 kept = good ? l : vec3(0.0);
    if (y > thr && y > t) {
        vec3 r = l * (thr / y);
        if (own) kept = r;
        uint k = atomicAdd(state[EXTRACT_WORD_COUNTER], 1u);
        if (k < pc.max) {
            vec2 uv = (vec2(p) + 0.5) / vec2(pc.size);
            vec3 dir = coord_to_dir(MAPPING, Coord(id.z, uv));
            float omega = texel_solid_angle(MAPPING, pc.size, p);
            records[k].dir_omega = vec4(dir, omega);
            records[k].excess_y = vec4(l - r, y);
            records[k].texel = uvec4(id.z, id.xy, 0u);
            atomicMax(state[EXTRACT_WORD_OMEGA_MAX], floatBitsToUint(omega));
        }
    }
    if (!own) {
        // A rim or caption texel: stored as is (finite), its value stands elsewhere.
        vec3 v = texelFetch(map_, ivec3(p, id.z), 0).rgb;
        kept = finite3(v) ? v : vec3(0.0);
    }
    imageStore(residual, ivec3(p, id.z), vec4(kept, 1.0));
}

#ifdef EXTRACT_SELECT
shared uint chunk_sums[gl_WorkGroupSize.x * gl_WorkGroupSize.y];

// One workgroup: the bin, from the top of `bins` bins at `base`, where the running count from
// the top first exceeds `target`; `above` the count in the bins above it.
uint select_bin(uint base, uint bins, uint target, out uint above) {
    uint n = gl_WorkGroupSize.x * gl_WorkGroupSize.y;
    uint t = gl_LocalInvocationIndex;
    uint per = bins / n;
    uint hi = bins - t * per;
    uint sum = 0u;
    for (uint b = hi - per; b < hi; b++) sum += state[base + b];
    chunk_sums[t] = sum;
    barrier();
    above = 0u;
    uint found = NO_BIN;
    if (t == 0u) {
        uint acc = 0u;
        for (uint c = 0u; c < n && found == NO_BIN; c++) {
            if (acc + chunk_sums[c] > target) {
                uint top = bins - c * per;
                for (uint b = top; b > top - per; b--) {
                    uint h = state[base + b - 1u];
                    if (acc + h > target) {
                        found = b - 1u;
                        break;
                    }
                    acc += h;
                }
            } else {
                acc += chunk_sums[c];
            }
        }
        above = acc;
    }
    return found;
}

void write_light_args(uint kept) {
    state[EXTRACT_WORD_KEPT] = kept;
    state[EXTRACT_WORD_LIGHT_ARGS] = (kept + EXTRACT_LIGHT_GROUP - 1u) / EXTRACT_LIGHT_GROUP;
    state[EXTRACT_WORD_LIGHT_ARGS + 1u] = 1u;
    state[EXTRACT_WORD_LIGHT_ARGS + 2u] = 1u;
}

void select_top() {
    uint total = state[EXTRACT_WORD_CANDIDATES];
    bool binds = total > pc.max;
    uint above;
    uint b = binds ? select_bin(TOP, EXTRACT_TOP_BINS, pc.max, above) : NO_BIN;
    if (gl_LocalInvocationIndex != 0u) return;
    state[EXTRACT_WORD_BIN] = b;
    uvec3 groups = uvec3((pc.size + gl_WorkGroupSize.xy - 1u) / gl_WorkGroupSize.xy,
                         mapping_layers(pc.mapping));
    state[EXTRACT_WORD_LOW_ARGS] = binds ? groups.x : 0u;
    state[EXTRACT_WORD_LOW_ARGS + 1u] = groups.y;
    state[EXTRACT_WORD_LOW_ARGS + 2u] = groups.z;
    if (binds) {
        state[EXTRACT_WORD_RANK] = pc.max - above;
        // Texels of the bins above; the low select adds those above the threshold in b.
        state[EXTRACT_WORD_KEPT] = above;
    } else {
        state[EXTRACT_WORD_THRESHOLD] = floatBitsToUint(tau());
        write_light_args(total);
    }
}

void select_low() {
    uint b = state[EXTRACT_WORD_BIN];
    if (b == NO_BIN) return;
    uint above;
    uint lb = select_bin(LOW, EXTRACT_LOW_BINS, state[EXTRACT_WORD_RANK], above);
    if (gl_LocalInvocationIndex != 0u) return;
    state[EXTRACT_WORD_THRESHOLD] = (b << 16) | lb;
    write_light_args(state[EXTRACT_WORD_KEPT] + above);
}

#endif

void main() {
#ifdef EXTRACT_SELECT
    if (pc.mode == EXTRACT_MODE_SELECT_TOP) {
        select_top();
    } else {
        select_low();
    }
#else
    per_texel();
#endif
}
