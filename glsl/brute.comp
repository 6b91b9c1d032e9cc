#version 460
// Brute-force convolution of a whole map with the clamped cosine or a normalised Phong lobe
// (Miller & Hoffman 1984), the float64 twin being src/math/filter.rs. Built five ways:
// - PREPARE: one invocation per source texel writes its centre direction (world), the cosine of
//   its angular radius, its radiance and its exact solid angle (0 where it holds no sphere),
//   and its shape for the tilted rule;
// - TILES: one invocation per tile of BRUTE_TILE² source texels writes a cone bounding all
//   its texels' cones (w = 2 when it holds none);
// - MOMENTS: one invocation per texel of level src_level of the power-moment pyramid (2^s × 2^s
//   prepared texels each) writes its cone and, per channel, its light's power and the uniform
//   parallelogram with the light's centroid and covariance (twin of moments::MomentLevel::new);
// - otherwise: one invocation per output texel and part of the source sums L·∫K over the
//   part's texels, choosing per texel the same rule as the CPU (skip, centre node, the tilted
//   rule, or s×s cells of 3×3 Gauss points, on CPU devices those last in a second walk),
//   with Kahan compensation so a sun 1e5 times the sky does not swamp the sum, into its
//   partial sum; parts let a small output (a coarse Phong level) fill the device. The source
//   is taken in chunks, one dispatch each, accumulating into the partial sums, so that no
//   invocation runs more loop iterations than llvmpipe allows
//   (DeviceInfo::loop_iteration_limit); the node loops are unrolled for the same reason;
// - RESOLVE: one invocation per output texel adds its parts' sums into the map. Texels are
//   walked tile by tile ("slots": tile-major, BRUTE_TILE² per tile, the chunks count slots),
//   and a tile whose cone lies wholly where the rule skips texels is skipped whole: every
//   texel in it would have been skipped, so the sum is the same, term for term.
// Per-texel data (cones, radiance, shapes, a level's light) are rgba32f image arrays: llvmpipe
// loads a storage buffer's element lane by lane behind a branch each, an image's texel as one
// gather; the loads were half of the texel loop's time (Phong 2049 into a cube 32: 580 ->
// 443 ms of GPU).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

#if defined(TILES)
layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_TILE_CONES, rgba32f) uniform readonly image2DArray cones;
layout(std430, set = 0, binding = BINDING_BRUTE_TILE_OUT) writeonly buffer Tiles { vec4 tiles[]; };
#elif defined(MOMENTS)
layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_MOM_RADIANCE, rgba32f) uniform readonly image2DArray rad;
layout(set = 0, binding = BINDING_BRUTE_MOM_SHAPES, rgba32f) uniform readonly image2DArray shapes;
layout(set = 0, binding = BINDING_BRUTE_MOM_CONES, rgba32f) uniform writeonly image2DArray cones;
layout(set = 0, binding = BINDING_BRUTE_MOM_LIGHT, rgba32f) uniform writeonly image2DArray light;
#elif defined(RESOLVE)
layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_BRUTE_RESOLVE_PARTIALS) readonly buffer Partials { vec4 partials[]; };
layout(set = 0, binding = BINDING_BRUTE_RESOLVE_DST, rgba32f) uniform writeonly image2DArray dst;
#elif defined(PREPARE)
layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_PREP_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_BRUTE_PREP_CONES, rgba32f) uniform writeonly image2DArray cones;
layout(set = 0, binding = BINDING_BRUTE_PREP_RADIANCE, rgba32f) uniform writeonly image2DArray rad;
layout(set = 0, binding = BINDING_BRUTE_PREP_SHAPES, rgba32f) uniform writeonly image2DArray shapes;
#else
layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_CONES, rgba32f) uniform readonly image2DArray cones;
layout(set = 0, binding = BINDING_BRUTE_RADIANCE, rgba32f) uniform readonly image2DArray rad;
layout(std430, set = 0, binding = BINDING_BRUTE_PARTIALS) buffer Partials { vec4 partials[]; };
layout(std430, set = 0, binding = BINDING_BRUTE_TILES) readonly buffer Tiles { vec4 tiles[]; };
layout(set = 0, binding = BINDING_BRUTE_SHAPES, rgba32f) uniform readonly image2DArray shapes;
layout(set = 0, binding = BINDING_BRUTE_COARSE_CONES, rgba32f) uniform readonly image2DArray coarse_cones;
layout(set = 0, binding = BINDING_BRUTE_LIGHT, rgba32f) uniform readonly image2DArray light;
#endif

// The push block, generated from src/abi.rs.
PUSH_BrutePush

#if defined(MOMENTS) || !(defined(TILES) || defined(RESOLVE) || defined(PREPARE))
// Vec4 k of prepared texel t's shape (0: centroid and regularity, 1 and 2: half-edges): three
// layers a source layer.
vec4 shape(ivec3 t, int k) {
    return imageLoad(shapes, ivec3(t.xy, 3 * t.z + k));
}
#endif

// Source and destination mappings are specialisation constants (they equal the push block's):
// other mappings' branches, the disc rim's clipped rule above all, vanish from the texel loop,
// which llvmpipe then runs several times faster.
layout(constant_id = 2) const uint SRC_MAPPING = 0u;
layout(constant_id = 3) const uint DST_MAPPING = 0u;
// Whether the sum runs over a level of the moment pyramid (pc.src_size is then that level's
// size, and the prepared texels are pc.src_level levels finer).
layout(constant_id = 4) const bool MOMENT_SOURCE = false;
// Whether texels that take Gauss cells wait for a second walk (CPU devices; see cells_wanted).
// A GPU takes every rule in one walk: a branch no lane of a warp takes costs it nothing, and
// the second walk's code cost the H100 registers (Phong n = 2049, cube 64: 41 -> 59 ms).
layout(constant_id = 5) const bool CELLS_WALK = false;
// Invocations per output texel (CPU devices: the SIMD width; 1 elsewhere), each summing every
// TEXEL_LANES-th slot into its own part: of each tile (walk), or of each row's columns within
// the lobe's reach in a lat-long source, whose slots are then its texels, row-major
// (walk_rows).
layout(constant_id = 6) const uint TEXEL_LANES = 1u;

// The size of the prepared (finest) texels.
uvec2 fine_size() {
    return pc.src_size << pc.src_level;
}

vec3 to_world(vec3 f) {
    return vec3(dot(pc.file_to_world[0].xyz, f), dot(pc.file_to_world[1].xyz, f), dot(pc.file_to_world[2].xyz, f));
}

vec3 src_dir(uint layer, vec2 uv) {
    Coord c;
    c.layer = layer;
    c.uv = uv;
    return to_world(coord_to_dir(SRC_MAPPING, c));
}

bool rim_cut(ivec2 p) {
    if (SRC_MAPPING != MAPPING_ANGULAR && SRC_MAPPING != MAPPING_DUAL_PARABOLOID) return false;
    vec2 lo = 2.0 * vec2(p) / vec2(fine_size()) - 1.0;
    vec2 hi = 2.0 * vec2(p + 1) / vec2(fine_size()) - 1.0;
    vec2 f = max(abs(lo), abs(hi));
    return dot(f, f) > 1.0;
}

// Tiles per row and per layer of the source.
uvec2 tile_grid() {
    return (pc.src_size + BRUTE_TILE - 1u) / BRUTE_TILE;
}

// Tile `tile`'s first texel (x, y) and its layer: divisions by values known only at run
// time, once a tile rather than once a texel.
uvec3 tile_origin(uint tile) {
    uvec2 g = tile_grid();
    uvec2 lr = div_rem(tile, g.x * g.y);
    uvec2 yx = div_rem(lr.y, g.x);
    return uvec3(uvec2(yx.y, yx.x) * BRUTE_TILE, lr.x);
}

// The texel (column, row, layer) in slot s of the tile at `origin` (tile_origin), or x = -1
// where the tile overhangs the map's edge.
ivec3 slot_texel(uvec3 origin, uint s) {
    uvec2 q = origin.xy + uvec2(s % BRUTE_TILE, s / BRUTE_TILE);
    if (any(greaterThanEqual(q, pc.src_size))) return ivec3(-1);
    return ivec3(q, origin.z);
}

// Output texels in all layers.
uint dst_texels() {
    return pc.dst_size.x * pc.dst_size.y * mapping_layers(DST_MAPPING);
}

// Kahan summation, so a sun 1e5 times the sky does not swamp the sum.
void kahan_add(inout vec3 sum, inout vec3 comp, vec3 term) {
    precise vec3 y = term - comp;
    precise vec3 t = sum + y;
    comp = (t - sum) - y;
    sum = t;
}

#if defined(PREPARE) || defined(MOMENTS)
// The square root of a symmetric positive semi-definite 2×2 matrix (a, b, c) = [a b; b c].
vec3 sqrt2(vec3 m) {
    float d = sqrt(max(m.x * m.z - m.y * m.y, 0.0));
    float t = sqrt(m.x + m.z + 2.0 * d);
    return t > 0.0 ? vec3(m.x + d, m.y, m.z + d) / t : vec3(0.0);
}

// Texel p's centre direction (world) and the cosine of its angular radius: corners and edge
// midpoints (pulled into the disc), 25% wider for the bulge of the edges between them (twin of
// texel_cos_radius), for a texel of a pc.src_size map.
vec4 texel_cone(uint layer, ivec2 p) {
    vec3 c = src_dir(layer, (vec2(p) + 0.5) / vec2(pc.src_size));
    // Angular radius: corners and edge midpoints (pulled into the disc), 25% wider for the
    // bulge of the edges between them (twin of texel_cos_radius).
    bool disc = SRC_MAPPING == MAPPING_ANGULAR || SRC_MAPPING == MAPPING_DUAL_PARABOLOID;
    float min_dot = 1.0;
    for (int k = 0; k < 9; k++) {
        if (k == 4) continue;
        vec2 uv = (vec2(p) + 0.5 * vec2(k % 3, k / 3)) / vec2(pc.src_size);
        if (disc) {
            vec2 xy = 2.0 * uv - 1.0;
            float rr = length(xy);
            if (rr > 1.0) uv = 0.5 * (xy / rr + 1.0);
        }
        min_dot = min(min_dot, dot(c, src_dir(layer, uv)));
    }
    // acos via atan2 so a tiny radius keeps its digits.
    float md = clamp(min_dot, -1.0, 1.0);
    float rho = min(FILTER_CONE_MARGIN * atan2_precise(sqrt(max(0.0, (1.0 - md) * (1.0 + md))), md), PI);
    return vec4(c, cos(rho));
}

#endif

#if defined(TILES)
void main() {
    uint tile = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    uvec2 g = tile_grid();
    if (tile >= g.x * g.y * pc.src_layers) return;
    // Axis: the mean of the texel centres; radius: the farthest texel cone edge from it.
    uvec3 origin = tile_origin(tile);
    vec3 sum = vec3(0.0);
    for (uint s = 0u; s < BRUTE_TILE * BRUTE_TILE; s++) {
        ivec3 t = slot_texel(origin, s);
        if (t.x < 0) continue;
        vec4 c = imageLoad(cones, t);
        if (c.w <= 1.0) sum += c.xyz;
    }
    if (dot(sum, sum) == 0.0) {
        tiles[tile] = vec4(0.0, 0.0, 1.0, 2.0);
        return;
    }
    vec3 axis = normalize(sum);
    float radius = 0.0;
    for (uint s = 0u; s < BRUTE_TILE * BRUTE_TILE; s++) {
        ivec3 t = slot_texel(origin, s);
        if (t.x < 0) continue;
        vec4 c = imageLoad(cones, t);
        if (c.w > 1.0) continue;
        float d = clamp(dot(axis, c.xyz), -1.0, 1.0);
        float apart = atan2_precise(length(cross(axis, c.xyz)), d);
        float cr = clamp(c.w, -1.0, 1.0);
        radius = max(radius, apart + atan2_precise(sqrt(max(0.0, (1.0 - cr) * (1.0 + cr))), cr));
    }
    // A relative and an absolute margin cover f32 rounding in the angles, so the tile's
    // bound is never tighter than its texels' own.
    radius = min(radius * (1.0 + FILTER_TILE_MARGIN_REL) + FILTER_TILE_MARGIN_ABS, PI);
    tiles[tile] = vec4(axis, cos(radius));
}
#elif defined(MOMENTS)
// Per channel c: the centroid ∑ P·c_f normalised over the fine texels f, then the covariance in
// the tangent plane there, ∑ P·((e·c_f)(e′·c_f) + eᵀΣ_f e′) / ∑ P with Σ_f = (hu huᵀ + hv hvᵀ)/3,
// taken directly (no difference of large second moments), and the parallelogram √3·Σ^½.
void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    if (i >= pc.texels) return;
    uint per_layer = pc.src_size.x * pc.src_size.y;
    uint layer = i / per_layer, r = i % per_layer;
    ivec2 p = ivec2(r % pc.src_size.x, r / pc.src_size.x);
    imageStore(cones, ivec3(p, layer), texel_cone(layer, p));
    uint side = 1u << pc.src_level;
    uvec2 base = uvec2(p) * side;
    vec3 power = vec3(0.0);
    vec3 m1[3] = vec3[3](vec3(0.0), vec3(0.0), vec3(0.0));
    for (uint k = 0u; k < side * side; k++) {
        ivec2 q = ivec2(base + uvec2(k % side, k / side));
        vec4 rt = imageLoad(rad, ivec3(q, layer));
        vec3 pw = rt.rgb * rt.w;
        vec3 c = shape(ivec3(q, layer), 0).xyz;
        power += pw;
        m1[0] += pw.r * c;
        m1[1] += pw.g * c;
        m1[2] += pw.b * c;
    }
    for (int ch = 0; ch < 3; ch++) {
        // Layers 9·layer + 3·ch + 0, 1, 2 hold this channel's three vec4.
        int o = int(9u * layer) + 3 * ch;
        if (!(power[ch] > 0.0) || dot(m1[ch], m1[ch]) == 0.0) {
            imageStore(light, ivec3(p, o), vec4(0.0));
            imageStore(light, ivec3(p, o + 1), vec4(0.0));
            imageStore(light, ivec3(p, o + 2), vec4(0.0));
            continue;
        }
        vec3 cen = normalize(m1[ch]);
        vec3 e1 = normalize(abs(cen.x) < 0.9 ? cross(cen, vec3(1.0, 0.0, 0.0)) : cross(cen, vec3(0.0, 1.0, 0.0)));
        vec3 e2 = cross(cen, e1);
        vec3 cov = vec3(0.0);
        for (uint k = 0u; k < side * side; k++) {
            ivec2 q = ivec2(base + uvec2(k % side, k / side));
            vec4 rt = imageLoad(rad, ivec3(q, layer));
            float pw = rt[ch] * rt.w;
            ivec3 f = ivec3(q, layer);
            vec3 c = shape(f, 0).xyz, hu = shape(f, 1).xyz, hv = shape(f, 2).xyz;
            vec2 a = vec2(dot(e1, c), dot(e2, c));
            vec2 u = vec2(dot(e1, hu), dot(e2, hu));
            vec2 v = vec2(dot(e1, hv), dot(e2, hv));
            cov += pw * (vec3(a.x * a.x, a.x * a.y, a.y * a.y)
                + vec3(u.x * u.x + v.x * v.x, u.x * u.y + v.x * v.y, u.y * u.y + v.y * v.y) / 3.0);
        }
        vec3 sq = sqrt2(cov / power[ch]) * sqrt(3.0);
        imageStore(light, ivec3(p, o), vec4(cen, power[ch]));
        imageStore(light, ivec3(p, o + 1), vec4(e1 * sq.x + e2 * sq.y, 0.0));
        imageStore(light, ivec3(p, o + 2), vec4(e1 * sq.y + e2 * sq.z, 0.0));
    }
}
#elif defined(PREPARE)

// The tilted rule's view of texel p (twin of filter::texel_shape): the centroid of its solid
// angle from its 3×3 Gauss nodes, its half-edges mapped so that their parallelogram has the
// texel's covariance, and whether the texel is regular (w of the first vec4).
void write_shape(uint layer, ivec2 p) {
    vec3 sum = vec3(0.0);
    vec3 d[9];
    float wq[9];
    [[unroll]] for (int k = 0; k < 9; k++) {
        vec2 ab = vec2(k % 3 - 1, k / 3 - 1);
        vec2 uv = (vec2(p) + 0.5 + 0.387298335 * ab) / vec2(pc.src_size);
        vec2 gw = mix(vec2(8.0 / 18.0), vec2(5.0 / 18.0), abs(ab));
        wq[k] = gw.x * gw.y * density(SRC_MAPPING, uv);
        d[k] = coord_to_dir(SRC_MAPPING, Coord(layer, uv));
        sum += wq[k] * d[k];
    }
    vec2 size = vec2(pc.src_size);
    vec3 c = dot(sum, sum) > 0.0 ? normalize(sum) : coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + 0.5) / size));
    vec3 hu = coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(1.0, 0.5)) / size))
        - coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(0.0, 0.5)) / size));
    vec3 hv = coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(0.5, 1.0)) / size))
        - coord_to_dir(SRC_MAPPING, Coord(layer, (vec2(p) + vec2(0.5, 0.0)) / size));
    hu = 0.5 * (hu - c * dot(hu, c));
    hv = 0.5 * (hv - c * dot(hv, c));
    float dmin = 3.4e38, dmax = 0.0;
    for (int k = 0; k < 9; k++) {
        float dk = density(SRC_MAPPING, (vec2(p) + 0.5 * vec2(k % 3, k / 3)) / size);
        dmin = min(dmin, dk);
        dmax = max(dmax, dk);
    }
    bool regular = !rim_cut(p) && dmin > 0.0 && dmax <= FILTER_TILT_DENSITY_RATIO * dmin;
    if (regular) {
        vec3 e1 = normalize(abs(c.x) < 0.9 ? cross(c, vec3(1.0, 0.0, 0.0)) : cross(c, vec3(0.0, 1.0, 0.0)));
        vec3 e2 = cross(c, e1);
        float wsum = 0.0;
        vec3 cov = vec3(0.0);
        for (int k = 0; k < 9; k++) {
            vec3 y = d[k] - c * dot(d[k], c);
            vec2 q = vec2(dot(y, e1), dot(y, e2));
            cov += wq[k] * vec3(q.x * q.x, q.x * q.y, q.y * q.y);
            wsum += wq[k];
        }
        cov /= wsum;
        vec2 a = vec2(dot(hu, e1), dot(hu, e2)), b = vec2(dot(hv, e1), dot(hv, e2));
        vec3 par = vec3(a.x * a.x + b.x * b.x, a.x * a.y + b.x * b.y, a.y * a.y + b.y * b.y) / 3.0;
        vec3 sq = sqrt2(cov), sp = sqrt2(par);
        float det = sp.x * sp.z - sp.y * sp.y;
        if (det > 0.0) {
            vec3 ip = vec3(sp.z, -sp.y, sp.x) / det;
            mat2 m = mat2(sq.x * ip.x + sq.y * ip.y, sq.y * ip.x + sq.z * ip.y,
                          sq.x * ip.y + sq.y * ip.z, sq.y * ip.y + sq.z * ip.z);
            vec2 ma = m * a, mb = m * b;
            hu = e1 * ma.x + e2 * ma.y;
            hv = e1 * mb.x + e2 * mb.y;
        } else {
            regular = false;
        }
    }
    int l = int(3u * layer);
    imageStore(shapes, ivec3(p, l), vec4(to_world(c), regular ? 1.0 : 0.0));
    imageStore(shapes, ivec3(p, l + 1), vec4(to_world(hu), 0.0));
    imageStore(shapes, ivec3(p, l + 2), vec4(to_world(hv), 0.0));
}

void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    if (i >= pc.texels) return;
    uint per_layer = pc.src_size.x * pc.src_size.y;
    uint layer = i / per_layer, r = i % per_layer;
    ivec2 p = ivec2(r % pc.src_size.x, r / pc.src_size.x);
    ivec2 source = integration_source(SRC_MAPPING, pc.src_size, p);
    if (source.x < 0) {
        imageStore(cones, ivec3(p, layer), vec4(0.0, 0.0, 1.0, 1.0));
        imageStore(rad, ivec3(p, layer), vec4(0.0));
        return;
    }
    imageStore(cones, ivec3(p, layer), texel_cone(layer, p));
    float omega = texel_solid_angle(SRC_MAPPING, pc.src_size, p);
    imageStore(rad, ivec3(p, layer), vec4(texelFetch(src, ivec3(source, int(layer)), 0).rgb, omega));
    write_shape(layer, p);
}
#elif defined(RESOLVE)

// One invocation per output texel adds its parts' sums in part order (deterministic), each
// part's compensation too, and writes the texel.
void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    if (DST_MAPPING == MAPPING_ANGULAR && !texel_in_domain(DST_MAPPING, pc.dst_size, ivec2(id.xy))) {
        imageStore(dst, ivec3(id), vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    uint o = (id.z * pc.dst_size.y + id.y) * pc.dst_size.x + id.x;
    uint parts = pc.parts.x * pc.parts.y;
    precise vec3 sum = partials[2u * o].rgb;
    precise vec3 comp = partials[2u * o + 1u].rgb;
    for (uint k = 1u; k < parts; k++) {
        uint e = 2u * (k * dst_texels() + o);
        kahan_add(sum, comp, partials[e].rgb);
        kahan_add(sum, comp, -partials[e + 1u].rgb);
    }
    imageStore(dst, ivec3(id), vec4(sum - comp, 1.0));
}
#else

// Mean of the kernel over prepared texel t (column, row, layer) split into s×s cells of 3×3
// Gauss points, or over the clipped rule (pieces and chords split s ways, s ≤ 4) when a
// disc's rim cuts it.
float texel_mean(vec3 axis, ivec3 t, uint s) {
    uint layer = uint(t.z);
    ivec2 p = t.xy;
    float acc = 0.0, wsum = 0.0;
    // Only a disc's rim cuts texels: the rule's 8×8 nodes unrolled more than double the module
    // and lavapipe's build time (ShaderId::BruteDisc).
#if defined(DISC_SOURCE)
    if (rim_cut(p)) {
        uint split = min(s, 4u);
        vec2 lo = 2.0 * vec2(p) / vec2(fine_size()) - 1.0;
        vec2 hi = 2.0 * vec2(p + 1) / vec2(fine_size()) - 1.0;
        float xs[6];
        int cnt = clipped_breaks(lo, hi, xs);
        for (int pi = 0; pi + 1 < cnt; pi++) {
            int parts = max(int(ceil((xs[pi + 1] - xs[pi]) * 4.0)), 1) * int(split);
            float hx = 0.5 * (xs[pi + 1] - xs[pi]) / float(parts);
            for (int q = 0; q < parts; q++) {
                float x0 = xs[pi] + 2.0 * hx * float(q);
                [[unroll]] for (int a = 0; a < 8; a++) {
                    float u = 0.5 + 0.5 * (a < 4 ? -1.0 : 1.0) * GL8_X[a & 3];
                    float x = x0 + 2.0 * hx * u * u * (3.0 - 2.0 * u);
                    float jac = 6.0 * u * (1.0 - u);
                    if (abs(x) >= 1.0) continue;
                    float e = sqrt((1.0 - x) * (1.0 + x));
                    float ya = max(lo.y, -e), yb = min(hi.y, e);
                    if (yb <= ya) continue;
                    float hy = 0.5 * (yb - ya) / float(split);
                    for (uint sp = 0u; sp < split; sp++) {
                        float my = ya + hy * float(2u * sp + 1u);
                        [[unroll]] for (int b = 0; b < 8; b++) {
                            vec2 pt = vec2(x, my + hy * (b < 4 ? -1.0 : 1.0) * GL8_X[b & 3]);
                            vec2 uv = 0.5 * (pt + 1.0);
                            float w = GL8_W[a & 3] * GL8_W[b & 3] * hx * hy * jac * density(SRC_MAPPING, uv);
                            acc += w * kernel_eval(pc.exponent, axis, src_dir(layer, uv));
                            wsum += w;
                        }
                    }
                }
            }
        }
    } else
#endif
    {
        // s×s cells in one loop, 3-point Gauss-Legendre per cell side (twin of
        // filter::for_each_node), the nine nodes unrolled.
        for (uint cell = 0u; cell < s * s; cell++) {
            vec2 corner = vec2(p) + vec2(cell % s, cell / s) / float(s);
            [[unroll]] for (int b = -1; b <= 1; b++) {
                [[unroll]] for (int a = -1; a <= 1; a++) {
                    vec2 ab = vec2(a, b);
                    vec2 uv = (corner + (0.5 + 0.387298335 * ab) / float(s)) / vec2(fine_size());
                    vec2 gw = mix(vec2(8.0 / 18.0), vec2(5.0 / 18.0), abs(ab));
                    float w = gw.x * gw.y * density(SRC_MAPPING, uv);
                    acc += w * kernel_eval(pc.exponent, axis, src_dir(layer, uv));
                    wsum += w;
                }
            }
        }
    }
    return wsum > 0.0 ? acc / wsum : -1.0;
}


// The tilted rule (twin of filter::tilted_mean): the mean of K over texel t taken as the
// uniform parallelogram of its shape, ln K linear across it plus the curvature's mean.
// ln(sinh z / z), E[s] = coth z − 1/z and E[s²] = 1 − 2E[s]/z (s uniform on [−1, 1] tilted
// by e^{zs}) take series below |z| = FILTER_TILT_SERIES_BELOW, where the closed forms cancel in f32, as the twin
// does; above it they share e^{−2|z|} per axis and one log for both axes, because llvmpipe
// evaluates both sides of every branch and transcendentals dominate this loop.
float tilted_shape(vec3 axis, float n, float ln_scale, vec3 c, vec3 hu, vec3 hv) {
    vec3 e = axis - c;
    float gap = 0.5 * dot(e, e);
    float x = 1.0 - gap;
    if (x <= 0.0) return 0.0;
    float bu = dot(e, hu), bv = dot(e, hv);
    vec2 z = n * vec2(bu, bv) / x;
    vec2 a = abs(z);
    vec2 z2 = z * z;
    bvec2 small = lessThan(a, vec2(FILTER_TILT_SERIES_BELOW));
    vec2 big = max(a, vec2(FILTER_TILT_SERIES_BELOW));
    vec2 ex = exp(-2.0 * big);
    // ln sinhc: series, or |z| + ln((1 − e^{−2|z|}) / (2|z|)) with one log for both axes.
    vec2 series = z2 * (1.0 / 6.0 - z2 * (1.0 / 180.0 - z2 * (1.0 / 2835.0 - z2 / 37800.0)));
    vec2 ratio = mix((1.0 - ex) / (2.0 * big), vec2(1.0), small);
    float ln_sinhc = dot(mix(big, series, small), vec2(1.0)) + log(ratio.x * ratio.y);
    vec2 m1_series = z * (1.0 / 3.0 - z2 * (1.0 / 45.0 - z2 * (2.0 / 945.0 - z2 / 4725.0)));
    vec2 m1_closed = sign(z) * ((1.0 + ex) / (1.0 - ex) - 1.0 / big);
    vec2 m1 = mix(m1_closed, m1_series, small);
    vec2 m2_series = 1.0 / 3.0 + z2 * (2.0 / 45.0 - z2 * (4.0 / 945.0 - z2 * 2.0 / 4725.0));
    vec2 m2 = mix(1.0 - 2.0 * m1_closed * sign(z) / big, m2_series, small);
    float x2 = x * x;
    float q = (dot(hu, hu) + bu * bu / x2) * m2.x + (dot(hv, hv) + bv * bv / x2) * m2.y
        + 2.0 * (dot(hu, hv) + bu * bv / x2) * m1.x * m1.y;
    return exp(ln_scale + n * log1m(gap) + ln_sinhc - 0.5 * n * q);
}

// The cosine below which the lobe is under its cut-off, exp(FILTER_LOG_CUTOFF / n) (0 for
// n ≤ 1, whose lobes have none): set once per invocation in main, so that the per-texel test
// is a comparison rather than a logarithm.
float x_cut = 0.0;

// Whether the rule skips everything inside cone c (axis, cos of radius; w > 1: empty): the
// largest cosine to the axis over the cone, cos(θc − ρ), is at or below the horizon, or the
// lobe there is below the cutoff. texel_weight makes the same two tests per texel.
bool cone_skipped(vec3 axis, float n, vec4 c) {
    if (c.w > 1.0) return true;
    float x = dot(axis, c.xyz);
    float sin_rho = sqrt(max(0.0, (1.0 - c.w) * (1.0 + c.w)));
    float sin_c = sqrt(max(0.0, (1.0 - x) * (1.0 + x)));
    float x_max = x >= c.w ? 1.0 : x * c.w + sin_c * sin_rho;
    return x_max <= 0.0 || x_max < x_cut;
}

const int RULE_SKIP = 0, RULE_CENTRE = 1, RULE_TILTED = 2, RULE_CELLS = 3;

// The rule of filter::rule for a texel with cone c (centre, cos of radius), decision for
// decision; `cells` is the cells' count a side where it asks for cells.
int texel_rule(vec3 axis, float n, vec4 cone, bool regular, out uint cells) {
    cells = 1u;
    float x = dot(axis, cone.xyz);
    float cos_rho = cone.w;
    float sin_rho = sqrt(max(0.0, (1.0 - cos_rho) * (1.0 + cos_rho)));
    float sin_c = sqrt(max(0.0, (1.0 - x) * (1.0 + x)));
    // The largest and smallest x over the texel: cos(θc − ρ) and cos(θc + ρ).
    float x_max = x >= cos_rho ? 1.0 : x * cos_rho + sin_c * sin_rho;
    float x_min = x * cos_rho - sin_c * sin_rho;
    if (x_max <= 0.0) return RULE_SKIP;
    if (x_max < x_cut) return RULE_SKIP;
    float rho2 = 2.0 * (1.0 - cos_rho);
    bool straddles = x_min < 0.0;
    if (!straddles && n * rho2 < FILTER_CENTRE_LIMIT) return RULE_CENTRE;
    if (regular && !straddles && n * rho2 <= FILTER_TILT_LIMIT * x_min * x_min) return RULE_TILTED;
    float s = max(ceil(FILTER_CELLS_PER_WIDTH * sqrt(n * rho2)), 1.0);
    if (straddles) s = max(s, float(FILTER_EDGE_CELLS));
    cells = uint(min(s, float(FILTER_MAX_CELLS)));
    return RULE_CELLS;
}

// Whether this invocation met a texel whose rule asks for Gauss cells. With CELLS_WALK the sum
// takes those in a second walk (cells_pass): llvmpipe runs every branch of the texel loop's
// body at every step, and a nested loop's first iteration even where no lane enters it, so
// with the cells' nine nodes of trigonometry in the one walk every texel paid for the few
// that need them (Phong n = 2049 from a 1k lat-long, where only the pole rows take cells:
// 9.3 -> 3.5 s into a cube 64). BruteFilter::chunk_size counts both walks against llvmpipe's
// loop limit.
bool cells_wanted = false;

// ∫K over prepared texel t (0 where skipped), whose solid angle is omega. With CELLS_WALK, the
// first walk takes the rules other than cells (a texel that asks for them sets cells_wanted
// and gives 0) and the second (cells_pass) cells alone; cells_pass is a constant at each
// call, so each walk holds only its own rules. Without it, one walk takes them all. Each
// image is read once: llvmpipe loads a texel lane by lane, the loop's main cost.
float texel_weight(vec3 axis, float n, float ln_scale, ivec3 t, float omega, bool cells_pass) {
    if (omega == 0.0) return 0.0;
    vec4 cone = imageLoad(cones, t);
    vec4 s0 = shape(t, 0);
    uint cells;
    int r = texel_rule(axis, n, cone, s0.w > 0.5, cells);
    if (r == RULE_SKIP) return 0.0;
    if (r == RULE_CELLS) {
        if (CELLS_WALK && !cells_pass) {
            cells_wanted = true;
            return 0.0;
        }
        float k = texel_mean(axis, t, cells);
        return k < 0.0 ? kernel_eval(pc.exponent, axis, cone.xyz) : k;
    }
    if (cells_pass) return 0.0;
    if (!CELLS_WALK) {
        if (r == RULE_CENTRE) return kernel_eval(pc.exponent, axis, cone.xyz);
        return tilted_shape(axis, n, ln_scale, s0.xyz, shape(t, 1).xyz, shape(t, 2).xyz);
    }
    // The centre node is the tilted rule's value for a point texel at the centre: one
    // evaluation serves both rules (llvmpipe would take both at every texel).
    bool centre = r == RULE_CENTRE;
    vec3 c = centre ? cone.xyz : s0.xyz;
    vec3 hu = centre ? vec3(0.0) : shape(t, 1).xyz;
    vec3 hv = centre ? vec3(0.0) : shape(t, 2).xyz;
    return tilted_shape(axis, n, ln_scale, c, hu, hv);
}

// Texel t's term L·∫K (with CELLS_WALK, the part of it the first walk or the second takes): a
// prepared texel, or with MOMENT_SOURCE a texel of the pyramid's level, taken whole (each
// channel's parallelogram, first walk) where the rule takes it by centre or tilt, and from its
// 2^s × 2^s prepared texels elsewhere (twin of MomentLevel::convolve).
void add_texel(vec3 axis, float n, float ln_scale, ivec3 t, bool cells_pass, inout vec3 sum, inout vec3 comp) {
    if (!MOMENT_SOURCE) {
        vec4 rt = imageLoad(rad, t);
#if defined(VISITS)
        // The visit floor (ShaderId::BruteVisits): the walk and one read a texel, no rule.
        kahan_add(sum, comp, rt.rgb * rt.w);
#else
        float k = texel_weight(axis, n, ln_scale, t, rt.w, cells_pass);
        if (k > 0.0) kahan_add(sum, comp, rt.rgb * (rt.w * k));
#endif
        return;
    }
    uint cells;
    int r = texel_rule(axis, n, imageLoad(coarse_cones, t), true, cells);
    if (r == RULE_SKIP) return;
    if (r != RULE_CELLS) {
        if (cells_pass) return;
        vec3 term = vec3(0.0);
        for (int ch = 0; ch < 3; ch++) {
            // Layers 9·layer + 3·ch + 0, 1, 2 (brute_moments).
            int o = 9 * t.z + 3 * ch;
            vec4 cp = imageLoad(light, ivec3(t.xy, o));
            if (cp.w > 0.0) {
                term[ch] = cp.w * tilted_shape(axis, n, ln_scale, cp.xyz, imageLoad(light, ivec3(t.xy, o + 1)).xyz,
                                               imageLoad(light, ivec3(t.xy, o + 2)).xyz);
            }
        }
        kahan_add(sum, comp, term);
        return;
    }
    uint side = 1u << pc.src_level;
    ivec2 base = t.xy * int(side);
    for (uint k = 0u; k < side * side; k++) {
        ivec3 f = ivec3(base + ivec2(k % side, k / side), t.z);
        vec4 rf = imageLoad(rad, f);
        float kk = texel_weight(axis, n, ln_scale, f, rf.w, cells_pass);
        if (kk > 0.0) kahan_add(sum, comp, rf.rgb * (rf.w * kk));
    }
}

// Slots [begin, end) tile by tile, skipping the tiles whose cone the rule skips whole: the
// first walk (cells_pass false) or the second (true; see cells_wanted); with TEXEL_LANES lanes
// an output, this lane takes every TEXEL_LANES-th slot of each tile.
void walk(vec3 axis, float n, float ln_scale, uint begin, uint end, uint lane, bool cells_pass,
          inout vec3 sum, inout vec3 comp) {
    const uint per_tile = BRUTE_TILE * BRUTE_TILE;
    for (uint tile = begin / per_tile; tile * per_tile < end; tile++) {
        if (cone_skipped(axis, n, tiles[tile])) continue;
        uint first = max(begin, tile * per_tile) - tile * per_tile;
        uint last = min(end, (tile + 1u) * per_tile) - tile * per_tile;
        uvec3 origin = tile_origin(tile);
        for (uint s = first + lane; s < last; s += TEXEL_LANES) {
            ivec3 ti = slot_texel(origin, s);
            if (ti.x < 0) continue;
            add_texel(axis, n, ln_scale, ti, cells_pass, sum, comp);
        }
    }
}

// The reach of a lobe about `axis` in a lat-long source: its axis's longitude and colatitude
// in the file's frame (x, y) and the angle d (z) within which every texel centre lies whose
// texel the rule keeps: the lobe's cap above its cut-off (x_cut; the horizon at most) widened
// by the widest texel cone, CONE_MARGIN times the half diagonal √(Δφ² + Δθ²)/2 and
// REACH_MARGIN_REL more (the sphere's excess over the plane), and REACH_MARGIN_ABS radians
// for f32 rounding in x_cut and the texel's x_max.
vec3 lobe_reach(vec3 axis, float n) {
    vec2 step = vec2(TAU, PI) / vec2(pc.src_size);
    // 1 − x_cut without cancellation for large n.
    float u = -FILTER_LOG_CUTOFF / n;
    float below = n > 1.0 ? (u < 1e-3 ? u * (1.0 - 0.5 * u) : 1.0 - exp(-u)) : 1.0;
    float d = 2.0 * asin(sqrt(0.5 * below))
        + (1.0 + FILTER_REACH_MARGIN_REL) * FILTER_CONE_MARGIN * 0.5 * length(step) + FILTER_REACH_MARGIN_ABS;
    vec3 f = pc.file_to_world[0].xyz * axis.x + pc.file_to_world[1].xyz * axis.y
        + pc.file_to_world[2].xyz * axis.z;
    vec2 uv = dir_to_coord(MAPPING_LATLONG, f).uv;
    return vec3(TAU * uv.x, PI * uv.y, d);
}

// Slots [begin, end) of a lat-long source, row-major texels (CPU devices, TEXEL_LANES lanes an
// output): each row of the lobe's reach, only the columns whose centres lie within d of the
// axis, this lane taking every TEXEL_LANES-th of them. By the haversine formula a centre at
// colatitude θ is within d of the axis (φa, θa) where
// sin²(Δφ/2) ≤ (sin²(d/2) − sin²((θ − θa)/2)) / (sin θ sin θa), stable for small angles; the
// interval is widened by a column each side. Tiles overhang a lobe's cap (16² tiles: 1.9×
// its texels); rows follow it to a column.
void walk_rows(vec3 axis, float n, float ln_scale, uint begin, uint end, uint lane,
               bool cells_pass, inout vec3 sum, inout vec3 comp) {
    if (begin >= end) return;
    int w = int(pc.src_size.x), h = int(pc.src_size.y);
    vec2 step = vec2(TAU, PI) / vec2(pc.src_size);
    vec3 reach = lobe_reach(axis, n);
    float half_d = 0.5 * min(reach.z, PI);
    float hav_d = sin(half_d) * sin(half_d);
    float sin_a = sin(reach.y);
    int first_row = int(begin / uint(w)), last_row = int((end - 1u) / uint(w));
    int first_col = int(begin % uint(w)), last_col = int((end - 1u) % uint(w));
    int j0 = max(int(floor((reach.y - reach.z) / step.y - 0.5)), first_row);
    int j1 = min(int(ceil((reach.y + reach.z) / step.y - 0.5)), last_row);
    for (int j = max(j0, 0); j <= min(j1, h - 1); j++) {
        float theta = (float(j) + 0.5) * step.y;
        float dt = sin(0.5 * (theta - reach.y));
        float room = hav_d - dt * dt;
        // Columns lo … lo + count − 1 (unwrapped), all of them where the reach holds a pole.
        int lo = 0, count = w;
        float den = sin_a * sin(theta);
        if (room < 0.0) {
            count = 0;
        } else if (room < den) {
            float dphi = 2.0 * asin(sqrt(room / den));
            lo = int(floor((reach.x - dphi) / step.x - 0.5)) - 1;
            count = min(int(ceil((reach.x + dphi) / step.x - 0.5)) + 2 - lo, w);
            if (lo < 0) lo += w;
        }
        // This chunk's columns of row j: [ca, cb). One loop over the interval, wrapping by a
        // subtraction: llvmpipe runs a loop's first iteration even where no lane enters it,
        // and divides integers lane by lane.
        int ca = j == first_row ? first_col : 0;
        int cb = j == last_row ? last_col + 1 : w;
        for (int k = int(lane); k < count; k += int(TEXEL_LANES)) {
            int c = lo + k;
            if (c >= w) c -= w;
            if (c < ca || c >= cb) continue;
            add_texel(axis, n, ln_scale, ivec3(c, j, 0), cells_pass, sum, comp);
        }
    }
}

// One invocation per output texel and part of the source: the grid holds pc.parts blocks of
// the output's size, block k summing slots [k·part_slots, (k + 1)·part_slots) of this
// dispatch's chunk, so that small outputs (the coarse Phong levels) still fill the device.
void main() {
    uvec3 gid = gl_GlobalInvocationID;
    uint lane = gid.x % TEXEL_LANES;
    gid.x /= TEXEL_LANES;
    uvec2 block = gid.xy / pc.dst_size;
    if (any(greaterThanEqual(block, pc.parts))) return;
    uvec3 id = uvec3(gid.xy - block * pc.dst_size, gid.z);
    if (DST_MAPPING == MAPPING_ANGULAR && !texel_in_domain(DST_MAPPING, pc.dst_size, ivec2(id.xy))) return;
    uint part = block.y * pc.parts.x + block.x;
    uint begin = min(pc.chunk_begin + part * pc.part_slots, pc.chunk_end);
    uint end = min(begin + pc.part_slots, pc.chunk_end);
    Coord oc;
    oc.layer = id.z;
    oc.uv = (vec2(id.xy) + 0.5) / vec2(pc.dst_size);
    vec3 axis = coord_to_dir(DST_MAPPING, oc);
    float n = pc.exponent == 0.0 ? 1.0 : pc.exponent;
    float ln_scale = pc.exponent == 0.0 ? 0.0 : log((n + 1.0) / TAU);
    x_cut = n > 1.0 ? exp(FILTER_LOG_CUTOFF / n) : 0.0;
    uint o = 2u * ((part * TEXEL_LANES + lane) * dst_texels() + (id.z * pc.dst_size.y + id.y) * pc.dst_size.x + id.x);
    precise vec3 sum = vec3(0.0);
    precise vec3 comp = vec3(0.0);
    if (pc.chunk_begin > 0u) {
        sum = partials[o].rgb;
        comp = partials[o + 1u].rgb;
    }
    if (TEXEL_LANES > 1u && SRC_MAPPING == MAPPING_LATLONG) {
        walk_rows(axis, n, ln_scale, begin, end, lane, false, sum, comp);
        if (CELLS_WALK && cells_wanted) walk_rows(axis, n, ln_scale, begin, end, lane, true, sum, comp);
    } else {
        walk(axis, n, ln_scale, begin, end, lane, false, sum, comp);
        if (CELLS_WALK && cells_wanted) walk(axis, n, ln_scale, begin, end, lane, true, sum, comp);
    }
    partials[o] = vec4(sum, 0.0);
    partials[o + 1u] = vec4(comp, 0.0);
}
#endif
