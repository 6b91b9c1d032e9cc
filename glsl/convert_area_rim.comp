#version 460
// A dual paraboloid's texels outside its disc, for ConvertArea's split dispatches: each takes
// the source texel nearest its half's rim (store_rim, as the sampled conversion), over the
// tiles holding any (math::convert::area_tiles). A dispatch of its own, because llvmpipe
// would run the fast path's code for these lanes too.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "convert_area.glsl"
layout(std430, set = 0, binding = BINDING_CONVERT_LIST) readonly buffer Tiles {
    uvec4 tiles[];  // (tile column, tile row, layer, 0) of each tile with a texel outside
};

void main() {
    uvec4 tile = tiles[gl_WorkGroupID.x];
    uvec3 id = uvec3(tile.xy * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy, tile.z);
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    if (!texel_in_domain(DST_MAPPING, pc.dst_size, ivec2(id.xy))) store_rim(id);
}
