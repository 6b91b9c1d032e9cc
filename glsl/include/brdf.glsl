// BRDFs: evaluation, sampling, pdf and sample weight in the local frame (normal +z). Twin of
// src/math/brdf.rs, formula for formula; see there for what each material means.
#ifndef ENVLIGHT_BRDF_GLSL
#define ENVLIGHT_BRDF_GLSL
#include "generated.glsl"
#include "mappings.glsl"
#include "kernel.glsl"

struct Brdf {
    uint id;
    float p0;
    float p1;
};

// Whether the code of BRDF k is kept: a shader that includes this file may define
// BRDF_KEPT(k) from a specialisation constant so that BRDFs its draw never meets fold away
// (shade.frag: llvmpipe runs every branch of a loop's body).
#ifndef BRDF_KEPT
#define BRDF_KEPT(k) true
#endif

bool brdf_is(Brdf b, uint k) {
    return BRDF_KEPT(k) && b.id == k;
}

// Tangent ŷ × n (x̂ × n near the poles) and bitangent n × t.
void shading_frame(vec3 n, out vec3 t, out vec3 b) {
    vec3 a = abs(n.y) < POLE_THRESHOLD ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    t = normalize(cross(a, n));
    b = cross(n, t);
}

// Orthonormal completion of unit a (Duff et al. 2017).
void basis(vec3 a, out vec3 e1, out vec3 e2) {
    float s = a.z >= 0.0 ? 1.0 : -1.0;
    float p = -1.0 / (s + a.z);
    float q = a.x * a.y * p;
    e1 = vec3(1.0 + s * a.x * a.x * p, s * q, -s * a.x);
    e2 = vec3(q, s + a.y * a.y * p, -a.y);
}

float gap(vec3 a, vec3 b) {
    vec3 e = a - b;
    return 0.5 * dot(e, e);
}

float pow_from_gap(float k, float g) {
    return g >= 1.0 ? 0.0 : exp(k * log1m(g));
}

// e^x − 1 for x ≤ 0 without cancellation near 0.
float expm1_neg(float x) {
    if (x > -0.01) return x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))));
    return exp(x) - 1.0;
}

// Smallest first uniform the samplers take (log(0) is undefined in GLSL).
const float U_MIN = 1e-12;

vec3 sample_power_lobe(vec3 axis, float k, vec2 u) {
    float om = -expm1_neg(log(max(u.x, U_MIN)) / (k + 1.0));
    float s = sqrt(max(om * (2.0 - om), 0.0));
    vec3 e1, e2;
    basis(axis, e1, e2);
    float phi = TAU * u.y;
    return axis * (1.0 - om) + (e1 * cos(phi) + e2 * sin(phi)) * s;
}

// The Phong lobe about the reflection of wo: its f·cos θᵢ and its pdf alike.
float phong_lobe(float n, vec3 wo, vec3 wi) {
    vec3 r = vec3(-wo.x, -wo.y, wo.z);
    return (n + 1.0) / TAU * pow_from_gap(n, gap(r, wi));
}

vec3 reflect_about(vec3 wo, vec3 h) {
    return h * (2.0 * dot(wo, h)) - wo;
}

float ggx_d(float a, vec3 h) {
    float a2 = a * a;
    float s = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
    return a2 / (PI * s * s);
}

float ggx_root(float a, float c) {
    float a2 = a * a;
    return sqrt(a2 + (1.0 - a2) * c * c);
}

float ggx_g1(float a, float c) {
    return 2.0 * c / (c + ggx_root(a, c));
}

float ward_exponent(float ax, float ay, vec3 h) {
    float x = h.x / ax, y = h.y / ay;
    return -(x * x + y * y) / (h.z * h.z);
}

float brdf_eval_cos(Brdf b, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    if (brdf_is(b, BRDF_LAMBERT)) return wi.z / PI;
    if (brdf_is(b, BRDF_PHONG)) return phong_lobe(b.p0, wo, wi);
    if (brdf_is(b, BRDF_BLINN)) {
        vec3 h = normalize(wo + wi);
        return (b.p0 + 8.0) / (8.0 * PI) * pow_from_gap(b.p0, gap(h, vec3(0.0, 0.0, 1.0))) * wi.z;
    }
    if (brdf_is(b, BRDF_GGX)) {
        float a = max(b.p0, GGX_ALPHA_MIN);
        vec3 h = normalize(wo + wi);
        float g = b.p1 != 0.0
            ? 2.0 * wo.z * wi.z / (ggx_root(a, wo.z) * wi.z + ggx_root(a, wi.z) * wo.z)
            : ggx_g1(a, wo.z) * ggx_g1(a, wi.z);
        return ggx_d(a, h) * g / (4.0 * wo.z);
    }
    if (brdf_is(b, BRDF_WARD)) {
        vec3 h = normalize(wo + wi);
        return exp(ward_exponent(b.p0, b.p1, h)) / (4.0 * PI * b.p0 * b.p1 * sqrt(wi.z * wo.z)) * wi.z;
    }
    return 0.0;  // mirror: a delta
}

vec3 brdf_sample(Brdf b, vec3 wo, vec2 u) {
    if (brdf_is(b, BRDF_LAMBERT)) {
        float r = sqrt(u.x), phi = TAU * u.y;
        return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
    }
    if (brdf_is(b, BRDF_PHONG)) return sample_power_lobe(vec3(-wo.x, -wo.y, wo.z), b.p0, u);
    if (brdf_is(b, BRDF_BLINN)) return reflect_about(wo, sample_power_lobe(vec3(0.0, 0.0, 1.0), b.p0, u));
    if (brdf_is(b, BRDF_GGX)) {
        float a = max(b.p0, GGX_ALPHA_MIN);
        vec3 vh = normalize(vec3(a * wo.x, a * wo.y, wo.z));
        float lensq = vh.x * vh.x + vh.y * vh.y;
        vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) / sqrt(lensq) : vec3(1.0, 0.0, 0.0);
        vec3 t2 = cross(vh, t1);
        float r = sqrt(u.x), phi = TAU * u.y;
        float p1 = r * cos(phi);
        float s = 0.5 * (1.0 + vh.z);
        float p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
        vec3 nh = t1 * p1 + t2 * p2 + vh * sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0));
        vec3 h = normalize(vec3(a * nh.x, a * nh.y, max(nh.z, 0.0)));
        return reflect_about(wo, h);
    }
    if (brdf_is(b, BRDF_WARD)) {
        float phi = TAU * u.y;
        float ps = b.p1 * sin(phi), pc = b.p0 * cos(phi);
        float len = sqrt(ps * ps + pc * pc);
        float sp = ps / len, cp = pc / len;
        float tan2 = -log(max(u.x, U_MIN)) / (cp * cp / (b.p0 * b.p0) + sp * sp / (b.p1 * b.p1));
        float t = sqrt(tan2);
        return reflect_about(wo, normalize(vec3(t * cp, t * sp, 1.0)));
    }
    return vec3(-wo.x, -wo.y, wo.z);  // mirror
}

float brdf_pdf(Brdf b, vec3 wo, vec3 wi) {
    if (brdf_is(b, BRDF_LAMBERT)) return max(wi.z, 0.0) / PI;
    if (brdf_is(b, BRDF_PHONG)) return phong_lobe(b.p0, wo, wi);
    if (brdf_is(b, BRDF_BLINN)) {
        vec3 h = normalize(wo + wi);
        float oh = dot(wo, h);
        if (oh <= 0.0 || h.z <= 0.0) return 0.0;
        return (b.p0 + 1.0) / TAU * pow_from_gap(b.p0, gap(h, vec3(0.0, 0.0, 1.0))) / (4.0 * oh);
    }
    if (brdf_is(b, BRDF_GGX)) {
        if (wo.z <= 0.0) return 0.0;
        float a = max(b.p0, GGX_ALPHA_MIN);
        vec3 h = normalize(wo + wi);
        if (h.z <= 0.0) return 0.0;
        return ggx_g1(a, wo.z) * ggx_d(a, h) / (4.0 * wo.z);
    }
    if (brdf_is(b, BRDF_WARD)) {
        vec3 h = normalize(wo + wi);
        float oh = dot(wo, h);
        if (oh <= 0.0 || h.z <= 0.0) return 0.0;
        return exp(ward_exponent(b.p0, b.p1, h)) / (4.0 * PI * b.p0 * b.p1 * h.z * h.z * h.z * oh);
    }
    return 0.0;
}

float brdf_weight(Brdf b, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    if (brdf_is(b, BRDF_BLINN)) {
        vec3 h = normalize(wo + wi);
        return max((b.p0 + 8.0) / (b.p0 + 1.0) * wi.z * dot(wo, h), 0.0);
    }
    if (brdf_is(b, BRDF_GGX)) {
        float a = max(b.p0, GGX_ALPHA_MIN);
        if (b.p1 != 0.0) {
            float ro = ggx_root(a, wo.z), ri = ggx_root(a, wi.z);
            return wi.z * (wo.z + ro) / (ro * wi.z + ri * wo.z);
        }
        return ggx_g1(a, wi.z);
    }
    if (brdf_is(b, BRDF_WARD)) {
        vec3 h = normalize(wo + wi);
        return max(h.z * h.z * h.z * dot(wo, h) * sqrt(wi.z / wo.z), 0.0);
    }
    return 1.0;
}

// The view direction in the local frame, lifted to 1e-4 above the surface where float32
// silhouettes put it at or below (the same rule as src/math/brdf.rs's local_view).
vec3 local_view(vec3 v, vec3 t, vec3 bt, vec3 n) {
    vec3 wo = vec3(dot(v, t), dot(v, bt), dot(v, n));
    if (wo.z < VIEW_LIFT) {
        wo.z = VIEW_LIFT;
        wo = normalize(wo);
    }
    return wo;
}
#endif
