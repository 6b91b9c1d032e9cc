// Footprint lookups, the twin of src/math/footprint.rs: the mean over a pixel's footprint
// from the dual-paraboloid chain by sub-pixel rays, and the light texels it covers. Included
// by shade.frag where it uses them, after its bindings, env_lookup, occluded and dp_lookup.
// What pixel q looks up where it sees what index `index` names (-1: the background): the
// reflected direction, or the view ray; false where it sees something else or lies outside.
bool looked_up(ivec2 q, float index, out vec3 d) {
    d = vec3(0.0);
    ivec2 size = textureSize(gbuf_normal, 0).xy;
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) return false;
    vec4 nrm = texelFetch(gbuf_normal, ivec3(q, 0), 0);
    if (nrm.w != index) return false;
    vec3 v = texelFetch(gbuf_view, ivec3(q, 0), 0).xyz;
    if (index < 0.0) {
        d = -v;
    } else {
        vec3 n = normalize(nrm.xyz);
        d = 2.0 * dot(v, n) * n - v;
    }
    return true;
}

// Twin of math::footprint::spread: the differential of the looked-up direction c along
// `step`, from the neighbours that see the same; `both`: both do (else it is one-sided, or
// zero).
vec3 spread(ivec2 q, ivec2 step, float index, vec3 c, out bool both) {
    vec3 m, p;
    bool hm = looked_up(q - step, index, m);
    bool hp = looked_up(q + step, index, p);
    both = hm && hp;
    vec3 d = hm && hp ? 0.5 * (p - m) : (hp ? p - c : (hm ? c - m : vec3(0.0)));
    return d - c * dot(c, d);
}

// What image point px looks up for a pixel that sees what `index` names (-1: the
// background): the ray's reflection off that object, or the ray itself where it meets nothing
// (background pixels: always); false where it meets another object (twin of
// math::footprint::camera_tap).
bool tap_dir(vec2 px, float index, out vec3 dir, out bool past) {
    vec3 o, d;
    camera_ray(cam[0], cam[1].xyz, cam[2].xyz, cam[3].xyz, cam[4].xy, px, o, d);
    dir = d;
    past = false;
    if (index < 0.0) return true;
    float best = 1e30;
    int hit = -1;
    vec3 hn = vec3(0.0);
    for (uint k = 0u; k < pc.count; k++) {
        vec3 n;
        float t = object_hit(objects[k], o, d, n);
        if (t > 0.0 && t < best) {
            best = t;
            hit = int(k);
            hn = n;
        }
    }
    // Past the edge of the shape the pixel sees: the background (math::footprint::camera_tap_seen).
    past = hit < 0;
    if (hit < 0) return true;
    if (float(hit) != index) return false;
    dir = d - 2.0 * dot(hn, d) * hn;
    return true;
}

// Twin of math::footprint::taps: taps along a and b.
uvec2 footprint_taps(float la, float lb) {
    float s = max(max(la, lb) / float(FOOTPRINT_MAX_TAPS), min(la, lb) / float(FOOTPRINT_MIN_TAPS));
    uint na = 1u, nb = 1u;
    if (s > 0.0) {
        na = clamp(uint(max(ceil(la / s - FOOTPRINT_TAP_SLACK), 0.0)), 1u, FOOTPRINT_MAX_TAPS);
        nb = clamp(uint(max(ceil(lb / s - FOOTPRINT_TAP_SLACK), 0.0)), 1u, FOOTPRINT_MAX_TAPS);
    }
    return uvec2(na, nb);
}

// Twin of math::footprint::lookup: the mean over pixel q's footprint from the chain, by a
// grid of sub-pixel rays (na along x, nb along y from the differentials a, b), each read at
// the lod whose texel is the taps' spacing; `past`: some tap saw past the shape's edge.
vec3 footprint_lookup(ivec2 q, float index, vec3 r, vec3 a, vec3 b, out bool past) {
    float la = length(a), lb = length(b);
    uvec2 nt = footprint_taps(la, lb);
    uint na = nt.x, nb = nt.y;
    float spacing = max(max(la / float(na), lb / float(nb)), FOOTPRINT_MIN_SPREAD);
    vec3 acc = vec3(0.0);
    uint n = 0u;
    past = false;
    for (uint j = 0u; j < nb; j++) {
        for (uint i = 0u; i < na; i++) {
            vec2 f = (vec2(i, j) + 0.5) / vec2(na, nb) - 0.5;
            vec3 d;
            bool p;
            if (!tap_dir(vec2(q) + 0.5 + f, index, d, p)) continue;
            past = past || p;
            float lod = 0.5 * log2(spacing * spacing / dp_texel_solid_angle(d, pc.dp_size));
            acc += dp_lookup(d, clamp(lod + FOOTPRINT_LOD_BIAS, 0.0, pc.max_lod));
            n++;
        }
    }
    if (n == 0u) {
        float lod = 0.5 * log2(spacing * spacing / dp_texel_solid_angle(r, pc.dp_size));
        return dp_lookup(r, clamp(lod + FOOTPRINT_LOD_BIAS, 0.0, pc.max_lod));
    }
    return acc / float(n);
}

// Length of [s - h, s + h] within [-1/2, 1/2].
float overlap(float s, float h) {
    return max(min(s + h, 0.5) - max(s - h, -0.5), 0.0);
}

// Twin of math::footprint::light_overlap: each light texel's excess times the share of the
// pixel it covers (the texel's square mapped to pixel coordinates by the footprint's inverse).
vec3 footprint_lights(vec3 r, vec3 a, vec3 b) {
    vec3 t, bt;
    shading_frame(r, t, bt);
    float j00 = dot(a, t), j01 = dot(b, t), j10 = dot(a, bt), j11 = dot(b, bt);
    float det = j00 * j11 - j01 * j10;
    bool point = abs(det) < FOOTPRINT_MIN_SPREAD * FOOTPRINT_MIN_SPREAD;
    // Rows of J^-1 and their lengths; k scales half sides so a texel's area is Ω/|det J|.
    float inv = point ? 0.0 : 1.0 / det;
    float i00 = j11 * inv, i01 = -j01 * inv, i10 = -j10 * inv, i11 = j00 * inv;
    float n0 = length(vec2(i00, i01)), n1 = length(vec2(i10, i11));
    float k = point ? 0.0 : 0.5 / sqrt(n0 * n1 * abs(det));
    float jn = length(vec4(j00, j01, j10, j11));
    vec3 sum = vec3(0.0);
    // The shares' total: the texels' squares do not tile the pixel, so where they overlap it
    // may pass 1, and the sum is divided by it.
    float total = 0.0;
    // One item per iteration, a texel of the current leaf or a node (as walk_step).
    uint i = 0u, j = 0u, end = 0u;
    for (uint step = 0u; step < pc.tree_nodes + pc.lights; step++) {
        bool done = j >= end && i >= pc.tree_nodes;
        if (walk_done(done)) break;
        if (done) continue;
        if (j < end) {
            uint q0 = j * pc.light_stride;
            j++;
            vec4 centre = lights[q0];
            vec4 light = lights[q0 + 1u];
            float cj = dot(centre.xyz, r);
            if (cj <= 0.0) continue;
            vec3 ej = centre.xyz / cj - r;
            float ejx = dot(ej, t), ejy = dot(ej, bt);
            float share;
            if (point) {
                float h = 0.5 * light.w;
                share = abs(ejx) <= h && abs(ejy) <= h ? 1.0 : 0.0;
            } else {
                float h = k * light.w;
                share = overlap(i00 * ejx + i01 * ejy, h * n0) * overlap(i10 * ejx + i11 * ejy, h * n1);
            }
            sum += share * light.rgb;
            total += share;
            continue;
        }
        uint at = pc.tree_at + i * LIGHT_TREE_VEC4S;
        vec4 node = lights[at];
        uvec4 range = uvec4(lights[at + 4u]);
        // Skip a node none of whose texels can touch the pixel (math::footprint::OverlapShape::misses).
        float c = dot(node.xyz, r), low = c - node.w;
        float rho = lights[at + 1u].w;
        float e_max = point ? 0.70710678 * rho
                            : jn * length(vec2(0.5 + k * rho * n0, 0.5 + k * rho * n1));
        bool miss = length(node.xyz - r) > node.w + e_max;
        if (!miss && low > 0.0) {
            float g = 0.5 * PI * node.w / (low * low);
            vec3 e = node.xyz / c - r;
            float ex = dot(e, t), ey = dot(e, bt);
            if (point) {
                float h = 0.5 * rho;
                miss = abs(ex) - g > h || abs(ey) - g > h;
            } else {
                float h = k * rho;
                miss = abs(i00 * ex + i01 * ey) - n0 * g >= 0.5 + h * n0
                    || abs(i10 * ex + i11 * ey) - n1 * g >= 0.5 + h * n1;
            }
        }
        if (miss) {
            i = range.z;
        } else if (range.y > LIGHT_LEAF_TEXELS) {
            i++;
        } else {
            j = range.x;
            end = range.x + range.y;
            i = range.z;
        }
    }
    return total > 1.0 ? sum / total : sum;
}

// Twin of math::footprint::silhouette_lights: on a silhouette pixel, the light texels per tap
// over a square about the tap's direction as wide as the taps' spacing, averaged.
vec3 silhouette_lights(ivec2 q, float index, vec3 a, vec3 b) {
    float la = length(a), lb = length(b);
    uvec2 nt = footprint_taps(la, lb);
    float spacing = max(max(la / float(nt.x), lb / float(nt.y)), FOOTPRINT_MIN_SPREAD);
    vec3 acc = vec3(0.0);
    uint n = 0u;
    for (uint j = 0u; j < nt.y; j++) {
        for (uint i = 0u; i < nt.x; i++) {
            vec2 f = (vec2(i, j) + 0.5) / vec2(nt) - 0.5;
            vec3 d, t, bt;
            bool past;
            if (!tap_dir(vec2(q) + 0.5 + f, index, d, past)) continue;
            shading_frame(d, t, bt);
            acc += footprint_lights(d, spacing * t, spacing * bt);
            n++;
        }
    }
    return acc / float(max(n, 1u));
}

// The pixel's mean radiance about r seen where `index` is seen (footprint filtering).
vec3 footprint_radiance(ivec2 q, float index, vec3 r) {
    bool along_a, along_b, past;
    vec3 a = spread(q, ivec2(1, 0), index, r, along_a);
    vec3 b = spread(q, ivec2(0, 1), index, r, along_b);
    vec3 l = footprint_lookup(q, index, r, a, b, past);
    // A silhouette (math::footprint::beside_other: a neighbour sees something else or lies
    // outside the image, or a tap sees past the shape's edge) takes its lights per tap.
    if ((pc.footprint & FOOTPRINT_LIGHTS) != 0u) {
        l += past || !(along_a && along_b) ? silhouette_lights(q, index, a, b)
                                           : footprint_lights(r, a, b);
    }
    return l;
}
