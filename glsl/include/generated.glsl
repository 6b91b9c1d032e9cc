// Generated from src/gpu/layout.rs by `cargo xtask shaders`; do not edit.
#ifndef ENVLIGHT_GENERATED_GLSL
#define ENVLIGHT_GENERATED_GLSL
#define BINDING_CONVERT_SRC 0
#define BINDING_CONVERT_DST 1
#define BINDING_PROBE_IN 0
#define BINDING_PROBE_OUT 1
#define BINDING_COPY_SRC 0
#define BINDING_COPY_DST 1
#define BINDING_BUSY_OUT 0
#define MAPPING_LATLONG 0u
#define MAPPING_ANGULAR 1u
#define MAPPING_CUBE 2u
#define MAPPING_DUAL_PARABOLOID 3u
#endif
