// The light tree walk, the twin of math::light_tree::LightTree::walk: one step at a time,
// each step four weighted directions. Included by shade.frag where it uses it, after its
// bindings and push block.
// A light tree walk (math::light_tree::LightTree::walk): the next node i, the current leaf's
// texels j..end, and which four of texel j's quadrature nodes come next (c).
struct Walk {
    uint i;
    uint j;
    uint end;
    uint c;
};

// Whether every node and texel of walk k has been visited.
bool walk_over(Walk k) {
    return k.j >= k.end && k.i >= pc.tree_nodes;
}

// Most steps a walk can take (every node, every texel in fours of its quadrature nodes): the
// loops' bound, which llvmpipe needs (it miscompiled an unbounded while, zeroing other
// pixels of the frame).
uint walk_bound() {
    return pc.tree_nodes + pc.lights * max((pc.light_stride - LIGHT_HEADER_VEC4S) / LIGHT_STEP_NODES, 1u);
}

// One step of walk k for a kernel of scale `scale` about r whose cut plane has normal `cut`
// (fading as cos^fade towards it), a node allowed an error `allowance` (light_tree_whole).
// False where it only descended; otherwise what to sum: four weighted directions d·w (a
// node taken whole: its sigma points, a quarter of its power each; a texel small against
// the kernel: its centre, then zero weights; else four of its quadrature nodes) and the
// radiance or power they carry; a texel's centre also in `centre` (zero for a node). Every
// item is four directions so that the caller evaluates its kernel in one place: llvmpipe
// runs a loop's whole body at every step, each copy of the kernel included.
bool walk_step(inout Walk k, vec3 r, float scale, vec3 cut, float fade, float allowance,
               out mat4x3 d, out vec4 w, out vec3 light, out vec3 centre) {
    d = mat4x3(0.0);
    w = vec4(0.0);
    light = vec3(0.0);
    centre = vec3(0.0);
    // The same six loads whichever the item (llvmpipe runs both branches' loads, lane by
    // lane): a texel's header and four quadrature nodes, or a node's five vec4s (the sixth
    // unused; the buffer ends in padding for it).
    bool texel = k.j < k.end;
    uint q0 = k.j * pc.light_stride;
    uint at = pc.tree_at + k.i * LIGHT_TREE_VEC4S;
    uint base = texel ? q0 : at;
    uint more = texel ? q0 + LIGHT_HEADER_VEC4S + LIGHT_STEP_NODES * k.c : at + 2u;
    vec4 v0 = lights[base], v1 = lights[base + 1u];
    vec4 v2 = lights[more], v3 = lights[more + 1u], v4 = lights[more + 2u], v5 = lights[more + 3u];
    if (texel) {
        light = v1.rgb;
        centre = v0.xyz;
        if (light_centre_only(v1.w, light_scale2(scale, r - v0.xyz), pc.light_stride)) {
            d = mat4x3(v0.xyz, v0.xyz, v0.xyz, v0.xyz);
            w = vec4(v0.w, 0.0, 0.0, 0.0);
            k.j++;
        } else {
            d = mat4x3(v2.xyz, v3.xyz, v4.xyz, v5.xyz);
            w = vec4(v2.w, v3.w, v4.w, v5.w);
            k.c++;
            if (more + LIGHT_STEP_NODES >= q0 + pc.light_stride) {
                k.c = 0u;
                k.j++;
            }
        }
        return true;
    }
    // A node: (centre, reach), (power, ρ), (axis 0, luminance), (axis 1, 0), (first, count, skip).
    uvec4 range = uvec4(v4);
    if (!light_tree_whole(v0, v2.w, r, scale, cut, allowance, fade)) {
        if (range.y <= LIGHT_LEAF_TEXELS) {
            k.j = range.x;
            k.end = range.x + range.y;
            k.i = range.z;
        } else {
            k.i++;
        }
        return false;
    }
    d = mat4x3(normalize(v0.xyz + v2.xyz), normalize(v0.xyz - v2.xyz), normalize(v0.xyz + v3.xyz),
               normalize(v0.xyz - v3.xyz));
    w = vec4(0.25);
    light = v1.rgb;
    k.i = range.z;
    return true;
}
