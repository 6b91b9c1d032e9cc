// Scene objects, their materials, and ray casting (twin of src/math/camera.rs and
// src/render/records.rs's GPU records).
#ifndef ENVLIGHT_SCENE_GLSL
#define ENVLIGHT_SCENE_GLSL

struct Object {
    vec4 a;       // sphere: centre, radius; plane: unit normal, offset
    vec4 b;       // x: 0 sphere, 1 plane; y: plane extent (0: unbounded)
    vec4 albedo;  // rgb: albedo (diffuse) or specular colour; w: technique id
    vec4 brdf;    // x: BRDF id; y, z: its parameters; w: FIS sample count
    vec4 extra;   // x: FIS lod bias; y: offset of its data (SH, prefiltered); z: SH lmax or
                  // prefiltered width; w: flags (bit 0: rotate FIS samples per pixel)
};

// Distance along unit d from o to object ob, or -1 when the ray misses it; n gets the normal.
float object_hit(Object ob, vec3 o, vec3 d, out vec3 n) {
    n = vec3(0.0);
    if (ob.b.x == 0.0) {
        vec3 oc = o - ob.a.xyz;
        float b = dot(oc, d);
        vec3 h = oc - b * d;
        float disc = ob.a.w * ob.a.w - dot(h, h);
        if (disc < 0.0) return -1.0;
        float s = sqrt(disc);
        float t = -b - s > 0.0 ? -b - s : -b + s;
        n = (o + t * d - ob.a.xyz) / ob.a.w;
        return t;
    }
    float dn = dot(d, ob.a.xyz);
    if (dn >= 0.0) return -1.0;
    float t = (ob.a.w - dot(o, ob.a.xyz)) / dn;
    n = ob.a.xyz;
    if (ob.b.y > 0.0) {
        vec3 p = o + t * d - ob.a.w * ob.a.xyz;
        if (dot(p, p) > ob.b.y * ob.b.y) return -1.0;
    }
    return t;
}

// The ray through image point px (pixels from the top-left corner) of a camera: eye (w: 1
// for orthographic), unit forward, right and up scaled by the half extents, image size (twin
// of math::camera::Camera::ray_at; passes::gbuffer::camera_record writes these).
void camera_ray(vec4 eye, vec3 forward, vec3 right, vec3 up, vec2 size, vec2 px, out vec3 o,
                out vec3 d) {
    vec2 ndc = vec2(2.0 * px.x / size.x - 1.0, 1.0 - 2.0 * px.y / size.y);
    if (eye.w != 0.0) {
        o = eye.xyz + ndc.x * right + ndc.y * up;
        d = forward;
    } else {
        o = eye.xyz;
        d = normalize(forward + ndc.x * right + ndc.y * up);
    }
}

// Where a shadow ray starts: off the surface by a margin relative to the scene's scale, so
// the surface it leaves never shadows itself.
vec3 shadow_origin(vec3 p, vec3 n) {
    return p + n * (SHADOW_OFFSET * (1.0 + length(p)));
}
#endif
