#version 460
// Brute-force convolution of a whole map with the clamped cosine or a normalised Phong lobe
// (Miller & Hoffman 1984), the float64 twin being src/math/filter.rs. Built twice:
// - PREPARE: one invocation per source texel writes its centre direction (world), the cosine of
//   its angular radius, its radiance and its exact solid angle (0 where it holds no sphere);
// - TILES: one invocation per tile of BRUTE_TILE² source texels writes a cone bounding all
//   its texels' cones (w = 2 when it holds none);
// - otherwise: one invocation per output texel sums L·∫K over every source texel, choosing per
//   texel the same rule as the CPU (skip, centre node, or s×s cells of 3×3 Gauss points), with
//   Kahan compensation so a sun 1e5 times the sky does not swamp the sum. The source is taken
//   in chunks, one dispatch each, accumulating into dst (and the compensation buffer), so that
//   no invocation runs more loop iterations than llvmpipe allows (DeviceInfo::
//   loop_iteration_limit); the node loops are unrolled for the same reason. Texels are
//   walked tile by tile ("slots": tile-major, BRUTE_TILE² per tile, the chunks count slots),
//   and a tile whose cone lies wholly where the rule skips texels is skipped whole: every
//   texel in it would have been skipped, so the sum is the same, term for term.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

#if defined(TILES)
layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_BRUTE_TILE_CONES) readonly buffer Cones { vec4 cones[]; };
layout(std430, set = 0, binding = BINDING_BRUTE_TILE_OUT) writeonly buffer Tiles { vec4 tiles[]; };
#elif defined(PREPARE)
layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_PREP_SRC) uniform sampler2DArray src;
layout(std430, set = 0, binding = BINDING_BRUTE_PREP_CONES) writeonly buffer Cones { vec4 cones[]; };
layout(std430, set = 0, binding = BINDING_BRUTE_PREP_RADIANCE) writeonly buffer Rad { vec4 rad[]; };
#else
layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_BRUTE_CONES) readonly buffer Cones { vec4 cones[]; };
layout(std430, set = 0, binding = BINDING_BRUTE_RADIANCE) readonly buffer Rad { vec4 rad[]; };
layout(set = 0, binding = BINDING_BRUTE_DST, rgba32f) uniform image2DArray dst;
layout(std430, set = 0, binding = BINDING_BRUTE_COMP) buffer Comp { vec4 comp_buf[]; };
layout(std430, set = 0, binding = BINDING_BRUTE_TILES) readonly buffer Tiles { vec4 tiles[]; };
#endif

// The push block, generated from src/abi.rs.
PUSH_BrutePush

vec3 to_world(vec3 f) {
    return vec3(dot(pc.file_to_world[0].xyz, f), dot(pc.file_to_world[1].xyz, f), dot(pc.file_to_world[2].xyz, f));
}

vec3 src_dir(uint layer, vec2 uv) {
    Coord c;
    c.layer = layer;
    c.uv = uv;
    return to_world(coord_to_dir(pc.src_mapping, c));
}

bool rim_cut(ivec2 p) {
    if (pc.src_mapping != MAPPING_ANGULAR && pc.src_mapping != MAPPING_DUAL_PARABOLOID) return false;
    vec2 lo = 2.0 * vec2(p) / vec2(pc.src_size) - 1.0;
    vec2 hi = 2.0 * vec2(p + 1) / vec2(pc.src_size) - 1.0;
    vec2 f = max(abs(lo), abs(hi));
    return dot(f, f) > 1.0;
}

// Tiles per row and per layer of the source.
uvec2 tile_grid() {
    return (pc.src_size + BRUTE_TILE - 1u) / BRUTE_TILE;
}

// The texel in slot s of tile `tile`, or -1 where the tile overhangs the map's edge.
int slot_texel(uint tile, uint s) {
    uvec2 g = tile_grid();
    uint per_layer = g.x * g.y;
    uint layer = tile / per_layer, r = tile % per_layer;
    uvec2 q = uvec2(r % g.x, r / g.x) * BRUTE_TILE + uvec2(s % BRUTE_TILE, s / BRUTE_TILE);
    if (any(greaterThanEqual(q, pc.src_size))) return -1;
    return int((layer * pc.src_size.y + q.y) * pc.src_size.x + q.x);
}

#if defined(TILES)
void main() {
    uint tile = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    uvec2 g = tile_grid();
    if (tile >= g.x * g.y * pc.src_layers) return;
    // Axis: the mean of the texel centres; radius: the farthest texel cone edge from it.
    vec3 sum = vec3(0.0);
    for (uint s = 0u; s < BRUTE_TILE * BRUTE_TILE; s++) {
        int t = slot_texel(tile, s);
        if (t >= 0 && cones[t].w <= 1.0) sum += cones[t].xyz;
    }
    if (dot(sum, sum) == 0.0) {
        tiles[tile] = vec4(0.0, 0.0, 1.0, 2.0);
        return;
    }
    vec3 axis = normalize(sum);
    float radius = 0.0;
    for (uint s = 0u; s < BRUTE_TILE * BRUTE_TILE; s++) {
        int t = slot_texel(tile, s);
        if (t < 0 || cones[t].w > 1.0) continue;
        vec4 c = cones[t];
        float d = clamp(dot(axis, c.xyz), -1.0, 1.0);
        float apart = atan2_precise(length(cross(axis, c.xyz)), d);
        float cr = clamp(c.w, -1.0, 1.0);
        radius = max(radius, apart + atan2_precise(sqrt(max(0.0, (1.0 - cr) * (1.0 + cr))), cr));
    }
    // A relative and an absolute margin cover f32 rounding in the angles, so the tile's
    // bound is never tighter than its texels' own.
    radius = min(radius * (1.0 + FILTER_TILE_MARGIN_REL) + FILTER_TILE_MARGIN_ABS, PI);
    tiles[tile] = vec4(axis, cos(radius));
}
#elif defined(PREPARE)
void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    if (i >= pc.texels) return;
    uint per_layer = pc.src_size.x * pc.src_size.y;
    uint layer = i / per_layer, r = i % per_layer;
    ivec2 p = ivec2(r % pc.src_size.x, r / pc.src_size.x);
    ivec2 source = integration_source(pc.src_mapping, pc.src_size, p);
    if (source.x < 0) {
        cones[i] = vec4(0.0, 0.0, 1.0, 1.0);
        rad[i] = vec4(0.0);
        return;
    }
    vec3 c = src_dir(layer, (vec2(p) + 0.5) / vec2(pc.src_size));
    // Angular radius: corners and edge midpoints (pulled into the disc), 25% wider for the
    // bulge of the edges between them (twin of texel_cos_radius).
    bool disc = pc.src_mapping == MAPPING_ANGULAR || pc.src_mapping == MAPPING_DUAL_PARABOLOID;
    float min_dot = 1.0;
    for (int k = 0; k < 9; k++) {
        if (k == 4) continue;
        vec2 uv = (vec2(p) + 0.5 * vec2(k % 3, k / 3)) / vec2(pc.src_size);
        if (disc) {
            vec2 xy = 2.0 * uv - 1.0;
            float rr = length(xy);
            if (rr > 1.0) uv = 0.5 * (xy / rr + 1.0);
        }
        min_dot = min(min_dot, dot(c, src_dir(layer, uv)));
    }
    // acos via atan2 so a tiny radius keeps its digits.
    float md = clamp(min_dot, -1.0, 1.0);
    float rho = min(FILTER_CONE_MARGIN * atan2_precise(sqrt(max(0.0, (1.0 - md) * (1.0 + md))), md), PI);
    cones[i] = vec4(c, cos(rho));
    float omega = texel_solid_angle(pc.src_mapping, pc.src_size, p);
    rad[i] = vec4(texelFetch(src, ivec3(source, int(layer)), 0).rgb, omega);
}
#else

// Mean of the kernel over texel t split into s×s cells of 3×3 Gauss points, or over the
// clipped rule (pieces and chords split s ways, s ≤ 4) when a disc's rim cuts it.
float texel_mean(vec3 axis, uint t, uint s) {
    uint per_layer = pc.src_size.x * pc.src_size.y;
    uint layer = t / per_layer, r = t % per_layer;
    ivec2 p = ivec2(r % pc.src_size.x, r / pc.src_size.x);
    float acc = 0.0, wsum = 0.0;
    if (rim_cut(p)) {
        uint split = min(s, 4u);
        vec2 lo = 2.0 * vec2(p) / vec2(pc.src_size) - 1.0;
        vec2 hi = 2.0 * vec2(p + 1) / vec2(pc.src_size) - 1.0;
        float xs[6];
        int cnt = clipped_breaks(lo, hi, xs);
        for (int pi = 0; pi + 1 < cnt; pi++) {
            int parts = max(int(ceil((xs[pi + 1] - xs[pi]) * 4.0)), 1) * int(split);
            float hx = 0.5 * (xs[pi + 1] - xs[pi]) / float(parts);
            for (int q = 0; q < parts; q++) {
                float x0 = xs[pi] + 2.0 * hx * float(q);
                [[unroll]] for (int a = 0; a < 8; a++) {
                    float u = 0.5 + 0.5 * (a < 4 ? -1.0 : 1.0) * GL8_X[a & 3];
                    float x = x0 + 2.0 * hx * u * u * (3.0 - 2.0 * u);
                    float jac = 6.0 * u * (1.0 - u);
                    if (abs(x) >= 1.0) continue;
                    float e = sqrt((1.0 - x) * (1.0 + x));
                    float ya = max(lo.y, -e), yb = min(hi.y, e);
                    if (yb <= ya) continue;
                    float hy = 0.5 * (yb - ya) / float(split);
                    for (uint sp = 0u; sp < split; sp++) {
                        float my = ya + hy * float(2u * sp + 1u);
                        [[unroll]] for (int b = 0; b < 8; b++) {
                            vec2 pt = vec2(x, my + hy * (b < 4 ? -1.0 : 1.0) * GL8_X[b & 3]);
                            vec2 uv = 0.5 * (pt + 1.0);
                            float w = GL8_W[a & 3] * GL8_W[b & 3] * hx * hy * jac * density(pc.src_mapping, uv);
                            acc += w * kernel_eval(pc.exponent, axis, src_dir(layer, uv));
                            wsum += w;
                        }
                    }
                }
            }
        }
    } else {
        // s×s cells in one loop, 3-point Gauss-Legendre per cell side (twin of
        // filter::for_each_node), the nine nodes unrolled.
        for (uint cell = 0u; cell < s * s; cell++) {
            vec2 corner = vec2(p) + vec2(cell % s, cell / s) / float(s);
            [[unroll]] for (int b = -1; b <= 1; b++) {
                [[unroll]] for (int a = -1; a <= 1; a++) {
                    vec2 ab = vec2(a, b);
                    vec2 uv = (corner + (0.5 + 0.387298335 * ab) / float(s)) / vec2(pc.src_size);
                    vec2 gw = mix(vec2(8.0 / 18.0), vec2(5.0 / 18.0), abs(ab));
                    float w = gw.x * gw.y * density(pc.src_mapping, uv);
                    acc += w * kernel_eval(pc.exponent, axis, src_dir(layer, uv));
                    wsum += w;
                }
            }
        }
    }
    return wsum > 0.0 ? acc / wsum : -1.0;
}

// Whether the rule skips everything inside cone c (axis, cos of radius; w > 1: empty): the
// largest cosine to the axis over the cone, cos(θc − ρ), is at or below the horizon, or the
// lobe there is below the cutoff. texel_weight makes the same two tests per texel.
bool cone_skipped(vec3 axis, float n, vec4 c) {
    if (c.w > 1.0) return true;
    float x = dot(axis, c.xyz);
    float sin_rho = sqrt(max(0.0, (1.0 - c.w) * (1.0 + c.w)));
    float sin_c = sqrt(max(0.0, (1.0 - x) * (1.0 + x)));
    float x_max = x >= c.w ? 1.0 : x * c.w + sin_c * sin_rho;
    return x_max <= 0.0 || (n > 1.0 && n * log(x_max) < FILTER_LOG_CUTOFF);
}

// ∫K over source texel t (0 where skipped): the rule of filter::rule, decision for decision.
float texel_weight(vec3 axis, float n, uint t) {
    float omega = rad[t].w;
    if (omega == 0.0) return 0.0;
    vec4 cone = cones[t];
    float x = dot(axis, cone.xyz);
    float cos_rho = cone.w;
    float sin_rho = sqrt(max(0.0, (1.0 - cos_rho) * (1.0 + cos_rho)));
    float sin_c = sqrt(max(0.0, (1.0 - x) * (1.0 + x)));
    // The largest and smallest x over the texel: cos(θc − ρ) and cos(θc + ρ).
    float x_max = x >= cos_rho ? 1.0 : x * cos_rho + sin_c * sin_rho;
    float x_min = x * cos_rho - sin_c * sin_rho;
    if (x_max <= 0.0) return 0.0;
    if (n > 1.0 && n * log(x_max) < FILTER_LOG_CUTOFF) return 0.0;
    float rho2 = 2.0 * (1.0 - cos_rho);
    bool straddles = x_min < 0.0;
    if (!straddles && n * rho2 < FILTER_CENTRE_LIMIT) return kernel_eval(pc.exponent, axis, cone.xyz);
    float s = max(ceil(FILTER_CELLS_PER_WIDTH * sqrt(n * rho2)), 1.0);
    if (straddles) s = max(s, float(FILTER_EDGE_CELLS));
    float k = texel_mean(axis, t, uint(min(s, float(FILTER_MAX_CELLS))));
    return k < 0.0 ? kernel_eval(pc.exponent, axis, cone.xyz) : k;
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    if (pc.dst_mapping == MAPPING_ANGULAR && !texel_in_domain(pc.dst_mapping, pc.dst_size, ivec2(id.xy))) {
        imageStore(dst, ivec3(id), vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    Coord oc;
    oc.layer = id.z;
    oc.uv = (vec2(id.xy) + 0.5) / vec2(pc.dst_size);
    vec3 axis = coord_to_dir(pc.dst_mapping, oc);
    float n = pc.exponent == 0.0 ? 1.0 : pc.exponent;
    uint o = (id.z * pc.dst_size.y + id.y) * pc.dst_size.x + id.x;
    precise vec3 sum = vec3(0.0);
    precise vec3 comp = vec3(0.0);
    if (pc.chunk_begin > 0u) {
        sum = imageLoad(dst, ivec3(id)).rgb;
        comp = comp_buf[o].rgb;
    }
    const uint per_tile = BRUTE_TILE * BRUTE_TILE;
    for (uint tile = pc.chunk_begin / per_tile; tile * per_tile < pc.chunk_end; tile++) {
        if (cone_skipped(axis, n, tiles[tile])) continue;
        uint first = max(pc.chunk_begin, tile * per_tile) - tile * per_tile;
        uint last = min(pc.chunk_end, (tile + 1u) * per_tile) - tile * per_tile;
        for (uint s = first; s < last; s++) {
            int ti = slot_texel(tile, s);
            if (ti < 0) continue;
            uint t = uint(ti);
            float k = texel_weight(axis, n, t);
            if (k > 0.0) {
                vec4 rw = rad[t];
                precise vec3 y = rw.rgb * (rw.w * k) - comp;
                precise vec3 tsum = sum + y;
                comp = (tsum - sum) - y;
                sum = tsum;
            }
        }
    }
    comp_buf[o] = vec4(comp, 0.0);
    imageStore(dst, ivec3(id), vec4(sum, 1.0));
}
#endif
