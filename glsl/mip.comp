#version 460
// The dual-paraboloid MIP chain, stored premultiplied: each texel holds (Σ w·L, Σ w)/area
// over its footprint, w the part of the level-0 texel inside the unit disc (1 inside, its
// covered share of solid angle on the rim). A lookup divides rgb by alpha, so texels outside
// the disc weigh nothing in the down-filter or in bilinear and trilinear filtering. Radiance
// is averaged evenly over the (s, t) plane, not by solid angle, which would lean coarse
// texels towards the pole (src/math/mip.rs). Twin of src/math/mip.rs.
// MODE 0 premultiplies level 0 in place; MODE 1 box-filters a finer level into the next,
// with fractional footprints for sizes that are not powers of two.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_MIP_SRC, rgba32f) uniform readonly image2DArray src;
layout(set = 0, binding = BINDING_MIP_DST, rgba32f) uniform writeonly image2DArray dst;

// The push block, generated from src/abi/push.rs.
PUSH_MipPush

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, uvec2(pc.dst_size)))) return;
    if (pc.mode == 0u) {
        vec4 t = imageLoad(src, ivec3(id));
        float w = paraboloid_weight(id.xy, pc.src_size);
        imageStore(dst, ivec3(id), vec4(t.rgb * w, w));
        return;
    }
    float scale = float(pc.src_size) / float(pc.dst_size);
    vec2 lo = vec2(id.xy) * scale, hi = (vec2(id.xy) + 1.0) * scale;
    ivec2 c0 = ivec2(floor(lo)), c1 = min(ivec2(ceil(hi)), ivec2(pc.src_size));
    vec4 acc = vec4(0.0);
    float area = 0.0;
    for (int y = c0.y; y < c1.y; y++) {
        float oy = min(hi.y, float(y + 1)) - max(lo.y, float(y));
        for (int x = c0.x; x < c1.x; x++) {
            float a = (min(hi.x, float(x + 1)) - max(lo.x, float(x))) * oy;
            acc += a * imageLoad(src, ivec3(x, y, id.z));
            area += a;
        }
    }
    imageStore(dst, ivec3(id), acc / area);
}
