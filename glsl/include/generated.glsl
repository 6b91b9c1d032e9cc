// Generated from src/abi by `cargo xtask shaders`; do not edit.
#ifndef ENVLIGHT_GENERATED_GLSL
#define ENVLIGHT_GENERATED_GLSL
#define BINDING_CONVERT_SRC 0
#define BINDING_CONVERT_DST 1
#define BINDING_CONVERT_SLOPES_U 2
#define BINDING_CONVERT_LIST 3
#define BINDING_CONVERT_PLAN_OFFSETS 4
#define BINDING_CONVERT_PLAN_ENTRIES 5
#define BINDING_CONVERT_RESIDUAL 6
#define BINDING_CONVERT_SLOPES_Z 7
#define BINDING_PROBE_IN 0
#define BINDING_PROBE_OUT 1
#define BINDING_COPY_SRC 0
#define BINDING_COPY_DST 1
#define BINDING_SANITIZE_SRC 0
#define BINDING_SANITIZE_DST 1
#define BINDING_SANITIZE_COUNT 2
#define BINDING_CLAMP_MAP 0
#define BINDING_BUSY_OUT 0
#define BINDING_EXACT_MAP 0
#define BINDING_EXACT_OMEGA 1
#define BINDING_EXACT_QUERIES 2
#define BINDING_EXACT_PARTIALS 3
#define BINDING_POISON_IMAGE 0
#define BINDING_POISON_BUFFER 0
#define BINDING_SH_SRC 0
#define BINDING_SH_PARTIALS 1
#define BINDING_SH_ROWS_SRC 0
#define BINDING_SH_ROWS_OUT 1
#define BINDING_SH_LATLONG_ROWS 0
#define BINDING_SH_LATLONG_PARTIALS 1
#define BINDING_SH_PACK_RADIANCE 0
#define BINDING_SH_PACK_ENTRIES 1
#define BINDING_SH_PACK_MINUS 2
#define BINDING_SH_PACK_OUT 3
#define BINDING_SH_REDUCE_IN 0
#define BINDING_SH_REDUCE_OUT 1
#define BINDING_BRUTE_PREP_SRC 0
#define BINDING_BRUTE_PREP_CONES 1
#define BINDING_BRUTE_PREP_RADIANCE 2
#define BINDING_BRUTE_PREP_SHAPES 3
#define BINDING_BRUTE_CONES 0
#define BINDING_BRUTE_RADIANCE 1
#define BINDING_BRUTE_PARTIALS 3
#define BINDING_BRUTE_TILES 4
#define BINDING_BRUTE_SHAPES 5
#define BINDING_BRUTE_COARSE_CONES 6
#define BINDING_BRUTE_LIGHT 7
#define BINDING_BRUTE_RESOLVE_PARTIALS 0
#define BINDING_BRUTE_RESOLVE_DST 1
#define BINDING_BRUTE_MOM_RADIANCE 0
#define BINDING_BRUTE_MOM_SHAPES 1
#define BINDING_BRUTE_MOM_CONES 2
#define BINDING_BRUTE_MOM_LIGHT 3
#define BINDING_BRUTE_TILE_CONES 0
#define BINDING_BRUTE_TILE_OUT 1
#define BINDING_SH_EVAL_COEFFS 0
#define BINDING_SH_EVAL_DST 1
#define BINDING_GBUF_OBJECTS 0
#define BINDING_SHADE_NORMAL 0
#define BINDING_SHADE_VIEW 1
#define BINDING_SHADE_OBJECTS 2
#define BINDING_SHADE_COEFFS 3
#define BINDING_SHADE_ENV 4
#define BINDING_SHADE_POSITION 5
#define BINDING_SHADE_DP 6
#define BINDING_SHADE_PREFILTERED 7
#define BINDING_SHADE_MC 8
#define BINDING_MIP_SRC 0
#define BINDING_MIP_DST 1
#define BINDING_MC_NORMAL 0
#define BINDING_MC_VIEW 1
#define BINDING_MC_POSITION 2
#define BINDING_MC_OBJECTS 3
#define BINDING_MC_ENV 4
#define BINDING_MC_TABLES 5
#define BINDING_MC_ACCUM 6
#define BINDING_SH_BRDF_TABLE 0
#define BINDING_SH_ROT_IN 0
#define BINDING_SH_ROT_OUT 1
#define BINDING_SH_ROT_X90 2
#define BINDING_SHADE_BRDF_SH 9
#define BINDING_SHADE_X90 10
#define BINDING_SHADE_SPLIT 11
#define BINDING_SHADE_DFG 12
#define BINDING_SHADE_LIGHTS 13
#define BINDING_SHADE_CAMERA 14
#define BINDING_DFG_TABLE 0
#define BINDING_PREFILTER_GGX_SRC 0
#define BINDING_PREFILTER_GGX_DST 1
#define BINDING_PREFILTER_GGX_SAMPLES 2
#define BINDING_LIGHTS_TEXELS 0
#define BINDING_LIGHTS_DST 1
#define BINDING_EXTRACT_MAP 0
#define BINDING_EXTRACT_SH 1
#define BINDING_EXTRACT_STATE 2
#define BINDING_EXTRACT_LIGHTS 3
#define BINDING_EXTRACT_RESIDUAL 4
#define BINDING_EXTRACT_FILL 5
#define BINDING_EXTRACT_ADD_STATE 0
#define BINDING_EXTRACT_ADD_LIGHTS 1
#define BINDING_EXTRACT_ADD_DST 2
#define BINDING_CLUSTERS_STATE 0
#define BINDING_CLUSTERS_LIGHTS 1
#define BINDING_CLUSTERS_SORT 2
#define BINDING_CLUSTERS_OUT 3
#define BINDING_PREPARE_STATE 0
#define BINDING_PREPARE_LIGHTS 1
#define BINDING_PREPARE_OUT 2
#define BINDING_PREPARE_SORT 3
#define SH_MAX_LMAX 8
#define SH_MAX_COEFFS 81
#define SH_WORKGROUP 64
#define EXACT_WORKGROUP 64u
#define EXACT_QUERY_VEC4S 5u
#define EXACT_HORIZON_SHRINK 4.0
#define EXACT_HORIZON_REACH 8.0
#define EXACT_MAX_CELLS_PER_WIDTH 8.0
#define BRUTE_TILE 16u
#define LIGHT_HEADER_VEC4S 2u
#define LIGHT_STEP_NODES 4u
#define LIGHT_CLUSTER_VEC4S 3u
#define CLUSTER_SORT_CELL_ARRAYS 4u
#define LIGHTS_KERNEL_COSINE 0u
#define LIGHTS_KERNEL_GGX 1u
#define LIGHTS_KERNEL_CLUSTERS 2u
#define LIGHT_PER_WIDTH 4.0
#define LIGHT_CENTRE_BELOW 0.2
#define LIGHT_TAIL_FRACTION 0.125
#define LIGHT_TREE_BELOW 0.35
#define LIGHT_TREE_BUDGET 0.01
#define LIGHT_TREE_BUDGET_REACH 1.0
#define LIGHT_KERNEL_FADE 1.0
#define LIGHT_LEAF_TEXELS 4u
#define LIGHT_TREE_TAIL 0.25
#define LIGHT_TREE_VEC4S 5u
#define EXTRACT_HEADER_WORDS 48u
#define EXTRACT_TOP_BINS 32768u
#define EXTRACT_LOW_BINS 65536u
#define FILL_MAX_RINGS 8u
#define FILL_SLOT_BITS 24u
#define FILL_SLOT_ARRAYS 4u
#define EXTRACT_RECORD_VEC4S 3u
#define EXTRACT_LIGHT_GROUP 64u
#define EXTRACT_MODE_HISTOGRAM 0u
#define EXTRACT_MODE_SELECT_TOP 1u
#define EXTRACT_MODE_HISTOGRAM_LOW 2u
#define EXTRACT_MODE_SELECT_LOW 3u
#define EXTRACT_MODE_MARK_LIST 4u
#define EXTRACT_MODE_MARK 5u
#define EXTRACT_MODE_RING 6u
#define EXTRACT_MODE_RIMS 7u
#define EXTRACT_MODE_DECIDE 8u
#define EXTRACT_MODE_FILL 9u
#define EXTRACT_MODE_COMPACT 10u
#define CLUSTERS_MODE_COUNT 0u
#define CLUSTERS_MODE_SCAN 1u
#define CLUSTERS_MODE_SCATTER 2u
#define CLUSTERS_MODE_SUM 3u
#define PREPARE_MODE_KEYS 0u
#define PREPARE_MODE_SCAN 1u
#define PREPARE_MODE_SCATTER 2u
#define PREPARE_MODE_TEXELS 3u
#define PREPARE_MODE_NODES 4u
#define TREE_BUCKET_BITS 16u
#define TREE_KEY_AXIS_BITS 15u
#define TREE_SORT_BUCKET_ARRAYS 3u
#define EXTRACT_WORD_LOW_ARGS 0u
#define EXTRACT_WORD_OMEGA_MAX 3u
#define EXTRACT_WORD_LIGHT_ARGS 4u
#define EXTRACT_WORD_CANDIDATES 8u
#define EXTRACT_WORD_KEPT 9u
#define EXTRACT_WORD_THRESHOLD 10u
#define EXTRACT_WORD_BIN 11u
#define EXTRACT_WORD_RANK 12u
#define EXTRACT_WORD_NONFINITE 13u
#define EXTRACT_WORD_TAU 14u
#define EXTRACT_WORD_COUNTER 15u
#define EXTRACT_WORD_MEMBERS 16u
#define EXTRACT_WORD_ACCEPTED 17u
#define EXTRACT_WORD_GROWN 18u
#define EXTRACT_WORD_ROUNDS 19u
#define EXTRACT_WORD_RING_COUNT 20u
#define EXTRACT_WORD_RIMS 29u
#define EXTRACT_WORD_MARK_LIST_ARGS 38u
#define EXTRACT_WORD_MARK_ARGS 41u
#define EXTRACT_WORD_COMPACT_ARGS 44u
#define AREA_EDGE_STEPS 2u
#define PREFILTER_SAMPLE_VEC4S 2u
#define AREA_POLE_STEPS 8u
#define AREA_POLE_NEAR 8.0
#define AREA_MAX_VERTICES 35u
#define AREA_PARABOLOID_EDGE_STEPS 2u
#define AREA_PARABOLOID_RIM_STEPS 2u
#define AREA_SLIVER_NUDGE 0.001
#define AREA_PLAN_ROW_SHIFT 16u
#define AREA_FAST_WINDOW 6u
#define AREA_FAST_MIN_SIZE 32u
#define AREA_POLE_FACE_0 2u
#define AREA_POLE_FACE_1 3u
#define FOOTPRINT_MIN_TAPS 8u
#define FOOTPRINT_MAX_TAPS 16u
#define FOOTPRINT_MIRROR 1u
#define FOOTPRINT_BACKGROUND 2u
#define FOOTPRINT_LIGHTS 4u
#define FOOTPRINT_CODE 65536u
#define SHADOWS_CODE 131072u
#define BRDF_CODE_SHIFT 20u
#define FILTER_EDGE_CELLS 4u
#define FILTER_MAX_CELLS 16u
#define FILTER_CELLS_PER_WIDTH 2.0
#define FILTER_CENTRE_LIMIT 1e-5
#define FILTER_TILT_LIMIT 0.1
#define FILTER_TILT_DENSITY_RATIO 1.4
#define FILTER_TILT_SERIES_BELOW 0.5
#define FILTER_LOG_CUTOFF -23.02585
#define FILTER_CONE_MARGIN 1.25
#define FILTER_REACH_MARGIN_REL 0.001
#define FILTER_REACH_MARGIN_ABS 0.0001
#define FILTER_TILE_MARGIN_REL 0.0001
#define FILTER_TILE_MARGIN_ABS 1e-5
#define DFG_MU_MIN 0.0001
#define SPLIT_TAP_SCALE 0.7
#define POLE_THRESHOLD 0.999
#define VIEW_LIFT 0.0001
#define SHADOW_OFFSET 0.0001
#define RIM_PULL_IN 0.0001
#define GAUSS2_OFFSET 0.28867513
#define GGX_ALPHA_MIN 0.0001
#define FOOTPRINT_LOD_BIAS -0.5
#define FOOTPRINT_MIN_SPREAD 1e-6
#define FOOTPRINT_TAP_SLACK 0.001
#define LUMINANCE vec3(0.2126, 0.7152, 0.0722)
const float SH_K[45] = float[45](2.820947918e-1, 4.886025119e-1, 3.454941495e-1, 6.307831305e-1, 2.575161347e-1, 1.287580673e-1, 7.463526652e-1, 2.154534561e-1, 6.813236510e-2, 2.781492158e-2, 8.462843753e-1, 1.892349392e-1, 4.460310290e-2, 1.192068068e-2, 4.214597071e-3, 9.356025796e-1, 1.708168792e-1, 3.228135587e-2, 6.589404174e-3, 1.553137459e-3, 4.911451888e-4, 1.017107236e0, 1.569430538e-1, 2.481487565e-2, 4.135812609e-3, 7.550926198e-4, 1.609862875e-4, 4.647273820e-5, 1.092548431e0, 1.459979252e-1, 1.986780113e-2, 2.809731381e-3, 4.235829432e-4, 7.059715721e-5, 1.384524162e-5, 3.700296471e-6, 1.163106623e0, 1.370734301e-1, 1.638340852e-2, 2.016658182e-3, 2.603494518e-4, 3.610397300e-5, 5.570963980e-6, 1.017114213e-6, 2.542785532e-7);
#define BRDF_LAMBERT 0u
#define BRDF_MIRROR 1u
#define BRDF_PHONG 2u
#define BRDF_BLINN 3u
#define BRDF_GGX 4u
#define BRDF_WARD 5u
#define TECH_LOOKUP 0u
#define TECH_FIS 1u
#define TECH_SH 2u
#define TECH_PREFILTERED 3u
#define TECH_MC 4u
#define TECH_SH_BRDF 5u
#define TECH_SPLIT_SUM 6u
#define OBJECT_SPHERE 0u
#define OBJECT_PLANE 1u
#define OBJECT_ROTATE 1u
#define OBJECT_LIGHTS 2u
#define SH_ROTATION_ZXZXZ 0u
#define SH_ROTATION_IVANIC 1u
#define SH_ROTATE_HEADER 12u
#define SH_BRDF_PANELS 16u
#define SH_BRDF_GL_NODES 4u
#define SH_BRDF_GRADED_LEVELS 8u
const float SH_BRDF_GL_X[4] = float[4](-8.611363116e-1, -3.399810436e-1, 3.399810436e-1, 8.611363116e-1);
const float BRDF_HORIZON_FADE[6] = float[6](1.0, 0.0, 0.0, 1.0, 1.0, 0.5);
const float SH_BRDF_GL_W[4] = float[4](3.478548451e-1, 6.521451549e-1, 6.521451549e-1, 3.478548451e-1);
#define MAPPING_LATLONG 0u
#define MAPPING_ANGULAR 1u
#define MAPPING_CUBE 2u
#define MAPPING_DUAL_PARABOLOID 3u
#define PUSH_ConvertPush layout(push_constant) uniform Push { vec4[3] world_to_file; uvec2 src_size; uvec2 dst_size; uint src_mapping; uint dst_mapping; uint ss; uint nearest; float threshold; } pc;
#define PUSH_ProbePush layout(push_constant) uniform Push { uint mode; uint mapping; uint count; uint width; uint height; uint[3] pad; } pc;
#define PUSH_SanitizePush layout(push_constant) uniform Push { uvec2 size; uint[2] pad; } pc;
#define PUSH_ClampPush layout(push_constant) uniform Push { uvec2 size; uint mapping; float threshold; } pc;
#define PUSH_CopyPush layout(push_constant) uniform Push { uvec2 size; uint[2] pad; } pc;
#define PUSH_BusyPush layout(push_constant) uniform Push { uint iterations; uint count; uint[2] pad; } pc;
#define PUSH_PoisonPush layout(push_constant) uniform Push { uint mode; float factor; uint width; uint height; uint layers; uint nan_at; uint first; uint stride; uint scale_mask; uint mirror_mask; uint sh_channels; uint sh_count; } pc;
#define PUSH_ShProjectPush layout(push_constant) uniform Push { vec4[3] file_to_world; uvec2 size; uint mapping; uint lmax; uint texels; uint[3] pad; } pc;
#define PUSH_ShLatLongPush layout(push_constant) uniform Push { vec4[3] rotation; uvec2 size; uint lmax; uint parity; } pc;
#define PUSH_ShPackPush layout(push_constant) uniform Push { uint count; uint[3] pad; } pc;
#define PUSH_ShReducePush layout(push_constant) uniform Push { uint rows; uint coeffs; uint[2] pad; } pc;
#define PUSH_BrutePush layout(push_constant) uniform Push { vec4[3] file_to_world; uvec2 src_size; uvec2 dst_size; uint src_mapping; uint dst_mapping; uint texels; float exponent; uint chunk_begin; uint chunk_end; uint src_layers; uint src_level; uvec2 parts; uint part_slots; uint pad; } pc;
#define PUSH_ShEvalPush layout(push_constant) uniform Push { uvec2 dst_size; uint dst_mapping; uint lmax; } pc;
#define PUSH_GBufferPush layout(push_constant) uniform Push { vec4 eye; vec4 forward; vec4 right; vec4 up; uvec2 size; uint ortho; uint count; } pc;
#define PUSH_ShadePush layout(push_constant) uniform Push { vec4[3] world_to_file; uvec2 env_size; uint env_mapping; uint count; uint dp_size; float max_lod; uint shadows; uint mc_samples; uint sh_rotation; uint lights; uint light_stride; uint footprint; uint clusters; uint cluster_at; uint tree_nodes; uint tree_at; } pc;
#define PUSH_ExactShadePush layout(push_constant) uniform Push { uvec2 size; uint mapping; uint texels; uint run; uint groups; uint first; uint brdf; float p0; float p1; float per_width; uint count; } pc;
#define PUSH_ShBrdfPush layout(push_constant) uniform Push { uint grid; float p0; float p1; uint offset; uint panel; uint[3] pad; } pc;
#define PUSH_DfgPush layout(push_constant) uniform Push { uint size; uint correlated; uint offset; uint panel; uint centres; } pc;
#define PUSH_PrefilterGgxPush layout(push_constant) uniform Push { uint size; uint src_size; float src_max_lod; float alpha; uint samples; uint dst_mapping; uint layer; } pc;
#define PUSH_ExtractPush layout(push_constant) uniform Push { uvec2 size; uint mapping; uint mode; uint max; float ratio; uint fill; uint grow; } pc;
#define PUSH_ExtractAddPush layout(push_constant) uniform Push { vec4[3] file_to_world; uvec2 map_size; uint mapping; uint size; uint kernel; float alpha; float inv_norm; uint layer; } pc;
#define PUSH_ExtractClustersPush layout(push_constant) uniform Push { vec4[3] file_to_world; uint mode; uint grid; uint at; uint max; } pc;
#define PUSH_ExtractPreparePush layout(push_constant) uniform Push { vec4[3] file_to_world; uvec2 map_size; uint mapping; uint cells; uint stride; uint tree_at; uint max; uint mode; uint tree_room; uint coarse_at; uint[2] pad; } pc;
#define PUSH_LightsPush layout(push_constant) uniform Push { uint size; uint count; uint nodes; uint kernel; float alpha; float inv_norm; uint at; uint coarse_at; uint cells; uint tree_at; uint tree_nodes; float budget; uint layer; } pc;
#define PUSH_ShRotatePush layout(push_constant) uniform Push { uint count; uint lmax; uint method; uint pad; } pc;
#define PUSH_MipPush layout(push_constant) uniform Push { uint src_size; uint dst_size; uint mode; uint pad; } pc;
#define PUSH_McPush layout(push_constant) uniform Push { vec4[3] world_to_file; uvec2 env_size; uint count; uint shadows; uvec2 size; uint first; uint samples; uint seed; uint mis; uint[2] pad; } pc;
struct Object {
    vec4 shape;
    vec4 albedo;
    uint kind;
    float extent;
    uint technique;
    uint brdf;
    float[2] params;
    uint samples;
    float lod_bias;
    float last_lod;
    float lobe;
    float light_norm;
    uint data_offset;
    uint size;
    uint table_offset;
    uint grid;
    uint flags;
};
#endif
