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
#endif
