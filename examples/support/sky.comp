// The engine's own sky of examples/dynamic.rs: a gradient sky over a dark ground and a sun
// disc 4° across at 10⁴ × the zenith, written into the six faces of a cube image (envlight's
// cube convention: layers +X −X +Y −Y +Z −Z, docs/design.md). Compiled by tools/shaderc into
// sky.spv beside it; nothing of envlight's GLSL is included.
#version 450

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0, rgba32f) uniform writeonly image2DArray sky;

layout(push_constant) uniform Push {
    vec4 sun;   // direction (xyz), radiance of the disc (w)
    uint size;  // face side in texels
} pc;

vec3 face_dir(uint layer, vec2 uv) {
    vec2 st = 2.0 * uv - 1.0;
    switch (layer) {
        case 0u: return vec3(1.0, -st.y, -st.x);
        case 1u: return vec3(-1.0, -st.y, st.x);
        case 2u: return vec3(st.x, 1.0, st.y);
        case 3u: return vec3(st.x, -1.0, -st.y);
        case 4u: return vec3(st.x, -st.y, 1.0);
        default: return vec3(-st.x, -st.y, -1.0);
    }
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (id.x >= pc.size || id.y >= pc.size) return;
    vec3 d = normalize(face_dir(id.z, (vec2(id.xy) + 0.5) / float(pc.size)));
    vec3 zenith = vec3(0.12, 0.2, 0.45), horizon = vec3(0.7, 0.75, 0.8);
    vec3 c = d.y >= 0.0
        ? mix(horizon, zenith, sqrt(d.y))
        : vec3(0.12, 0.1, 0.08);
    if (dot(d, pc.sun.xyz) >= cos(radians(2.0))) c += vec3(pc.sun.w);
    imageStore(sky, ivec3(id), vec4(c, 1.0));
}
