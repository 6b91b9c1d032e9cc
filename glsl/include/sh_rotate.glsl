// Rotation of real SH coefficient vectors on the GPU, twin of src/math/sh_rotate.rs: for a
// rotation R, c ← M(R)·c with y(R·d) = M(R)·y(d). Two constructions:
// - sh_rotate_zxzxz (Kautz, Sloan & Snyder 2002): R = Rz(α)·Ry(β)·Rz(γ) and
//   Ry(β) = Rx(−90°)·Rz(β)·Rx(90°): three turns of the (m, −m) pairs and two products with the
//   fixed blocks of M(Rx(90°)), which the includer provides as SH_X90(i) (bands in order,
//   band l at l(2l−1)(2l+1)/3, row-major);
// - sh_rotate_ivanic (Ivanic & Ruedenberg 1996/1998): band l's block from band l−1's and the
//   3×3 rotation, applied band by band.
// Both take the band lmax at run time and rotate the array in place.
#ifndef ENVLIGHT_SH_ROTATE_GLSL
#define ENVLIGHT_SH_ROTATE_GLSL
#include "generated.glsl"

// Turns every (m, −m) pair by mφ, given cs = (cos φ, sin φ) (multiples by angle addition).
void sh_rotate_z(uint lmax, vec2 cs, inout float c[SH_MAX_COEFFS]) {
    float sm = 0.0, cm = 1.0;
    for (uint m = 1u; m <= lmax; m++) {
        float t = cm * cs.x - sm * cs.y;
        sm = sm * cs.x + cm * cs.y;
        cm = t;
        for (uint l = m; l <= lmax; l++) {
            uint kp = l * (l + 1u) + m, km = l * (l + 1u) - m;
            float a = c[kp], b = c[km];
            c[kp] = cm * a - sm * b;
            c[km] = sm * a + cm * b;
        }
    }
}

// c ← M(Rx(±90°))·c band by band (transposed for −90°).
void sh_apply_x90(uint lmax, bool transposed, inout float c[SH_MAX_COEFFS]) {
    float band[2u * SH_MAX_LMAX + 1u];
    for (uint l = 1u; l <= lmax; l++) {
        uint w = 2u * l + 1u, o = l * l, base = l * (2u * l - 1u) * (2u * l + 1u) / 3u;
        for (uint i = 0u; i < w; i++) band[i] = c[o + i];
        for (uint i = 0u; i < w; i++) {
            float acc = 0.0;
            for (uint j = 0u; j < w; j++) {
                acc += SH_X90(transposed ? base + j * w + i : base + i * w + j) * band[j];
            }
            c[o + i] = acc;
        }
    }
}

// (cos, sin) of the ZYZ angles of R (GLSL column-major: R[col][row]), with no trigonometry
// (llvmpipe's sin, cos and atan err by ~1e-5): α from the third column (0 where it is ±ẑ),
// then β and γ from Rz(α)ᵀ·R = Ry(β)·Rz(γ), with no division by sin β. Twin of
// math::sh_rotate::zyz_cos_sin.
void sh_zyz(mat3 r, out vec2 a, out vec2 b, out vec2 g) {
    float h = length(r[2].xy);
    a = h > 0.0 ? r[2].xy / h : vec2(1.0, 0.0);
    float q02 = a.x * r[2][0] + a.y * r[2][1];
    float q10 = -a.y * r[0][0] + a.x * r[0][1];
    float q11 = -a.y * r[1][0] + a.x * r[1][1];
    b = normalize(vec2(r[2][2], q02));
    g = normalize(vec2(q11, q10));
}

void sh_rotate_zxzxz(mat3 r, uint lmax, inout float c[SH_MAX_COEFFS]) {
    vec2 a, b, g;
    sh_zyz(r, a, b, g);
    sh_rotate_z(lmax, g, c);
    sh_apply_x90(lmax, false, c);
    sh_rotate_z(lmax, b, c);
    sh_apply_x90(lmax, true, c);
    sh_rotate_z(lmax, a, c);
}

// Ivanic–Ruedenberg. The blocks of bands l−1 and l live in one private array, ping-ponged.
const uint IR_BLOCK = (2u * SH_MAX_LMAX + 1u) * (2u * SH_MAX_LMAX + 1u);
float ir_m[2u * IR_BLOCK];
mat3 ir_r1;  // band 1 in (y, z, x) order: ir_r1[n + 1][m + 1] = M₁[m][n]

float ir_prev(uint pb, int l, int a, int b) {
    int wp = 2 * l - 1;
    return ir_m[pb + uint((a + l - 1) * wp + b + l - 1)];
}

float ir_p(uint pb, int i, int l, int a, int b) {
    if (b == l) return ir_r1[2][i + 1] * ir_prev(pb, l, a, l - 1) - ir_r1[0][i + 1] * ir_prev(pb, l, a, -l + 1);
    if (b == -l) return ir_r1[2][i + 1] * ir_prev(pb, l, a, -l + 1) + ir_r1[0][i + 1] * ir_prev(pb, l, a, l - 1);
    return ir_r1[1][i + 1] * ir_prev(pb, l, a, b);
}

void sh_rotate_ivanic(mat3 r, uint lmax, inout float c[SH_MAX_COEFFS]) {
    // M₁[m][n] = R[p(m)][p(n)], p = (y, z, x).
    const int p[3] = int[3](1, 2, 0);
    for (int m = 0; m < 3; m++)
        for (int n = 0; n < 3; n++) ir_r1[n][m] = r[p[n]][p[m]];
    if (lmax == 0u) return;
    vec3 b1 = vec3(c[1], c[2], c[3]);
    for (int m = 0; m < 3; m++) {
        c[1 + m] = dot(vec3(ir_r1[0][m], ir_r1[1][m], ir_r1[2][m]), b1);
        for (int n = 0; n < 3; n++) ir_m[uint(m * 3 + n)] = ir_r1[n][m];
    }
    uint pb = 0u, cb = IR_BLOCK;
    float band[2u * SH_MAX_LMAX + 1u];
    for (int l = 2; l <= int(lmax); l++) {
        int w = 2 * l + 1;
        for (int m = -l; m <= l; m++) {
            int am = abs(m);
            float d = m == 0 ? 1.0 : 0.0;
            for (int n = -l; n <= l; n++) {
                float denom = abs(n) < l ? float((l + n) * (l - n)) : float(2 * l * (2 * l - 1));
                float u = sqrt(float((l + m) * (l - m)) / denom);
                float v = 0.5 * sqrt((1.0 + d) * float((l + am - 1) * (l + am)) / denom) * (1.0 - 2.0 * d);
                float ww = -0.5 * sqrt(float((l - am - 1) * (l - am)) / denom) * (1.0 - d);
                float x = 0.0;
                if (u != 0.0) x += u * ir_p(pb, 0, l, m, n);
                if (v != 0.0) {
                    float vv;
                    if (m == 0) {
                        vv = ir_p(pb, 1, l, 1, n) + ir_p(pb, -1, l, -1, n);
                    } else if (m > 0) {
                        float d1 = m == 1 ? 1.0 : 0.0;
                        vv = ir_p(pb, 1, l, m - 1, n) * sqrt(1.0 + d1) - ir_p(pb, -1, l, -m + 1, n) * (1.0 - d1);
                    } else {
                        float d1 = m == -1 ? 1.0 : 0.0;
                        vv = ir_p(pb, 1, l, m + 1, n) * (1.0 - d1) + ir_p(pb, -1, l, -m - 1, n) * sqrt(1.0 + d1);
                    }
                    x += v * vv;
                }
                if (ww != 0.0) {
                    x += ww * (m > 0 ? ir_p(pb, 1, l, m + 1, n) + ir_p(pb, -1, l, -m - 1, n)
                                     : ir_p(pb, 1, l, m - 1, n) - ir_p(pb, -1, l, -m + 1, n));
                }
                ir_m[cb + uint((m + l) * w + n + l)] = x;
            }
        }
        uint o = uint(l * l);
        for (int i = 0; i < w; i++) band[i] = c[o + uint(i)];
        for (int i = 0; i < w; i++) {
            float acc = 0.0;
            for (int j = 0; j < w; j++) acc += ir_m[cb + uint(i * w + j)] * band[j];
            c[o + uint(i)] = acc;
        }
        uint t = pb;
        pb = cb;
        cb = t;
    }
}
#endif
