// What every brute-force kernel shares (glsl/brute*.comp; their float64 twin is
// src/math/filter.rs): the specialisation constants, the source's directions
// and tiles, and Kahan summation. A kernel declares its bindings and push block (and includes
// brute_shape.glsl where it reads shapes) before including it.
#ifndef ENVLIGHT_BRUTE_GLSL
#define ENVLIGHT_BRUTE_GLSL

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
// the second walk's code would cost it registers.
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
#endif
