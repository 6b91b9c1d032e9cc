#version 460
// The GPU extraction's light records (passes::extract) gathered into the clusters diffuse
// techniques sum (math::lights::clusters, its float64 twin): the cells of a grid × grid/2
// lat-long grid over the records' file directions, each holding per channel V = Σ L·Ω·ω (ω
// turned to the world) over its records, as CLUSTER_VEC4S vec4s (V, 0) from vec4 `at` of the
// output: the non-empty cells only, in row-major order (the host's), their count after the
// grid's room (vec4 at + 3·cells, in x), which bounds the shade pass's loop. A counting sort,
// the record count read from the extraction's header: COUNT (per record: its cell, counted),
// SCAN (one workgroup: each cell's first slot and its place among the non-empty cells),
// SCATTER (per record: its slot), SUM (per non-empty cell: its records summed).
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "extract.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_CLUSTERS_STATE) readonly buffer State { uint state[]; };
layout(std430, set = 0, binding = BINDING_CLUSTERS_LIGHTS) readonly buffer Lights { Record records[]; };
// cells' counts, first slots, cursors and places among the non-empty cells (grid·grid/2
// each: CLUSTER_SORT_CELL_ARRAYS), then each record's cell and the records in cell order
// (max each).
layout(std430, set = 0, binding = BINDING_CLUSTERS_SORT) buffer Sort { uint sorted[]; };
layout(std430, set = 0, binding = BINDING_CLUSTERS_OUT) writeonly buffer Out { vec4 clusters[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ExtractClustersPush

shared uint partial[gl_WorkGroupSize.x];
shared uint partial_used[gl_WorkGroupSize.x];

uint cells() {
    return pc.grid * max(pc.grid / 2u, 1u);
}

// The row-major cell of file direction d (math::lights::clusters' rule).
uint cell_of(vec3 d) {
    uint rows = max(pc.grid / 2u, 1u);
    vec2 uv = dir_to_coord(MAPPING_LATLONG, d).uv;
    uint col = min(uint(max(floor(uv.x * float(pc.grid)), 0.0)), pc.grid - 1u);
    uint row = min(uint(max(floor(uv.y * float(rows)), 0.0)), rows - 1u);
    return row * pc.grid + col;
}

vec3 to_world(vec3 d) {
    return vec3(dot(pc.file_to_world[0].xyz, d), dot(pc.file_to_world[1].xyz, d),
                dot(pc.file_to_world[2].xyz, d));
}

void scan() {
    uint n = cells(), t = gl_LocalInvocationID.x, lanes = gl_WorkGroupSize.x;
    uint chunk = (n + lanes - 1u) / lanes;
    uint first = min(t * chunk, n), end = min(first + chunk, n);
    uint sum = 0u, used = 0u;
    for (uint c = first; c < end; c++) {
        sum += sorted[c];
        used += sorted[c] > 0u ? 1u : 0u;
    }
    partial[t] = sum;
    partial_used[t] = used;
    barrier();
    // Exclusive scans of the lanes' sums, one lane (64 values each).
    if (t == 0u) {
        uint run = 0u, places = 0u;
        for (uint k = 0u; k < lanes; k++) {
            uint v = partial[k], u = partial_used[k];
            partial[k] = run;
            partial_used[k] = places;
            run += v;
            places += u;
        }
        clusters[pc.at + LIGHT_CLUSTER_VEC4S * n] = vec4(float(places), 0.0, 0.0, 0.0);
    }
    barrier();
    uint run = partial[t], place = partial_used[t];
    for (uint c = first; c < end; c++) {
        sorted[n + c] = run;
        sorted[2u * n + c] = run;
        sorted[3u * n + c] = place;
        run += sorted[c];
        place += sorted[c] > 0u ? 1u : 0u;
    }
}

void main() {
    uint n = cells();
    if (pc.mode == CLUSTERS_MODE_SCAN) {
        scan();
        return;
    }
    uint i = gl_GlobalInvocationID.x;
    if (pc.mode == CLUSTERS_MODE_SUM) {
        if (i >= n || sorted[i] == 0u) return;
        vec3 v[3] = vec3[3](vec3(0.0), vec3(0.0), vec3(0.0));
        uint first = sorted[n + i], count = sorted[i];
        for (uint s = first; s < first + count; s++) {
            Record r = records[sorted[CLUSTER_SORT_CELL_ARRAYS * n + pc.max + s]];
            vec3 w = to_world(r.dir_omega.xyz) * r.dir_omega.w;
            v[0] += w * r.excess_y.r;
            v[1] += w * r.excess_y.g;
            v[2] += w * r.excess_y.b;
        }
        uint place = sorted[3u * n + i];
        for (uint ch = 0u; ch < 3u; ch++) clusters[pc.at + LIGHT_CLUSTER_VEC4S * place + ch] = vec4(v[ch], 0.0);
        return;
    }
    if (i >= min(state[EXTRACT_WORD_KEPT], pc.max)) return;
    if (pc.mode == CLUSTERS_MODE_COUNT) {
        uint c = cell_of(records[i].dir_omega.xyz);
        sorted[CLUSTER_SORT_CELL_ARRAYS * n + i] = c;
        atomicAdd(sorted[c], 1u);
    } else {
        uint c = sorted[CLUSTER_SORT_CELL_ARRAYS * n + i];
        uint slot = atomicAdd(sorted[2u * n + c], 1u);
        sorted[CLUSTER_SORT_CELL_ARRAYS * n + pc.max + slot] = i;
    }
}
