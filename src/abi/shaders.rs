//! The shader table: every SPIR-V module once, with its source, stage, defines, push block
//! and bindings, and the build settings of all of them.

use super::binding;

/// SPIR-V target environment: Vulkan 1.2 (Vulkan 1.3 output uses LocalSizeId, which
/// validation rejects without maintenance4).
pub const TARGET_ENV: &str = "vulkan1.2";
/// Optimisation level handed to shaderc.
pub const OPTIMIZATION: &str = "performance";

/// Where `generated_header` is written.
pub const GENERATED_HEADER: &str = "glsl/include/generated.glsl";
/// Where the hashes of the sources each SPIR-V file was built from are written.
pub const MANIFEST: &str = "spirv/manifest.txt";

/// A shader stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Compute shader.
    Compute,
    /// Vertex shader.
    Vertex,
    /// Fragment shader.
    Fragment,
}

/// One SPIR-V module: which GLSL file, with which defines.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    /// File stem of the SPIR-V output in `spirv/` (`NAME.spv`).
    pub name: &'static str,
    /// GLSL source file in `glsl/`.
    pub file: &'static str,
    /// Stage.
    pub stage: Stage,
    /// Preprocessor defines (name, value).
    pub defines: &'static [(&'static str, &'static str)],
}

/// What a descriptor binding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A combined image sampler.
    Sampled,
    /// A storage image.
    StorageImage,
    /// A storage buffer.
    StorageBuffer,
    /// A uniform texel buffer: a buffer's rgba32f view, read with texelFetch (llvmpipe reads
    /// it as one gather where it reads a storage buffer lane by lane).
    TexelBuffer,
}

/// What a shader does to a binding; the recorder derives barriers from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Only reads.
    Read,
    /// Only writes (earlier contents may be discarded only where the caller says so).
    Write,
    /// Reads and writes (an accumulation, or a level read while another is written).
    ReadWrite,
}

/// Descriptor bindings (set 0) and push-constant size a module expects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interface {
    /// (binding, kind, access) triples.
    pub bindings: &'static [(u32, Kind, Access)],
    /// Size in bytes of the push-constant block (0 for none).
    pub push_size: u32,
    /// The push block's fields: (name, GLSL type, byte offset).
    pub push_fields: &'static [(&'static str, &'static str, usize)],
}

/// The shader table: each module once, with its name, source, stage, defines, push block and
/// bindings. `shader_table!(callback)` hands the whole table to `callback!`, so that the
/// library can embed each module's SPIR-V by name while this file stays std-only.
macro_rules! shader_table {
    ($callback:ident) => {
        $callback! {
            /// Resampling between mappings from a 2D-array source.
            Convert2d = "convert_2d", "convert.comp", Compute, [], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write)];
            /// A 2D source resampled into two dual paraboloids at once, the map's and its
            /// residual's (clamped at a luminance), both premultiplied.
            ConvertSplit = "convert_split", "convert.comp", Compute, [("SPLIT", "1")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_RESIDUAL, StorageImage, Write)];
            /// Resampling between mappings from a cube source.
            ConvertCube = "convert_cube", "convert.comp", Compute, [("SRC_CUBE", "1")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write)];
            /// Lat-long to cube by exact footprint areas (power-conserving): the general walk.
            ConvertArea = "convert_area", "convert_area.comp", Compute, [("DST", "MAPPING_CUBE")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read)];
            /// Lat-long to dual paraboloid by exact footprint areas.
            ConvertAreaParaboloid = "convert_area_paraboloid", "convert_area.comp", Compute,
                [("DST", "MAPPING_DUAL_PARABOLOID")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read)];
            /// ConvertArea's fast path for cube texels away from the poles, over a list of tiles.
            ConvertAreaFast = "convert_area_fast", "convert_area_fast.comp", Compute,
                [("DST", "MAPPING_CUBE")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read),
                 (CONVERT_LIST, StorageBuffer, Read)];
            /// ConvertAreaParaboloid's fast path for texels inside the disc away from the poles.
            ConvertAreaFastParaboloid = "convert_area_fast_paraboloid", "convert_area_fast.comp",
                Compute, [("DST", "MAPPING_DUAL_PARABOLOID"), ("SIDE_EDGE_POINTS", "1")],
                ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read),
                 (CONVERT_LIST, StorageBuffer, Read)];
            /// ConvertAreaParaboloid's texels outside the disc (their rim's source texel), over
            /// a list of tiles.
            ConvertAreaRim = "convert_area_rim", "convert_area_rim.comp", Compute,
                [("DST", "MAPPING_DUAL_PARABOLOID")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_LIST, StorageBuffer, Read)];
            /// ConvertAreaParaboloid's general walk over the texels its fast path leaves.
            ConvertAreaListParaboloid = "convert_area_list_paraboloid", "convert_area_list.comp",
                Compute, [("DST", "MAPPING_DUAL_PARABOLOID")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read),
                 (CONVERT_LIST, StorageBuffer, Read)];
            /// ConvertArea's general walk over a list of texels (those the fast path leaves).
            ConvertAreaList = "convert_area_list", "convert_area_list.comp", Compute,
                [("DST", "MAPPING_CUBE")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read),
                 (CONVERT_LIST, StorageBuffer, Read)];
            /// Lat-long to cube or dual paraboloid by exact footprint areas from a plan: a
            /// gather of each output texel's source texels with their weights.
            ConvertPlanned = "convert_planned", "convert_planned.comp", Compute, [], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES_U, TexelBuffer, Read), (CONVERT_SLOPES_Z, TexelBuffer, Read),
                 (CONVERT_PLAN_OFFSETS, StorageBuffer, Read),
                 (CONVERT_PLAN_ENTRIES, StorageBuffer, Read)];
            /// The limited slopes of a lat-long source that ConvertArea integrates.
            ConvertSlopes = "convert_slopes", "convert_slopes.comp", Compute, [], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_SLOPES_U, StorageBuffer, Write),
                 (CONVERT_SLOPES_Z, StorageBuffer, Write)];
            /// Mapping functions exposed for tests.
            MappingProbe = "mapping_probe", "mapping_probe.comp", Compute, [], ProbePush,
                [(PROBE_IN, StorageBuffer, Read), (PROBE_OUT, StorageBuffer, Write)];
            /// An engine's map copied with texels that are not finite and non-negative zeroed
            /// and counted (the resident path's first pass).
            Sanitize = "sanitize", "sanitize.comp", Compute, [], SanitizePush,
                [(SANITIZE_SRC, Sampled, Read), (SANITIZE_DST, StorageImage, Write),
                 (SANITIZE_COUNT, StorageBuffer, ReadWrite)];
            /// A map clamped in place at a luminance (a bake's residual, made on the GPU).
            Clamp = "clamp", "clamp.comp", Compute, [], ClampPush,
                [(CLAMP_MAP, StorageImage, ReadWrite)];
            /// A plain texel copy (the benchmark floor).
            Copy = "copy", "copy.comp", Compute, [], CopyPush,
                [(COPY_SRC, Sampled, Read), (COPY_DST, StorageImage, Write)];
            /// The exact reference: the radiance a BRDF reflects at each query, summed over
            /// every texel (twin: `ExactFilter::shade`), a partial sum per workgroup.
            ExactShade = "exact_shade", "exact_shade.comp", Compute, [], ExactShadePush,
                [(EXACT_MAP, Sampled, Read), (EXACT_OMEGA, StorageBuffer, Read),
                 (EXACT_QUERIES, StorageBuffer, Read), (EXACT_PARTIALS, StorageBuffer, Write)];
            /// A deliberately costly dispatch (timestamp test).
            Busy = "busy", "busy.comp", Compute, [], BusyPush,
                [(BUSY_OUT, StorageBuffer, Write)];
            /// Test hook: corrupts a level a pass wrote, in place (tests/mutation.rs).
            PoisonImage = "poison_image", "poison_image.comp", Compute, [], PoisonPush,
                [(POISON_IMAGE, StorageImage, ReadWrite)];
            /// Test hook: corrupts floats a pass wrote, in place.
            PoisonBuffer = "poison_buffer", "poison_buffer.comp", Compute, [],
                PoisonPush, [(POISON_BUFFER, StorageBuffer, ReadWrite)];
            /// Fullscreen triangle vertex shader.
            FullscreenVert = "fullscreen_vert", "fullscreen.vert", Vertex, [], (), [];
            /// Flat colour fragment shader.
            FlatFrag = "flat_frag", "flat.frag", Fragment, [], (), [];
            /// SH projection, first level, with subgroup arithmetic.
            ShProjectSubgroup = "sh_project_subgroup", "sh_project.comp", Compute,
                [("USE_SUBGROUPS", "1")], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH projection, first level, shared-memory tree.
            ShProjectShared = "sh_project_shared", "sh_project.comp", Compute, [], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH projection of cube maps (no disc rim rule in the module, which
            /// lavapipe compiles at every run, so it builds faster), with subgroup arithmetic.
            ShProjectGridSubgroup = "sh_project_grid_subgroup", "sh_project.comp", Compute,
                [("USE_SUBGROUPS", "1"), ("GRID_ONLY", "1")], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH projection of cube maps, shared-memory tree.
            ShProjectGridShared = "sh_project_grid_shared", "sh_project.comp", Compute,
                [("GRID_ONLY", "1")], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH projection of lat-long maps, first step: each row's Fourier sums, subgroups.
            ShRowsSubgroup = "sh_rows_subgroup", "sh_rows.comp", Compute,
                [("USE_SUBGROUPS", "1")], ShLatLongPush,
                [(SH_ROWS_SRC, Sampled, Read), (SH_ROWS_OUT, StorageBuffer, Write)];
            /// The same, shared-memory tree.
            ShRowsShared = "sh_rows_shared", "sh_rows.comp", Compute, [], ShLatLongPush,
                [(SH_ROWS_SRC, Sampled, Read), (SH_ROWS_OUT, StorageBuffer, Write)];
            /// SH projection of lat-long maps, second step: the sum over rows, turned into the
            /// world frame, a partial sum per workgroup, subgroups.
            ShLatLongSubgroup = "sh_latlong_subgroup", "sh_latlong.comp", Compute,
                [("USE_SUBGROUPS", "1")], ShLatLongPush,
                [(SH_LATLONG_ROWS, StorageBuffer, Read), (SH_LATLONG_PARTIALS, StorageBuffer, Write)];
            /// The same, shared-memory tree.
            ShLatLongShared = "sh_latlong_shared", "sh_latlong.comp", Compute, [], ShLatLongPush,
                [(SH_LATLONG_ROWS, StorageBuffer, Read), (SH_LATLONG_PARTIALS, StorageBuffer, Write)];
            /// SH coefficients packed for the shade pass: irradiance or windowed sets.
            ShPack = "sh_pack", "sh_pack.comp", Compute, [], ShPackPush,
                [(SH_PACK_RADIANCE, StorageBuffer, Read), (SH_PACK_ENTRIES, StorageBuffer, Read),
                 (SH_PACK_MINUS, StorageBuffer, Read), (SH_PACK_OUT, StorageBuffer, Write)];
            /// SH partial-sum reduction with subgroup arithmetic.
            ShReduceSubgroup = "sh_reduce_subgroup", "sh_reduce.comp", Compute,
                [("USE_SUBGROUPS", "1")], ShReducePush,
                [(SH_REDUCE_IN, StorageBuffer, Read), (SH_REDUCE_OUT, StorageBuffer, Write)];
            /// SH partial-sum reduction, shared-memory tree.
            ShReduceShared = "sh_reduce_shared", "sh_reduce.comp", Compute, [], ShReducePush,
                [(SH_REDUCE_IN, StorageBuffer, Read), (SH_REDUCE_OUT, StorageBuffer, Write)];
            /// Brute-force convolution: per-texel cones, radiance and solid angles.
            BrutePrepare = "brute_prepare", "brute_prepare.comp", Compute, [], BrutePush,
                [(BRUTE_PREP_SRC, Sampled, Read), (BRUTE_PREP_CONES, StorageImage, Write),
                 (BRUTE_PREP_RADIANCE, StorageImage, Write),
                 (BRUTE_PREP_SHAPES, StorageImage, Write)];
            /// Brute-force convolution: one level of the power-moment pyramid.
            BruteMoments = "brute_moments", "brute_moments.comp", Compute, [], BrutePush,
                [(BRUTE_MOM_RADIANCE, StorageImage, Read), (BRUTE_MOM_SHAPES, StorageImage, Read),
                 (BRUTE_MOM_CONES, StorageImage, Write), (BRUTE_MOM_LIGHT, StorageImage, Write)];
            /// Brute-force convolution: a bounding cone per tile of BRUTE_TILE² texels.
            BruteTiles = "brute_tiles", "brute_tiles.comp", Compute, [], BrutePush,
                [(BRUTE_TILE_CONES, StorageImage, Read), (BRUTE_TILE_OUT, StorageBuffer, Write)];
            /// Brute-force convolution with the cosine or a Phong lobe, from a lat-long or cube
            /// source.
            Brute = "brute", "brute.comp", Compute, [], BrutePush,
                [(BRUTE_CONES, StorageImage, Read), (BRUTE_RADIANCE, StorageImage, Read),
                 (BRUTE_PARTIALS, StorageBuffer, ReadWrite),
                 (BRUTE_TILES, StorageBuffer, Read), (BRUTE_SHAPES, StorageImage, Read),
                 (BRUTE_COARSE_CONES, StorageImage, Read), (BRUTE_LIGHT, StorageImage, Read)];
            /// Brute, from an angular or dual-paraboloid source: with the clipped rule for the
            /// texels the disc's rim cuts, whose unrolled nodes more than double the module
            /// and the time lavapipe takes to build it at every run.
            BruteDisc = "brute_disc", "brute.comp", Compute, [("DISC_SOURCE", "1")], BrutePush,
                [(BRUTE_CONES, StorageImage, Read), (BRUTE_RADIANCE, StorageImage, Read),
                 (BRUTE_PARTIALS, StorageBuffer, ReadWrite),
                 (BRUTE_TILES, StorageBuffer, Read), (BRUTE_SHAPES, StorageImage, Read),
                 (BRUTE_COARSE_CONES, StorageImage, Read), (BRUTE_LIGHT, StorageImage, Read)];
            /// Brute's visit floor, a benchmark instrument: Σ L·Ω over the source texels the
            /// walk visits for each output (its one-level walk, no moment source), without the
            /// rule, so that its time is what visiting the exact sum's texels costs.
            BruteVisits = "brute_visits", "brute.comp", Compute, [("VISITS", "1")], BrutePush,
                [(BRUTE_CONES, StorageImage, Read), (BRUTE_RADIANCE, StorageImage, Read),
                 (BRUTE_PARTIALS, StorageBuffer, ReadWrite),
                 (BRUTE_TILES, StorageBuffer, Read), (BRUTE_SHAPES, StorageImage, Read),
                 (BRUTE_COARSE_CONES, StorageImage, Read), (BRUTE_LIGHT, StorageImage, Read)];
            /// Brute-force convolution: the parts' sums, added per output texel into the map.
            BruteResolve = "brute_resolve", "brute_resolve.comp", Compute, [], BrutePush,
                [(BRUTE_RESOLVE_PARTIALS, StorageBuffer, Read), (BRUTE_RESOLVE_DST, StorageImage, Write)];
            /// Irradiance from SH coefficients into a map.
            ShEval = "sh_eval", "sh_eval.comp", Compute, [], ShEvalPush,
                [(SH_EVAL_COEFFS, StorageBuffer, Read), (SH_EVAL_DST, StorageImage, Write)];
            /// G-buffer of analytic spheres and planes.
            GBuffer = "gbuffer", "gbuffer.frag", Fragment, [], GBufferPush,
                [(GBUF_OBJECTS, StorageBuffer, Read)];
            /// Shading of every material, and the frame's composite.
            Shade = "shade", "shade.frag", Fragment, [], ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] whose light tree walks end on a subgroup vote (see
            /// shade.frag's walk_done), where fragment shaders have vote operations.
            ShadeVote = "shade_vote", "shade.frag", Fragment, [("USE_VOTE", "1")], ShadePush,
                SHADE_BINDINGS;
            /// The split-sum DFG table (A, B) per n·v and √α.
            Dfg = "dfg", "dfg.comp", Compute, [], DfgPush,
                [(DFG_TABLE, StorageBuffer, ReadWrite)];
            /// One roughness level of the split-sum prefiltered GGX chain.
            PrefilterGgx = "prefilter_ggx", "prefilter_ggx.comp", Compute, [], PrefilterGgxPush,
                [(PREFILTER_GGX_SRC, Sampled, Read), (PREFILTER_GGX_DST, StorageImage, Write),
                 (PREFILTER_GGX_SAMPLES, StorageBuffer, Read)];
            /// Light texels (extracted from a map) added exactly to a cube level.
            Lights = "lights", "lights.comp", Compute, [], LightsPush,
                [(LIGHTS_TEXELS, StorageBuffer, Read), (LIGHTS_DST, StorageImage, ReadWrite)];
            /// The same, reading the light list through its texel view.
            LightsView = "lights_view", "lights.comp", Compute, [("TEXEL_VIEW", "1")], LightsPush,
                [(LIGHTS_TEXELS, TexelBuffer, Read), (LIGHTS_DST, StorageImage, ReadWrite)];
            /// Light texels found on the GPU, the per-texel steps: histograms, compaction.
            Extract = "extract", "extract.comp", Compute, [], ExtractPush,
                [(EXTRACT_MAP, Sampled, Read), (EXTRACT_SH, StorageBuffer, Read),
                 (EXTRACT_STATE, StorageBuffer, ReadWrite), (EXTRACT_LIGHTS, StorageBuffer, Write),
                 (EXTRACT_RESIDUAL, StorageImage, Write), (EXTRACT_FILL, StorageBuffer, ReadWrite)];
            /// The same, the one-workgroup selects of the cap's threshold (their shared memory
            /// The same, the steps over lists of a filled extraction (ring 0 from the listed
            /// candidates, the rings grown), specialised per mapping.
            ExtractGrow = "extract_grow", "extract.comp", Compute, [("EXTRACT_GROW", "1")],
                ExtractPush,
                [(EXTRACT_MAP, Sampled, Read), (EXTRACT_SH, StorageBuffer, Read),
                 (EXTRACT_STATE, StorageBuffer, ReadWrite), (EXTRACT_LIGHTS, StorageBuffer, Write),
                 (EXTRACT_RESIDUAL, StorageImage, Write), (EXTRACT_FILL, StorageBuffer, ReadWrite)];
            /// and barriers kept out of the per-texel steps).
            ExtractSelect = "extract_select", "extract.comp", Compute, [("EXTRACT_SELECT", "1")],
                ExtractPush,
                [(EXTRACT_MAP, Sampled, Read), (EXTRACT_SH, StorageBuffer, Read),
                 (EXTRACT_STATE, StorageBuffer, ReadWrite), (EXTRACT_LIGHTS, StorageBuffer, Write),
                 (EXTRACT_RESIDUAL, StorageImage, Write), (EXTRACT_FILL, StorageBuffer, ReadWrite)];
            /// The GPU extraction's light records filtered by a kernel into a cube level.
            ExtractAdd = "extract_add", "extract_add.comp", Compute, [], ExtractAddPush,
                [(EXTRACT_ADD_STATE, StorageBuffer, Read), (EXTRACT_ADD_LIGHTS, StorageBuffer, Read),
                 (EXTRACT_ADD_DST, StorageImage, ReadWrite)];
            /// The GPU extraction's light records gathered into the diffuse clusters.
            ExtractClusters = "extract_clusters", "extract_clusters.comp", Compute, [],
                ExtractClustersPush,
                [(CLUSTERS_STATE, StorageBuffer, Read), (CLUSTERS_LIGHTS, StorageBuffer, Read),
                 (CLUSTERS_SORT, StorageBuffer, ReadWrite), (CLUSTERS_OUT, StorageBuffer, Write)];
            /// The GPU extraction's light records prepared for the shade pass's walk: sorted
            /// by a spatial key, texel quadratures and a light tree over them.
            ExtractPrepare = "extract_prepare", "extract_prepare.comp", Compute, [],
                ExtractPreparePush,
                [(PREPARE_STATE, StorageBuffer, Read), (PREPARE_LIGHTS, StorageBuffer, Read),
                 (PREPARE_OUT, StorageBuffer, ReadWrite), (PREPARE_SORT, StorageBuffer, ReadWrite)];
            /// SH projection of a BRDF per view of a grid (SH-BRDF shading's table).
            ShBrdf = "sh_brdf", "sh_brdf.comp", Compute, [], ShBrdfPush,
                [(SH_BRDF_TABLE, StorageBuffer, ReadWrite)];
            /// Rotation of SH vectors by either construction (tests, benchmark).
            ShRotate = "sh_rotate", "sh_rotate.comp", Compute, [], ShRotatePush,
                [(SH_ROT_IN, StorageBuffer, Read), (SH_ROT_OUT, StorageBuffer, Write),
                 (SH_ROT_X90, StorageBuffer, Read)];
            /// One level of the dual-paraboloid MIP chain.
            Mip = "mip", "mip.comp", Compute, [], MipPush,
                [(MIP_SRC, StorageImage, ReadWrite), (MIP_DST, StorageImage, ReadWrite)];
            /// One progressive frame of the Monte Carlo reference.
            Mc = "mc", "mc.comp", Compute, [], McPush,
                [(MC_NORMAL, Sampled, Read), (MC_VIEW, Sampled, Read),
                 (MC_POSITION, Sampled, Read), (MC_OBJECTS, StorageBuffer, Read),
                 (MC_ENV, Sampled, Read), (MC_TABLES, StorageBuffer, Read),
                 (MC_ACCUM, StorageImage, ReadWrite)];
            // shade.frag's variants (below, `shade_variants`) follow the entries above.
            @shade_variants {
                /// mirrors and the background alone
                (ShadeLookup, ShadeVoteLookup, ShadeLeanLookup, ShadeVoteLeanLookup) = "lookup", [];
                /// filtered importance sampling alone
                (ShadeFis, ShadeVoteFis, ShadeLeanFis, ShadeVoteLeanFis) = "fis", [FIS];
                /// SH irradiance alone
                (ShadeSh, ShadeVoteSh, ShadeLeanSh, ShadeVoteLeanSh) = "sh", [SH];
                /// prefiltered maps alone
                (ShadePrefiltered, ShadeVotePrefiltered, ShadeLeanPrefiltered,
                 ShadeVoteLeanPrefiltered) = "prefiltered", [PREFILTERED];
                /// Monte Carlo alone
                (ShadeMc, ShadeVoteMc, ShadeLeanMc, ShadeVoteLeanMc) = "mc", [MC];
                /// SH-BRDF (with SH, whose projection it reads) alone
                (ShadeShBrdf, ShadeVoteShBrdf, ShadeLeanShBrdf, ShadeVoteLeanShBrdf) = "sh_brdf",
                    [SH, SH_BRDF];
                /// split-sum (with FIS, whose chain it reads) alone
                (ShadeSplitSum, ShadeVoteSplitSum, ShadeLeanSplitSum, ShadeVoteLeanSplitSum) =
                    "split_sum", [FIS, SPLIT_SUM];
            }
        }
    };
}
// The library's gpu::shaders embeds the SPIR-V through it; tools/shaderc does not use it.
#[allow(unused_imports)]
pub(crate) use shader_table;

/// A shader's bindings: a list of (binding, kind, access), or the name of a shared one.
macro_rules! binding_list {
    ([$(($b:ident, $kind:ident, $acc:ident)),*]) => {
        &[$((binding::$b, Kind::$kind, Access::$acc)),*]
    };
    ($shared:ident) => {
        $shared
    };
}

/// The bindings of shade.frag, whichever of its variants.
const SHADE_BINDINGS: &[(u32, Kind, Access)] = binding_list!([
    (SHADE_NORMAL, Sampled, Read),
    (SHADE_VIEW, Sampled, Read),
    (SHADE_OBJECTS, StorageBuffer, Read),
    (SHADE_COEFFS, StorageBuffer, Read),
    (SHADE_ENV, Sampled, Read),
    (SHADE_POSITION, Sampled, Read),
    (SHADE_DP, Sampled, Read),
    (SHADE_PREFILTERED, StorageBuffer, Read),
    (SHADE_MC, Sampled, Read),
    (SHADE_BRDF_SH, StorageBuffer, Read),
    (SHADE_X90, StorageBuffer, Read),
    (SHADE_SPLIT, Sampled, Read),
    (SHADE_DFG, StorageBuffer, Read),
    (SHADE_LIGHTS, StorageBuffer, Read),
    (SHADE_CAMERA, StorageBuffer, Read)
]);

/// One of shade.frag's variants for scenes of one technique, built with ONLY_TECHS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShadeVariant {
    /// The techniques kept besides the lookup, as mask bits.
    pub techs: u32,
    /// Its modules: plain and with vote, then both LEAN (no footprint or shadow code).
    pub modules: [ShaderId; 4],
}

/// The ONLY_TECHS define of a shade.frag variant keeping techniques `$tech`.
macro_rules! only_techs {
    ($($tech:ident),*) => {
        concat!("0u" $(, " | (1u << TECH_", stringify!($tech), ")")*)
    };
}

macro_rules! define_shaders {
    ($( $(#[$m:meta])* $id:ident = $name:literal, $file:literal, $stage:ident,
        [$(($k:literal, $v:literal)),*], $push:ty, $binds:tt; )*
     @shade_variants {
        $( $(#[$vm:meta])* ($plain:ident, $vote:ident, $lean:ident, $vote_lean:ident) =
            $short:literal, [$($tech:ident),*]; )*
     }) => {
        /// A shader module envlight uses.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum ShaderId {
            $( $(#[$m])* $id, )*
            $(
                #[doc = "shade.frag for scenes of"] $(#[$vm])* #[doc = "(its ONLY_TECHS variant)."]
                $plain,
                #[doc = "shade.frag with vote for scenes of"] $(#[$vm])*
                $vote,
                #[doc = "shade.frag, LEAN (no footprint or shadow code), for scenes of"] $(#[$vm])*
                $lean,
                #[doc = "shade.frag with vote, LEAN, for scenes of"] $(#[$vm])*
                $vote_lean,
            )*
        }

        /// Every module's build recipe, in table order.
        pub const SHADER_SOURCES: &[ShaderSource] = &[
            $( ShaderSource { name: $name, file: $file, stage: Stage::$stage, defines: &[$(($k, $v)),*] }, )*
            $(
                ShaderSource {
                    name: concat!("shade_", $short), file: "shade.frag", stage: Stage::Fragment,
                    defines: &[("ONLY_TECHS", only_techs!($($tech),*))],
                },
                ShaderSource {
                    name: concat!("shade_vote_", $short), file: "shade.frag", stage: Stage::Fragment,
                    defines: &[("USE_VOTE", "1"), ("ONLY_TECHS", only_techs!($($tech),*))],
                },
                ShaderSource {
                    name: concat!("shade_lean_", $short), file: "shade.frag", stage: Stage::Fragment,
                    defines: &[("ONLY_TECHS", only_techs!($($tech),*)), ("LEAN", "1")],
                },
                ShaderSource {
                    name: concat!("shade_vote_lean_", $short), file: "shade.frag",
                    stage: Stage::Fragment,
                    defines: &[("USE_VOTE", "1"), ("ONLY_TECHS", only_techs!($($tech),*)), ("LEAN", "1")],
                },
            )*
        ];

        /// shade.frag's variants for scenes of one technique, from the table's one list.
        pub const SHADE_VARIANTS: &[ShadeVariant] = &[$(
            ShadeVariant {
                techs: 0 $(| 1 << super::parameters::brdf::technique::$tech)*,
                modules: [ShaderId::$plain, ShaderId::$vote, ShaderId::$lean, ShaderId::$vote_lean],
            },
        )*];

        impl ShaderId {
            /// Every module, in table order.
            pub const ALL: &'static [ShaderId] = &[
                $(ShaderId::$id,)*
                $(ShaderId::$plain, ShaderId::$vote, ShaderId::$lean, ShaderId::$vote_lean,)*
            ];

            /// The build recipe of this module.
            pub fn source(self) -> &'static ShaderSource {
                &SHADER_SOURCES[self as usize]
            }

            /// Its name (the file stem of `spirv/NAME.spv`).
            pub fn name(self) -> &'static str {
                self.source().name
            }

            /// What the pipeline built on this module binds and pushes.
            pub fn interface(self) -> Interface {
                match self {
                    $(
                        ShaderId::$id => Interface {
                            bindings: binding_list!($binds),
                            push_size: std::mem::size_of::<$push>() as u32,
                            push_fields: <$push as PushBlock>::FIELDS,
                        },
                    )*
                    $(ShaderId::$plain | ShaderId::$vote | ShaderId::$lean | ShaderId::$vote_lean)|* => {
                        Interface {
                            bindings: SHADE_BINDINGS,
                            push_size: std::mem::size_of::<ShadePush>() as u32,
                            push_fields: <ShadePush as PushBlock>::FIELDS,
                        }
                    }
                }
            }

            /// The push block's name in the generated header (`PUSH_<name>`), if any.
            pub fn push_block(self) -> Option<&'static str> {
                match self {
                    $(
                        ShaderId::$id => {
                            let n = stringify!($push);
                            (n != "()").then_some(n)
                        }
                    )*
                    $(ShaderId::$plain | ShaderId::$vote | ShaderId::$lean | ShaderId::$vote_lean)|* => {
                        Some("ShadePush")
                    }
                }
            }
        }
    };
}
use super::push::*;
shader_table!(define_shaders);
