// Direction <-> texture coordinate for the four mappings, texel solid angles and solid-angle
// densities. The float64 twins are in src/math/mapping.rs; docs/design.md §1 states the conventions.
#ifndef ENVLIGHT_MAPPINGS_GLSL
#define ENVLIGHT_MAPPINGS_GLSL
#include "generated.glsl"

const float PI = 3.14159265358979;
const float TAU = 6.28318530717959;

struct Coord {
    uint layer;
    vec2 uv;
};

// (a / b, a % b) for b > 0 and a / b < 2^22 (texel indices: layer and row, row and column),
// by a float quotient and one fix-up each way: llvmpipe divides integers lane by lane, a
// float quotient in one vector instruction.
uvec2 div_rem(uint a, uint b) {
    int q = int(float(a) / float(b));
    int r = int(a) - q * int(b);
    if (r < 0) { q--; r += int(b); }
    if (r >= int(b)) { q++; r -= int(b); }
    return uvec2(q, r);
}

// atan2 accurate to a few ulps, defined at the origin. GLSL's atan may be off by 4096 ulps
// (lavapipe's is ~1e-6 rad off), which would show in round trips and in the short arcs of rim
// texel solid angles. Two half-angle reductions bring |t| under 0.21, where 8 odd Taylor terms
// are exact in float.
float atan2_precise(float y, float x) {
    float ax = abs(x), ay = abs(y);
    float hi = max(ax, ay);
    if (hi == 0.0) return 0.0;
    float t = min(ax, ay) / hi;
    t = t / (1.0 + sqrt(1.0 + t * t));
    t = t / (1.0 + sqrt(1.0 + t * t));
    float t2 = t * t;
    float a = t * (1.0 + t2 * (-1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (-1.0 / 7.0 + t2 * (1.0 / 9.0
        + t2 * (-1.0 / 11.0 + t2 * (1.0 / 13.0 + t2 * (-1.0 / 15.0))))))));
    a *= 4.0;
    if (ay > ax) a = 0.5 * PI - a;
    if (x < 0.0) a = PI - a;
    return y < 0.0 ? -a : a;
}

Coord dir_to_coord(uint m, vec3 d) {
    Coord c;
    c.layer = 0u;
    if (m == MAPPING_LATLONG) {
        float u = atan2_precise(d.x, -d.z) / TAU;
        if (u < 0.0) u += 1.0;
        if (u >= 1.0) u -= 1.0;
        // atan2 rather than acos(d.y): acos loses half the digits at the poles.
        c.uv = vec2(u, atan2_precise(length(d.xz), d.y) / PI);
    } else if (m == MAPPING_ANGULAR) {
        float rho = length(d.xy);
        float r = atan2_precise(rho, d.z) / PI;
        vec2 ab = rho > 0.0 ? r * (d.xy / rho) : (d.z >= 0.0 ? vec2(0.0) : vec2(0.0, -1.0));
        c.uv = vec2(0.5 * (ab.x + 1.0), 0.5 * (1.0 - ab.y));
    } else if (m == MAPPING_CUBE) {
        vec3 a = abs(d);
        float sc, tc, ma;
        if (a.x >= a.y && a.x >= a.z) {
            c.layer = d.x >= 0.0 ? 0u : 1u;
            sc = d.x >= 0.0 ? -d.z : d.z;
            tc = -d.y;
            ma = a.x;
        } else if (a.y >= a.z) {
            c.layer = d.y >= 0.0 ? 2u : 3u;
            sc = d.x;
            tc = d.y >= 0.0 ? d.z : -d.z;
            ma = a.y;
        } else {
            c.layer = d.z >= 0.0 ? 4u : 5u;
            sc = d.z >= 0.0 ? d.x : -d.x;
            tc = -d.y;
            ma = a.z;
        }
        c.uv = 0.5 * (vec2(sc, tc) / ma + 1.0);
    } else {
        c.layer = d.y >= 0.0 ? 0u : 1u;
        float k = 1.0 / (1.0 + abs(d.y));
        c.uv = 0.5 * (d.xz * k + 1.0);
    }
    return c;
}

vec3 coord_to_dir(uint m, Coord c) {
    if (m == MAPPING_LATLONG) {
        float phi = TAU * c.uv.x, theta = PI * c.uv.y;
        float st = sin(theta);
        return vec3(st * sin(phi), cos(theta), -st * cos(phi));
    } else if (m == MAPPING_ANGULAR) {
        vec2 ab = vec2(2.0 * c.uv.x - 1.0, 1.0 - 2.0 * c.uv.y);
        float r = length(ab);
        if (r == 0.0) return vec3(0.0, 0.0, 1.0);
        float t = PI * r;
        return vec3(sin(t) * (ab / r), cos(t));
    } else if (m == MAPPING_CUBE) {
        vec2 st = 2.0 * c.uv - 1.0;
        vec3 d;
        switch (c.layer) {
            case 0u: d = vec3(1.0, -st.y, -st.x); break;
            case 1u: d = vec3(-1.0, -st.y, st.x); break;
            case 2u: d = vec3(st.x, 1.0, st.y); break;
            case 3u: d = vec3(st.x, -1.0, -st.y); break;
            case 4u: d = vec3(st.x, -st.y, 1.0); break;
            default: d = vec3(-st.x, -st.y, -1.0); break;
        }
        return normalize(d);
    } else {
        vec2 st = 2.0 * c.uv - 1.0;
        float rho2 = dot(st, st);
        float k = 1.0 / (1.0 + rho2);
        float y = (1.0 - rho2) * k;
        return vec3(2.0 * st.x * k, c.layer == 0u ? y : -y, 2.0 * st.y * k);
    }
}

// dω / (du dv) at uv; zero outside the disc of angular and paraboloid maps.
float density(uint m, vec2 uv) {
    vec2 ab = 2.0 * uv - 1.0;
    float r2 = dot(ab, ab);
    if (m == MAPPING_LATLONG) {
        return 2.0 * PI * PI * sin(PI * uv.y);
    } else if (m == MAPPING_ANGULAR) {
        if (r2 > 1.0) return 0.0;
        float r = sqrt(r2);
        return r == 0.0 ? 4.0 * PI * PI : 4.0 * PI * sin(PI * r) / r;
    } else if (m == MAPPING_CUBE) {
        float q = 1.0 + r2;
        return 4.0 / (q * sqrt(q));
    } else {
        if (r2 > 1.0) return 0.0;
        float q = 1.0 + r2;
        return 16.0 / (q * q);
    }
}

// Weight of a point of a texel's footprint when the conversion pass averages over it. Angular
// footprints use |dω/(du dv)| of the mapping continued past the rim: the rim is the single
// direction −Z, the continuation covers directions next to it, and rim texels then hold a mean
// centred on their centre. Paraboloid footprints stop at the rim, so that each half's texels
// hold the mean over their part of the hemisphere and ∑ L·Ω over both halves is the power.
float footprint_weight(uint m, vec2 uv) {
    if (m == MAPPING_ANGULAR) {
        vec2 ab = 2.0 * uv - 1.0;
        float r = length(ab);
        return r == 0.0 ? 4.0 * PI * PI : abs(4.0 * PI * sin(PI * r) / r);
    }
    return density(m, uv);
}

// +∞.
#define FLOAT_INF uintBitsToFloat(0x7f800000u)

// Whether every channel is finite (|NaN| < x is false: one comparison a channel).
bool finite3(vec3 v) {
    return all(lessThan(abs(v), vec3(FLOAT_INF)));
}

// A radiance value as integrals over the sphere count it: zero where a channel is NaN or
// infinite (an engine's frame may hold such texels; the light extraction counts them).
vec3 finite_or_zero(vec3 l) {
    return finite3(l) ? l : vec3(0.0);
}

// Layers of a map of mapping m (twin of Mapping::layers).
uint mapping_layers(uint m) {
    return m == MAPPING_CUBE ? 6u : (m == MAPPING_DUAL_PARABOLOID ? 2u : 1u);
}

// A paraboloid half's (s, t) pulled onto its disc, just inside the rim (RIM_PULL_IN), where it
// lies outside; unchanged inside (twin: math::convert's rim_nearest).
vec2 rim_pulled(vec2 st) {
    return st * ((1.0 - RIM_PULL_IN) / max(length(st), 1.0 - RIM_PULL_IN));
}

// Whether texel (i, j) of a w x h layer is ever read (docs/design.md §1: angular texels whose centre is
// outside the disc hold captions; paraboloid texels that overlap the disc hold its mean).
bool texel_in_domain(uint m, uvec2 size, ivec2 p) {
    if (m == MAPPING_ANGULAR) {
        vec2 ab = 2.0 * (vec2(p) + 0.5) / vec2(size) - 1.0;
        return dot(ab, ab) <= 1.0;
    } else if (m == MAPPING_DUAL_PARABOLOID) {
        // The texel's nearest point to the disc's centre in half texels: integers, as the
        // twin's (a square map: n² fits an int up to 46340 a side).
        int n = int(size.x);
        ivec2 near_ = clamp(ivec2(0), 2 * p - n, 2 * p + 2 - n);
        return near_.x * near_.x + near_.y * near_.y < n * n;
    }
    return true;
}

// Which texel stands for texel p in integrals over the sphere (twin of
// Mapping::integration_source): p itself when read; for an angular texel centred outside the
// disc that overlaps it, the texel just inside the rim on the same radius; (-1, -1) otherwise.
ivec2 integration_source(uint m, uvec2 size, ivec2 p) {
    if (texel_in_domain(m, size, p)) return p;
    if (m != MAPPING_ANGULAR) return ivec2(-1);
    vec2 lo = 2.0 * vec2(p) / vec2(size) - 1.0;
    vec2 hi = 2.0 * vec2(p + 1) / vec2(size) - 1.0;
    vec2 n = clamp(vec2(0.0), lo, hi);
    if (dot(n, n) >= 1.0) return ivec2(-1);
    vec2 ab = 2.0 * (vec2(p) + 0.5) / vec2(size) - 1.0;
    float r = length(ab);
    for (int step = 1; step < 4; step++) {
        float k = (1.0 - float(step) / float(min(size.x, size.y))) / r;
        ivec2 q = min(ivec2(floor((ab * k + 1.0) * 0.5 * vec2(size))), ivec2(size) - 1);
        if (texel_in_domain(m, size, q)) return q;
    }
    return ivec2(-1);
}

// 8-point Gauss-Legendre rule on [-1, 1] (exact for degree 15).
const float GL8_X[4] = float[4](0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363);
const float GL8_W[4] = float[4](0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763);

// dω / (dx dy) in the map's own [-1,1]² coordinates (cube face, angular disc, paraboloid disc).
float square_density(uint m, vec2 p) {
    float r2 = dot(p, p);
    if (m == MAPPING_CUBE) {
        float q = 1.0 + r2;
        return 1.0 / (q * sqrt(q));
    } else if (m == MAPPING_ANGULAR) {
        float r = sqrt(r2);
        return r == 0.0 ? PI * PI : PI * sin(PI * r) / r;
    }
    float q = 1.0 + r2;
    return 4.0 / (q * q);
}

float gl8_square(uint m, vec2 lo, vec2 hi) {
    vec2 mid = 0.5 * (lo + hi), half_ = 0.5 * (hi - lo);
    float s = 0.0;
    for (int a = 0; a < 8; a++) {
        float xa = (a < 4 ? -1.0 : 1.0) * GL8_X[a & 3], wa = GL8_W[a & 3];
        for (int b = 0; b < 8; b++) {
            float xb = (b < 4 ? -1.0 : 1.0) * GL8_X[b & 3], wb = GL8_W[b & 3];
            s += wa * wb * square_density(m, mid + half_ * vec2(xa, xb));
        }
    }
    return s * half_.x * half_.y;
}

// Layers this many texels a side or more take a 2-point Gauss rule each way for a cube or
// paraboloid texel's solid angle (square_solid_angle): a texel's density there is smooth
// enough that it errs by at most 3.2e-8 of the angle (cube 2e-8, paraboloid 3.2e-8 at 64; 1e-9
// and 2e-9 at 128), below float32's rounding of gl8_square's 64 terms, at a sixteenth of the
// density evaluations.
const uint GL2_MIN_SIDE = 64u;

// The positive nodes and weights of the 2-point rule (first) and of the 8-point one.
const float GLS_X[5] = float[5](0.5773502691896258, GL8_X[0], GL8_X[1], GL8_X[2], GL8_X[3]);
const float GLS_W[5] = float[5](1.0, GL8_W[0], GL8_W[1], GL8_W[2], GL8_W[3]);

// The solid angle of a cube texel, or a paraboloid's wholly inside its disc, [lo, hi] of a
// layer `size` texels a side: gl8_square's integral, by 2 points each way from GL2_MIN_SIDE
// on. The rule's size is the loops' bound, which llvmpipe runs only as far as it is (a
// select between two calls would run both).
float square_solid_angle(uint m, uvec2 size, vec2 lo, vec2 hi) {
    bool two = min(size.x, size.y) >= GL2_MIN_SIDE;
    uint n = two ? 2u : 8u, half_n = n / 2u, base = two ? 0u : 1u;
    vec2 mid = 0.5 * (lo + hi), half_ = 0.5 * (hi - lo);
    float s = 0.0;
    for (uint a = 0u; a < n; a++) {
        uint ka = base + a % half_n;
        float xa = (a < half_n ? -1.0 : 1.0) * GLS_X[ka], wa = GLS_W[ka];
        for (uint b = 0u; b < n; b++) {
            uint kb = base + b % half_n;
            float xb = (b < half_n ? -1.0 : 1.0) * GLS_X[kb], wb = GLS_W[kb];
            s += wa * wb * square_density(m, mid + half_ * vec2(xa, xb));
        }
    }
    return s * half_.x * half_.y;
}

// Where a texel [lo, hi] (disc coordinates) must be cut in x so that each piece's chord
// through the unit disc is smooth: its ends and the circle's crossings of its top and bottom
// edges, sorted. Returns how many of xs hold them (2 to 6).
int clipped_breaks(vec2 lo, vec2 hi, out float xs[6]) {
    int n = 0;
    xs[n++] = lo.x;
    for (int k = 0; k < 2; k++) {
        float y = k == 0 ? lo.y : hi.y;
        if (abs(y) < 1.0) {
            float e = sqrt((1.0 - y) * (1.0 + y));
            if (-e > lo.x && -e < hi.x) xs[n++] = -e;
            if (e > lo.x && e < hi.x) xs[n++] = e;
        }
    }
    xs[n++] = hi.x;
    for (int i = 1; i < n; i++) {
        float v = xs[i];
        int j = i - 1;
        while (j >= 0 && xs[j] > v) { xs[j + 1] = xs[j]; j--; }
        xs[j + 1] = v;
    }
    return n;
}

// ∫∫ square_density over [lo, hi] ∩ unit disc, for texels the rim cuts: Gauss-Legendre in x
// over pieces split where the circle crosses the texel's top and bottom edges (so each piece
// is smooth), and in y over the chord inside the disc. Unlike the divergence theorem used on
// the CPU, nothing cancels, so slivers keep their relative precision in float.
float clipped_square(uint m, vec2 lo, vec2 hi) {
    float xs[6];
    int n = clipped_breaks(lo, hi, xs);
    float total = 0.0;
    for (int p = 0; p + 1 < n; p++) {
        // Pieces wider than 1/4 (maps under 8 texels) are cut further so 8 nodes suffice.
        int parts = int(ceil((xs[p + 1] - xs[p]) * 4.0));
        float hx = 0.5 * (xs[p + 1] - xs[p]) / float(max(parts, 1));
        for (int q = 0; q < parts; q++) {
            float x0 = xs[p] + 2.0 * hx * float(q);
            for (int a = 0; a < 8; a++) {
                // x = x0 + (x1 - x0)(3u² - 2u³) clusters nodes at the piece's ends, where the
                // chord may shrink like a square root (at x = ±1); the Jacobian 6u(1-u)
                // smooths that.
                float u = 0.5 + 0.5 * (a < 4 ? -1.0 : 1.0) * GL8_X[a & 3];
                float x = x0 + 2.0 * hx * u * u * (3.0 - 2.0 * u);
                float jac = 6.0 * u * (1.0 - u);
                if (abs(x) >= 1.0) continue;
                float e = sqrt((1.0 - x) * (1.0 + x));
                float ya = max(lo.y, -e), yb = min(hi.y, e);
                if (yb <= ya) continue;
                float my = 0.5 * (ya + yb), hy = 0.5 * (yb - ya), inner = 0.0;
                for (int b = 0; b < 8; b++) {
                    float y = my + hy * (b < 4 ? -1.0 : 1.0) * GL8_X[b & 3];
                    inner += GL8_W[b & 3] * square_density(m, vec2(x, y));
                }
                total += GL8_W[a & 3] * inner * hy * hx * jac;
            }
        }
    }
    return total;
}

bool in_rect(vec2 p, vec2 lo, vec2 hi) {
    return all(greaterThanEqual(p, lo)) && all(lessThanEqual(p, hi));
}

// sin(x) for x in [0, π/2] to a few ulps relative. GLSL's sin is bound by an absolute error
// only (NVIDIA's is ~2^-21): at the small angles of a lat-long row's half height and of the
// rows next to the poles that is a relative error of 1e-4 or more, which the texel solid
// angles, the SH mean of a map and the light threshold taken from it would carry. Taylor
// terms to x^9 below π/4, the cosine's to x^10 above (as cos(π/2 - x)).
float sin_half_pi(float x) {
    float y = x <= 0.25 * PI ? x : 0.5 * PI - x;
    float y2 = y * y;
    if (x <= 0.25 * PI) {
        return y * (1.0 + y2 * (-1.0 / 6.0 + y2 * (1.0 / 120.0 + y2 * (-1.0 / 5040.0
            + y2 * (1.0 / 362880.0)))));
    }
    return 1.0 + y2 * (-0.5 + y2 * (1.0 / 24.0 + y2 * (-1.0 / 720.0 + y2 * (1.0 / 40320.0
        + y2 * (-1.0 / 3628800.0)))));
}

// Solid angle of texel (i, j) of a w x h layer (the part inside the disc for angular and
// paraboloid maps). Closed form for lat-long; 8x8 Gauss-Legendre for cube texels and for disc
// texels wholly inside; clipped_square for texels the rim cuts.
float texel_solid_angle(uint m, uvec2 size, ivec2 p) {
    if (m == MAPPING_LATLONG) {
        // 2 sin(θ_mid) sin(Δθ/2) per unit φ, θ_mid folded into the northern half (the rows
        // are symmetric about the equator, and half-integers fold exactly).
        float rows = float(size.y), mid = float(p.y) + 0.5;
        float north = min(mid, rows - mid);
        return (TAU / float(size.x)) * 2.0 * sin_half_pi(PI * north / rows)
            * sin_half_pi(0.5 * PI / rows);
    }
    vec2 lo = 2.0 * vec2(p) / vec2(size) - 1.0;
    vec2 hi = 2.0 * vec2(p + 1) / vec2(size) - 1.0;
    if (m == MAPPING_CUBE) return square_solid_angle(m, size, lo, hi);
    vec2 far_ = max(abs(lo), abs(hi));
    if (dot(far_, far_) <= 1.0) {
        return m == MAPPING_DUAL_PARABOLOID ? square_solid_angle(m, size, lo, hi) : gl8_square(m, lo, hi);
    }
    return clipped_square(m, lo, hi);
}

// The premultiplication weight of level-0 texel `id` of a `size`-texel paraboloid half: 1
// wholly inside the disc, 0 wholly outside, on the rim the share of its (continued) solid
// angle inside the disc (glsl/mip.comp, convert.comp's SPLIT; twin: math::mip::weight).
float paraboloid_weight(uvec2 id, uint size) {
    vec2 lo = 2.0 * vec2(id) / float(size) - 1.0;
    vec2 hi = 2.0 * vec2(id + 1u) / float(size) - 1.0;
    vec2 far_ = max(abs(lo), abs(hi));
    if (dot(far_, far_) <= 1.0) return 1.0;
    float inside = clipped_square(MAPPING_DUAL_PARABOLOID, lo, hi);
    return inside > 0.0 ? min(inside / gl8_square(MAPPING_DUAL_PARABOLOID, lo, hi), 1.0) : 0.0;
}

// z = cos θ at the top of lat-long row `row` of `h` (row h: the south pole), the band edges of
// the area conversion (convert_slopes.comp, convert_area.comp; math::convert::band_edge).
float latlong_band_edge(int row, int h) {
    if (row <= 0) return 1.0;
    if (row >= h) return -1.0;
    return cos(PI * float(row) / float(h));
}
#endif
