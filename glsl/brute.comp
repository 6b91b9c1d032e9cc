#version 460
// Brute-force convolution of a whole map with the clamped cosine or a normalised Phong lobe
// (Miller & Hoffman 1984), step 3 of 4 (brute_prepare.comp, brute_tiles.comp, this,
// brute_resolve.comp); the float64 twin is src/math/filter.rs. One invocation per output
// texel and part of the source sums L·∫K over the part's texels, choosing per texel the same
// rule as the CPU (skip, centre node, the tilted rule, or s×s cells of 3×3 Gauss points, on
// CPU devices those last in a second walk), with Kahan compensation so a sun 1e5 times the
// sky does not swamp the sum, into its partial sum; parts let a small output (a coarse Phong
// level) fill the device. The source is taken in chunks, one dispatch each, accumulating into
// the partial sums, so that no invocation runs more loop iterations than llvmpipe allows
// (DeviceInfo::loop_iteration_limit); the node loops are unrolled for the same reason.
// Texels are walked tile by tile ("slots": tile-major, BRUTE_TILE² per tile, the chunks count
// slots). Variants: DISC_SOURCE takes the clipped rule at a disc's rim; VISITS is the visit
// floor (the walk and one read a texel, no rule).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_CONES, rgba32f) uniform readonly image2DArray cones;
layout(set = 0, binding = BINDING_BRUTE_RADIANCE, rgba32f) uniform readonly image2DArray rad;
layout(std430, set = 0, binding = BINDING_BRUTE_PARTIALS) buffer Partials { vec4 partials[]; };
layout(std430, set = 0, binding = BINDING_BRUTE_TILES) readonly buffer Tiles { vec4 tiles[]; };
layout(set = 0, binding = BINDING_BRUTE_SHAPES, rgba32f) uniform readonly image2DArray shapes;
layout(set = 0, binding = BINDING_BRUTE_COARSE_CONES, rgba32f) uniform readonly image2DArray coarse_cones;
layout(set = 0, binding = BINDING_BRUTE_LIGHT, rgba32f) uniform readonly image2DArray light;

// The push block, generated from src/abi/push.rs.
PUSH_BrutePush

#include "brute_shape.glsl"
#include "brute.glsl"
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
// with the cells' nine nodes of trigonometry in the one walk every texel would pay for the
// few that need them (a narrow Phong lobe from a lat-long, where only the pole rows take
// cells). BruteFilter::chunk_size counts both walks against llvmpipe's loop limit.
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
