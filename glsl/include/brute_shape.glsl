// The tilted rule's per-texel shapes, read (brute_moments.comp, brute.comp); a kernel
// declares the `shapes` image before including it.
#ifndef ENVLIGHT_BRUTE_SHAPE_GLSL
#define ENVLIGHT_BRUTE_SHAPE_GLSL
// Vec4 k of prepared texel t's shape (0: centroid and regularity, 1 and 2: half-edges): three
// layers a source layer.
vec4 shape(ivec3 t, int k) {
    return imageLoad(shapes, ivec3(t.xy, 3 * t.z + k));
}
#endif
