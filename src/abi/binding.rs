//! Descriptor binding numbers, per pass (all in set 0).

macro_rules! bindings {
    ($( $(#[$m:meta])* $name:ident = $v:literal; )*) => {
        $( $(#[$m])* pub const $name: u32 = $v; )*
        /// Every binding: (name, number), for the generated header.
        pub const ALL: &[(&str, u32)] = &[$( (stringify!($name), $name) ),*];
    };
}

bindings! {
    /// convert: the source map (sampler2DArray, or samplerCube for cube sources).
    CONVERT_SRC = 0;
    /// convert: the destination map (rgba32f image2DArray).
    CONVERT_DST = 1;
    /// convert_slopes, convert_area: per lat-long texel its limited slope dL/dU (one vec4,
    /// rgb used; storage buffer). A buffer of its own, as is dL/dz's: each then spans 16 B a
    /// texel, so that a 4096 × 2048 source's fits a device's 128 MiB storage buffer range.
    CONVERT_SLOPES_U = 2;
    /// convert_area (LIST): the texels the general walk takes, (i, j, layer, 0) each
    /// (uvec4 storage buffer).
    CONVERT_LIST = 3;
    /// convert_planned: per output texel its first plan entry, then the entry count (uint
    /// storage buffer).
    CONVERT_PLAN_OFFSETS = 4;
    /// convert_planned: the plan's entries, (col | row << area::PLAN_ROW_SHIFT, area, mu, mz as
    /// float bits)
    /// each (uvec4 storage buffer).
    CONVERT_PLAN_ENTRIES = 5;
    /// convert (SPLIT): the residual's paraboloid (rgba32f image2DArray).
    CONVERT_RESIDUAL = 6;
    /// convert_slopes, convert_area: per lat-long texel its limited slope dL/dz (one vec4,
    /// rgb used; storage buffer).
    CONVERT_SLOPES_Z = 7;
    /// mapping_probe: input directions (vec4 storage buffer).
    PROBE_IN = 0;
    /// mapping_probe: results (vec4 storage buffer).
    PROBE_OUT = 1;
    /// copy: the source image (sampler2DArray, read with texelFetch).
    COPY_SRC = 0;
    /// copy: the destination image (rgba32f image2DArray).
    COPY_DST = 1;
    /// sanitize: the engine's map (sampler2DArray, read with texelFetch).
    SANITIZE_SRC = 0;
    /// sanitize: envlight's copy of it (rgba32f image2DArray).
    SANITIZE_DST = 1;
    /// sanitize: the count of texels zeroed (uint storage buffer).
    SANITIZE_COUNT = 2;
    /// clamp: the map clamped in place (rgba32f image2DArray).
    CLAMP_MAP = 0;
    /// busy: the buffer the costly loop writes to.
    BUSY_OUT = 0;
    /// exact_shade: the map (sampler2DArray, read with texelFetch).
    EXACT_MAP = 0;
    /// exact_shade: each texel's solid angle, a lat-long's one a row (float storage buffer).
    EXACT_OMEGA = 1;
    /// exact_shade: per query its lobe, [`crate::passes::exact::QUERY_VEC4S`] vec4 (storage
    /// buffer).
    EXACT_QUERIES = 2;
    /// exact_shade: per query and workgroup its partial sum, vec4 (rgb used; storage buffer).
    EXACT_PARTIALS = 3;
    /// poison_image: the level a pass wrote, corrupted in place (rgba32f image2DArray).
    POISON_IMAGE = 0;
    /// poison_buffer: the floats a pass wrote, corrupted in place (float storage buffer).
    POISON_BUFFER = 0;
    /// sh_project: the map (sampler2DArray, read with texelFetch).
    SH_SRC = 0;
    /// sh_project: per-workgroup partial sums (storage buffer).
    SH_PARTIALS = 1;
    /// sh_rows: the lat-long map (sampler2DArray, read with texelFetch).
    SH_ROWS_SRC = 0;
    /// sh_rows: per row its Fourier sums, 2·lmax + 1 RGB triples (storage buffer).
    SH_ROWS_OUT = 1;
    /// sh_latlong: the rows' Fourier sums.
    SH_LATLONG_ROWS = 0;
    /// sh_latlong: per workgroup of rows its partial sums, world frame (storage buffer).
    SH_LATLONG_PARTIALS = 1;
    /// sh_pack: the radiance coefficients, RGB f32 triples (storage buffer).
    SH_PACK_RADIANCE = 0;
    /// sh_pack: per packed coefficient (source, scale's bits, minus + 1 or 0, 0) (uvec4).
    SH_PACK_ENTRIES = 1;
    /// sh_pack: the set subtracted, vec4 each (rgb used).
    SH_PACK_MINUS = 2;
    /// sh_pack: the packed coefficients, vec4 each, as the shade pass reads them.
    SH_PACK_OUT = 3;
    /// sh_reduce: partial sums in.
    SH_REDUCE_IN = 0;
    /// sh_reduce: partial sums out.
    SH_REDUCE_OUT = 1;
    /// brute_prepare: the source map (sampler2DArray, read with texelFetch).
    BRUTE_PREP_SRC = 0;
    /// brute_prepare: per-texel centre direction and cos of angular radius (rgba32f
    /// image2DArray of the source's size and layers; the brute pass's per-texel data are
    /// images because llvmpipe loads a buffer element lane by lane, an image texel as one
    /// gather).
    BRUTE_PREP_CONES = 1;
    /// brute_prepare: per-texel radiance and solid angle (rgba32f image2DArray).
    BRUTE_PREP_RADIANCE = 2;
    /// brute_prepare: per-texel shape for the tilted rule (rgba32f image2DArray, layers
    /// 3·l, 3·l + 1, 3·l + 2 for source layer l: centroid and whether the texel is
    /// regular, then the two half-edge vectors).
    BRUTE_PREP_SHAPES = 3;
    /// brute: the cones written by brute_prepare.
    BRUTE_CONES = 0;
    /// brute: the radiance and solid angles written by brute_prepare.
    BRUTE_RADIANCE = 1;
    /// brute: per part of the source and output texel, the Kahan sum and its compensation
    /// (2 vec4, part-major), carried between rounds of chunks.
    BRUTE_PARTIALS = 3;
    /// brute: per-tile bounding cones written by brute_tiles (vec4 buffer).
    BRUTE_TILES = 4;
    /// brute: the texel shapes written by brute_prepare.
    BRUTE_SHAPES = 5;
    /// brute: with a moment source, the pyramid level's cones written by brute_moments.
    BRUTE_COARSE_CONES = 6;
    /// brute: with a moment source, the level's light (rgba32f image2DArray, layers
    /// 9·l + 3·c + 0, 1, 2 for layer l and channel c: centroid and power, then the
    /// parallelogram's two half-edges).
    BRUTE_LIGHT = 7;
    /// brute_resolve: the partial sums written by brute.
    BRUTE_RESOLVE_PARTIALS = 0;
    /// brute_resolve: the output map (rgba32f image2DArray).
    BRUTE_RESOLVE_DST = 1;
    /// brute_moments: the prepared texels' radiance and solid angles.
    BRUTE_MOM_RADIANCE = 0;
    /// brute_moments: the prepared texels' shapes.
    BRUTE_MOM_SHAPES = 1;
    /// brute_moments: the level's cones (rgba32f image2DArray).
    BRUTE_MOM_CONES = 2;
    /// brute_moments: the level's light (rgba32f image2DArray, 9 layers a layer).
    BRUTE_MOM_LIGHT = 3;
    /// brute_tiles: the per-texel cones written by brute_prepare.
    BRUTE_TILE_CONES = 0;
    /// brute_tiles: the per-tile bounding cones (axis, cos of radius; w = 2 when empty).
    BRUTE_TILE_OUT = 1;
    /// sh_eval: the coefficients, Â_l and window folded in (vec4 buffer).
    SH_EVAL_COEFFS = 0;
    /// sh_eval: the output map (rgba32f image2DArray).
    SH_EVAL_DST = 1;
    /// gbuffer: the scene's objects (storage buffer of `Object`).
    GBUF_OBJECTS = 0;
    /// shade_sh: G-buffer normals and object indices.
    SHADE_NORMAL = 0;
    /// shade_sh: G-buffer directions to the eye.
    SHADE_VIEW = 1;
    /// shade_sh: the scene's objects (albedo).
    SHADE_OBJECTS = 2;
    /// shade_sh: SH irradiance coefficients (vec4 buffer).
    SHADE_COEFFS = 3;
    /// shade: the environment map in its own mapping (background, mirror lookups).
    SHADE_ENV = 4;
    /// shade: G-buffer hit positions (shadow rays).
    SHADE_POSITION = 5;
    /// shade: the dual-paraboloid MIP chain (FIS).
    SHADE_DP = 6;
    /// shade: prefiltered lat-long maps, texel after texel (vec4 buffer).
    SHADE_PREFILTERED = 7;
    /// shade: the Monte Carlo accumulation (rgb sum, luminance² sum), read for MC pixels.
    SHADE_MC = 8;
    /// mip: the finer level (storage image, read).
    MIP_SRC = 0;
    /// mip: the coarser level (storage image, written).
    MIP_DST = 1;
    /// mc: G-buffer normals and object indices.
    MC_NORMAL = 0;
    /// mc: G-buffer directions to the eye.
    MC_VIEW = 1;
    /// mc: G-buffer hit positions.
    MC_POSITION = 2;
    /// mc: the scene's objects and materials.
    MC_OBJECTS = 3;
    /// mc: the full-resolution lat-long map (texelFetch).
    MC_ENV = 4;
    /// mc: the environment sampling tables (float buffer, see `math::envsample`).
    MC_TABLES = 5;
    /// mc: the accumulation image (rgba32f storage: rgb sum, luminance² sum).
    MC_ACCUM = 6;
    /// sh_brdf: the BRDF's coefficient vectors, view after view (float buffer), summed
    /// over one dispatch per panel.
    SH_BRDF_TABLE = 0;
    /// sh_rotate: rotations and coefficient vectors in (float buffer).
    SH_ROT_IN = 0;
    /// sh_rotate: rotated vectors out (float buffer).
    SH_ROT_OUT = 1;
    /// sh_rotate: the fixed M(Rx(90°)) blocks (float buffer).
    SH_ROT_X90 = 2;
    /// shade: SH-BRDF coefficient tables, concatenated (float buffer).
    SHADE_BRDF_SH = 9;
    /// shade: the fixed M(Rx(90°)) blocks of the zxzxz rotation (float buffer).
    SHADE_X90 = 10;
    /// shade: the split-sum prefiltered GGX chain (dual paraboloid, one roughness a level).
    SHADE_SPLIT = 11;
    /// shade: the split-sum DFG tables (float buffer, (A, B) pairs).
    SHADE_DFG = 12;
    /// shade: extracted light texels (float buffer, as `lights` takes them).
    SHADE_LIGHTS = 13;
    /// shade: the camera (vec4 buffer, [`crate::passes::gbuffer::camera_record`]), for
    /// footprint lookups' sub-pixel rays.
    SHADE_CAMERA = 14;
    /// dfg: the tables, (A, B) per entry (float buffer), summed over one dispatch per panel.
    DFG_TABLE = 0;
    /// prefilter_ggx: the source dual-paraboloid MIP chain (sampler2DArray, trilinear).
    PREFILTER_GGX_SRC = 0;
    /// prefilter_ggx: the level written (rgba32f storage image).
    PREFILTER_GGX_DST = 1;
    /// prefilter_ggx: the level's samples (vec4 buffer, `split_sum::PREFILTER_SAMPLE_VEC4S` a
    /// sample: the direction in the texel's frame and the weight; the lod before the texel
    /// term), [`crate::math::split_sum::prefilter_samples`].
    PREFILTER_GGX_SAMPLES = 2;
    /// lights: the light texels (float buffer, LIGHT_STRIDE vec4 each).
    LIGHTS_TEXELS = 0;
    /// lights: the level their light is added to (rgba32f storage image).
    LIGHTS_DST = 1;
    /// extract: the map (sampler2DArray, read with texelFetch).
    EXTRACT_MAP = 0;
    /// extract: the SH projection's output, RGB f32 triples (L00 gives the mean).
    EXTRACT_SH = 1;
    /// extract: header and histograms (uint storage buffer, also the indirect arguments).
    EXTRACT_STATE = 2;
    /// extract: the light records (storage buffer, `EXTRACT_RECORD_VEC4S` vec4 each).
    EXTRACT_LIGHTS = 3;
    /// extract: the residual map (rgba32f image2DArray).
    EXTRACT_RESIDUAL = 4;
    /// extract: a filled extraction's light set (uint storage buffer: a label per texel,
    /// then per member slot its texel, its filled luminance and the next round's).
    EXTRACT_FILL = 5;
    /// extract_add: the extraction's state (its count and largest solid angle).
    EXTRACT_ADD_STATE = 0;
    /// extract_add: the extraction's light records.
    EXTRACT_ADD_LIGHTS = 1;
    /// extract_add: the cube level the filtered lights are added to (rgba32f image2DArray).
    EXTRACT_ADD_DST = 2;
    /// extract_clusters: the extraction's state (its count).
    CLUSTERS_STATE = 0;
    /// extract_clusters: the extraction's light records.
    CLUSTERS_LIGHTS = 1;
    /// extract_clusters: the counting sort's counts, slots and order (uint buffer).
    CLUSTERS_SORT = 2;
    /// extract_clusters: the clusters written (vec4 buffer, the shade pass's lights).
    CLUSTERS_OUT = 3;
    /// extract_prepare: the extraction's state (its count).
    PREPARE_STATE = 0;
    /// extract_prepare: the extraction's light records.
    PREPARE_LIGHTS = 1;
    /// extract_prepare: the shade pass's lights buffer the prepared texels and their tree
    /// are written into (vec4 storage buffer; the tree's nodes read the texels back).
    PREPARE_OUT = 2;
    /// extract_prepare: the counting sort's counts, slots, keys and order (uint buffer).
    PREPARE_SORT = 3;
}
