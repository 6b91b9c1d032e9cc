#version 460
// The GPU extraction's light records (passes::extract) prepared for the shade pass's light
// walk (glsl/include/light_walk.glsl), in the layout of math::lights::gpu_list and
// math::light_tree::LightTree::gpu_nodes; the float64 twin is math::lights::prepare_cells and
// math::light_tree::LightTree::implicit over the same order.
//
// The records are ordered by a spatial key (a Morton code over the octahedral map of their
// world directions, ties by texel position, so the order is the same whatever order the
// compaction left them in): a counting sort by the key's top TREE_BUCKET_BITS (KEYS, SCAN,
// SCATTER), then each record's rank within its bucket by counting (TEXELS), where its texel is
// written: its centre turned to the world and its (2·cells)² quadrature nodes
// (math::lights::nodes), and where the output keeps them (pc.coarse_at) its coarser ones
// (math::lights::prepare_local). NODES then builds the tree over that order: leaves of
// LIGHT_LEAF_TEXELS texels, each node over a run of leaves split in halves (the left one
// larger), in pre-order, so node p's range and skip follow from p alone; each node's
// statistics are math::light_tree's (power, luminance-weighted centre, reach, sigma axes),
// summed over its texels. The node after the last ends the walk (its skip is the room).
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "extract.glsl"
#include "lights.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_PREPARE_STATE) readonly buffer State { uint state[]; };
layout(std430, set = 0, binding = BINDING_PREPARE_LIGHTS) readonly buffer Lights { Record records[]; };
layout(std430, set = 0, binding = BINDING_PREPARE_OUT) buffer Out { vec4 prepared[]; };
// Per bucket: counts, first slots, cursors; per record: its key, the records in bucket order.
layout(std430, set = 0, binding = BINDING_PREPARE_SORT) buffer Sort { uint sorted[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ExtractPreparePush

shared uint partial[gl_WorkGroupSize.x];

const uint BUCKETS = 1u << TREE_BUCKET_BITS;

vec3 to_world(vec3 d) {
    return vec3(dot(pc.file_to_world[0].xyz, d), dot(pc.file_to_world[1].xyz, d),
                dot(pc.file_to_world[2].xyz, d));
}

// The texel position's place in (layer, row, column) order.
uint texel_key(uvec4 t) {
    return (t.x * pc.map_size.y + t.z) * pc.map_size.x + t.y;
}

// The key's bits: TREE_KEY_AXIS_BITS a side, interleaved.
const uint KEY_BITS = 2u * TREE_KEY_AXIS_BITS;

// The low TREE_KEY_AXIS_BITS (at most 16) bits of v spread to the even bits.
uint spread(uint v) {
    v &= (1u << TREE_KEY_AXIS_BITS) - 1u;
    v = (v | (v << 8u)) & 0x00ff00ffu;
    v = (v | (v << 4u)) & 0x0f0f0f0fu;
    v = (v | (v << 2u)) & 0x33333333u;
    v = (v | (v << 1u)) & 0x55555555u;
    return v;
}

// Morton code of world direction d on the octahedral map (z folded), KEY_BITS bits.
uint spatial_key(vec3 d) {
    vec2 p = d.xy / (abs(d.x) + abs(d.y) + abs(d.z));
    if (d.z < 0.0) {
        vec2 s = vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
        p = (1.0 - abs(p.yx)) * s;
    }
    float side = float(1u << TREE_KEY_AXIS_BITS);
    uvec2 q = uvec2(clamp((p * 0.5 + 0.5) * side, vec2(0.0), vec2(side - 1.0)));
    return spread(q.x) | (spread(q.y) << 1u);
}

uint kept() {
    return min(state[EXTRACT_WORD_KEPT], pc.max);
}

// Quadrature node (a, b)'s place in its texel, in texel units: two Gauss points a cell each
// way, `cells` cells a side (math::lights::nodes).
vec2 node_offset(uint a, uint b, uint cells) {
    float g = 0.5 / sqrt(3.0);
    vec2 cell = vec2(float(a / 2u), float(b / 2u)) + 0.5;
    vec2 side = vec2(a % 2u == 1u ? g : -g, b % 2u == 1u ? g : -g);
    return (cell + side) / float(cells);
}

// Where node n starts.
uint node_at(uint n) {
    return pc.tree_at + n * LIGHT_TREE_VEC4S;
}

void scan() {
    uint t = gl_LocalInvocationID.x, lanes = gl_WorkGroupSize.x;
    uint chunk = (BUCKETS + lanes - 1u) / lanes;
    uint first = min(t * chunk, BUCKETS), end = min(first + chunk, BUCKETS);
    uint sum = 0u;
    for (uint c = first; c < end; c++) sum += sorted[c];
    partial[t] = sum;
    barrier();
    if (t == 0u) {
        uint run = 0u;
        for (uint k = 0u; k < lanes; k++) {
            uint v = partial[k];
            partial[k] = run;
            run += v;
        }
    }
    barrier();
    uint run = partial[t];
    for (uint c = first; c < end; c++) {
        sorted[BUCKETS + c] = run;
        sorted[2u * BUCKETS + c] = run;
        run += sorted[c];
    }
}

// The (2·cells)² quadrature nodes of the texel at `texel` (layer, column, row; centre `dir`,
// solid angle `omega`) from `at`: each node's world direction and its share of omega by the
// mapping's footprint weight (math::lights::nodes).
void write_nodes(uint at, uvec4 texel, vec3 dir, float omega, uint cells) {
    uint side = 2u * cells;
    float total = 0.0;
    for (uint b = 0u; b < side; b++) {
        for (uint a = 0u; a < side; a++) {
            vec2 uv = (vec2(texel.yz) + node_offset(a, b, cells)) / vec2(pc.map_size);
            total += footprint_weight(pc.mapping, uv);
        }
    }
    for (uint b = 0u; b < side; b++) {
        for (uint a = 0u; a < side; a++) {
            Coord c;
            c.layer = texel.x;
            c.uv = (vec2(texel.yz) + node_offset(a, b, cells)) / vec2(pc.map_size);
            vec4 node = total > 0.0
                ? vec4(to_world(coord_to_dir(pc.mapping, c)), footprint_weight(pc.mapping, c.uv) * omega / total)
                : vec4(dir, omega / float(side * side));
            prepared[at + b * side + a] = node;
        }
    }
}

// Record i's texel, written at its place in the spatial order.
void write_texel(uint i, uint n) {
    Record r = records[i];
    uint keys = TREE_SORT_BUCKET_ARRAYS * BUCKETS, members = keys + pc.max;
    uint key = sorted[keys + i], bucket = key >> (KEY_BITS - TREE_BUCKET_BITS);
    uint own = texel_key(r.texel);
    uint first = sorted[BUCKETS + bucket], count = sorted[bucket];
    uint place = first;
    for (uint s = first; s < first + count; s++) {
        uint j = sorted[members + s];
        uint kj = sorted[keys + j];
        bool before = kj < key || (kj == key && texel_key(records[j].texel) < own);
        place += before ? 1u : 0u;
    }
    vec3 dir = to_world(r.dir_omega.xyz);
    float omega = r.dir_omega.w;
    uint at = place * pc.stride;
    prepared[at] = vec4(dir, omega);
    prepared[at + 1u] = vec4(r.excess_y.rgb, sqrt(omega));
    write_nodes(at + LIGHT_HEADER_VEC4S, r.texel, dir, omega, pc.cells);
    // Its coarser quadratures, coarsest first, where the output keeps them (the lights pass
    // reads them; math::lights::prepare_local).
    if (pc.coarse_at != 0u) {
        uint first = pc.coarse_at + place * coarse_offset(pc.cells);
        for (uint c = 1u; c < pc.cells; c++) {
            write_nodes(first + coarse_offset(c), r.texel, dir, omega, c);
        }
    }
}

// The tangent pair of unit n (glam's DVec3::any_orthonormal_pair, Duff et al. 2017).
void orthonormal_pair(vec3 n, out vec3 t1, out vec3 t2) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    t1 = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    t2 = vec3(b, s + n.y * n.y * a, -n.y);
}

// The tree over n texels ends at node 2·leaves − 1 (0 where there are none).
uint end_node(uint n) {
    uint leaves = (n + LIGHT_LEAF_TEXELS - 1u) / LIGHT_LEAF_TEXELS;
    return leaves == 0u ? 0u : 2u * leaves - 1u;
}

// The end node of the tree over n texels: written by the scan, so that a tree of no texels
// (whose node pass the indirect dispatch starts no workgroup for) has it too.
void write_end_node(uint n) {
    uint at = node_at(end_node(n));
    prepared[at] = vec4(0.0, 0.0, 1.0, 0.0);
    prepared[at + 1u] = vec4(0.0);
    prepared[at + 2u] = vec4(0.0);
    prepared[at + 3u] = vec4(0.0);
    prepared[at + 4u] = vec4(0.0, 0.0, float(pc.tree_room), 0.0);
}

// Node p (below the end node) of the tree over n texels: its range of texels and its
// statistics (math::light_tree's node_of).
void write_node(uint p, uint n) {
    uint leaves = (n + LIGHT_LEAF_TEXELS - 1u) / LIGHT_LEAF_TEXELS;
    uint at = node_at(p);
    // Descend from the root: a node of m leaves has its left child next (⌈m/2⌉ leaves) and
    // its right child after the left's 2⌈m/2⌉ − 1 nodes.
    uint q = 0u, lo = 0u, m = leaves;
    for (uint depth = 0u; depth < 32u && q != p; depth++) {
        uint left = (m + 1u) / 2u;
        if (p < q + 2u * left) {
            q += 1u;
            m = left;
        } else {
            q += 2u * left;
            lo += left;
            m -= left;
        }
    }
    uint first = lo * LIGHT_LEAF_TEXELS, last = min((lo + m) * LIGHT_LEAF_TEXELS, n);
    float total = 0.0;
    for (uint k = first; k < last; k++) {
        vec4 h0 = prepared[k * pc.stride], h1 = prepared[k * pc.stride + 1u];
        total += max(dot(h1.rgb, LUMINANCE), 0.0) * h0.w;
    }
    float count = float(last - first);
    vec3 mean = vec3(0.0), power = vec3(0.0);
    float rho = 0.0;
    for (uint k = first; k < last; k++) {
        vec4 h0 = prepared[k * pc.stride], h1 = prepared[k * pc.stride + 1u];
        float w = total > 0.0 ? max(dot(h1.rgb, LUMINANCE), 0.0) * h0.w / total : 1.0 / count;
        mean += h0.xyz * w;
        power += h1.rgb * h0.w;
        rho = max(rho, h1.w);
    }
    float len = length(mean);
    vec3 centre = len > 0.0 ? mean / len : prepared[first * pc.stride].xyz;
    vec3 t1, t2;
    orthonormal_pair(centre, t1, t2);
    float reach = 0.0, sxx = 0.0, sxy = 0.0, syy = 0.0;
    for (uint k = first; k < last; k++) {
        vec4 h0 = prepared[k * pc.stride], h1 = prepared[k * pc.stride + 1u];
        float w = total > 0.0 ? max(dot(h1.rgb, LUMINANCE), 0.0) * h0.w / total : 1.0 / count;
        vec3 e = h0.xyz - centre;
        reach = max(reach, length(e) + h1.w);
        float x = dot(e, t1), y = dot(e, t2), own = h1.w * h1.w / 12.0;
        sxx += w * (x * x + own);
        syy += w * (y * y + own);
        sxy += w * x * y;
    }
    float half_sum = 0.5 * (sxx + syy);
    float dev = sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
    float l1 = half_sum + dev, l2 = max(half_sum - dev, 0.0);
    float th = 0.5 * atan(2.0 * sxy, sxx - syy);
    vec3 e1 = t1 * cos(th) + t2 * sin(th), e2 = t2 * cos(th) - t1 * sin(th);
    prepared[at] = vec4(centre, reach);
    prepared[at + 1u] = vec4(power, rho);
    prepared[at + 2u] = vec4(e1 * sqrt(2.0 * l1), dot(power, LUMINANCE));
    prepared[at + 3u] = vec4(e2 * sqrt(2.0 * l2), 0.0);
    prepared[at + 4u] = vec4(float(first), float(last - first), float(p + 2u * m - 1u), 0.0);
}

void main() {
    if (pc.mode == PREPARE_MODE_SCAN) {
        scan();
        if (gl_LocalInvocationID.x == 0u) write_end_node(kept());
        return;
    }
    uint i = gl_GlobalInvocationID.x, n = kept();
    if (pc.mode == PREPARE_MODE_NODES) {
        // Dispatched per record: 2·⌈n/LEAF⌉ − 1 nodes below the end never outnumber the
        // 64·⌈n/64⌉ invocations (LEAF ≥ 2).
        if (i < end_node(n)) write_node(i, n);
        return;
    }
    if (i >= n) return;
    uint keys = TREE_SORT_BUCKET_ARRAYS * BUCKETS;
    if (pc.mode == PREPARE_MODE_KEYS) {
        uint key = spatial_key(to_world(records[i].dir_omega.xyz));
        sorted[keys + i] = key;
        atomicAdd(sorted[key >> (KEY_BITS - TREE_BUCKET_BITS)], 1u);
    } else if (pc.mode == PREPARE_MODE_SCATTER) {
        uint bucket = sorted[keys + i] >> (KEY_BITS - TREE_BUCKET_BITS);
        uint slot = atomicAdd(sorted[2u * BUCKETS + bucket], 1u);
        sorted[keys + pc.max + slot] = i;
    } else {
        write_texel(i, n);
    }
}
