#version 460
// Diffuse shading from SH irradiance per fragment (R&H 2001): albedo·E(n)/π with
// E(n) = Σ c_lm Y_lm(n), the coefficients holding Â_l (and any window); ringing below zero is
// clamped. Pixels the G-buffer missed show the environment (nearest texel) along the ray.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "sh.glsl"
#include "scene.glsl"

layout(set = 0, binding = BINDING_SHADE_NORMAL) uniform sampler2DArray gbuf_normal;
layout(set = 0, binding = BINDING_SHADE_VIEW) uniform sampler2DArray gbuf_view;
layout(std430, set = 0, binding = BINDING_SHADE_OBJECTS) readonly buffer Objects { Object objects[]; };
layout(std430, set = 0, binding = BINDING_SHADE_COEFFS) readonly buffer Coeffs { vec4 coeffs[]; };
layout(set = 0, binding = BINDING_SHADE_ENV) uniform sampler2DArray env;

layout(push_constant) uniform Push {
    vec4 world_to_file[3];  // environment orientation (rows)
    uvec2 env_size;
    uint env_mapping;
    uint lmax;
} pc;

layout(location = 0) out vec4 out_color;

void main() {
    ivec3 p = ivec3(gl_FragCoord.xy, 0);
    vec4 nrm = texelFetch(gbuf_normal, p, 0);
    if (nrm.w < 0.0) {
        vec3 d = -texelFetch(gbuf_view, p, 0).xyz;
        vec3 f = vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d), dot(pc.world_to_file[2].xyz, d));
        Coord c = dir_to_coord(pc.env_mapping, f);
        ivec2 texel = min(ivec2(c.uv * vec2(pc.env_size)), ivec2(pc.env_size) - 1);
        out_color = vec4(texelFetch(env, ivec3(texel, int(c.layer)), 0).rgb, 1.0);
        return;
    }
    float y[SH_MAX_COEFFS];
    sh_basis(pc.lmax, normalize(nrm.xyz), y);
    vec3 e = vec3(0.0);
    uint n = (pc.lmax + 1u) * (pc.lmax + 1u);
    for (uint k = 0u; k < n; k++) e += coeffs[k].rgb * y[k];
    vec3 albedo = objects[uint(nrm.w)].albedo.rgb;
    out_color = vec4(albedo * max(e, vec3(0.0)) / PI, 1.0);
}
