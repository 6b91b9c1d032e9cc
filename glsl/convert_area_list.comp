#version 460
// ConvertArea's general walk (convert_area.comp has the method) over a list of texels: those
// the fast path (convert_area_fast.comp) leaves.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "convert_area.glsl"
layout(std430, set = 0, binding = BINDING_CONVERT_LIST) readonly buffer List {
    uvec4 list[];  // (i, j, layer, 0) of each texel general_texel leaves to this dispatch
};

void main() {
    if (gl_GlobalInvocationID.x >= uint(list.length())) return;
    general(list[gl_GlobalInvocationID.x].xyz);
}
