// Real SH basis up to SH_MAX_LMAX in the convention of docs/design.md §2 (twin of src/math/sh.rs):
// associated Legendre functions divided by sin^m (polynomials in z) times Re/Im((x+iy)^m).
#ifndef ENVLIGHT_SH_GLSL
#define ENVLIGHT_SH_GLSL
#include "generated.glsl"

// The recurrence, once, for both entry points below: LM is the highest band, Y the array
// written. The inner loop runs over every l and skips l < m, so its trip count is constant
// when LM is: then NIR unrolls both loops and SH_K folds to constants.
#define SH_BASIS_BODY(LM, Y)                                                                  \
    float re = 1.0, im = 0.0, pmm = 1.0;                                                       \
    for (uint m = 0u; m <= LM; m++) {                                                          \
        if (m > 0u) {                                                                          \
            float r = re * d.x - im * d.y;                                                     \
            im = re * d.y + im * d.x;                                                          \
            re = r;                                                                            \
            pmm *= float(2u * m - 1u);                                                         \
        }                                                                                      \
        float p_prev = 0.0, p = pmm;                                                           \
        for (uint l = 0u; l <= LM; l++) {                                                      \
            if (l < m) continue;                                                               \
            if (l == m + 1u) {                                                                 \
                p_prev = p;                                                                    \
                p = d.z * float(2u * m + 1u) * pmm;                                            \
            } else if (l > m + 1u) {                                                           \
                float next = (float(2u * l - 1u) * d.z * p - float(l + m - 1u) * p_prev) / float(l - m); \
                p_prev = p;                                                                    \
                p = next;                                                                      \
            }                                                                                  \
            float k = SH_K[l * (l + 1u) / 2u + m];                                             \
            uint c = l * (l + 1u);                                                             \
            if (m == 0u) {                                                                     \
                Y[c] = k * p;                                                                  \
            } else {                                                                           \
                float s = 1.41421356237 * k * p;                                               \
                Y[c + m] = s * re;                                                             \
                Y[c - m] = s * im;                                                             \
            }                                                                                  \
        }                                                                                      \
    }

// The basis to band lmax, chosen at run time.
void sh_basis(uint lmax, vec3 d, out float y[SH_MAX_COEFFS]) {
    SH_BASIS_BODY(lmax, y)
}

#ifdef SH_SPEC_BASIS
// The same basis with the band a specialisation constant LMAX (declared by the includer, with
// NC = (LMAX+1)²), written to the private array sh_y: its loops unroll and sh_y lives in
// registers, which on llvmpipe is what makes the SH projection fast.
float sh_y[NC];
void sh_basis_spec(vec3 d) {
    SH_BASIS_BODY(LMAX, sh_y)
}
#endif
#endif
