#version 460
// Brute-force convolution, step 1 of 4 (the others: brute_tiles.comp, brute.comp,
// brute_resolve.comp; brute_moments.comp builds the moment pyramid). One invocation per source
// texel writes its centre direction (world), the cosine of its angular radius, its radiance
// and its exact solid angle (0 where it holds no sphere), and its shape for the tilted rule.
// Per-texel data are rgba32f image arrays: llvmpipe loads a storage buffer's element lane by
// lane behind a branch each, an image's texel as one gather.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_PREP_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_BRUTE_PREP_CONES, rgba32f) uniform writeonly image2DArray cones;
layout(set = 0, binding = BINDING_BRUTE_PREP_RADIANCE, rgba32f) uniform writeonly image2DArray rad;
layout(set = 0, binding = BINDING_BRUTE_PREP_SHAPES, rgba32f) uniform writeonly image2DArray shapes;

// The push block, generated from src/abi/push.rs.
PUSH_BrutePush

#include "brute.glsl"
#include "brute_cones.glsl"
// The tilted rule's view of texel p (twin of filter::texel_shape): the centroid of its solid
// angle from its 3×3 Gauss nodes, its half-edges mapped so that their parallelogram has the
// texel's covariance, and whether the texel is regular (w of the first vec4).
void write_shape(uint layer, ivec2 p) {
    vec3 sum = vec3(0.0);
    vec3 d[9];
    float wq[9];
    [[unroll]] for (int k = 0; k < 9; k++) {
        vec2 ab = vec2(k % 3 - 1, k / 3 - 1);
        vec2 uv = (vec2(p) + 0.5 + 0.387298335 * ab) / vec2(pc.src_size);
        vec2 gw = mix(vec2(8.0 / 18.0), vec2(5.0 / 18.0), abs(ab));
        wq[k] = gw.x * gw.y * density(SRC_MAPPING, uv);
        d[k] = coord_to_dir(SRC_MAPPING, Coord(layer, uv));
        sum += wq[k] * d[k];
    }
    vec2 size = vec2(pc.src_size);
    vec3 c = dot(sum, sum) > 0.0 ? normalize(sum) : coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + 0.5) / size));
    vec3 hu = coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(1.0, 0.5)) / size))
        - coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(0.0, 0.5)) / size));
    vec3 hv = coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(0.5, 1.0)) / size))
        - coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(0.5, 0.0)) / size));
    hu = 0.5 * (hu - c * dot(hu, c));
    hv = 0.5 * (hv - c * dot(hv, c));
    float dmin = 3.4e38, dmax = 0.0;
    for (int k = 0; k < 9; k++) {
        float dk = density(SRC_MAPPING, (vec2(p) + 0.5 * vec2(k % 3, k / 3)) / size);
        dmin = min(dmin, dk);
        dmax = max(dmax, dk);
    }
    bool regular = !rim_cut(p) && dmin > 0.0 && dmax <= FILTER_TILT_DENSITY_RATIO * dmin;
    if (regular) {
        vec3 e1 = normalize(abs(c.x) < 0.9 ? cross(c, vec3(1.0, 0.0, 0.0)) : cross(c, vec3(0.0, 1.0, 0.0)));
        vec3 e2 = cross(c, e1);
        float wsum = 0.0;
        vec3 cov = vec3(0.0);
        for (int k = 0; k < 9; k++) {
            vec3 y = d[k] - c * dot(d[k], c);
            vec2 q = vec2(dot(y, e1), dot(y, e2));
            cov += wq[k] * vec3(q.x * q.x, q.x * q.y, q.y * q.y);
            wsum += wq[k];
        }
        cov /= wsum;
        vec2 a = vec2(dot(hu, e1), dot(hu, e2)), b = vec2(dot(hv, e1), dot(hv, e2));
        vec3 par = vec3(a.x * a.x + b.x * b.x, a.x * a.y + b.x * b.y, a.y * a.y + b.y * b.y) / 3.0;
        vec3 sq = sqrt2(cov), sp = sqrt2(par);
        float det = sp.x * sp.z - sp.y * sp.y;
        if (det > 0.0) {
            vec3 ip = vec3(sp.z, -sp.y, sp.x) / det;
            mat2 m = mat2(sq.x * ip.x + sq.y * ip.y, sq.y * ip.x + sq.z * ip.y,
                          sq.x * ip.y + sq.y * ip.z, sq.y * ip.y + sq.z * ip.z);
            vec2 ma = m * a, mb = m * b;
            hu = e1 * ma.x + e2 * ma.y;
            hv = e1 * mb.x + e2 * mb.y;
        } else {
            regular = false;
        }
    }
    int l = int(3u * layer);
    imageStore(shapes, ivec3(p, l), vec4(to_world(c), regular ? 1.0 : 0.0));
    imageStore(shapes, ivec3(p, l + 1), vec4(to_world(hu), 0.0));
    imageStore(shapes, ivec3(p, l + 2), vec4(to_world(hv), 0.0));
}

void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    if (i >= pc.texels) return;
    uint per_layer = pc.src_size.x * pc.src_size.y;
    uint layer = i / per_layer, r = i % per_layer;
    ivec2 p = ivec2(r % pc.src_size.x, r / pc.src_size.x);
    ivec2 source = integration_source(SRC_MAPPING, pc.src_size, p);
    if (source.x < 0) {
        imageStore(cones, ivec3(p, layer), vec4(0.0, 0.0, 1.0, 1.0));
        imageStore(rad, ivec3(p, layer), vec4(0.0));
        return;
    }
    imageStore(cones, ivec3(p, layer), texel_cone(layer, p));
    float omega = texel_solid_angle(SRC_MAPPING, pc.src_size, p);
    imageStore(rad, ivec3(p, layer), vec4(texelFetch(src, ivec3(source, int(layer)), 0).rgb, omega));
    write_shape(layer, p);
}
