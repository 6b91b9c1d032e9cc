#version 460
// Resamples an environment map into another mapping. Each output texel is the solid-angle-
// weighted mean of ss x ss samples spread over its footprint, so minification filters instead
// of aliasing (see footprint_weight for the angular and paraboloid rims). Built twice: with SRC_CUBE
// the source is a cube view (hardware filtering crosses faces), otherwise a 2D array read with
// masked bilinear filtering that never touches texels outside the source's domain. With
// `nearest` each sample reads the texel it falls in. Built a third time with SPLIT (2D sources,
// to a dual paraboloid): one read of the source writes the whole map and its residual clamped
// at luminance pc.threshold texel by texel (glsl/clamp.comp's rule), both premultiplied as
// glsl/mip.comp keeps level 0, so that both MIP chains start from level 1.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
// Source and destination mappings are specialisation constants: every other mapping's branch
// vanishes from the per-sample code, which runs faster and JITs sooner on llvmpipe.
layout(constant_id = 2) const uint SRC_MAPPING = 0u;
layout(constant_id = 3) const uint DST_MAPPING = 0u;

#ifdef SRC_CUBE
layout(set = 0, binding = BINDING_CONVERT_SRC) uniform samplerCube src_cube;
#else
layout(set = 0, binding = BINDING_CONVERT_SRC) uniform sampler2DArray src;
#endif
layout(set = 0, binding = BINDING_CONVERT_DST, rgba32f) uniform writeonly image2DArray dst;
#ifdef SPLIT
layout(set = 0, binding = BINDING_CONVERT_RESIDUAL, rgba32f) uniform writeonly image2DArray residual;
#endif

// The push block, generated from src/abi/push.rs.
PUSH_ConvertPush

// Polar angle of the solid-angle centroid of lat-long row j (rows of height h; rows -1 and H
// are rows 0 and H-1 seen across the pole): θm + cot θm · (1 - x cot x), x = h/2, with the
// bracket's series so nothing cancels.
float row_centroid(int j, float h) {
    float tm = (float(j) + 0.5) * h;
    float x2 = 0.25 * h * h;
    float k = x2 * (1.0 / 3.0 + x2 * (1.0 / 45.0 + x2 * (2.0 / 945.0)));
    return tm + cos(tm) / sin(tm) * k;
}

// A source texel clamped at luminance pc.threshold, chroma kept (glsl/clamp.comp's rule).
vec3 clamped(vec3 v) {
    float y = dot(LUMINANCE, v);
    return y > pc.threshold ? v * (pc.threshold / y) : v;
}

// One sample of the source: the map's radiance, and (SPLIT) its residual's.
struct Sample {
    vec3 whole;
    vec3 residual;
};

Sample sample_src(vec3 d) {
    vec3 f = vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d),
                  dot(pc.world_to_file[2].xyz, d));
#ifdef SRC_CUBE
    if (pc.nearest != 0u) {
        // The texel f falls in, read at its centre (where bilinear weights are 1, 0, 0, 0),
        // by the same face and texel rule as the float64 twin.
        Coord c = dir_to_coord(MAPPING_CUBE, f);
        vec2 size = vec2(pc.src_size);
        c.uv = (min(floor(c.uv * size), size - 1.0) + 0.5) / size;
        f = coord_to_dir(MAPPING_CUBE, c);
    }
    vec3 v = textureLod(src_cube, f, 0.0).rgb;
    return Sample(v, v);
#else
    Coord c = dir_to_coord(SRC_MAPPING, f);
    ivec2 size = ivec2(pc.src_size);
    if (pc.nearest != 0u) {
        ivec2 q = clamp(ivec2(floor(c.uv * vec2(size))), ivec2(0), size - 1);
        vec3 v = texelFetch(src, ivec3(q, int(c.layer)), 0).rgb;
#ifdef SPLIT
        return Sample(v, clamped(v));
#else
        return Sample(v, v);
#endif
    }
    vec2 p = c.uv * vec2(size) - 0.5;
    ivec2 i0 = ivec2(floor(p));
    vec2 t = p - vec2(i0);
    if (SRC_MAPPING == MAPPING_LATLONG) {
        // A lat-long texel holds the mean of its footprint, whose centroid lies nearer the
        // equator than its centre (by h/6 in the polar rows). Interpolating between centroids
        // keeps reconstruction second-order accurate up to the poles.
        float h = PI / float(size.y), theta = PI * c.uv.y;
        float c0 = row_centroid(i0.y, h), c1 = row_centroid(i0.y + 1, h);
        if (theta < c0) {
            i0.y -= 1;
            c1 = c0;
            c0 = row_centroid(i0.y, h);
        } else if (theta >= c1) {
            i0.y += 1;
            c0 = c1;
            c1 = row_centroid(i0.y + 1, h);
        }
        t.y = clamp((theta - c0) / (c1 - c0), 0.0, 1.0);
    }
    vec3 acc = vec3(0.0), acc_r = vec3(0.0);
    float wsum = 0.0;
    vec3 nearest = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        ivec2 q = i0 + ivec2(k & 1, k >> 1);
        if (SRC_MAPPING == MAPPING_LATLONG) {
            // Over a pole the neighbouring row is the same row half a turn away.
            if (q.y < 0) {
                q = ivec2(q.x + size.x / 2, -1 - q.y);
            } else if (q.y >= size.y) {
                q = ivec2(q.x + size.x / 2, 2 * size.y - 1 - q.y);
            }
            q.x = (q.x % size.x + size.x) % size.x;  // u wraps around the seam
        }
        q = clamp(q, ivec2(0), size - 1);
        float w = ((k & 1) == 1 ? t.x : 1.0 - t.x) * ((k >> 1) == 1 ? t.y : 1.0 - t.y);
        vec3 v = texelFetch(src, ivec3(q, int(c.layer)), 0).rgb;
        if (k == 0 || w > 0.25) nearest = v;
        if (!texel_in_domain(SRC_MAPPING, pc.src_size, q)) continue;
        acc += w * v;
#ifdef SPLIT
        acc_r += w * clamped(v);
#endif
        wsum += w;
    }
    // Only at the very rim can every neighbour be outside the domain.
    if (wsum > 0.0) return Sample(acc / wsum, acc_r / wsum);
#ifdef SPLIT
    return Sample(nearest, clamped(nearest));
#else
    return Sample(nearest, nearest);
#endif
#endif
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    Sample result = Sample(vec3(0.0), vec3(0.0));
    // Angular texels centred outside the disc are never read: they stay black.
    if (texel_in_domain(DST_MAPPING, pc.dst_size, ivec2(id.xy)) || DST_MAPPING != MAPPING_ANGULAR) {
        vec3 acc = vec3(0.0), acc_r = vec3(0.0);
        float wsum = 0.0;
        float inv = 1.0 / float(pc.ss);
        for (uint b = 0u; b < pc.ss; b++) {
            for (uint a = 0u; a < pc.ss; a++) {
                Coord c;
                c.layer = id.z;
                c.uv = (vec2(id.xy) + (vec2(a, b) + 0.5) * inv) / vec2(pc.dst_size);
                float w = footprint_weight(DST_MAPPING, c.uv);
                if (w <= 0.0) continue;
                Sample v = sample_src(coord_to_dir(DST_MAPPING, c));
                acc += w * v.whole;
#ifdef SPLIT
                acc_r += w * v.residual;
#endif
                wsum += w;
            }
        }
        // Only disc mappings have texels whose samples may all weigh nothing: on a cube or a
        // lat-long (every weight positive) the branch below is compiled out, which matters
        // because llvmpipe runs both sides of a branch whose condition differs between lanes:
        // here a second sample_src a texel.
        bool may_be_empty = DST_MAPPING == MAPPING_DUAL_PARABOLOID || DST_MAPPING == MAPPING_ANGULAR;
        if (wsum > 0.0 || !may_be_empty) {
            result = Sample(acc / wsum, acc_r / wsum);
        } else {
            // A paraboloid texel whose samples all fall outside its disc holds its own half's
            // rim nearest its centre (not the other half, which the centre's continuation
            // would be): bilinear taps and the MIP chain's partly covered texels read it.
            Coord c;
            c.layer = id.z;
            c.uv = (vec2(id.xy) + 0.5) / vec2(pc.dst_size);
            if (DST_MAPPING == MAPPING_DUAL_PARABOLOID) {
                c.uv = 0.5 * (rim_pulled(2.0 * c.uv - 1.0) + 1.0);
            }
            result = sample_src(coord_to_dir(DST_MAPPING, c));
        }
    }
#ifdef SPLIT
    float w = paraboloid_weight(id.xy, pc.dst_size.x);
    imageStore(dst, ivec3(id), vec4(result.whole * w, w));
    imageStore(residual, ivec3(id), vec4(result.residual * w, w));
#else
    imageStore(dst, ivec3(id), vec4(result.whole, 1.0));
#endif
}
