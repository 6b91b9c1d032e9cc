// What the exact-area conversions share (convert_area.comp, convert_area_fast.comp,
// convert_area_list.comp): their bindings and push block, the source's reconstruction, the
// texels' polygons and the general walk, `general(id)`.
#ifndef ENVLIGHT_CONVERT_AREA_GLSL
#define ENVLIGHT_CONVERT_AREA_GLSL
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;

layout(set = 0, binding = BINDING_CONVERT_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_CONVERT_DST, rgba32f) uniform writeonly image2DArray dst;
// Limited slopes of each source texel (convert_slopes.comp): (dL/dU rgb, 0) in one buffer,
// (dL/dz rgb, 0) in another. Through the buffers' texel views: llvmpipe reads a storage
// buffer at a per-lane address lane by lane, a texel buffer as one gather.
layout(set = 0, binding = BINDING_CONVERT_SLOPES_U) uniform samplerBuffer slopes_u;
layout(set = 0, binding = BINDING_CONVERT_SLOPES_Z) uniform samplerBuffer slopes_z;

// The push block, generated from src/abi/push.rs.
PUSH_ConvertPush

// The destination mapping, cube or dual paraboloid: a module each (ShaderId::ConvertArea and
// ConvertAreaParaboloid), since lavapipe's build time follows the module's size and a
// specialisation constant would keep the other's code in it.
const uint DST_MAPPING = DST;

// Points per edge of a paraboloid texel's polygon away from the poles (ConvertOptions::
// edge_points; 1 to AREA_POLE_STEPS): a specialisation constant, so that the default's loop
// keeps a constant bound (as a push constant it cost the default conversion 6%).
layout(constant_id = 2) const uint EDGE_POINTS = AREA_PARABOLOID_EDGE_STEPS;

// Columns a footprint may reach across and still take U from a column near it (general()).
const float AREA_LOCAL_REACH = 8.0;
const uint MAXV = 2u * AREA_MAX_VERTICES;  // a clip at most doubles a polygon
vec2 poly[MAXV];
vec2 tmp[MAXV];
vec2 band[MAXV];
uint npoly;
// The general walk's boundary points: their directions and their U (footprint_u).
vec3 ds[4u * AREA_POLE_STEPS];
float us[4u * AREA_POLE_STEPS];

vec3 point(uint face, uint a, uint b, uint m) {
    Coord c;
    c.layer = face;
    c.uv = vec2(float(a), float(b)) / float(pc.dst_size.x * m);
    vec3 d = coord_to_dir(DST_MAPPING, c);
    return vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d),
                dot(pc.world_to_file[2].xyz, d));
}

// Column c (U unwrapped) in [0, w), by a float quotient and a fix-up rather than integer
// remainders, which llvmpipe takes lane by lane.
int wrap_column(int c, int w) {
    c -= w * int(floor(float(c) / float(w)));
    c += c < 0 ? w : 0;
    return c >= w ? c - w : c;
}

bool on_pole(vec3 d) { return d.x == 0.0 && d.z == 0.0; }

bool before(vec2 a, vec2 b) { return a.x < b.x || (a.x == b.x && a.y <= b.y); }
// Directions in their coordinates' order (twin: the tuples'): a chord's canonical order.
bool before(vec3 a, vec3 b) {
    return a.x < b.x || (a.x == b.x && (a.y < b.y || (a.y == b.y && a.z <= b.z)));
}

// src clipped to z >= bound (above) or z <= bound, into dst; returns the vertex count. A
// macro, so that the arrays stay globals instead of copies.
#define CUT(dst, src, n, bound, above, out) { \
    uint k_ = 0u; \
    for (uint i_ = 0u; i_ < (n); i_++) { \
        vec2 a_ = src[i_], b_ = src[i_ + 1u == (n) ? 0u : i_ + 1u]; \
        bool ia_ = (above) ? a_.y >= (bound) : a_.y <= (bound); \
        bool ib_ = (above) ? b_.y >= (bound) : b_.y <= (bound); \
        if (ia_) dst[k_++] = a_; \
        if (ia_ != ib_) { \
            bool f_ = before(a_, b_); \
            vec2 p_ = f_ ? a_ : b_, q_ = f_ ? b_ : a_; \
            float t_ = ((bound) - p_.y) / (q_.y - p_.y); \
            dst[k_++] = vec2(p_.x + (q_.x - p_.x) * t_, (bound)); \
        } \
    } \
    out = k_; \
}

// The row whose band holds z (edge row + 1 < z <= edge row, the clip's band edges), by the
// band edge nearest acos's estimate (llvmpipe's acos errs by ~1e-4 rad, under half a row up
// to 15 000 rows).
int row_of(float z, int h) {
    int edge = int(round(acos(clamp(z, -1.0, 1.0)) / PI * float(h)));
    return clamp(z > latlong_band_edge(edge, h) ? edge - 1 : edge, 0, h - 1);
}

// The rows a polygon spanning z in [zmin, zmax] meets, by the same band edges as the clip:
// row r0 holds zmax (row_of), row r1 zmin with its band's top edge open (edge r1 + 1 <= zmin
// < edge r1).
ivec2 rows_met(float zmin, float zmax, int h) {
    int r0 = row_of(zmax, h);
    int e1 = int(round(acos(clamp(zmin, -1.0, 1.0)) / PI * float(h)));
    int r1 = clamp(zmin < latlong_band_edge(e1, h) ? e1 : e1 - 1, r0, h - 1);
    return ivec2(r0, r1);
}

// atan(y / x) for |y| ≤ x (within 45°): one half-angle step (|t| ≤ tan 22.5°), then its odd
// series to t¹⁵ (error below 4e-8 rad at 45°, 1e-13 at 22°, the most the fast path's points
// turn from their reference; area::FAST_MIN_SOURCE_WIDTH). Cheaper on llvmpipe than GLSL's
// two-argument atan, whose quadrant logic and reduction it runs for every lane, and nearer
// the true angle (lavapipe's atan errs by ~1e-6 rad), so that the fast path and the general
// walk place the points they share alike.
float atan_near(float y, float x) {
    // tan of half the angle, y / (x + |(x, y)|): one division.
    float t = y / (x + sqrt(x * x + y * y));
    float t2 = t * t;
    return 2.0 * t * (1.0 + t2 * (-1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (-1.0 / 7.0 + t2 * (1.0 / 9.0
        + t2 * (-1.0 / 11.0 + t2 * (1.0 / 13.0 + t2 * (-1.0 / 15.0))))))));
}

// atan(y, x) in (−π, π]: atan_near within 45° of x's axis, atan2_precise beyond.
float atan2_near(float y, float x) {
    return abs(y) <= x ? atan_near(y, x) : atan2_precise(y, x);
}

// local_u for a direction within 45° of the reference azimuth (the fast path's points, within
// a column and a texel's reach of it), without local_u's test of that.
float local_u_near(vec3 d, float sr, float cr) {
    return atan_near(d.x * cr + d.z * sr, -d.z * cr + d.x * sr);
}

// The azimuth of direction d from the azimuth whose sine and cosine are sr and cr, in
// (−π, π]: the direction turned by that azimuth, then atan, so that a point near it comes out
// to ~1e-7 of its distance from it (atan of d itself would round it to ~1e-7 of π).
float local_u(vec3 d, float sr, float cr) {
    return atan2_near(d.x * cr + d.z * sr, -d.z * cr + d.x * sr);
}

// The column under direction d (`scale` columns a radian), the reference U is counted from
// near d, and the sine and cosine of its azimuth for local_u.
int reference_column(vec3 d, float scale, out float sr, out float cr) {
    int c = int(floor(atan(d.x, -d.z) * scale));
    float phi = float(c) / scale;
    sr = sin(phi);
    cr = cos(phi);
    return c;
}

// The azimuth from direction u to direction v, in (−π, π]: the angle between their (−z, x),
// which no column count rounds.
float azimuth_between(vec3 u, vec3 v) {
    return atan2_near(u.x * v.z - u.z * v.x, u.z * v.z + u.x * v.x);
}

// sliver() from the (U, z) of the chord's ends and its curve's midpoint, their U from one
// reference column (the fast path's; the ends' directions a and b give the canonical order).
float sliver_local(vec3 a, vec3 b, vec2 va, vec2 vm, vec2 vb) {
    bool fwd = before(a, b);
    vec2 p = fwd ? va : vb, q = fwd ? vb : va;
    vec2 d = q - p, o = vm - 0.5 * (p + q);
    float s = (2.0 / 3.0) * (d.x * o.y - d.y * o.x);
    return fwd ? s : -s;
}

// A chord's sliver (twin: math::convert::sliver; AREA_PARABOLOID_EDGE_STEPS): the signed area
// in the (U, z) plane (`scale` columns a radian) between the chord from a to b and the
// parabola through a, the curve's midpoint m and b, as ∫ z dU along a → b adds it:
// (2/3)·(ΔU·δz − Δz·δU), δ the midpoint's offset from the chord's. Taken from the lesser of a
// and b and signed, so that the two texels sharing the chord add opposite amounts.
float sliver(vec3 a, vec3 m, vec3 b, float scale) {
    bool fwd = before(a, b);
    vec3 p = fwd ? a : b, q = fwd ? b : a;
    float s = sliver_local(p, q, vec2(0.0, p.y), vec2(azimuth_between(p, m) * scale, m.y),
                           vec2(azimuth_between(p, q) * scale, q.y));
    return fwd ? s : -s;
}

// The source texel that takes a sliver whose curve's midpoint is v in the (U, z) plane, U
// counted from column c_ref (twin: math::convert::cell_under): U nudged off the columns'
// edges, where midpoints lie by symmetry; its row the band that holds z (row_of).
vec3 cell_value(vec2 v, int c_ref, int w, int h) {
    int c = c_ref + int(floor(v.x + AREA_SLIVER_NUDGE));
    return texelFetch(src, ivec3(wrap_column(c, w), row_of(v.y, h), 0), 0).rgb;
}

// Whether corner (a, b) of a paraboloid of side n lies in the closed disc (integers, as
// math::convert::edge_steps decides).
bool corner_in_disc(uvec2 e, uint n) {
    int s = 2 * int(e.x) - int(n), t = 2 * int(e.y) - int(n);
    return s * s + t * t <= int(n) * int(n);
}

// kept_sliver's antiderivative of z·U' along the parabola z = a + b·t + c·t², U' = e + f·t.
float kept_big(float t, vec3 abc, vec2 ef) {
    float a = abc.x, b = abc.y, c = abc.z, e = ef.x, f = ef.y;
    return t * (a * e + t * ((a * f + b * e) / 2.0 + t * ((b * f + c * e) / 3.0 + t * c * f / 4.0)));
}

// The part of a chord's sliver on its half's side of the rim, z ≥ 0 (`above`) or z ≤ 0, in
// the chord's frame: the chord from (0, z0) by d, the parabola's midpoint o off the chord's
// (twin: math::convert's kept_sliver). Returns (U from the chord's start, z) of the parabola's
// point midway along its kept part and the kept area; area 0 where nothing is kept.
vec3 kept_sliver(vec2 d, vec2 o, float z0, bool above) {
    float sgn = above ? 1.0 : -1.0;
    vec3 abc = vec3(z0, d.y + 4.0 * o.y, -4.0 * o.y);
    vec2 ef = vec2(d.x + 4.0 * o.x, -8.0 * o.x);
    // Breakpoints where the chord or the parabola crosses z = 0 (1.0 where none).
    float s0 = d.y != 0.0 ? -z0 / d.y : 1.0, s1 = 1.0, s2 = 1.0;
    if (abc.z != 0.0) {
        float disc = abc.y * abc.y - 4.0 * abc.x * abc.z;
        if (disc >= 0.0) {
            float hh = -0.5 * (abc.y + (abc.y < 0.0 ? -1.0 : 1.0) * sqrt(disc));
            s1 = hh / abc.z;
            s2 = hh != 0.0 ? abc.x / hh : 1.0;
        }
    } else if (abc.y != 0.0) {
        s1 = -abc.x / abc.y;
    }
    s0 = clamp(s0, 0.0, 1.0);
    s1 = clamp(s1, 0.0, 1.0);
    s2 = clamp(s2, 0.0, 1.0);
    float lo = min(s0, min(s1, s2)), hi = max(s0, max(s1, s2));
    float ts[5] = float[5](0.0, lo, s0 + s1 + s2 - lo - hi, hi, 1.0);
    float area = 0.0, k0 = 2.0, k1 = -1.0;
    for (uint k = 0u; k < 4u; k++) {
        float t0 = ts[k], t1 = ts[k + 1u];
        if (!(t1 > t0)) continue;
        float tm = 0.5 * (t0 + t1);
        if (sgn * (abc.x + tm * (abc.y + tm * abc.z)) > 0.0) {
            area += kept_big(t1, abc, ef) - kept_big(t0, abc, ef);
            k0 = min(k0, t0);
            k1 = t1;
        }
        if (sgn * (z0 + tm * d.y) > 0.0) {
            area -= d.x * (t1 * (z0 + 0.5 * d.y * t1) - t0 * (z0 + 0.5 * d.y * t0));
        }
    }
    if (!(k1 > k0)) return vec3(0.0);
    float t = 0.5 * (k0 + k1);
    return vec3(d.x * t + 4.0 * o.x * t * (1.0 - t), abc.x + t * (abc.y + t * abc.z), area);
}

// A chord's sliver on a paraboloid edge that the rim cuts (twin: math::convert::sliver_kept):
// its part on the half's side of the rim, z ≥ 0 (`above`) or z ≤ 0, signed as sliver()'s,
// and that area times the source texel under the parabola's point midway along its kept part
// (value).
float sliver_kept(vec3 a, vec3 m, vec3 b, float scale, bool above, int w, int h, out vec3 value) {
    bool fwd = before(a, b);
    vec3 p = fwd ? a : b, q = fwd ? b : a;
    float du = azimuth_between(p, q) * scale, du_mid = azimuth_between(p, m) * scale;
    vec3 k = kept_sliver(vec2(du, q.y - p.y), vec2(du_mid - 0.5 * du, m.y - 0.5 * (p.y + q.y)),
                         p.y, above);
    float sr, cr;
    int c = reference_column(p, scale, sr, cr);
    float s = fwd ? k.z : -k.z;
    value = s * cell_value(vec2(local_u(p, sr, cr) * scale + k.x, k.y), c, w, h);
    return s;
}

// The source texel under point v of the (U, z) plane.
vec3 texel_under(vec2 v, int w, int h) {
    int row = clamp(int(floor(acos(clamp(v.y, -1.0, 1.0)) / PI * float(h))), 0, h - 1);
    return texelFetch(src, ivec3(wrap_column(int(floor(v.x)), w), row, 0), 0).rgb;
}

// The source texel that takes the sliver whose curve's midpoint is m (twin:
// math::convert::cell_under), its U counted from column c_ref (whose azimuth's sine and cosine
// are sr and cr; the column holding m or one near it), so that float32 places it to ~1e-7 of
// a column (cell_value).
vec3 sliver_texel(vec3 m, int c_ref, float sr, float cr, float scale, int w, int h) {
    return cell_value(vec2(local_u(m, sr, cr) * scale, m.y), c_ref, w, h);
}

// A paraboloid texel outside its disc: the source texel at its own half's rim nearest its
// centre (as the sampled conversion; twin rim_nearest and sample_nearest).
void store_rim(uvec3 id) {
    Coord c;
    c.layer = id.z;
    c.uv = 0.5 * (rim_pulled(2.0 * ((vec2(id.xy) + 0.5) / vec2(pc.dst_size)) - 1.0) + 1.0);
    vec3 d = coord_to_dir(DST_MAPPING, c);
    d = vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d),
             dot(pc.world_to_file[2].xyz, d));
    Coord s = dir_to_coord(MAPPING_LATLONG, d);
    ivec2 p = clamp(ivec2(floor(s.uv * vec2(pc.src_size))), ivec2(0), ivec2(pc.src_size) - 1);
    imageStore(dst, ivec3(id), vec4(texelFetch(src, ivec3(p, 0), 0).rgb, 1.0));
}

// U of the general walk's `count` points ds into us, unwrapped from the first, in columns from
// a reference column near them (returned; `scale` columns a radian, the map `wf` wide), as the
// fast path: float32 then holds U to ~1e-7 of the footprint's reach. Not where the footprint
// holds a pole (`pole`) or wraps round one, or reaches across more than AREA_LOCAL_REACH
// columns: there the reference gains little and its rounding would part the points that
// neighbours share, so U is the map's own (reference 0, no turn), as theirs.
int footprint_u(uint count, float scale, float wf, out bool pole) {
    pole = false;
    for (uint k = 0u; k < count; k++) pole = pole || on_pole(ds[k]);
    int c_ref = 0;
    float sr = 0.0, cr = 1.0;
    if (!pole) c_ref = reference_column(ds[0], scale, sr, cr);
    for (uint attempt = 0u; attempt < 2u; attempt++) {
        bool have_prev = false;
        float prev = 0.0, lo = 3.4e38, hi = -3.4e38;
        for (uint k = 0u; k < count; k++) {
            us[k] = 0.0;
            if (on_pole(ds[k])) continue;
            float u = local_u(ds[k], sr, cr) * scale;
            if (have_prev) {
                float d = u - prev;
                u = prev + (d - wf * round(d / wf));
            }
            us[k] = u;
            prev = u;
            have_prev = true;
            lo = min(lo, u);
            hi = max(hi, u);
        }
        float d = us[0] - us[count - 1u];
        bool wraps = round(d / wf) != 0.0;
        if (sr == 0.0 || !(wraps || hi - lo > AREA_LOCAL_REACH)) break;
        c_ref = 0;
        sr = 0.0;
        cr = 1.0;
    }
    return c_ref;
}

// The general walk's boundary points of texel (i, j) of layer `face` (side n) into ds, their
// count returned: each edge's points as math::convert::edge_steps picks them, from the edge
// alone; a paraboloid's edges take chords with slivers (clipped to the half where the rim cuts
// the edge), and so do a small cube's, whose areas (sl_den) and areas times the source texel
// under each (sl_num) are summed.
uint boundary_points(uint face, uint i, uint j, uint n, float scale, int w, int h,
                     out vec3 sl_num, out float sl_den) {
    const uvec2 steps[4] = uvec2[4](uvec2(0, 0), uvec2(1, 0), uvec2(1, 1), uvec2(0, 1));
    uint count = 0u;
    sl_num = vec3(0.0);
    sl_den = 0.0;
    for (uint k = 0u; k < 4u; k++) {
        uvec2 e0 = uvec2(i, j) + steps[k], e1 = uvec2(i, j) + steps[(k + 1u) % 4u];
        vec3 pa = point(face, e0.x, e0.y, 1u), pb = point(face, e1.x, e1.y, 1u);
        bool near = min(length(pa.xz), length(pb.xz)) < AREA_POLE_NEAR / float(n);
        // Chords with slivers: a paraboloid's (kept to the half where an end lies outside the
        // disc), a cube's below the fast path's size (math::convert::edge_steps).
        bool parab = DST_MAPPING == MAPPING_DUAL_PARABOLOID;
        bool in_disc = corner_in_disc(e0, n) && corner_in_disc(e1, n);
        bool chords = parab || n < AREA_FAST_MIN_SIZE, kept = parab && !in_disc;
        uint m = near ? AREA_POLE_STEPS
                      : (parab ? (in_disc ? EDGE_POINTS : AREA_PARABOLOID_RIM_STEPS)
                               : AREA_EDGE_STEPS);
        for (uint q = 0u; q < m; q++) {
            uvec2 ab = e0 * (m - q) + e1 * q;
            ds[count++] = point(face, ab.x, ab.y, m);
            if (chords) {
                // A chord from a pole is a meridian, and the polygon meets the pole's line.
                uvec2 nx = e0 * (m - q - 1u) + e1 * (q + 1u), mid = e0 * (2u * (m - q) - 1u) + e1 * (2u * q + 1u);
                vec3 a = ds[count - 1u], b = point(face, nx.x, nx.y, m);
                vec3 dm = point(face, mid.x, mid.y, 2u * m);
                if (on_pole(a) || on_pole(b)) continue;
                if (kept) {
                    vec3 value;
                    sl_den += sliver_kept(a, dm, b, scale, face == 0u, w, h, value);
                    sl_num += value;
                    continue;
                }
                float s = sliver(a, dm, b, scale);
                float sr, cr;
                int c = reference_column(dm, scale, sr, cr);
                sl_num += s * sliver_texel(dm, c, sr, cr, scale, w, h);
                sl_den += s;
            }
        }
    }
    return count;
}

// The texel's footprint walked band by band (any texel: a pole on its boundary or inside it,
// a paraboloid's rim).
void general(uvec3 id) {
    if (DST_MAPPING == MAPPING_DUAL_PARABOLOID && !texel_in_domain(DST_MAPPING, pc.dst_size, ivec2(id.xy))) {
        store_rim(id);
        return;
    }
    uint face = id.z, i = id.x, j = id.y, n = pc.dst_size.x;
    int w = int(pc.src_size.x), h = int(pc.src_size.y);
    float wf = float(w), scale = wf / (2.0 * PI);

    // The boundary points and their unwrapped U (as area_polygon in math/convert.rs).
    vec3 sl_num;
    float sl_den;
    uint count = boundary_points(face, i, j, n, scale, w, h, sl_num, sl_den);
    bool pole = false;
    int c_ref = footprint_u(count, scale, wf, pole);
    npoly = 0u;
    for (uint k = 0u; k < count; k++) {
        if (on_pole(ds[k])) {
            pole = true;
            float zp = sign(ds[k].y);
            poly[npoly++] = vec2(us[(k + count - 1u) % count], zp);
            poly[npoly++] = vec2(us[(k + 1u) % count], zp);
        } else {
            poly[npoly++] = vec2(us[k], ds[k].y);
        }
    }
    if (!pole) {
        float first = us[0], last = us[count - 1u];
        float d = first - last;
        float closed = last + (d - wf * round(d / wf));
        if (abs(closed - first) > 0.5 * wf) {
            // A paraboloid texel can hold only its own half's pole (the other is at infinity
            // in (s, t)), and its boundary may lie past the rim, in the other hemisphere.
            float zp = DST_MAPPING == MAPPING_DUAL_PARABOLOID ? (face == 0u ? 1.0 : -1.0) : sign(ds[0].y);
            poly[npoly++] = vec2(closed, ds[0].y);
            poly[npoly++] = vec2(closed, zp);
            poly[npoly++] = vec2(first, zp);
        }
    }

    if (DST_MAPPING == MAPPING_DUAL_PARABOLOID) {
        // The half's rim is the equator: keep z >= 0 (layer 0) or z <= 0.
        uint nc;
        CUT(tmp, poly, npoly, 0.0, face == 0u, nc);
        for (uint k = 0u; k < nc; k++) poly[k] = tmp[k];
        npoly = nc;
        if (npoly < 3u) {
            // Inside the disc by less than the chords' error.
            store_rim(id);
            return;
        }
    }

    float zmin = 2.0, zmax = -2.0;
    for (uint k = 0u; k < npoly; k++) {
        zmin = min(zmin, poly[k].y);
        zmax = max(zmax, poly[k].y);
    }
    ivec2 rows = rows_met(zmin, zmax, h);
    int r0 = rows.x, r1 = rows.y;

    // Sums of (L − L0) rather than L: a constant map comes out exact, whatever the pieces'
    // rounding. L0 is the least, per channel, of the texels under the polygon's points: one
    // that merely touches the footprint may be a sun 1e5 × the mean, whose cancellation would
    // cost float32 its digits; the least is at most the mean.
    vec3 l0 = vec3(3.4e38);
    for (uint k = 0u; k < npoly; k++) l0 = min(l0, texel_under(poly[k] + vec2(float(c_ref), 0.0), w, h));
    vec3 num = vec3(0.0);
    float den = 0.0;
    for (int row = r0; row <= r1; row++) {
        float zhi = latlong_band_edge(row, h), zlo = latlong_band_edge(row + 1, h);
        float zc = 0.5 * (zhi + zlo), base = (zlo - zc) * (zlo - zc);
        uint nb;
        CUT(tmp, poly, npoly, zlo, true, nb);
        CUT(band, tmp, nb, zhi, false, nb);
        // The band's pieces, edge by edge and column by column, in one loop: llvmpipe runs a
        // loop for as long as the SIMD group's longest lane, so a loop per edge would cost the
        // longest lane's columns at every edge, one loop only the longest lane's total.
        uint k = 0u;
        int c = 0;
        vec2 p = vec2(0.0), q = vec2(0.0);
        float sgn = 0.0;
        bool walking = false;
        for (;;) {
            if (!walking) {
                if (k >= nb) break;
                vec2 a = band[k], b = band[k + 1u == nb ? 0u : k + 1u];
                k++;
                bool fwd = before(a, b);
                p = fwd ? a : b;
                q = fwd ? b : a;
                sgn = fwd ? 1.0 : -1.0;
                // An upright edge bounds no area, and the band's lower edge only zeros.
                if (p.x == q.x || (p.y == zlo && q.y == zlo)) continue;
                c = int(floor(p.x));
                walking = true;
            }
            float u0 = max(p.x, float(c)), u1 = min(q.x, float(c + 1));
            if (u1 > u0) {
                // ∫∫ 1, ∫∫ (U − Uc) and ∫∫ (z − zc) over this piece (Green's theorem;
                // Simpson's rule, exact for these quadratics), as area_mean's.
                float um = 0.5 * (u0 + u1);
                float z0 = p.y + (q.y - p.y) * ((u0 - p.x) / (q.x - p.x));
                float zm = p.y + (q.y - p.y) * ((um - p.x) / (q.x - p.x));
                float z1 = p.y + (q.y - p.y) * ((u1 - p.x) / (q.x - p.x));
                float d = sgn * (u1 - u0);
                float uc = float(c) + 0.5;
                float area = d * (0.5 * (z0 + z1) - zlo);
                float mu = d / 6.0 * ((u0 - uc) * (z0 - zlo) + 4.0 * (um - uc) * (zm - zlo) +
                                      (u1 - uc) * (z1 - zlo));
                float mz = d / 6.0 * 0.5 *
                           (((z0 - zc) * (z0 - zc) - base) + 4.0 * ((zm - zc) * (zm - zc) - base) +
                            ((z1 - zc) * (z1 - zc) - base));
                int col = wrap_column(c + c_ref, w);
                int o = row * w + col;
                vec3 gu = texelFetch(slopes_u, o).xyz, gz = texelFetch(slopes_z, o).xyz;
                num += area * (texelFetch(src, ivec3(col, row, 0), 0).rgb - l0) + mu * gu +
                       mz * gz;
                den += area;
            }
            c++;
            if (float(c) >= q.x) walking = false;
        }
    }
    num += sl_num - sl_den * l0;
    den += sl_den;
    vec3 result = den != 0.0 ? l0 + num / den : l0;
    imageStore(dst, ivec3(id), vec4(max(result, vec3(0.0)), 1.0));
}

// Whether texel (i, j) of layer `face` is left to the general walk (general()): every texel of
// a small output; on the layers that hold the poles (the cube's +Y and −Y faces, each
// paraboloid half: the orientations turn about Y and may flip it) a window of AREA_FAST_WINDOW
// texels either side of the centre, which holds every texel with a corner near the pole's axis
// (AREA_POLE_NEAR); and a paraboloid's texels with a corner outside the disc, whose polygons are
// clipped to their half. Integers, so that the fast and the general dispatch split the texels
// exactly (twin: math::convert::area_general_texel).
bool general_texel(uint face, uint i, uint j, uint n) {
    if (n < AREA_FAST_MIN_SIZE) return true;
    int lim = 2 * int(AREA_FAST_WINDOW);
    bool window = abs(int(2u * i + 1u) - int(n)) <= lim && abs(int(2u * j + 1u) - int(n)) <= lim;
    if (DST_MAPPING == MAPPING_DUAL_PARABOLOID) {
        int nn = int(n) * int(n);
        for (uint k = 0u; k < 4u; k++) {
            int a = 2 * int(i + (k & 1u)) - int(n), b = 2 * int(j + (k >> 1u)) - int(n);
            if (a * a + b * b > nn) return true;
        }
        return window;
    }
    return (face == AREA_POLE_FACE_0 || face == AREA_POLE_FACE_1) && window;
}
#endif
