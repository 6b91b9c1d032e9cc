// Scene objects and camera rays (twin of src/math/camera.rs).
#ifndef ENVLIGHT_SCENE_GLSL
#define ENVLIGHT_SCENE_GLSL

struct Object {
    vec4 a;       // sphere: centre, radius; plane: unit normal, offset
    vec4 b;       // x: 0 sphere, 1 plane; y: plane extent (0: unbounded)
    vec4 albedo;  // rgb
};
#endif
