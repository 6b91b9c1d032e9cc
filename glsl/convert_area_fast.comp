#version 460
// ConvertArea's fast path (convert_area.comp has the method): one invocation per cube or
// paraboloid texel away from the poles (and inside a paraboloid's disc), over the tiles that
// hold such texels.
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

// A polygon edge in canonical order (neighbours sharing it take the same pieces): its ends
// p, q (p before q), the sign of a → b against that order, dz/dU and dU/dz (0 where level or
// upright: an upright edge bounds no area).
struct Edge {
    vec2 p, q;
    float sgn, k, ik;
    bool level;
};

Edge edge_of(vec2 a, vec2 b) {
    Edge e;
    bool fwd = before(a, b);
    e.p = fwd ? a : b;
    e.q = fwd ? b : a;
    e.sgn = fwd ? 1.0 : -1.0;
    float du = e.q.x - e.p.x, dz = e.q.y - e.p.y;
    // Slopes below 1e-20 count as level: dU/dz would overflow, and z moves by nothing.
    e.level = abs(dz) <= 1e-20 * abs(du);
    e.k = du != 0.0 ? dz / du : 0.0;
    e.ik = e.level ? 0.0 : du / dz;
    return e;
}

// (area, ∫∫(U − uc), ∫∫(z − zc)) of edge e within column [c, c + 1] and the band [zlo, zhi]
// (zc its centre, uc the column's), signed by the edge's direction. Divisions are the edge's
// (edge_of), once per texel, not once per cell.
vec3 edge_cell(Edge e, float c, float uc, float zlo, float zhi, float zc) {
    float u0 = max(e.p.x, c), u1 = min(e.q.x, c + 1.0);
    if (!(u1 > u0)) return vec3(0.0);
    float z0 = e.p.y + e.k * (u0 - e.p.x);
    float z1 = e.p.y + e.k * (u1 - e.p.x);
    // Where the piece crosses the band's edges, in U, in order. (A level piece is all
    // middle: its z may lie inside the band.)
    float ulo = clamp(e.p.x + (zlo - e.p.y) * e.ik, u0, u1);
    float uhi = clamp(e.p.x + (zhi - e.p.y) * e.ik, u0, u1);
    float ua = e.level ? u0 : min(ulo, uhi), ub = e.level ? u1 : max(ulo, uhi);
    // Outside [ua, ub] the clamped z is constant, at zlo or zhi: ∫∫(z − zc) vanishes there, and
    // the area and ∫∫(U − uc) are a rectangle's.
    float ga = clamp(z0, zlo, zhi), gb = clamp(z1, zlo, zhi);
    float ha = e.sgn * (ua - u0) * (ga - zlo), hb = e.sgn * (u1 - ub) * (gb - zlo);
    vec3 acc = vec3(ha + hb, ha * (0.5 * (u0 + ua) - uc) + hb * (0.5 * (ub + u1) - uc), 0.0);
    // Within [ua, ub], z itself, linear (its ends in the band): the trapezoid's integrals, in
    // closed form (Simpson's rule's with the midpoint's z the ends' mean).
    float za = clamp(e.p.y + e.k * (ua - e.p.x), zlo, zhi) - zlo;
    float zb = clamp(e.p.y + e.k * (ub - e.p.x), zlo, zhi) - zlo;
    float d = e.sgn * (ub - ua);
    float a = za + (zlo - zc), b = zb + (zlo - zc), base = (zlo - zc) * (zlo - zc);
    acc.x += d * 0.5 * (za + zb);
    acc.y += d / 6.0 * ((ua - uc) * (2.0 * za + zb) + (ub - uc) * (za + 2.0 * zb));
    acc.z += d / 6.0 * (a * a + a * b + b * b - 3.0 * base);
    return acc;
}

layout(std430, set = 0, binding = BINDING_CONVERT_LIST) readonly buffer Tiles {
    uvec4 tiles[];  // (tile column, tile row, layer, 0) of each tile holding a fast texel
};

void main() {
    // One workgroup per tile of the list (math::convert::area_tiles): the texels of the
    // others are the general walk's, or outside a paraboloid's disc (convert_area_rim.comp).
    uvec4 tile = tiles[gl_WorkGroupID.x];
    uvec3 id = uvec3(tile.xy * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy, tile.z);
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    uint face = id.z, i = id.x, j = id.y, n = pc.dst_size.x;
    if (general_texel(face, i, j, n)) return;
    int w = int(pc.src_size.x), h = int(pc.src_size.y);
    float wf = float(w), scale = wf / (2.0 * PI);

    // The boundary points, U in columns from a reference column near them (c_ref, the first
    // point's): float32 then holds U to ~1e-7 of the texel's reach rather than of the map's
    // width. No unwrapping: the fast path's texels lie away from the poles, so their points
    // lie within a few columns of the reference, far from the turned seam at ±π.
    const uvec2 steps[4] = uvec2[4](uvec2(0, 0), uvec2(1, 0), uvec2(1, 1), uvec2(0, 1));
    vec3 d_first = point(face, i * SIDE_POINTS, j * SIDE_POINTS, SIDE_POINTS);
    float sr, cr;
    int c_ref = reference_column(d_first, scale, sr, cr);
    vec2 v[FAST_POINTS];
    vec3 dirs[FAST_POINTS];
    [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) {
        uint e = k / SIDE_POINTS, q = k % SIDE_POINTS, m = SIDE_POINTS;
        uvec2 e0 = uvec2(i, j) + steps[e], e1 = uvec2(i, j) + steps[(e + 1u) % 4u];
        uvec2 ab = e0 * (m - q) + e1 * q;
        vec3 d = k == 0u ? d_first : point(face, ab.x, ab.y, m);
        dirs[k] = d;
        v[k] = vec2(local_u_near(d, sr, cr) * scale, d.y);
    }
    vec2 lo = v[0], hi = v[0];
    [[unroll]] for (uint k = 1u; k < FAST_POINTS; k++) {
        lo = min(lo, v[k]);
        hi = max(hi, v[k]);
    }
    int c0 = int(floor(lo.x)), c1 = int(floor(hi.x));
#ifdef SIDE_EDGE_POINTS
    // A paraboloid's chords' slivers (its fast texels' edges all lie in the disc, away from
    // the poles): their areas, their curves' midpoints and the columns under those (as
    // cell_value: U nudged). The box walk below hands each to the cell holding its midpoint
    // (its band and column), which the box grows to hold: no row's arccosine, no fetch.
    float sl[FAST_POINTS];
    vec2 sv[FAST_POINTS];
    int scol[FAST_POINTS];
    [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) {
        uint e = k / SIDE_POINTS, q = k % SIDE_POINTS, m = SIDE_POINTS;
        uvec2 e0 = uvec2(i, j) + steps[e], e1 = uvec2(i, j) + steps[(e + 1u) % 4u];
        uvec2 mid = e0 * (2u * (m - q) - 1u) + e1 * (2u * q + 1u);
        vec3 dm = point(face, mid.x, mid.y, 2u * m);
        uint k1 = (k + 1u) % FAST_POINTS;
        sv[k] = vec2(local_u_near(dm, sr, cr) * scale, dm.y);
        sl[k] = sliver_local(dirs[k], dirs[k1], v[k], sv[k], v[k1]);
        scol[k] = int(floor(sv[k].x + AREA_SLIVER_NUDGE));
        lo.y = min(lo.y, sv[k].y);
        hi.y = max(hi.y, sv[k].y);
        c0 = min(c0, scol[k]);
        c1 = max(c1, scol[k]);
    }
#endif
    ivec2 rows = rows_met(lo.y, hi.y, h);
    // Sums relative to L0 (as general()'s): here the least of the texels under the corners,
    // which a sun merely touching the footprint cannot be unless it holds all four.
    vec3 l0 = vec3(3.4e38);
    [[unroll]] for (uint k = 0u; k < FAST_POINTS; k += SIDE_POINTS) l0 = min(l0, texel_under(v[k] + vec2(float(c_ref), 0.0), w, h));

    Edge edges[FAST_POINTS];
    [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) edges[k] = edge_of(v[k], v[(k + 1u) % FAST_POINTS]);

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
            m += edge_cell(edges[k], cf, uc, zlo, zhi, zc);
        }
#ifdef SIDE_EDGE_POINTS
        // The slivers whose midpoints this cell holds (row_of's band: zlo < z <= zhi).
        [[unroll]] for (uint k = 0u; k < FAST_POINTS; k++) {
            m.x += scol[k] == c && sv[k].y > zlo && sv[k].y <= zhi ? sl[k] : 0.0;
        }
#endif
        int col = wrap_column(c + c_ref, w);
        int o = row * w + col;
        num += m.x * (texelFetch(src, ivec3(col, row, 0), 0).rgb - l0) +
               m.y * texelFetch(slopes_u, o).xyz + m.z * texelFetch(slopes_z, o).xyz;
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
