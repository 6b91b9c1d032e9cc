#version 460
// Brute-force convolution, step 2: one invocation per tile of BRUTE_TILE² source texels
// writes a cone bounding all its texels' cones (w = 2 when it holds none). The sum skips a
// tile whose cone lies wholly where the rule skips texels: every texel in it would have been
// skipped, so the sum is the same, term for term.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_TILE_CONES, rgba32f) uniform readonly image2DArray cones;
layout(std430, set = 0, binding = BINDING_BRUTE_TILE_OUT) writeonly buffer Tiles { vec4 tiles[]; };

// The push block, generated from src/abi/push.rs.
PUSH_BrutePush

#include "brute.glsl"

void main() {
    uint tile = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    uvec2 g = tile_grid();
    if (tile >= g.x * g.y * pc.src_layers) return;
    // Axis: the mean of the texel centres; radius: the farthest texel cone edge from it.
    uvec3 origin = tile_origin(tile);
    vec3 sum = vec3(0.0);
    for (uint s = 0u; s < BRUTE_TILE * BRUTE_TILE; s++) {
        ivec3 t = slot_texel(origin, s);
        if (t.x < 0) continue;
        vec4 c = imageLoad(cones, t);
        if (c.w <= 1.0) sum += c.xyz;
    }
    if (dot(sum, sum) == 0.0) {
        tiles[tile] = vec4(0.0, 0.0, 1.0, 2.0);
        return;
    }
    vec3 axis = normalize(sum);
    float radius = 0.0;
    for (uint s = 0u; s < BRUTE_TILE * BRUTE_TILE; s++) {
        ivec3 t = slot_texel(origin, s);
        if (t.x < 0) continue;
        vec4 c = imageLoad(cones, t);
        if (c.w > 1.0) continue;
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
