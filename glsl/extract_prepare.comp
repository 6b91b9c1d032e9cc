#version 460
// The GPU extraction's light records (passes::extract) prepared for the shade pass's light
// walk (glsl/include/light_walk.glsl), in the layout of math::lights::gpu_list and
// math::light_tree::LightTree::gpu_nodes (the float64 twin: math::light_tree::LightTree::flat
// over math::lights::prepare_cells): each kept record becomes the texel at the place of its
// texel position among the kept ones (layer, row, column order: the same whatever order the
// compaction left them in), its centre turned to the world, its (2·cells)² quadrature nodes
// (math::lights::nodes), and a leaf node of its own; the node after the last leaf ends the
// walk (its skip is past the room). One invocation per record, and one for the end node.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "extract.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_PREPARE_STATE) readonly buffer State { uint state[]; };
layout(std430, set = 0, binding = BINDING_PREPARE_LIGHTS) readonly buffer Lights { Record records[]; };
layout(std430, set = 0, binding = BINDING_PREPARE_OUT) writeonly buffer Out { vec4 prepared[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ExtractPreparePush

vec3 to_world(vec3 d) {
    return vec3(dot(pc.file_to_world[0].xyz, d), dot(pc.file_to_world[1].xyz, d),
                dot(pc.file_to_world[2].xyz, d));
}

// The texel position's place in (layer, row, column) order.
uint key_of(uvec4 t) {
    return (t.x * pc.map_size.y + t.z) * pc.map_size.x + t.y;
}

// Quadrature node (a, b)'s place in its texel, in texel units: two Gauss points a cell each
// way (math::lights::nodes).
vec2 node_offset(uint a, uint b) {
    float g = 0.5 / sqrt(3.0);
    vec2 cell = vec2(float(a / 2u), float(b / 2u)) + 0.5;
    vec2 side = vec2(a % 2u == 1u ? g : -g, b % 2u == 1u ? g : -g);
    return (cell + side) / float(pc.cells);
}

// Where node n starts.
uint node_at(uint n) {
    return pc.tree_at + n * LIGHT_TREE_VEC4S;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint kept = min(state[EXTRACT_WORD_KEPT], pc.max);
    if (i > kept) return;
    if (i == kept) {
        // The end: no power, no texels, its skip past every node (a unit centre, so that a
        // walk taking it whole sums zero times a finite kernel).
        uint at = node_at(kept);
        prepared[at] = vec4(0.0, 0.0, 1.0, 0.0);
        prepared[at + 1u] = vec4(0.0);
        prepared[at + 2u] = vec4(0.0);
        prepared[at + 3u] = vec4(0.0);
        prepared[at + 4u] = vec4(0.0, 0.0, float(pc.max + 1u), 0.0);
        return;
    }
    Record r = records[i];
    uint key = key_of(r.texel);
    uint place = 0u;
    for (uint k = 0u; k < kept; k++) place += key_of(records[k].texel) < key ? 1u : 0u;
    vec3 dir = to_world(r.dir_omega.xyz);
    float omega = r.dir_omega.w, rho = sqrt(omega);
    vec3 l = r.excess_y.rgb;
    uint at = place * pc.stride;
    prepared[at] = vec4(dir, omega);
    prepared[at + 1u] = vec4(l, rho);
    // The quadrature: two Gauss points a cell each way, weights the footprint's density
    // scaled to ω (math::lights::nodes).
    uint side = 2u * pc.cells;
    float total = 0.0;
    for (uint b = 0u; b < side; b++) {
        for (uint a = 0u; a < side; a++) {
            vec2 uv = (vec2(r.texel.yz) + node_offset(a, b)) / vec2(pc.map_size);
            total += footprint_weight(pc.mapping, uv);
        }
    }
    for (uint b = 0u; b < side; b++) {
        for (uint a = 0u; a < side; a++) {
            Coord c;
            c.layer = r.texel.x;
            c.uv = (vec2(r.texel.yz) + node_offset(a, b)) / vec2(pc.map_size);
            vec4 node = total > 0.0
                ? vec4(to_world(coord_to_dir(pc.mapping, c)), footprint_weight(pc.mapping, c.uv) * omega / total)
                : vec4(dir, omega / float(side * side));
            prepared[at + LIGHT_HEADER_VEC4S + b * side + a] = node;
        }
    }
    // Its leaf: (centre, reach), (power, ρ), (axis 0, the power's luminance), (axis 1, 0),
    // (first, count, skip, 0); one texel has no spread, so both axes are zero.
    uint n = node_at(place);
    vec3 power = l * omega;
    prepared[n] = vec4(dir, rho);
    prepared[n + 1u] = vec4(power, rho);
    prepared[n + 2u] = vec4(0.0, 0.0, 0.0, dot(power, LUMINANCE));
    prepared[n + 3u] = vec4(0.0);
    prepared[n + 4u] = vec4(float(place), 1.0, float(place + 1u), 0.0);
}
