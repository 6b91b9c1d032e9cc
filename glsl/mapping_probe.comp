#version 460
// Exposes the GLSL mapping functions to tests: mode 0 round-trips directions through
// dir_to_coord and coord_to_dir; mode 1 writes the solid angle of every texel of a layer.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;

layout(std430, set = 0, binding = BINDING_PROBE_IN) readonly buffer In { vec4 dirs[]; };
layout(std430, set = 0, binding = BINDING_PROBE_OUT) writeonly buffer Out { vec4 results[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ProbePush

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    if (pc.mode == 0u) {
        Coord c = dir_to_coord(pc.mapping, dirs[i].xyz);
        results[2u * i] = vec4(c.uv, float(c.layer), 0.0);
        results[2u * i + 1u] = vec4(coord_to_dir(pc.mapping, c), 0.0);
    } else {
        ivec2 p = ivec2(i % pc.width, i / pc.width);
        results[i] = vec4(texel_solid_angle(pc.mapping, uvec2(pc.width, pc.height), p), 0.0, 0.0, 0.0);
    }
}
