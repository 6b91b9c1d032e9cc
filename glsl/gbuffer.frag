#version 460
// G-buffer of analytic spheres and planes, ray cast per pixel centre (twin of
// src/math/camera.rs): the normal and object index, the hit position, and the unit direction
// back to the eye. Misses hold object index -1 and the direction the ray went out along.
#extension GL_GOOGLE_include_directive : require
#include "generated.glsl"
#include "scene.glsl"

layout(std430, set = 0, binding = BINDING_GBUF_OBJECTS) readonly buffer Objects { Object objects[]; };

// The push block, generated from src/abi/push.rs.
PUSH_GBufferPush

layout(location = 0) out vec4 out_normal;    // normal, object index (-1: miss)
layout(location = 1) out vec4 out_position;  // hit position, distance
layout(location = 2) out vec4 out_view;      // unit direction to the eye (misses: -ray)

void main() {
    vec3 o, d;
    camera_ray(vec4(pc.eye.xyz, float(pc.ortho)), pc.forward.xyz, pc.right.xyz, pc.up.xyz,
               vec2(pc.size), gl_FragCoord.xy, o, d);
    float best = 1e30;
    int index = -1;
    vec3 normal = vec3(0.0);
    for (uint k = 0u; k < pc.count; k++) {
        vec3 n;
        float t = object_hit(objects[k], o, d, n);
        if (t > 0.0 && t < best) {
            best = t;
            index = int(k);
            normal = n;
        }
    }
    if (index < 0) {
        out_normal = vec4(0.0, 0.0, 0.0, -1.0);
        out_position = vec4(0.0, 0.0, 0.0, -1.0);
        out_view = vec4(-d, 0.0);
        return;
    }
    out_normal = vec4(normal, float(index));
    out_position = vec4(o + best * d, best);
    out_view = vec4(-d, 0.0);
}
