//! The shared ABI: everything GLSL and Rust must agree on, written once. Binding numbers and
//! their access, workgroup sizes, ids, numeric constants both sides use, defaults, the
//! push-constant blocks (Rust structs and the GLSL blocks generated from the same list), and
//! the list of shaders with how each is built.
//!
//! This file is self-contained (std only) because `tools/shaderc` includes it by path to write
//! `glsl/include/generated.glsl` and `spirv/manifest.txt` without building the library. It is
//! the bottom of the import order: abi ← math ← gpu ← passes ← scene/render ← CLI.

use std::fmt::Write as _;
use std::path::Path;

macro_rules! bindings {
    ($( $(#[$m:meta])* $name:ident = $v:literal; )*) => {
        $( $(#[$m])* pub const $name: u32 = $v; )*
        /// Every binding: (name, number), for the generated header.
        pub const ALL: &[(&str, u32)] = &[$( (stringify!($name), $name) ),*];
    };
}

/// Descriptor binding numbers, per pass (all in set 0).
pub mod binding {
    bindings! {
        /// convert: the source map (sampler2DArray, or samplerCube for cube sources).
        CONVERT_SRC = 0;
        /// convert: the destination map (rgba32f image2DArray).
        CONVERT_DST = 1;
        /// convert_slopes, convert_area: per lat-long texel its limited slopes dL/dU, dL/dz
        /// (two vec4, rgb used; storage buffer).
        CONVERT_SLOPES = 2;
        /// convert_area (LIST): the texels the general walk takes, (i, j, layer, 0) each
        /// (uvec4 storage buffer).
        CONVERT_LIST = 3;
        /// mapping_probe: input directions (vec4 storage buffer).
        PROBE_IN = 0;
        /// mapping_probe: results (vec4 storage buffer).
        PROBE_OUT = 1;
        /// copy: the source image (sampler2DArray, read with texelFetch).
        COPY_SRC = 0;
        /// copy: the destination image (rgba32f image2DArray).
        COPY_DST = 1;
        /// busy: the buffer the costly loop writes to.
        BUSY_OUT = 0;
        /// sh_project: the map (sampler2DArray, read with texelFetch).
        SH_SRC = 0;
        /// sh_project: per-workgroup partial sums (storage buffer).
        SH_PARTIALS = 1;
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
        /// lights: the light texels (float buffer, LIGHT_STRIDE vec4 each).
        LIGHTS_TEXELS = 0;
        /// lights: the level their light is added to (rgba32f storage image).
        LIGHTS_DST = 1;
    }
}

/// Ids of BRDFs and shading techniques, and the constants their twins share.
pub mod brdf {
    /// BRDF ids (`Object.brdf.x`).
    pub mod ids {
        /// Lambertian diffuse.
        pub const LAMBERT: u32 = 0;
        /// Perfect mirror.
        pub const MIRROR: u32 = 1;
        /// Normalised Phong lobe about the reflected direction.
        pub const PHONG: u32 = 2;
        /// Blinn-Phong.
        pub const BLINN: u32 = 3;
        /// GGX.
        pub const GGX: u32 = 4;
        /// Ward anisotropic.
        pub const WARD: u32 = 5;
    }
    /// Technique ids (`Object.albedo.w`).
    pub mod technique {
        /// One lookup of the reflected direction (mirrors).
        pub const LOOKUP: u32 = 0;
        /// Filtered importance sampling.
        pub const FIS: u32 = 1;
        /// SH irradiance (diffuse).
        pub const SH: u32 = 2;
        /// A prefiltered map (irradiance by the normal, Phong by the reflected direction).
        pub const PREFILTERED: u32 = 3;
        /// The Monte Carlo reference.
        pub const MC: u32 = 4;
        /// SH shading of the BRDF (Kautz et al. 2002).
        pub const SH_BRDF: u32 = 5;
        /// Split-sum: one prefiltered lookup times the DFG table (Karis 2013).
        pub const SPLIT_SUM: u32 = 6;
    }
    /// How each BRDF's f·cos fades towards the surface's horizon, by id: f·cos ≤ C·cos^fade
    /// there, with C about its lobe's size (what a light tree node the horizon crosses may
    /// be taken whole by, [`crate::math::light_tree::horizon_share`]). Lambert and Blinn
    /// carry the cosine, GGX its masking (G ≤ 2 cos θ/α); Ward's 1/√cos leaves √cos; the
    /// normalised Phong lobe and mirrors do not fade.
    pub const HORIZON_FADE: [f64; 6] = [1.0, 0.0, 0.0, 1.0, 1.0, 0.5];
    /// GGX roughness below this is taken as this (the mirror limit with finite numbers).
    pub const GGX_ALPHA_MIN: f64 = 1e-4;
    /// Smallest Ward roughness accepted.
    pub const WARD_ALPHA_MIN: f64 = 1e-3;
}

/// The per-texel quadrature rule of the brute-force convolution, shared by
/// `src/math/filter.rs` and `glsl/brute.comp` (see the former for what each does).
pub mod filter_rule {
    /// Fewest cells per side for a texel the kernel's horizon cuts (the kink of max(0, cos)).
    pub const EDGE_CELLS: u32 = 4;
    /// Most cells per side of one texel.
    pub const MAX_CELLS: u32 = 16;
    /// Cells per side per unit of ρ·√n.
    pub const CELLS_PER_WIDTH: f64 = 2.0;
    /// Below this n·ρ² a texel away from the horizon takes one node.
    pub const CENTRE_LIMIT: f64 = 1e-5;
    /// A regular texel takes the tilted rule (one closed-form term) while n·ρ² is at most
    /// this times x_min², x_min the smallest axis·ω over its cone: the kernel's log-curvature
    /// across it is then small (measured per-texel error under 1e-3, docs/BENCHMARKS.md).
    pub const TILT_LIMIT: f64 = 0.1;
    /// Coarsest level of the power-moment pyramid a lobe is filtered from (4096 fine texels
    /// per coarse one, within llvmpipe's loop limit when the sum descends).
    pub const MAX_SOURCE_LEVEL: u32 = 6;
    /// A texel is regular (close enough to a parallelogram for the tilted rule) when the
    /// mapping's solid-angle density over it varies by at most this ratio and no disc rim
    /// cuts it: lat-long rows next to a pole are triangles, not parallelograms.
    pub const TILT_DENSITY_RATIO: f64 = 1.4;
    /// Below this |z| the tilted rule's sinh z / z, coth z − 1/z and their kin take series:
    /// the closed forms cancel there in f32.
    pub const TILT_SERIES_BELOW: f64 = 0.5;
    /// A tile's bounding radius is widened by this fraction, and then by TILE_MARGIN_ABS
    /// radians, so that f32 rounding in its angles never makes it tighter than its texels'.
    pub const TILE_MARGIN_REL: f64 = 1e-4;
    /// See TILE_MARGIN_REL.
    pub const TILE_MARGIN_ABS: f64 = 1e-5;
    /// Lobe values below this fraction of the peak are dropped (ln 1e-10).
    pub const LOG_CUTOFF: f64 = -23.025_850_929_940_457;
    /// A texel's angular radius is widened by this factor when bounding its cone, so the cone
    /// covers the texel's corners in every mapping.
    pub const CONE_MARGIN: f64 = 1.25;
    /// A lobe's reach in a lat-long source (glsl/brute.comp, walk_rows) widens the texel
    /// cone's bound, CONE_MARGIN times the flat half diagonal, by this fraction: the sphere's
    /// distance exceeds the flat one by a relative O(texel²).
    pub const REACH_MARGIN_REL: f64 = 1e-3;
    /// And then by this many radians, for f32 rounding in x_cut and a texel's x_max (~1e-5
    /// rad where n = 10⁶).
    pub const REACH_MARGIN_ABS: f64 = 1e-4;
}

/// Numbers both the float64 twins and the shaders use.
pub mod constants {
    /// Rec. 709 luminance weights of linear RGB.
    pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];
    /// Above this |n.y| a tangent frame is built from x̂ instead of ŷ (near the poles).
    pub const POLE_THRESHOLD: f64 = 0.999;
    /// A view direction closer than this to the surface is lifted to it (f32 grazing views).
    pub const VIEW_LIFT: f64 = 1e-4;
    /// Shadow rays start this far (times 1 + |p|) off the surface along the normal.
    pub const SHADOW_OFFSET: f64 = 1e-4;
    /// Paraboloid samples outside the unit disc are pulled in to radius 1 − this.
    pub const RIM_PULL_IN: f64 = 1e-4;
    /// Offset of the 2×2 Gauss–Legendre nodes from a texel's centre, in texels: 1/(2√3).
    pub const GAUSS2_OFFSET: f64 = 0.288_675_134_594_812_9;
    /// Phong and Blinn-Phong exponents accepted, materials and prefilters alike.
    pub const PHONG_EXPONENT_RANGE: (f64, f64) = (1.0, 1e7);
}

/// Defaults of per-run options, shared by the library, scene files and the command line.
pub mod defaults {
    /// Monte Carlo samples per pixel.
    pub const MC_SAMPLES: u32 = 1024;
    /// Monte Carlo samples per pixel per dispatch.
    pub const MC_PER_FRAME: u32 = 64;
    /// Monte Carlo random seed.
    pub const MC_SEED: u32 = 1;
    /// SH order of diffuse materials.
    pub const SH_ORDER: u32 = 2;
    /// FIS samples per pixel.
    pub const FIS_SAMPLES: u32 = 64;
    /// FIS lod bias (chosen by measurement, docs/BENCHMARKS.md "Centred MIP chain").
    pub const FIS_BIAS: f64 = 0.0;
    /// FIS lod bias where the samples read the residual of extracted lights, which is
    /// smooth, so finer levels alias less than they blur: FIS-64 on five 1k probes, GGX
    /// α 0.05–0.6 (128², 4096-spp references) erred by at most 3.22% at bias 0 (studio_small_08,
    /// α 0.05) and 2.42% at −0.5; −1 and −1.5 erred more at α ≥ 0.1.
    pub const FIS_BIAS_RESIDUAL: f64 = -0.5;
    /// Side of prefiltered lat-long maps.
    pub const PREFILTERED_SIZE: u32 = 64;
}

/// Side of the square tiles of source texels that the brute-force pass culls as a whole: a
/// tile whose bounding cone lies where the kernel is below the per-texel cutoff holds only
/// texels the per-texel rule would skip, so skipping it changes nothing.
pub const BRUTE_TILE: u32 = 16;

/// Highest SH band the GPU projection supports.
pub const SH_MAX_LMAX: u32 = 8;

/// SH shading of arbitrary BRDFs (Kautz et al. 2002), shared by `src/math/sh_brdf.rs` and
/// `glsl/sh_brdf.comp`, `glsl/shade.frag`.
pub mod sh_brdf {
    /// Uniform panels in the second (azimuthal) uniform of the BRDF projection's quadrature
    /// over the sampler's unit square; each panel takes GL_NODES × GL_NODES nodes.
    pub const PANELS: u32 = 16;
    /// Geometric levels toward each end of the first uniform (2·GRADED_LEVELS panels).
    pub const GRADED_LEVELS: u32 = 8;
    /// Gauss–Legendre nodes per panel axis (the rule of [`gauss4`]).
    pub const GL_NODES: u32 = 4;
    /// Views per side of the paraboloid-mapped view grid, by default (the furnace's
    /// interpolation error is 4× smaller than at 16: tests/sh_brdf.rs).
    pub const DEFAULT_GRID: u32 = 32;
    /// Largest view grid accepted.
    pub const MAX_GRID: u32 = 64;
    /// Rotation by Kautz et al.'s zxzxz decomposition (the default, by measurement).
    pub const ROTATION_ZXZXZ: u32 = 0;
    /// Rotation by the Ivanic–Ruedenberg recurrence.
    pub const ROTATION_IVANIC: u32 = 1;
    /// Floats before the coefficients in a `sh_rotate.comp` input record (three vec4 rows).
    pub const ROTATE_HEADER: u32 = 12;

    /// The 4-point Gauss–Legendre rule on [−1, 1] in closed form: nodes ±√(3/7 ∓ 2/7·√(6/5)),
    /// weights (18 ± √30)/36.
    pub fn gauss4() -> ([f64; 4], [f64; 4]) {
        let a = (3.0 / 7.0 - 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
        let b = (3.0 / 7.0 + 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
        let wa = (18.0 + 30.0f64.sqrt()) / 36.0;
        let wb = (18.0 - 30.0f64.sqrt()) / 36.0;
        ([-b, -a, a, b], [wb, wa, wa, wb])
    }
}
/// Split-sum shading (Karis 2013), shared by `src/math/split_sum.rs`, `glsl/dfg.comp`,
/// `glsl/prefilter_ggx.comp` and `glsl/shade.frag`.
pub mod split_sum {
    /// Roughness levels of the prefiltered chain by default: level k holds GGX
    /// α = (k/(levels − 1))², level 0 the mirror.
    pub const DEFAULT_LEVELS: u32 = 7;
    /// FIS samples per prefiltered texel by default (measured against MC on spiaggia, GGX
    /// α 0.16: 64 samples 16.7% relative RMS, 256 8.0%, 1024 5.5%, FIS's own 5.2%).
    pub const DEFAULT_SAMPLES: u32 = 256;
    /// Side of the prefiltered chain's level 0 by default (capped by the FIS paraboloid's).
    pub const DEFAULT_SIZE: u32 = 512;
    /// The coarsest level keeps at least this many texels a side.
    pub const MIN_LEVEL_SIZE: u32 = 8;
    /// Entries per side of the DFG table (n·v by √α) by default.
    pub const DEFAULT_DFG_SIZE: u32 = 32;
    /// Largest DFG table accepted.
    pub const MAX_DFG_SIZE: u32 = 256;
    /// The DFG table's grazing column (n·v = 0) is integrated at this n·v.
    pub const MU_MIN: f64 = 1e-4;
    /// Taps of the chain per pixel by default: 1 reads it once along r (Karis' n = v = r).
    pub const DEFAULT_TAPS: u32 = 1;
    /// Most taps a material may ask for.
    pub const MAX_TAPS: u32 = 64;
    /// With taps ≥ 2 each tap reads the chain at α = TAP_SCALE·√(Ωs/4π), Ωs = 1/(taps·pdf)
    /// its share of the lobe: the α whose n = v = r lobe has that solid angle (its peak
    /// density is 1/(4πα²)), narrowed so that neighbouring taps overlap less than they
    /// touch. 0.7 was the best of 0.5, 0.7 and 1 at 4, 8 and 16 taps on the sun and
    /// studio probes (float64, converged truth).
    pub const TAP_SCALE: f64 = 0.7;
}

/// Light extraction ([`crate::math::lights`]).
pub mod lights {
    /// A texel is a light texel above this many times the map's mean luminance by default
    /// in bakes and reports (renders extract deeper: [`CHAIN_RATIO`]).
    pub const DEFAULT_RATIO: f64 = 32.0;
    /// Most light texels kept (the threshold rises to keep to it): what the per-texel light
    /// sums of the bake cost.
    pub const MAX_TEXELS: u32 = 256;
    /// Diffuse techniques (SH irradiance, prefiltered irradiance) extract above this many
    /// times the mean luminance, uncapped, and sum the light texels by clusters: on five real
    /// probes it took SH 2's error (float64, 600 normals) on studio_small_08 from 3.8% at
    /// the default extraction to 0.55% (4: 0.84%, 8: 1.4%), on the others to 0.3–0.45%.
    pub const DIFFUSE_RATIO: f64 = 2.0;
    /// Columns of the lat-long grid whose cells gather light texels into clusters for the
    /// cosine (rows: half as many): 5.6° cells changed no probe's SH 2 error by more than 2%
    /// of itself against the texels one by one, at most 2048 clusters.
    pub const CLUSTER_GRID: u32 = 64;
    /// vec4s per cluster in the GPU's list: (Σ L·Ω·ω, 0) for red, green and blue.
    pub const CLUSTER_VEC4S: u32 = 3;
    /// `LightsPush::kernel`: the clamped cosine over light texels (irradiance).
    pub const KERNEL_COSINE: u32 = 0;
    /// `LightsPush::kernel`: split-sum's GGX at n = v = r over light texels.
    pub const KERNEL_GGX: u32 = 1;
    /// `LightsPush::kernel`: the light clusters' irradiance.
    pub const KERNEL_CLUSTERS: u32 = 2;
    /// FIS, split-sum and footprint lookups extract above this many times the mean
    /// luminance by default (the renderer's chain, summed through the light tree): at 32 ×
    /// the mean with 256 texels FIS-64 erred by 19.8% (α 0.05) to 7.3% on studio_small_08
    /// (float64 study, 150 normals, against every texel), at 2 uncapped by 5.2% to 0.9%.
    pub const CHAIN_RATIO: f64 = 2.0;
    /// Most light texels of the chain's extraction by default, and the most a scene may ask
    /// for: llvmpipe ends a loop after 65 535 iterations, and a pixel's walk may visit every
    /// texel's four quadrature nodes.
    pub const CHAIN_MAX_TEXELS: u32 = 16384;
    /// The chain's lights grow by this many rings of texels around them (where
    /// [`CHAIN_MAX_TEXELS`] leaves room) and the residual under them is filled from around
    /// them ([`crate::math::lights::ExtractOptions::fill`]): a residual clamped at the
    /// threshold keeps each softbox as a plateau whose edge FIS's few filtered samples alias.
    /// FIS-64 on studio_small_08 at α 0.05 (128², 4096-spp reference): clamped 5.13%, filled
    /// without growing 4.33%, one ring 3.28%, two 3.22% (a third did not fit the cap). A
    /// scene whose chain serves footprint lookups alone keeps the clamp: they take light
    /// texels by shares linearised over the pixel, and a mirror on studio_small_08 erred by
    /// 3.52% filled against 2.57% clamped.
    pub const CHAIN_FILL: u32 = 2;
    /// vec4s per light texel in the GPU's list: (world centre, Ω), (excess rgb, ρ = √Ω),
    /// then its quadrature nodes' (world direction, weight).
    pub const HEADER_VEC4S: u32 = 2;
    /// Directions a light walk step hands its kernel (shade.frag's walk_step: a node's sigma
    /// points, or this many of a texel's quadrature nodes, whose count is a multiple of it).
    pub const STEP_NODES: u32 = 4;
    /// A light texel takes its centre alone where PER_WIDTH·ρ < CENTRE_BELOW·w (w the
    /// kernel's scale there), its nodes elsewhere.
    pub const PER_WIDTH: f64 = 4.0;
    /// See [`PER_WIDTH`]: the centre's error is then about (ρ/w)²/24 of the texel's term.
    pub const CENTRE_BELOW: f64 = 0.2;
    /// A lobe's scale at chord c from its axis is at least this times c: K ∝ θ⁻⁴ in GGX's tail
    /// varies on a scale of θ/4, taken with a margin.
    pub const TAIL_FRACTION: f64 = 0.125;
    /// A light tree's node is taken whole where its reach is below this times the kernel's
    /// scale there: on five 1k probes (ratio 2, uncapped) the tree's light sums under GGX
    /// α 0.05–0.6 erred by 1e-5 to 1e-3 RMS against the texels one by one, at 200–3000
    /// kernel evaluations a pixel instead of 3 000–22 000.
    pub const TREE_BELOW: f64 = 0.35;
    /// A light tree node's kernel scale in the lobe's tail is at least this times the chord
    /// from the axis to the node's nearest point. Its four sigma points err at fourth order,
    /// so it can be twice [`TAIL_FRACTION`]: 0.125, 0.25 and 0.5 gave the same error on
    /// studio_small_08 (GGX α 0.05: 1.2e-3 RMS) at 2073, 1092 and 756 evaluations a pixel.
    pub const TREE_TAIL: f64 = 0.25;
    /// A node of reach up to [`TREE_BUDGET_REACH`] × the kernel's scale is also taken whole
    /// where its power times a bound on the kernel there (times (reach/scale)⁴ where no cut
    /// crosses it, the sigma points' order) is below this fraction of the pixel's estimate
    /// without the lights (FIS's, or the chain's): most nodes far out in the tail or across
    /// the horizon of a dim lobe. On five 1k probes under GGX α 0.05–0.6 it cut the walk's
    /// steps 2–25× (studio_small_08: 582 → 204 at α 0.05) and moved the worst light-sum
    /// error, relative to the pixel, from 2.65e-3 to 2.69e-3 (3e-2: 3.2e-3).
    pub const TREE_BUDGET: f64 = 1e-2;
    /// See [`TREE_BUDGET`]: beyond the kernel's scale the sigma points stop being a rule.
    pub const TREE_BUDGET_REACH: f64 = 1.0;
    /// How the light sums' own kernels fade towards their cut (`math::light_tree::
    /// horizon_share`): the cosine and split-sum's GGX (D·G/4, its masking) both linearly.
    pub const KERNEL_FADE: f64 = 1.0;
    /// A light tree's leaves hold at most this many texels.
    pub const LEAF_TEXELS: u32 = 4;
    /// vec4s per light tree node in the GPU's list (math::light_tree::LightTree::gpu_nodes).
    pub const TREE_VEC4S: u32 = 5;
}

/// Bits of shade.frag's code mask (its specialisation constant 0) beside the techniques' and
/// [`footprint::CODE`]: llvmpipe runs every branch of a loop's body whether or not a lane
/// takes it, so a light tree walk that could meet all six BRDFs and shadow rays pays for all
/// of them at every step; a pipeline keeps only the code its scene can reach.
pub mod shade_code {
    /// Keeps the shadow rays' code (scenes with `shadows`).
    pub const SHADOWS: u32 = 1 << 17;
    /// Bit `BRDF_SHIFT + id` keeps BRDF `id`'s code ([`super::brdf::ids`]).
    pub const BRDF_SHIFT: u32 = 20;
}

/// Footprint-filtered lookups (mirrors and the background, issue #10): the pixel's footprint
/// in direction space, from G-buffer differences, read from the dual-paraboloid chain by a
/// row of taps along its major axis ([`crate::math::footprint`]).
pub mod footprint {
    /// Taps across a footprint's minor axis: a tap's trilinear read spreads over about two
    /// texels of its level, so finer taps keep a bright texel beside the footprint out of it.
    pub const MIN_TAPS: u32 = 8;
    /// Most taps along a footprint's major axis; beyond that ratio the taps blur more.
    pub const MAX_TAPS: u32 = 16;
    /// Lod bias of each tap (log2 of the texel side over the tap's spacing): half a level
    /// finer offsets the tent a trilinear read adds to the box (measured in
    /// docs/BENCHMARKS.md: studio_small 4.7% -> 3.9% before the other refinements).
    pub const LOD_BIAS: f64 = -0.5;
    /// Taken off a footprint's length over the tap spacing before rounding up, so that a
    /// ratio of exactly k gives k taps in float32 as in float64, not k + 1.
    pub const TAP_SLACK: f64 = 1e-3;
    /// Shortest differential kept (radians per pixel): a footprint no wider is a point.
    pub const MIN_SPREAD: f64 = 1e-6;
    /// Push flag: mirror lookups are footprint-filtered.
    pub const MIRROR: u32 = 1;
    /// Push flag: the background is footprint-filtered.
    pub const BACKGROUND: u32 = 2;
    /// Push flag: the chain holds the residual; footprint lookups add the light texels.
    pub const LIGHTS: u32 = 4;
    /// Bit of shade.frag's specialisation constant 0 (its code mask: bit t for technique t)
    /// that keeps the footprint lookups' code.
    pub const CODE: u32 = 1 << 16;
}

/// Workgroup size of the SH passes: one texel (or partial sum) per invocation.
pub const SH_WORKGROUP: u32 = 64;
/// Texels each SH projection invocation sums in registers before the workgroup sums, on
/// lat-long and cube maps: fewer workgroup reductions (each a barrier per coefficient), at an
/// f32 sum SH_RUN long. Disc mappings take one (their rim rule is long; see sh_project.comp).
pub const SH_RUN: u32 = 16;

/// Workgroup size of 2D compute passes (specialization constants 0 and 1).
pub const WORKGROUP_2D: [u32; 2] = [8, 8];
/// Workgroup size of 1D compute passes (specialization constant 0).
pub const WORKGROUP_1D: u32 = 64;
/// Mapping ids, in [`crate::math::Mapping`]'s order.
pub const MAPPING_NAMES: [&str; 4] = ["LATLONG", "ANGULAR", "CUBE", "DUAL_PARABOLOID"];

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

/// A push-constant block: a `#[repr(C)]` struct of 4-byte scalars and arrays of them, with no
/// padding (checked at compile time), whose GLSL twin is generated from the same field list.
pub trait PushBlock: Copy + 'static {
    /// (name, GLSL type, byte offset) of each field, in order.
    const FIELDS: &'static [(&'static str, &'static str, usize)];
    /// The bytes pushed.
    fn bytes(&self) -> &[u8];
}

impl PushBlock for () {
    const FIELDS: &'static [(&'static str, &'static str, usize)] = &[];
    fn bytes(&self) -> &[u8] {
        &[]
    }
}

macro_rules! push_blocks {
    ($( $(#[$m:meta])* $name:ident { $( $(#[$fm:meta])* $field:ident : $ty:ty = $glsl:literal ),* $(,)? } )*) => {
        $(
            $(#[$m])*
            #[repr(C)]
            #[derive(Clone, Copy, Debug, Default, PartialEq)]
            pub struct $name { $( $(#[$fm])* pub $field: $ty, )* }

            // No padding: the bytes are exactly the fields.
            const _: () = assert!(
                std::mem::size_of::<$name>() == 0 $(+ std::mem::size_of::<$ty>())*
            );

            impl PushBlock for $name {
                const FIELDS: &'static [(&'static str, &'static str, usize)] =
                    &[$( (stringify!($field), $glsl, std::mem::offset_of!($name, $field)) ),*];
                fn bytes(&self) -> &[u8] {
                    // SAFETY: repr(C), every field is u32/f32 or arrays of them (no invalid
                    // bit patterns) and the assertion above rules out padding bytes.
                    unsafe {
                        std::slice::from_raw_parts(
                            (self as *const $name).cast::<u8>(),
                            std::mem::size_of::<$name>(),
                        )
                    }
                }
            }
        )*

        /// Every push block: (name, fields).
        pub const PUSH_BLOCKS: &[(&str, &[(&str, &str, usize)])] =
            &[$( (stringify!($name), <$name as PushBlock>::FIELDS) ),*];
    };
}

/// The lat-long → cube and dual-paraboloid conversion by exact footprint areas
/// (`math::convert::area_*`, `glsl/convert_area.comp`).
pub mod area {
    /// Points per edge of a cube texel's footprint polygon in the (U, z) plane: the chords
    /// err by about 1e-4 of a texel's area away from the poles (measured 5e-6 of the power of
    /// a map with suns at the poles and the seam, 1024 x 512 to cube 256).
    pub const EDGE_STEPS: u32 = 2;
    /// Points per edge of a dual-paraboloid texel's polygon: z = cos θ bends across its
    /// texels as much at the rim as anywhere, and a sun there lands whole in one rim texel, so
    /// that its power errs by that texel's chord error: 3.8e-5 of a map with a sun on the
    /// equator at 2 points, 9.5e-6 at 4 and 2.4e-6 at 8 (1024 x 512 to paraboloid 256,
    /// float64), the cube's 5e-6 at 2.
    pub const PARABOLOID_EDGE_STEPS: u32 = 8;
    /// Points per edge of a dual-paraboloid texel's polygon where the source is a residual,
    /// its lights taken out (FIS's chain), from [`RESIDUAL_EDGE_MIN_SIZE`] up: no sun lands
    /// in a rim texel, and the chords keep power as 8 points do with suns (1024 × 512 with
    /// suns at the poles and seam, to paraboloid 128: the residual 1.1e-5, the suns 1.2e-5 at
    /// 8 points, 1.3e-4 at 2). The FIS paraboloid of spiaggia 1k: 38 → 24 ms on llvmpipe.
    pub const RESIDUAL_EDGE_STEPS: u32 = 2;
    /// See [`RESIDUAL_EDGE_STEPS`]: the chords' error grows about as 1/size² (the residual
    /// above: 2.7e-6 at 256, 1.2e-4 at 32), and smaller paraboloids cost little anyway.
    pub const RESIDUAL_EDGE_MIN_SIZE: u32 = 128;
    /// Points per edge whose nearer end is within [`POLE_NEAR`] / size of the pole's axis,
    /// where great circles curve strongly in (U, z).
    pub const POLE_STEPS: u32 = 8;
    /// See [`POLE_STEPS`].
    pub const POLE_NEAR: f64 = 8.0;
    /// Most polygon vertices: four edges of [`POLE_STEPS`] (or [`PARABOLOID_EDGE_STEPS`])
    /// points, and three closing the polygon along a pole's line.
    pub const MAX_VERTICES: u32 = 4 * POLE_STEPS + 3;
    const _: () = assert!(
        PARABOLOID_EDGE_STEPS <= POLE_STEPS
            && EDGE_STEPS <= POLE_STEPS
            && RESIDUAL_EDGE_STEPS >= 1
            && RESIDUAL_EDGE_STEPS <= POLE_STEPS
    );
    /// vec4s of limited slopes per source texel (dL/dU rgb, then dL/dz rgb), the layout of
    /// the buffer convert_slopes.comp writes and convert_area.comp reads.
    pub const SLOPE_VEC4S: u32 = 2;
    /// Cube outputs at least this large take the fast path (glsl/convert_area.comp, FAST)
    /// away from the poles; smaller ones take the general walk everywhere.
    pub const FAST_MIN_SIZE: u32 = 32;
    /// On the cube faces that hold the poles, the texels within this many texels of the
    /// centre (Chebyshev, from the texel's centre) take the general walk: at size ≥
    /// [`FAST_MIN_SIZE`] every texel with a corner nearer the pole's axis than
    /// [`POLE_NEAR`] / size lies within 4.13 + 0.5 texels of it.
    pub const FAST_WINDOW: u32 = 6;
    /// The cube faces (Vulkan order) whose centres are +Y and −Y, the poles of a lat-long
    /// source under every `Orientation` (turns about Y, flips of Y).
    pub const POLE_FACES: [u32; 2] = [2, 3];
    const _: () = assert!(POLE_NEAR <= 8.0 && FAST_MIN_SIZE >= 32 && FAST_WINDOW >= 5);
    /// The conversion serves sizes whose longest polygon walk
    /// (`math::convert::area_walk_steps`) takes at most this many loop steps (host only), under
    /// llvmpipe's limit of 65 535 per invocation with room for the estimate's error.
    pub const WALK_STEPS: f64 = 40_000.0;
}

/// Push-constant blocks, one per shader family. GLSL reads them as `pc` through the
/// `PUSH_<Name>` macro of the generated header.
pub mod push {
    use super::PushBlock;

    push_blocks! {
        /// `glsl/convert.comp`.
        ConvertPush {
            /// Rows of the world → file rotation/reflection (w unused).
            world_to_file: [[f32; 4]; 3] = "vec4[3]",
            /// Source layer size.
            src_size: [u32; 2] = "uvec2",
            /// Destination layer size.
            dst_size: [u32; 2] = "uvec2",
            /// Source mapping id.
            src_mapping: u32 = "uint",
            /// Destination mapping id.
            dst_mapping: u32 = "uint",
            /// Samples per axis per output texel.
            ss: u32 = "uint",
            /// 1: each sample reads the source's nearest texel (box reconstruction).
            nearest: u32 = "uint",
        }
        /// `glsl/mapping_probe.comp`.
        ProbePush {
            /// 0: round trip; 1: solid angles.
            mode: u32 = "uint",
            /// Mapping id.
            mapping: u32 = "uint",
            /// Number of items.
            count: u32 = "uint",
            /// Layer width (mode 1).
            width: u32 = "uint",
            /// Layer height (mode 1).
            height: u32 = "uint",
            /// Padding.
            pad: [u32; 3] = "uint[3]",
        }
        /// `glsl/copy.comp`.
        CopyPush {
            /// Layer size.
            size: [u32; 2] = "uvec2",
            /// Padding.
            pad: [u32; 2] = "uint[2]",
        }
        /// `glsl/busy.comp`.
        BusyPush {
            /// Loop iterations per invocation.
            iterations: u32 = "uint",
            /// Invocations.
            count: u32 = "uint",
            /// Padding.
            pad: [u32; 2] = "uint[2]",
        }
        /// `glsl/sh_project.comp`.
        ShProjectPush {
            /// Rows of the file → world matrix.
            file_to_world: [[f32; 4]; 3] = "vec4[3]",
            /// Layer size.
            size: [u32; 2] = "uvec2",
            /// Mapping id.
            mapping: u32 = "uint",
            /// Highest band.
            lmax: u32 = "uint",
            /// Texels in all layers.
            texels: u32 = "uint",
            /// Padding.
            pad: [u32; 3] = "uint[3]",
        }
        /// `glsl/sh_reduce.comp`.
        ShReducePush {
            /// Rows of partial sums in the input.
            rows: u32 = "uint",
            /// Coefficients per row.
            coeffs: u32 = "uint",
            /// Padding.
            pad: [u32; 2] = "uint[2]",
        }
        /// `glsl/brute.comp` (both variants).
        BrutePush {
            /// Rows of the source file → world matrix.
            file_to_world: [[f32; 4]; 3] = "vec4[3]",
            /// Source layer size.
            src_size: [u32; 2] = "uvec2",
            /// Output layer size.
            dst_size: [u32; 2] = "uvec2",
            /// Source mapping id.
            src_mapping: u32 = "uint",
            /// Output mapping id.
            dst_mapping: u32 = "uint",
            /// Source texels in all layers.
            texels: u32 = "uint",
            /// 0 for the cosine, else the Phong exponent.
            exponent: f32 = "float",
            /// First source slot this dispatch sums (tile-major: BRUTE_TILE² slots a tile).
            chunk_begin: u32 = "uint",
            /// One past the last.
            chunk_end: u32 = "uint",
            /// Source layers.
            src_layers: u32 = "uint",
            /// Level of the moment pyramid `src_size` is the size of (0: the prepared texels).
            src_level: u32 = "uint",
            /// Parts the source is split into, laid out as a grid of output-sized blocks (x, y).
            parts: [u32; 2] = "uvec2",
            /// Source slots per part in one dispatch.
            part_slots: u32 = "uint",
            /// Padding.
            pad: u32 = "uint",
        }
        /// `glsl/sh_eval.comp`.
        ShEvalPush {
            /// Output layer size.
            dst_size: [u32; 2] = "uvec2",
            /// Output mapping id.
            dst_mapping: u32 = "uint",
            /// Highest band.
            lmax: u32 = "uint",
        }
        /// `glsl/gbuffer.frag`.
        GBufferPush {
            /// Eye position.
            eye: [f32; 4] = "vec4",
            /// Unit forward.
            forward: [f32; 4] = "vec4",
            /// Right, scaled by the image plane's half width.
            right: [f32; 4] = "vec4",
            /// Up, scaled by the half height.
            up: [f32; 4] = "vec4",
            /// Image size.
            size: [u32; 2] = "uvec2",
            /// 1 for orthographic.
            ortho: u32 = "uint",
            /// Number of objects.
            count: u32 = "uint",
        }
        /// `glsl/shade.frag`.
        ShadePush {
            /// Rows of the world → file matrix of the environment.
            world_to_file: [[f32; 4]; 3] = "vec4[3]",
            /// Environment layer size.
            env_size: [u32; 2] = "uvec2",
            /// Environment mapping id.
            env_mapping: u32 = "uint",
            /// Number of objects.
            count: u32 = "uint",
            /// Side of the dual paraboloid's level 0.
            dp_size: u32 = "uint",
            /// Its last MIP level.
            max_lod: f32 = "float",
            /// 1: shadow rays for lookups and FIS samples.
            shadows: u32 = "uint",
            /// Samples in the Monte Carlo accumulation.
            mc_samples: u32 = "uint",
            /// Rotation of SH-BRDF vectors: SH_ROTATION_ZXZXZ or SH_ROTATION_IVANIC.
            sh_rotation: u32 = "uint",
            /// Extracted light texels (FIS, split-sum and footprint lookups add them).
            lights: u32 = "uint",
            /// vec4s per light texel in their buffer.
            light_stride: u32 = "uint",
            /// Footprint filtering: FOOTPRINT_MIRROR | FOOTPRINT_BACKGROUND | FOOTPRINT_LIGHTS.
            footprint: u32 = "uint",
            /// Light clusters for the cosine (SH and prefiltered irradiance marked for them).
            clusters: u32 = "uint",
            /// Where they start in the lights buffer, in vec4s.
            cluster_at: u32 = "uint",
            /// Nodes of the light texels' tree (math::light_tree), 0 without lights.
            tree_nodes: u32 = "uint",
            /// Where they start in the lights buffer, in vec4s.
            tree_at: u32 = "uint",
        }
        /// `glsl/sh_brdf.comp`.
        ShBrdfPush {
            /// Views per side of the grid.
            grid: u32 = "uint",
            /// The BRDF's first parameter.
            p0: f32 = "float",
            /// Its second.
            p1: f32 = "float",
            /// Where the table starts in the output, in floats.
            offset: u32 = "uint",
            /// The panel of the first uniform this dispatch adds (panel 0 writes).
            panel: u32 = "uint",
            /// Padding.
            pad: [u32; 3] = "uint[3]",
        }
        /// `glsl/dfg.comp`.
        DfgPush {
            /// Entries per side.
            size: u32 = "uint",
            /// 1: height-correlated Smith masking.
            correlated: u32 = "uint",
            /// Where the table starts in the output, in floats.
            offset: u32 = "uint",
            /// The panel of the first uniform this dispatch adds (panel 0 writes).
            panel: u32 = "uint",
            /// 1: entries at texel centres ((i + ½)/size), 0: at endpoints (i/(size − 1)).
            centres: u32 = "uint",
        }
        /// `glsl/prefilter_ggx.comp`.
        PrefilterGgxPush {
            /// Side of the level written.
            size: u32 = "uint",
            /// Side of the source chain's level 0.
            src_size: u32 = "uint",
            /// The source chain's last level.
            src_max_lod: f32 = "float",
            /// GGX α of this level (0: a bilinear read of the source's level 0).
            alpha: f32 = "float",
            /// FIS samples per texel.
            samples: u32 = "uint",
            /// Lod bias.
            bias: f32 = "float",
            /// Mapping of the chain written: dual paraboloid (the shading's) or cube (bakes).
            dst_mapping: u32 = "uint",
            /// Padding.
            pad: u32 = "uint",
        }
        /// `glsl/lights.comp`.
        LightsPush {
            /// Side of the level written (a cube face).
            size: u32 = "uint",
            /// Light texels.
            count: u32 = "uint",
            /// Quadrature nodes per light texel.
            nodes: u32 = "uint",
            /// `lights::KERNEL_COSINE` (irradiance), `KERNEL_GGX` (split-sum's GGX at α) or
            /// `KERNEL_CLUSTERS` (the light clusters' irradiance, `count` from `at`).
            kernel: u32 = "uint",
            /// GGX α.
            alpha: f32 = "float",
            /// 1 / ∫ K dω, the kernel's normalisation (1 for the cosine).
            inv_norm: f32 = "float",
            /// Where the clusters start in the buffer, in vec4s.
            at: u32 = "uint",
            /// Padding.
            pad: u32 = "uint",
        }
        /// `glsl/sh_rotate.comp`.
        ShRotatePush {
            /// Records.
            count: u32 = "uint",
            /// Highest band.
            lmax: u32 = "uint",
            /// SH_ROTATION_ZXZXZ or SH_ROTATION_IVANIC.
            method: u32 = "uint",
            /// Padding.
            pad: u32 = "uint",
        }
        /// `glsl/mip.comp`.
        MipPush {
            /// Side of the level read.
            src_size: u32 = "uint",
            /// Side of the level written.
            dst_size: u32 = "uint",
            /// 0: premultiply level 0 in place; 1: filter down.
            mode: u32 = "uint",
            /// Padding.
            pad: u32 = "uint",
        }
        /// `glsl/mc.comp`.
        McPush {
            /// Rows of the world → file matrix.
            world_to_file: [[f32; 4]; 3] = "vec4[3]",
            /// Lat-long size.
            env_size: [u32; 2] = "uvec2",
            /// Number of objects.
            count: u32 = "uint",
            /// 1: shadow rays.
            shadows: u32 = "uint",
            /// Frame size.
            size: [u32; 2] = "uvec2",
            /// Index of the frame's first sample.
            first: u32 = "uint",
            /// Samples per pixel in this frame.
            samples: u32 = "uint",
            /// Random seed.
            seed: u32 = "uint",
            /// 1: MIS of BRDF and environment sampling; 0: BRDF sampling alone.
            mis: u32 = "uint",
            /// Padding.
            pad: [u32; 2] = "uint[2]",
        }
    }
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
            /// Resampling between mappings from a cube source.
            ConvertCube = "convert_cube", "convert.comp", Compute, [("SRC_CUBE", "1")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write)];
            /// Lat-long to cube by exact footprint areas (power-conserving): the general walk.
            ConvertArea = "convert_area", "convert_area.comp", Compute, [("DST", "MAPPING_CUBE")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES, TexelBuffer, Read)];
            /// Lat-long to dual paraboloid by exact footprint areas.
            ConvertAreaParaboloid = "convert_area_paraboloid", "convert_area.comp", Compute,
                [("DST", "MAPPING_DUAL_PARABOLOID")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES, TexelBuffer, Read)];
            /// ConvertArea's fast path for cube texels away from the poles.
            ConvertAreaFast = "convert_area_fast", "convert_area.comp", Compute,
                [("FAST", "1"), ("DST", "MAPPING_CUBE")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES, TexelBuffer, Read)];
            /// ConvertArea's general walk over a list of texels (those the fast path leaves).
            ConvertAreaList = "convert_area_list", "convert_area.comp", Compute,
                [("LIST", "1"), ("DST", "MAPPING_CUBE")], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_DST, StorageImage, Write),
                 (CONVERT_SLOPES, TexelBuffer, Read), (CONVERT_LIST, StorageBuffer, Read)];
            /// The limited slopes of a lat-long source that ConvertArea integrates.
            ConvertSlopes = "convert_slopes", "convert_slopes.comp", Compute, [], ConvertPush,
                [(CONVERT_SRC, Sampled, Read), (CONVERT_SLOPES, StorageBuffer, Write)];
            /// Mapping functions exposed for tests.
            MappingProbe = "mapping_probe", "mapping_probe.comp", Compute, [], ProbePush,
                [(PROBE_IN, StorageBuffer, Read), (PROBE_OUT, StorageBuffer, Write)];
            /// A plain texel copy (the benchmark floor).
            Copy = "copy", "copy.comp", Compute, [], CopyPush,
                [(COPY_SRC, Sampled, Read), (COPY_DST, StorageImage, Write)];
            /// A deliberately costly dispatch (timestamp test).
            Busy = "busy", "busy.comp", Compute, [], BusyPush,
                [(BUSY_OUT, StorageBuffer, Write)];
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
            /// SH projection of lat-long and cube maps (no disc rim rule in the module, which
            /// lavapipe compiles at every run: 38 → 24 ms), with subgroup arithmetic.
            ShProjectGridSubgroup = "sh_project_grid_subgroup", "sh_project.comp", Compute,
                [("USE_SUBGROUPS", "1"), ("GRID_ONLY", "1")], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH projection of lat-long and cube maps, shared-memory tree.
            ShProjectGridShared = "sh_project_grid_shared", "sh_project.comp", Compute,
                [("GRID_ONLY", "1")], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH projection of lat-long maps to l = 2, band and mapping compile-time
            /// constants (a third of the module: 24 → 15 ms to build on lavapipe), subgroups.
            ShProjectLatLong2Subgroup = "sh_project_latlong2_subgroup", "sh_project.comp", Compute,
                [("USE_SUBGROUPS", "1"), ("GRID_ONLY", "1"), ("FIXED_LMAX", "2u"),
                 ("FIXED_MAPPING", "MAPPING_LATLONG")], ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// The same, shared-memory tree.
            ShProjectLatLong2Shared = "sh_project_latlong2_shared", "sh_project.comp", Compute,
                [("GRID_ONLY", "1"), ("FIXED_LMAX", "2u"), ("FIXED_MAPPING", "MAPPING_LATLONG")],
                ShProjectPush,
                [(SH_SRC, Sampled, Read), (SH_PARTIALS, StorageBuffer, Write)];
            /// SH partial-sum reduction with subgroup arithmetic.
            ShReduceSubgroup = "sh_reduce_subgroup", "sh_reduce.comp", Compute,
                [("USE_SUBGROUPS", "1")], ShReducePush,
                [(SH_REDUCE_IN, StorageBuffer, Read), (SH_REDUCE_OUT, StorageBuffer, Write)];
            /// SH partial-sum reduction, shared-memory tree.
            ShReduceShared = "sh_reduce_shared", "sh_reduce.comp", Compute, [], ShReducePush,
                [(SH_REDUCE_IN, StorageBuffer, Read), (SH_REDUCE_OUT, StorageBuffer, Write)];
            /// Brute-force convolution: per-texel cones, radiance and solid angles.
            BrutePrepare = "brute_prepare", "brute.comp", Compute, [("PREPARE", "1")], BrutePush,
                [(BRUTE_PREP_SRC, Sampled, Read), (BRUTE_PREP_CONES, StorageImage, Write),
                 (BRUTE_PREP_RADIANCE, StorageImage, Write),
                 (BRUTE_PREP_SHAPES, StorageImage, Write)];
            /// Brute-force convolution: one level of the power-moment pyramid.
            BruteMoments = "brute_moments", "brute.comp", Compute, [("MOMENTS", "1")], BrutePush,
                [(BRUTE_MOM_RADIANCE, StorageImage, Read), (BRUTE_MOM_SHAPES, StorageImage, Read),
                 (BRUTE_MOM_CONES, StorageImage, Write), (BRUTE_MOM_LIGHT, StorageImage, Write)];
            /// Brute-force convolution: a bounding cone per tile of BRUTE_TILE² texels.
            BruteTiles = "brute_tiles", "brute.comp", Compute, [("TILES", "1")], BrutePush,
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
            /// (lavapipe built Brute in 123 ms with them, 52 without, every run).
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
            BruteResolve = "brute_resolve", "brute.comp", Compute, [("RESOLVE", "1")], BrutePush,
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
            /// [`ShaderId::Shade`] for scenes of mirrors and the background
            /// alone (shade.frag's ONLY_TECHS).
            ShadeLookup = "shade_lookup", "shade.frag", Fragment,
                [("ONLY_TECHS", "0u")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] for scenes of filtered importance
            /// sampling alone (shade.frag's ONLY_TECHS).
            ShadeFis = "shade_fis", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_FIS")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] for scenes of SH irradiance alone (shade.frag's ONLY_TECHS).
            ShadeSh = "shade_sh", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_SH")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] for scenes of prefiltered maps alone (shade.frag's ONLY_TECHS).
            ShadePrefiltered = "shade_prefiltered", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_PREFILTERED")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] for scenes of Monte Carlo alone (shade.frag's ONLY_TECHS).
            ShadeMc = "shade_mc", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_MC")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] for scenes of SH-BRDF (with SH, whose
            /// projection it reads) alone (shade.frag's ONLY_TECHS).
            ShadeShBrdf = "shade_sh_brdf", "shade.frag", Fragment,
                [("ONLY_TECHS", "(1u << TECH_SH) | (1u << TECH_SH_BRDF)")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::Shade`] for scenes of split-sum (with FIS, whose
            /// chain it reads) alone (shade.frag's ONLY_TECHS).
            ShadeSplitSum = "shade_split_sum", "shade.frag", Fragment,
                [("ONLY_TECHS", "(1u << TECH_FIS) | (1u << TECH_SPLIT_SUM)")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of mirrors and the background alone.
            ShadeVoteLookup = "shade_vote_lookup", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "0u")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of filtered importance sampling alone.
            ShadeVoteFis = "shade_vote_fis", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_FIS")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of SH irradiance alone.
            ShadeVoteSh = "shade_vote_sh", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_SH")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of prefiltered maps alone.
            ShadeVotePrefiltered = "shade_vote_prefiltered", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_PREFILTERED")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of Monte Carlo alone.
            ShadeVoteMc = "shade_vote_mc", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_MC")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of SH-BRDF (with SH) alone.
            ShadeVoteShBrdf = "shade_vote_sh_brdf", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "(1u << TECH_SH) | (1u << TECH_SH_BRDF)")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVote`] for scenes of split-sum (with FIS) alone.
            ShadeVoteSplitSum = "shade_vote_split_sum", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "(1u << TECH_FIS) | (1u << TECH_SPLIT_SUM)")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeLookup`] less footprint and shadow code (LEAN).
            ShadeLeanLookup = "shade_lean_lookup", "shade.frag", Fragment,
                [("ONLY_TECHS", "0u"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeFis`] less footprint and shadow code (LEAN).
            ShadeLeanFis = "shade_lean_fis", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_FIS"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeSh`] less footprint and shadow code (LEAN).
            ShadeLeanSh = "shade_lean_sh", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_SH"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadePrefiltered`] less footprint and shadow code (LEAN).
            ShadeLeanPrefiltered = "shade_lean_prefiltered", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_PREFILTERED"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeMc`] less footprint and shadow code (LEAN).
            ShadeLeanMc = "shade_lean_mc", "shade.frag", Fragment,
                [("ONLY_TECHS", "1u << TECH_MC"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeShBrdf`] less footprint and shadow code (LEAN).
            ShadeLeanShBrdf = "shade_lean_sh_brdf", "shade.frag", Fragment,
                [("ONLY_TECHS", "(1u << TECH_SH) | (1u << TECH_SH_BRDF)"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeSplitSum`] less footprint and shadow code (LEAN).
            ShadeLeanSplitSum = "shade_lean_split_sum", "shade.frag", Fragment,
                [("ONLY_TECHS", "(1u << TECH_FIS) | (1u << TECH_SPLIT_SUM)"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVoteLookup`] less footprint and shadow code.
            ShadeVoteLeanLookup = "shade_vote_lean_lookup", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "0u"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVoteFis`] less footprint and shadow code.
            ShadeVoteLeanFis = "shade_vote_lean_fis", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_FIS"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVoteSh`] less footprint and shadow code.
            ShadeVoteLeanSh = "shade_vote_lean_sh", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_SH"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVotePrefiltered`] less footprint and shadow code.
            ShadeVoteLeanPrefiltered = "shade_vote_lean_prefiltered", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_PREFILTERED"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVoteMc`] less footprint and shadow code.
            ShadeVoteLeanMc = "shade_vote_lean_mc", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "1u << TECH_MC"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVoteShBrdf`] less footprint and shadow code.
            ShadeVoteLeanShBrdf = "shade_vote_lean_sh_brdf", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "(1u << TECH_SH) | (1u << TECH_SH_BRDF)"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// [`ShaderId::ShadeVoteSplitSum`] less footprint and shadow code.
            ShadeVoteLeanSplitSum = "shade_vote_lean_split_sum", "shade.frag", Fragment,
                [("USE_VOTE", "1"), ("ONLY_TECHS", "(1u << TECH_FIS) | (1u << TECH_SPLIT_SUM)"), ("LEAN", "1")],
                ShadePush, SHADE_BINDINGS;
            /// The split-sum DFG table (A, B) per n·v and √α.
            Dfg = "dfg", "dfg.comp", Compute, [], DfgPush,
                [(DFG_TABLE, StorageBuffer, ReadWrite)];
            /// One roughness level of the split-sum prefiltered GGX chain.
            PrefilterGgx = "prefilter_ggx", "prefilter_ggx.comp", Compute, [], PrefilterGgxPush,
                [(PREFILTER_GGX_SRC, Sampled, Read), (PREFILTER_GGX_DST, StorageImage, Write)];
            /// Light texels (extracted from a map) added exactly to a cube level.
            Lights = "lights", "lights.comp", Compute, [], LightsPush,
                [(LIGHTS_TEXELS, StorageBuffer, Read), (LIGHTS_DST, StorageImage, ReadWrite)];
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

macro_rules! define_shaders {
    ($( $(#[$m:meta])* $id:ident = $name:literal, $file:literal, $stage:ident,
        [$(($k:literal, $v:literal)),*], $push:ty, $binds:tt; )*) => {
        /// A shader module envlight uses.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum ShaderId { $( $(#[$m])* $id, )* }

        /// Every module's build recipe, in table order.
        pub const SHADER_SOURCES: &[ShaderSource] = &[$(
            ShaderSource { name: $name, file: $file, stage: Stage::$stage, defines: &[$(($k, $v)),*] },
        )*];

        impl ShaderId {
            /// Every module, in table order.
            pub const ALL: &'static [ShaderId] = &[$(ShaderId::$id),*];

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
                match self {$(
                    ShaderId::$id => Interface {
                        bindings: binding_list!($binds),
                        push_size: std::mem::size_of::<$push>() as u32,
                        push_fields: <$push as PushBlock>::FIELDS,
                    },
                )*}
            }

            /// The push block's name in the generated header (`PUSH_<name>`), if any.
            pub fn push_block(self) -> Option<&'static str> {
                match self {$(
                    ShaderId::$id => {
                        let n = stringify!($push);
                        (n != "()").then_some(n)
                    }
                )*}
            }
        }
    };
}
use push::*;
shader_table!(define_shaders);

/// The GLSL header carrying the constants above.
pub fn generated_header() -> String {
    let mut s = String::from(
        "// Generated from src/abi.rs by `cargo xtask shaders`; do not edit.\n\
         #ifndef ENVLIGHT_GENERATED_GLSL\n#define ENVLIGHT_GENERATED_GLSL\n",
    );
    for (name, v) in binding::ALL {
        let _ = writeln!(s, "#define BINDING_{name} {v}");
    }
    let _ = writeln!(s, "#define SH_MAX_LMAX {SH_MAX_LMAX}");
    let n = (SH_MAX_LMAX + 1) * (SH_MAX_LMAX + 1);
    let _ = writeln!(s, "#define SH_MAX_COEFFS {n}");
    let _ = writeln!(s, "#define SH_WORKGROUP {SH_WORKGROUP}");
    let _ = writeln!(s, "#define BRUTE_TILE {BRUTE_TILE}u");
    let _ = writeln!(s, "#define LIGHT_HEADER_VEC4S {}u", lights::HEADER_VEC4S);
    let _ = writeln!(s, "#define LIGHT_STEP_NODES {}u", lights::STEP_NODES);
    let _ = writeln!(s, "#define LIGHT_CLUSTER_VEC4S {}u", lights::CLUSTER_VEC4S);
    let _ = writeln!(s, "#define LIGHTS_KERNEL_COSINE {}u", lights::KERNEL_COSINE);
    let _ = writeln!(s, "#define LIGHTS_KERNEL_GGX {}u", lights::KERNEL_GGX);
    let _ = writeln!(
        s,
        "#define LIGHTS_KERNEL_CLUSTERS {}u",
        lights::KERNEL_CLUSTERS
    );
    let _ = writeln!(s, "#define LIGHT_PER_WIDTH {:?}", lights::PER_WIDTH as f32);
    let _ = writeln!(
        s,
        "#define LIGHT_CENTRE_BELOW {:?}",
        lights::CENTRE_BELOW as f32
    );
    let _ = writeln!(
        s,
        "#define LIGHT_TAIL_FRACTION {:?}",
        lights::TAIL_FRACTION as f32
    );
    let _ = writeln!(
        s,
        "#define LIGHT_TREE_BELOW {:?}",
        lights::TREE_BELOW as f32
    );
    let _ = writeln!(
        s,
        "#define LIGHT_TREE_BUDGET {:?}",
        lights::TREE_BUDGET as f32
    );
    let _ = writeln!(
        s,
        "#define LIGHT_TREE_BUDGET_REACH {:?}",
        lights::TREE_BUDGET_REACH as f32
    );
    let _ = writeln!(
        s,
        "#define LIGHT_KERNEL_FADE {:?}",
        lights::KERNEL_FADE as f32
    );
    let _ = writeln!(s, "#define LIGHT_LEAF_TEXELS {}u", lights::LEAF_TEXELS);
    let _ = writeln!(s, "#define LIGHT_TREE_TAIL {:?}", lights::TREE_TAIL as f32);
    let _ = writeln!(s, "#define LIGHT_TREE_VEC4S {}u", lights::TREE_VEC4S);
    let _ = writeln!(s, "#define AREA_EDGE_STEPS {}u", area::EDGE_STEPS);
    let _ = writeln!(s, "#define AREA_POLE_STEPS {}u", area::POLE_STEPS);
    let _ = writeln!(s, "#define AREA_POLE_NEAR {:?}", area::POLE_NEAR as f32);
    let _ = writeln!(s, "#define AREA_MAX_VERTICES {}u", area::MAX_VERTICES);
    let _ = writeln!(
        s,
        "#define AREA_PARABOLOID_EDGE_STEPS {}u",
        area::PARABOLOID_EDGE_STEPS
    );
    let _ = writeln!(s, "#define AREA_SLOPE_VEC4S {}u", area::SLOPE_VEC4S);
    let _ = writeln!(s, "#define AREA_FAST_WINDOW {}u", area::FAST_WINDOW);
    let _ = writeln!(s, "#define AREA_FAST_MIN_SIZE {}u", area::FAST_MIN_SIZE);
    for (k, face) in area::POLE_FACES.iter().enumerate() {
        let _ = writeln!(s, "#define AREA_POLE_FACE_{k} {face}u");
    }
    let _ = writeln!(s, "#define FOOTPRINT_MIN_TAPS {}u", footprint::MIN_TAPS);
    let _ = writeln!(s, "#define FOOTPRINT_MAX_TAPS {}u", footprint::MAX_TAPS);
    let _ = writeln!(s, "#define FOOTPRINT_MIRROR {}u", footprint::MIRROR);
    let _ = writeln!(s, "#define FOOTPRINT_BACKGROUND {}u", footprint::BACKGROUND);
    let _ = writeln!(s, "#define FOOTPRINT_LIGHTS {}u", footprint::LIGHTS);
    let _ = writeln!(s, "#define FOOTPRINT_CODE {}u", footprint::CODE);
    let _ = writeln!(s, "#define SHADOWS_CODE {}u", shade_code::SHADOWS);
    let _ = writeln!(s, "#define BRDF_CODE_SHIFT {}u", shade_code::BRDF_SHIFT);
    let _ = writeln!(s, "#define FILTER_EDGE_CELLS {}u", filter_rule::EDGE_CELLS);
    let _ = writeln!(s, "#define FILTER_MAX_CELLS {}u", filter_rule::MAX_CELLS);
    let f = |x: f64| format!("{:?}", x as f32);
    let floats = [
        ("FILTER_CELLS_PER_WIDTH", filter_rule::CELLS_PER_WIDTH),
        ("FILTER_CENTRE_LIMIT", filter_rule::CENTRE_LIMIT),
        ("FILTER_TILT_LIMIT", filter_rule::TILT_LIMIT),
        ("FILTER_TILT_DENSITY_RATIO", filter_rule::TILT_DENSITY_RATIO),
        ("FILTER_TILT_SERIES_BELOW", filter_rule::TILT_SERIES_BELOW),
        ("FILTER_LOG_CUTOFF", filter_rule::LOG_CUTOFF),
        ("FILTER_CONE_MARGIN", filter_rule::CONE_MARGIN),
        ("FILTER_REACH_MARGIN_REL", filter_rule::REACH_MARGIN_REL),
        ("FILTER_REACH_MARGIN_ABS", filter_rule::REACH_MARGIN_ABS),
        ("FILTER_TILE_MARGIN_REL", filter_rule::TILE_MARGIN_REL),
        ("FILTER_TILE_MARGIN_ABS", filter_rule::TILE_MARGIN_ABS),
        ("DFG_MU_MIN", split_sum::MU_MIN),
        ("SPLIT_TAP_SCALE", split_sum::TAP_SCALE),
        ("POLE_THRESHOLD", constants::POLE_THRESHOLD),
        ("VIEW_LIFT", constants::VIEW_LIFT),
        ("SHADOW_OFFSET", constants::SHADOW_OFFSET),
        ("RIM_PULL_IN", constants::RIM_PULL_IN),
        ("GAUSS2_OFFSET", constants::GAUSS2_OFFSET),
        ("GGX_ALPHA_MIN", brdf::GGX_ALPHA_MIN),
        ("FOOTPRINT_LOD_BIAS", footprint::LOD_BIAS),
        ("FOOTPRINT_MIN_SPREAD", footprint::MIN_SPREAD),
        ("FOOTPRINT_TAP_SLACK", footprint::TAP_SLACK),
    ];
    for (name, v) in floats {
        let _ = writeln!(s, "#define {name} {}", f(v));
    }
    let l = constants::LUMINANCE;
    let _ = writeln!(
        s,
        "#define LUMINANCE vec3({}, {}, {})",
        f(l[0]),
        f(l[1]),
        f(l[2])
    );
    // K_lm for m ≥ 0, l ≤ SH_MAX_LMAX, at index l(l+1)/2 + m (see src/math/sh.rs).
    let mut k = Vec::new();
    for l in 0..=SH_MAX_LMAX {
        for m in 0..=l {
            let f = |a: u32| (1..=a).map(|x| x as f64).product::<f64>();
            let v =
                ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * f(l - m) / f(l + m)).sqrt();
            k.push(format!("{v:.9e}"));
        }
    }
    let _ = writeln!(
        s,
        "const float SH_K[{}] = float[{}]({});",
        k.len(),
        k.len(),
        k.join(", ")
    );
    let ids = [
        ("BRDF_LAMBERT", brdf::ids::LAMBERT),
        ("BRDF_MIRROR", brdf::ids::MIRROR),
        ("BRDF_PHONG", brdf::ids::PHONG),
        ("BRDF_BLINN", brdf::ids::BLINN),
        ("BRDF_GGX", brdf::ids::GGX),
        ("BRDF_WARD", brdf::ids::WARD),
        ("TECH_LOOKUP", brdf::technique::LOOKUP),
        ("TECH_FIS", brdf::technique::FIS),
        ("TECH_SH", brdf::technique::SH),
        ("TECH_PREFILTERED", brdf::technique::PREFILTERED),
        ("TECH_MC", brdf::technique::MC),
        ("TECH_SH_BRDF", brdf::technique::SH_BRDF),
        ("TECH_SPLIT_SUM", brdf::technique::SPLIT_SUM),
        ("SH_ROTATION_ZXZXZ", sh_brdf::ROTATION_ZXZXZ),
        ("SH_ROTATION_IVANIC", sh_brdf::ROTATION_IVANIC),
        ("SH_ROTATE_HEADER", sh_brdf::ROTATE_HEADER),
        ("SH_BRDF_PANELS", sh_brdf::PANELS),
        ("SH_BRDF_GL_NODES", sh_brdf::GL_NODES),
        ("SH_BRDF_GRADED_LEVELS", sh_brdf::GRADED_LEVELS),
    ];
    for (name, v) in ids {
        let _ = writeln!(s, "#define {name} {v}u");
    }
    let (x, w) = sh_brdf::gauss4();
    let list = |v: [f64; 4]| v.map(|a| format!("{a:.9e}")).join(", ");
    let _ = writeln!(s, "const float SH_BRDF_GL_X[4] = float[4]({});", list(x));
    let fades: Vec<String> = brdf::HORIZON_FADE.iter().map(|&x| f(x)).collect();
    let _ = writeln!(
        s,
        "const float BRDF_HORIZON_FADE[{}] = float[{}]({});",
        fades.len(),
        fades.len(),
        fades.join(", ")
    );
    let _ = writeln!(s, "const float SH_BRDF_GL_W[4] = float[4]({});", list(w));
    for (i, name) in MAPPING_NAMES.iter().enumerate() {
        let _ = writeln!(s, "#define MAPPING_{name} {i}u");
    }
    // Push blocks, generated from the Rust structs' field lists (std430, so the offsets of
    // 4-byte scalars, uvec2/vec4 and scalar arrays match repr(C) without padding).
    for (name, fields) in push::PUSH_BLOCKS {
        let decl: Vec<String> = fields
            .iter()
            .map(|(field, ty, _)| format!("{ty} {field};"))
            .collect();
        let _ = writeln!(
            s,
            "#define PUSH_{name} layout(push_constant) uniform Push {{ {} }} pc;",
            decl.join(" ")
        );
    }
    s.push_str("#endif\n");
    s
}

/// Reads a GLSL file with its `#include "…"` lines expanded from `glsl/include/`.
pub fn expand_includes(glsl_dir: &Path, file: &str, depth: u32) -> std::io::Result<String> {
    if depth > 16 {
        return Err(std::io::Error::other(format!(
            "{file}: includes nest too deep"
        )));
    }
    let path = if depth == 0 {
        glsl_dir.join(file)
    } else {
        glsl_dir.join("include").join(file)
    };
    let text = std::fs::read_to_string(&path)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    let mut out = String::new();
    for line in text.lines() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix("#include") {
            let name = rest.trim().trim_matches('"');
            out.push_str(&expand_includes(glsl_dir, name, depth + 1)?);
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(out)
}

/// FNV-1a hash of everything a SPIR-V module is built from: target, optimisation, defines and
/// the include-expanded source. `spirv/manifest.txt` records it; a test recomputes it.
pub fn source_hash(glsl_dir: &Path, src: &ShaderSource) -> std::io::Result<u64> {
    let mut text = format!("{TARGET_ENV} {OPTIMIZATION} {:?}\n", src.stage);
    for (k, v) in src.defines {
        let _ = writeln!(text, "#define {k} {v}");
    }
    text.push_str(&expand_includes(glsl_dir, src.file, 0)?);
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    Ok(h)
}

/// The manifest's text for the current sources.
pub fn manifest(glsl_dir: &Path) -> std::io::Result<String> {
    let mut s = String::new();
    for src in SHADER_SOURCES {
        let _ = writeln!(s, "{}.spv {:016x}", src.name, source_hash(glsl_dir, src)?);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_are_what_their_docs_say() {
        assert_eq!(constants::GAUSS2_OFFSET, 0.5 / 3f64.sqrt());
        assert!((filter_rule::LOG_CUTOFF - 1e-10f64.ln()).abs() < 1e-12);
        let l = constants::LUMINANCE;
        assert!((l[0] + l[1] + l[2] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn every_binding_of_the_table_is_named_once_in_its_shader() {
        for &id in ShaderId::ALL {
            let b = id.interface().bindings;
            for (i, x) in b.iter().enumerate() {
                assert!(
                    b[i + 1..].iter().all(|y| y.0 != x.0),
                    "{id:?}: binding {}",
                    x.0
                );
            }
            assert_eq!(id.source().name, id.name());
            assert_eq!(ShaderId::ALL[id as usize], id);
        }
    }

    #[test]
    fn the_header_defines_every_push_block_and_binding() {
        let h = generated_header();
        for (name, _) in push::PUSH_BLOCKS {
            assert!(h.contains(&format!("#define PUSH_{name} ")), "{name}");
        }
        for (name, v) in binding::ALL {
            assert!(
                h.contains(&format!("#define BINDING_{name} {v}\n")),
                "{name}"
            );
        }
    }
}
