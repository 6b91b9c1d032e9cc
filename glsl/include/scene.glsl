// Ray casting against the scene's objects (twin of src/math/camera.rs). Their records,
// `Object`, are generated from src/abi/record.rs.
#ifndef ENVLIGHT_SCENE_GLSL
#define ENVLIGHT_SCENE_GLSL

// Distance along unit d from o to object ob, or -1 when the ray misses it; n gets the normal.
float object_hit(Object ob, vec3 o, vec3 d, out vec3 n) {
    n = vec3(0.0);
    if (ob.kind == OBJECT_SPHERE) {
        vec3 oc = o - ob.shape.xyz;
        float b = dot(oc, d);
        vec3 h = oc - b * d;
        float disc = ob.shape.w * ob.shape.w - dot(h, h);
        if (disc < 0.0) return -1.0;
        float s = sqrt(disc);
        float t = -b - s > 0.0 ? -b - s : -b + s;
        n = (o + t * d - ob.shape.xyz) / ob.shape.w;
        return t;
    }
    float dn = dot(d, ob.shape.xyz);
    if (dn >= 0.0) return -1.0;
    float t = (ob.shape.w - dot(o, ob.shape.xyz)) / dn;
    n = ob.shape.xyz;
    if (ob.extent > 0.0) {
        vec3 p = o + t * d - ob.shape.w * ob.shape.xyz;
        if (dot(p, p) > ob.extent * ob.extent) return -1.0;
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
