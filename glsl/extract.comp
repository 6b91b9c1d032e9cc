#version 460
// Light texels found on the GPU (twin: math::lights::extract; passes::extract).
// The rule is the host's: a texel position holding part of the sphere (its integration
// source's value standing for it) is a light texel when its luminance Y exceeds
// τ = ratio × the mean luminance, raised where needed so that at most `max` pass: the
// threshold is then the luminance of the (max+1)-th brightest, found exactly by a radix select
// over the float bits of Y (positive floats order as their bits): a histogram of the top 16
// bits, the bin the cap falls in, a histogram of that bin's low 16 bits (an indirect dispatch
// of no workgroups where the cap does not bind), the exact key. The mean comes from the SH
// projection's L00 (mean = L00 · Y00), so nothing is read back. Clamped (FILLED 0), a light
// keeps L·(1 − thr/Y), the residual L·thr/Y. Filled (FILLED 1, the host's `fill`), the texels
// above the threshold that are their own source form ring 0 of a light set, which grows by
// rings of their 8 neighbours (positive, holding the sphere, same layer, a lat-long wrapping in
// u) while the cap has room for each ring's records whole; the residual luminance under the
// set is filled round by round from its edge inwards (each texel the mean of its settled edge
// neighbours; texels no round reaches take the threshold), at most the texel's own and the
// threshold, chroma kept; every position reading a member whose value exceeds that residual
// is a light holding the excess. Texels with a NaN or infinite channel are zero in the
// residual and counted. Records are in no particular order (atomic compaction). Built three
// times: the per-texel steps; with EXTRACT_SELECT the one-workgroup ones (the selects, the
// decision on the rings, the fill's rounds: their barriers and shared memory kept out of the
// per-texel steps); with EXTRACT_GROW the steps over lists (ring 0 from the listed candidates,
// the rings grown), kept out of the per-texel module: llvmpipe compiles a module's every
// branch into each dispatch, and the loops slow the per-texel passes several times over.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"
#include "mappings.glsl"
#include "extract.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
// The map's mapping, specialised per pipeline (the per-texel steps then compile one mapping's
// branches, not four; pc.mapping holds the same id).
layout(constant_id = 2) const uint MAPPING = 0u;
// Whether the extraction is filled, specialised per pipeline too, so that a clamped one's
// per-texel steps carry none of the fill's branches (pc.fill holds the same).
layout(constant_id = 3) const uint FILLED = 0u;
layout(set = 0, binding = BINDING_EXTRACT_MAP) uniform sampler2DArray map_;
layout(std430, set = 0, binding = BINDING_EXTRACT_SH) readonly buffer Sh { float sh[]; };
layout(std430, set = 0, binding = BINDING_EXTRACT_STATE) buffer State { uint state[]; };
layout(std430, set = 0, binding = BINDING_EXTRACT_LIGHTS) writeonly buffer Lights { Record records[]; };
layout(set = 0, binding = BINDING_EXTRACT_RESIDUAL, rgba32f) uniform writeonly image2DArray residual;
// A filled extraction's light set: a label per texel (NONE, or its ring above its slot in the
// low FILL_SLOT_BITS), then FILL_SLOT_ARRAYS arrays of a word per slot: its texel's index,
// its filled luminance's bits (UNSET until a round settles it), the round's next value, and
// the candidate HISTOGRAM listed there.
layout(std430, set = 0, binding = BINDING_EXTRACT_FILL) coherent buffer Fill { uint fill_[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ExtractPush

const uint TOP = EXTRACT_HEADER_WORDS;
const uint LOW = EXTRACT_HEADER_WORDS + EXTRACT_TOP_BINS;
const uint NO_BIN = 0xffffffffu;
const uint NONE = 0xffffffffu;
const uint UNSET = 0xffffffffu;
// A member's slot where its ring ran past the cap and stopped being listed.
const uint UNLISTED = (1u << FILL_SLOT_BITS) - 1u;

// The mapping: specialised in the per-texel steps, from the push block in the selects.
#ifdef EXTRACT_SELECT
#define MAP_ID pc.mapping
#else
#define MAP_ID MAPPING
#endif
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

// Texels of the map, and the fill buffer's arrays after the labels.
uint map_texels() {
    return pc.size.x * pc.size.y * mapping_layers(MAP_ID);
}
uint slot_texel_at() { return map_texels(); }
uint value_at() { return map_texels() + pc.max; }
uint next_at() { return map_texels() + 2u * pc.max; }
uint candidates_at() { return map_texels() + 3u * pc.max; }

uint index_of(ivec2 p, uint layer) {
    return (layer * pc.size.y + uint(p.y)) * pc.size.x + uint(p.x);
}

// (i, j, layer) of texel index k.
ivec3 texel_of(uint k) {
    uint w = pc.size.x, h = pc.size.y;
    return ivec3(int(k % w), int(k / w % h), int(k / (w * h)));
}

// The neighbour of t at d in its layer (a lat-long wraps in u); false outside the layer.
bool step_to(ivec3 t, ivec2 d, out ivec2 q) {
    q = t.xy + d;
    int w = int(pc.size.x);
    if (MAP_ID == MAPPING_LATLONG) q.x = (q.x + w) % w;
    return all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(pc.size)));
}

// The luminance of stored texel q where it is its own integration source and finite (the
// host's y; false elsewhere).
bool own_luminance(ivec2 q, uint layer, out float y) {
    y = 0.0;
    if (integration_source(MAP_ID, pc.size, q) != q) return false;
    vec3 l = texelFetch(map_, ivec3(q, layer), 0).rgb;
    y = dot(LUMINANCE, l);
    return finite3(l);
}

// The slot of an accepted member's label (ring at most `grown`, listed), or NONE.
uint accepted_slot(uint label, uint grown) {
    if (label == NONE || (label >> FILL_SLOT_BITS) > grown) return NONE;
    uint slot = label & UNLISTED;
    return slot == UNLISTED ? NONE : slot;
}

// Lists texel k as a member of ring `ring` (claimed by the caller) in the next slot.
void list_member(uint k, uint ring) {
    uint slot = atomicAdd(state[EXTRACT_WORD_MEMBERS], 1u);
    atomicAdd(state[EXTRACT_WORD_RING_COUNT + ring], 1u);
    if (slot >= pc.max) return;
    fill_[slot_texel_at() + slot] = k;
    fill_[value_at() + slot] = UNSET;
    fill_[k] = (ring << FILL_SLOT_BITS) | slot;
}

// RING: the members of ring pc.grow − 1 (its run of slots, a grid-stride loop over a few
// workgroups) list their neighbours in ring pc.grow.
void grow_from(uint k0, uint ring);

void grow_ring() {
    uint ring = pc.grow;
    uint id = gl_WorkGroupID.x * (gl_WorkGroupSize.x * gl_WorkGroupSize.y) + gl_LocalInvocationIndex;
    uint before = 0u;
    for (uint r = 0u; r + 1u < ring; r++) before += state[EXTRACT_WORD_RING_COUNT + r];
    uint n = state[EXTRACT_WORD_RING_COUNT + ring - 1u];
    // A ring listed only in part ran past the cap: no ring grows from it.
    if (before + n > pc.max) return;
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x * gl_WorkGroupSize.y;
    for (uint slot = id; slot < n; slot += stride) grow_from(fill_[slot_texel_at() + before + slot], ring);
}

// MARK_LIST: candidate `id` (listed by HISTOGRAM where the cap does not bind) joins ring 0
// where it is its own source and above the threshold.
void mark_listed() {
    uint id = gl_WorkGroupID.x * (gl_WorkGroupSize.x * gl_WorkGroupSize.y) + gl_LocalInvocationIndex;
    if (id >= min(state[EXTRACT_WORD_CANDIDATES], pc.max)) return;
    uint k = fill_[candidates_at() + id];
    ivec3 t = texel_of(k);
    vec3 l = vec3(0.0);
    bool own;
    bool counted = source_value(t.xy, uint(t.z), l, own);
    float y = counted ? lum(l) : 0.0;
    float thr = uintBitsToFloat(state[EXTRACT_WORD_THRESHOLD]);
    if (counted && own && y > thr && y > tau()) list_member(k, 0u);
}

// Lists the neighbours of texel k that join ring `ring`.
void grow_from(uint k0, uint ring) {
    ivec3 t = texel_of(k0);
    for (int dj = -1; dj <= 1; dj++) {
        for (int di = -1; di <= 1; di++) {
            ivec2 q;
            float y;
            if ((di == 0 && dj == 0) || !step_to(t, ivec2(di, dj), q)) continue;
            if (!own_luminance(q, uint(t.z), y) || !(y > 0.0)) continue;
            uint k = index_of(q, uint(t.z));
            if (atomicCompSwap(fill_[k], NONE, (ring << FILL_SLOT_BITS) | UNLISTED) == NONE) {
                list_member(k, ring);
            }
        }
    }
}

// Per texel: the histograms (HISTOGRAM, HISTOGRAM_LOW), ring 0 (MARK), the rims (RIMS) or the
// records and residual (COMPACT; a clamped extraction's HISTOGRAM too, at τ).
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
            uint k = atomicAdd(state[EXTRACT_WORD_CANDIDATES], 1u);
            atomicAdd(state[TOP + (floatBitsToUint(y) >> 16)], 1u);
            // A filled extraction lists the candidates while they fit the cap, so that ring 0
            // is found among them, not by another pass over the map.
            if (FILLED != 0u && k < pc.max) fill_[candidates_at() + k] = index_of(p, id.z);
        }
        // A clamped extraction goes on to write its records and residual at τ, the threshold
        // wherever the cap does not bind: the COMPACT pass over the map then runs (an
        // indirect dispatch, select_top's) only where it binds, and rewrites them all.
        if (FILLED != 0u) return;
    }
    if (pc.mode == EXTRACT_MODE_HISTOGRAM_LOW) {
        uint key = floatBitsToUint(y);
        if (y > t && (key >> 16) == state[EXTRACT_WORD_BIN]) {
            atomicAdd(state[LOW + (key & 0xffffu)], 1u);
        }
        return;
    }
    float thr = pc.mode == EXTRACT_MODE_HISTOGRAM ? t : uintBitsToFloat(state[EXTRACT_WORD_THRESHOLD]);
    if (pc.mode == EXTRACT_MODE_MARK) {
        if (counted && own && y > thr && y > t) list_member(index_of(p, id.z), 0u);
        return;
    }
    if (pc.mode == EXTRACT_MODE_RIMS) {
        ivec2 s = integration_source(MAPPING, pc.size, p);
        if (s.x < 0 || own) return;
        uint label = fill_[index_of(s, id.z)];
        if (label != NONE) atomicAdd(state[EXTRACT_WORD_RIMS + (label >> FILL_SLOT_BITS)], 1u);
        return;
    }
    vec3 kept = good ? l : vec3(0.0);
    bool light = y > thr && y > t;
    vec3 r = l * (thr / y);
    if (FILLED != 0u) {
        // A member's residual: its filled luminance, at most the threshold and its own.
        uint slot = NONE;
        if (counted && y > 0.0) {
            ivec2 s = integration_source(MAPPING, pc.size, p);
            slot = accepted_slot(fill_[index_of(s, id.z)], state[EXTRACT_WORD_GROWN]);
        }
        light = false;
        if (slot != NONE) {
            uint v = fill_[value_at() + slot];
            float c = v == UNSET ? thr : min(uintBitsToFloat(v), thr);
            r = l * (min(c, y) / y);
            light = any(notEqual(l - r, vec3(0.0)));
        }
    }
    if (light) {
        if (own) kept = r;
        uint k = atomicAdd(state[EXTRACT_WORD_COUNTER], 1u);
        if (k < pc.max && FILLED != 0u) {
            // The count and the records' indirect arguments, as records are written.
            atomicAdd(state[EXTRACT_WORD_KEPT], 1u);
            atomicMax(state[EXTRACT_WORD_LIGHT_ARGS], k / EXTRACT_LIGHT_GROUP + 1u);
        }
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
    // Ring 0 of a filled extraction: from the listed candidates where the cap does not bind
    // (all of them listed), else from every texel.
    uint listed = (total + gl_WorkGroupSize.x * gl_WorkGroupSize.y - 1u) / (gl_WorkGroupSize.x * gl_WorkGroupSize.y);
    state[EXTRACT_WORD_MARK_LIST_ARGS] = binds ? 0u : listed;
    state[EXTRACT_WORD_MARK_LIST_ARGS + 1u] = 1u;
    state[EXTRACT_WORD_MARK_LIST_ARGS + 2u] = 1u;
    state[EXTRACT_WORD_MARK_ARGS] = binds ? groups.x : 0u;
    state[EXTRACT_WORD_MARK_ARGS + 1u] = groups.y;
    state[EXTRACT_WORD_MARK_ARGS + 2u] = groups.z;
    // A clamped extraction's compaction, and the records HISTOGRAM wrote at τ discarded.
    state[EXTRACT_WORD_COMPACT_ARGS] = binds ? groups.x : 0u;
    state[EXTRACT_WORD_COMPACT_ARGS + 1u] = groups.y;
    state[EXTRACT_WORD_COMPACT_ARGS + 2u] = groups.z;
    if (binds) {
        state[EXTRACT_WORD_COUNTER] = 0u;
        state[EXTRACT_WORD_OMEGA_MAX] = 0u;
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

// DECIDE: the rings (up to pc.grow) whose records, with those before them, the cap has room
// for; the members they hold; the record count and its arguments restarted for the
// compaction to count.
void decide() {
    if (gl_LocalInvocationIndex != 0u) return;
    uint total = state[EXTRACT_WORD_RING_COUNT] + state[EXTRACT_WORD_RIMS];
    uint grown = 0u;
    for (uint k = 1u; k <= pc.grow; k++) {
        uint add = state[EXTRACT_WORD_RING_COUNT + k] + state[EXTRACT_WORD_RIMS + k];
        if (total + add > pc.max) break;
        total += add;
        grown = k;
    }
    uint members = 0u;
    for (uint k = 0u; k <= grown; k++) members += state[EXTRACT_WORD_RING_COUNT + k];
    state[EXTRACT_WORD_GROWN] = grown;
    state[EXTRACT_WORD_ACCEPTED] = members;
    write_light_args(0u);
    state[EXTRACT_WORD_LIGHT_ARGS] = 0u;
}

// The value a fill round reads at q: an accepted member's filled luminance once settled, a
// texel outside the set its own luminance; false where there is none.
bool fill_value(ivec2 q, uint layer, uint grown, out float v) {
    v = 0.0;
    uint slot = accepted_slot(fill_[index_of(q, layer)], grown);
    if (slot == NONE) return own_luminance(q, layer, v);
    uint bits = fill_[value_at() + slot];
    v = uintBitsToFloat(bits);
    return bits != UNSET;
}

shared uint settled_any;

// FILL: rounds until none settles; in each, every unsettled member with a settled edge
// neighbour takes their mean (all read before any is written), as the host's `fill`.
void fill_rounds() {
    uint n = state[EXTRACT_WORD_ACCEPTED];
    uint grown = state[EXTRACT_WORD_GROWN];
    uint t = gl_LocalInvocationIndex;
    uint stride = gl_WorkGroupSize.x * gl_WorkGroupSize.y;
    const ivec2 EDGE[4] = ivec2[4](ivec2(0, -1), ivec2(-1, 0), ivec2(1, 0), ivec2(0, 1));
    uint rounds = 0u;
    // At most one round per member, plus the last that settles none.
    for (uint round = 0u; round <= n; round++) {
        if (t == 0u) settled_any = 0u;
        for (uint s = t; s < n; s += stride) {
            uint next = UNSET;
            if (fill_[value_at() + s] == UNSET) {
                ivec3 tx = texel_of(fill_[slot_texel_at() + s]);
                float sum = 0.0;
                uint count = 0u;
                for (int e = 0; e < 4; e++) {
                    ivec2 q;
                    float v;
                    if (step_to(tx, EDGE[e], q) && fill_value(q, uint(tx.z), grown, v)) {
                        sum += v;
                        count++;
                    }
                }
                if (count > 0u) next = floatBitsToUint(sum / float(count));
            }
            fill_[next_at() + s] = next;
        }
        memoryBarrierBuffer();
        memoryBarrierShared();
        barrier();
        for (uint s = t; s < n; s += stride) {
            uint next = fill_[next_at() + s];
            if (next != UNSET) {
                fill_[value_at() + s] = next;
                settled_any = 1u;
            }
        }
        memoryBarrierBuffer();
        memoryBarrierShared();
        barrier();
        rounds++;
        bool done = settled_any == 0u;
        barrier();
        if (done) break;
    }
    if (t == 0u) state[EXTRACT_WORD_ROUNDS] = rounds;
}

#endif

void main() {
#ifdef EXTRACT_SELECT
    if (pc.mode == EXTRACT_MODE_SELECT_TOP) {
        select_top();
    } else if (pc.mode == EXTRACT_MODE_SELECT_LOW) {
        select_low();
    } else if (pc.mode == EXTRACT_MODE_DECIDE) {
        decide();
    } else {
        fill_rounds();
    }
#elif defined(EXTRACT_GROW)
    if (pc.mode == EXTRACT_MODE_RING) {
        grow_ring();
    } else {
        mark_listed();
    }
#else
    per_texel();
#endif
}
