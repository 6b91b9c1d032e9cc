// Sample sequences (twin of src/math/sequence.rs, bit for bit).
#ifndef ENVLIGHT_SEQUENCE_GLSL
#define ENVLIGHT_SEQUENCE_GLSL

// Radical inverse in base 2, to 24 bits so that float32 holds it exactly.
float radical_inverse(uint i) {
    return float(bitfieldReverse(i) >> 8u) * (1.0 / 16777216.0);
}

vec2 hammersley(uint i, uint n) {
    return vec2((float(i) + 0.5) / float(n), radical_inverse(i));
}

uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float unit_float(uint h) {
    return float(h >> 8u) * (1.0 / 16777216.0);
}

vec2 pixel_offset(uvec2 p) {
    uint h = pcg(p.x + pcg(p.y));
    return vec2(unit_float(h), unit_float(pcg(h)));
}

vec2 rotate_sample(vec2 u, vec2 offset) {
    vec2 s = u + offset;
    return vec2(s.x >= 1.0 ? s.x - 1.0 : s.x, s.y >= 1.0 ? s.y - 1.0 : s.y);
}

uint rng_init(uvec2 p, uint index, uint seed) {
    return pcg(pcg(pcg(p.x + pcg(p.y)) + index) ^ seed);
}

float rng_next(inout uint state) {
    state = pcg(state);
    return unit_float(state);
}
#endif
