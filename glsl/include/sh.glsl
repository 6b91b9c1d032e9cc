// Real SH basis up to SH_MAX_LMAX in the convention of DESIGN.md (twin of src/math/sh.rs):
// associated Legendre functions divided by sin^m (polynomials in z) times Re/Im((x+iy)^m).
#ifndef ENVLIGHT_SH_GLSL
#define ENVLIGHT_SH_GLSL
#include "generated.glsl"

void sh_basis(uint lmax, vec3 d, out float y[SH_MAX_COEFFS]) {
    float re = 1.0, im = 0.0, pmm = 1.0;
    for (uint m = 0u; m <= lmax; m++) {
        if (m > 0u) {
            float r = re * d.x - im * d.y;
            im = re * d.y + im * d.x;
            re = r;
            pmm *= float(2u * m - 1u);
        }
        float p_prev = 0.0, p = pmm;
        for (uint l = m; l <= lmax; l++) {
            if (l == m + 1u) {
                p_prev = p;
                p = d.z * float(2u * m + 1u) * pmm;
            } else if (l > m + 1u) {
                float next = (float(2u * l - 1u) * d.z * p - float(l + m - 1u) * p_prev) / float(l - m);
                p_prev = p;
                p = next;
            }
            float k = SH_K[l * (l + 1u) / 2u + m];
            uint c = l * (l + 1u);
            if (m == 0u) {
                y[c] = k * p;
            } else {
                float s = 1.41421356237 * k * p;
                y[c + m] = s * re;
                y[c - m] = s * im;
            }
        }
    }
}

#ifdef SH_SPEC_BASIS
// The same basis with the band a specialisation constant LMAX (declared by the includer, with
// NC = (LMAX+1)²), written to the private array sh_y. Both loops have constant trip counts
// (the inner one skips l < m rather than starting at m), so NIR unrolls them, SH_K folds to
// constants and sh_y lives in registers: on llvmpipe this is 4x faster than sh_basis.
float sh_y[NC];
void sh_basis_spec(vec3 d) {
    float re = 1.0, im = 0.0, pmm = 1.0;
    for (uint m = 0u; m <= LMAX; m++) {
        if (m > 0u) {
            float r = re * d.x - im * d.y;
            im = re * d.y + im * d.x;
            re = r;
            pmm *= float(2u * m - 1u);
        }
        float p_prev = 0.0, p = pmm;
        for (uint l = 0u; l <= LMAX; l++) {
            if (l < m) continue;
            if (l == m + 1u) {
                p_prev = p;
                p = d.z * float(2u * m + 1u) * pmm;
            } else if (l > m + 1u) {
                float next = (float(2u * l - 1u) * d.z * p - float(l + m - 1u) * p_prev) / float(l - m);
                p_prev = p;
                p = next;
            }
            float k = SH_K[l * (l + 1u) / 2u + m];
            uint c = l * (l + 1u);
            if (m == 0u) {
                sh_y[c] = k * p;
            } else {
                float s = 1.41421356237 * k * p;
                sh_y[c + m] = s * re;
                sh_y[c - m] = s * im;
            }
        }
    }
}
#endif
#endif
