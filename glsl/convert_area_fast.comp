#version 460
// ConvertArea's fast path (convert_area.comp has the method): one invocation per cube or
// paraboloid texel away from the poles (and inside a paraboloid's disc).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "convert_area.glsl"
// The fast path for a texel away from the poles: its polygon is the edge points a side (the
// cube's AREA_EDGE_STEPS, a paraboloid's EDGE_POINTS), with no pole on or inside it and, on a
// paraboloid, wholly in its half (no clip at the rim). Rather than clipping it band by band, each source texel
// (cell) of its bounding box takes, from each edge, the integrals under the edge clamped to the
// cell's band, ∫(clamp(z, zlo, zhi) − zlo) dU and the moments (Green's theorem again: the
// clamped edges bound the polygon's overlap with the band), so there are no arrays indexed at
// run time and no loops over clipped vertices, which llvmpipe takes lane by lane.
#ifdef SIDE_EDGE_POINTS
// A paraboloid's (a specialisation constant: its loops unroll once specialised).
const uint SIDE_POINTS = EDGE_POINTS;
#else
// The cube's (a constant: glslang unrolls the loops).
const uint SIDE_POINTS = AREA_EDGE_STEPS;
#endif
const uint FAST_POINTS = 4u * SIDE_POINTS;

// (area, ∫∫(U − uc), ∫∫(z − zc)) of the polygon edge a → b within column [c, c + 1] and the
// band [zlo, zhi] (zc its centre, uc the column's), signed by the edge's direction, computed
// from the canonical endpoint order so that neighbours sharing the edge cancel exactly.
vec3 edge_cell(vec2 a, vec2 b, float c, float uc, float zlo, float zhi, float zc) {
    bool fwd = before(a, b);
    vec2 p = fwd ? a : b, q = fwd ? b : a;
    float u0 = max(p.x, c), u1 = min(q.x, c + 1.0);
    if (!(u1 > u0)) return vec3(0.0);
    float sgn = fwd ? 1.0 : -1.0;
    float z0 = p.y + (q.y - p.y) * ((u0 - p.x) / (q.x - p.x));
    float z1 = p.y + (q.y - p.y) * ((u1 - p.x) / (q.x - p.x));
    float dz = z1 - z0;
    // Where the piece crosses the band's edges (as fractions of it), in order.
    // (A level piece is all middle: its z may lie inside the band.)
    float ta = dz != 0.0 ? clamp((zlo - z0) / dz, 0.0, 1.0) : 0.0;
    float tb = dz != 0.0 ? clamp((zhi - z0) / dz, 0.0, 1.0) : 1.0;
    float t1 = min(ta, tb), t2 = max(ta, tb);
    float base = (zlo - zc) * (zlo - zc);
    // Outside [t1, t2] the clamped z is constant, at zlo or zhi: ∫∫(z − zc) vanishes there, and
    // the area and ∫∫(U − uc) are a rectangle's.
    float du = sgn * (u1 - u0);
    float ga = clamp(z0, zlo, zhi), gb = clamp(z1, zlo, zhi);
    float ha = du * t1 * (ga - zlo), hb = du * (1.0 - t2) * (gb - zlo);
    vec3 acc = vec3(ha + hb, ha * (u0 + 0.5 * (u1 - u0) * t1 - uc) + hb * (u1 - 0.5 * (u1 - u0) * (1.0 - t2) - uc),
                    0.0);
    // Within [t1, t2], z itself: Simpson's rule, exact for these quadratics.
    float ua = u0 + (u1 - u0) * t1, ub = u0 + (u1 - u0) * t2, um = 0.5 * (ua + ub);
    float za = clamp(z0 + dz * t1, zlo, zhi), zb = clamp(z0 + dz * t2, zlo, zhi),
          zm = clamp(z0 + dz * (0.5 * (t1 + t2)), zlo, zhi);
    float d = sgn * (ub - ua);
    acc.x += d * (0.5 * (za + zb) - zlo);
    acc.y += d / 6.0 * ((ua - uc) * (za - zlo) + 4.0 * (um - uc) * (zm - zlo) + (ub - uc) * (zb - zlo));
    acc.z += d / 12.0 * (((za - zc) * (za - zc) - base) + 4.0 * ((zm - zc) * (zm - zc) - base) +
                         ((zb - zc) * (zb - zc) - base));
    return acc;
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    uint face = id.z, i = id.x, j = id.y, n = pc.dst_size.x;
    if (general_texel(face, i, j, n)) return;
    int w = int(pc.src_size.x), h = int(pc.src_size.y);
    float wf = float(w), scale = wf / (2.0 * PI);

    // The boundary points, U unwrapped from the first (as general()).
    const uvec2 steps[4] = uvec2[4](uvec2(0, 0), uvec2(1, 0), uvec2(1, 1), uvec2(0, 1));
    vec2 v[FAST_POINTS];
    [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) {
        uint e = k / SIDE_POINTS, q = k % SIDE_POINTS, m = SIDE_POINTS;
        uvec2 e0 = uvec2(i, j) + steps[e], e1 = uvec2(i, j) + steps[(e + 1u) % 4u];
        uvec2 ab = e0 * (m - q) + e1 * q;
        vec3 d = point(face, ab.x, ab.y, m);
        float u = atan(d.x, -d.z) * scale;
        if (k > 0u) {
            float dd = u - v[k - 1u].x;
            u = v[k - 1u].x + (dd - wf * round(dd / wf));
        }
        v[k] = vec2(u, d.y);
    }
    vec2 lo = v[0], hi = v[0];
    [[unroll]] for (uint k = 1u; k < FAST_POINTS; k++) {
        lo = min(lo, v[k]);
        hi = max(hi, v[k]);
    }
    ivec2 rows = rows_met(lo.y, hi.y, h);
    int c0 = int(floor(lo.x)), c1 = int(floor(hi.x));
    vec3 l0 = vec3(3.4e38);
    [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) l0 = min(l0, texel_under(v[k], w, h));

    vec3 num = vec3(0.0);
    float den = 0.0;
    // The box's cells row by row in one loop (llvmpipe runs a loop as long as the SIMD group's
    // longest lane: nested, the most rows times the most columns; one, the most cells).
    int row = rows.x, c = c0;
    float zhi = latlong_band_edge(row, h), zlo = latlong_band_edge(row + 1, h);
    while (row <= rows.y) {
        float zc = 0.5 * (zhi + zlo);
        float cf = float(c), uc = cf + 0.5;
        vec3 m = vec3(0.0);
        [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) {
            m += edge_cell(v[k], v[(k + 1u) % FAST_POINTS], cf, uc, zlo, zhi, zc);
        }
        int col = wrap_column(c, w);
        uint o = AREA_SLOPE_VEC4S * uint(row * w + col);
        num += m.x * (texelFetch(src, ivec3(col, row, 0), 0).rgb - l0) +
               m.y * texelFetch(slopes, int(o)).xyz + m.z * texelFetch(slopes, int(o + 1u)).xyz;
        den += m.x;
        if (++c > c1) {
            c = c0;
            row++;
            zhi = zlo;
            zlo = latlong_band_edge(row + 1, h);
        }
    }
    vec3 result = den != 0.0 ? l0 + num / den : l0;
    imageStore(dst, ivec3(id), vec4(max(result, vec3(0.0)), 1.0));
}
