#version 460
// A plain read and write of every texel: the floor the conversion pass is measured against.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_COPY_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_COPY_DST, rgba32f) uniform writeonly image2DArray dst;
// The push block, generated from src/abi/push.rs.
PUSH_CopyPush

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.size))) return;
    imageStore(dst, ivec3(id), texelFetch(src, ivec3(id), 0));
}
