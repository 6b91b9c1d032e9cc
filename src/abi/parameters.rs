//! The numbers GLSL and Rust share: ids, tuning parameters of each pass and workgroup sizes,
//! each once; GLSL reads them through the generated header.

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
    /// Technique ids (`record::ObjectRecord::technique`).
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

/// What an object record's kind and flags hold (`record::ObjectRecord`).
pub mod object {
    /// A sphere: `shape` holds its centre and radius.
    pub const SPHERE: u32 = 0;
    /// A plane: `shape` holds its unit normal and offset.
    pub const PLANE: u32 = 1;
    /// Flag: FIS rotates its sample set per pixel.
    pub const ROTATE: u32 = 1;
    /// Flag: the shader adds the extracted lights (the technique reads the residual).
    pub const LIGHTS: u32 = 2;
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
    /// across it is then small (per-texel error under 1e-3, the bound math::filter's
    /// `tilted_rule_matches_gauss_cells_texel_by_texel` holds it to).
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
    /// FIS samples per prefiltered texel by default: where more samples stop paying (on a
    /// sun probe at GGX α 0.16, 256 samples' chain errs 8% against converged MC, FIS's own
    /// render 5%; `cargo xtask lab recipes` scores the chain).
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
    /// vec4s a prefilter sample takes in `glsl/prefilter_ggx.comp`'s table: (wi, weight),
    /// (lod before the texel term, 0, 0, 0).
    pub const PREFILTER_SAMPLE_VEC4S: u32 = 2;
}

/// Light extraction ([`crate::math::lights`]).
pub mod lights {
    /// A texel is a light texel above this many times the map's mean luminance by default
    /// in bakes and reports (renders extract deeper: [`CHAIN_RATIO`]).
    pub const DEFAULT_RATIO: f64 = 32.0;
    /// Most light texels kept (the threshold rises to keep to it): what the bake's light
    /// sums cost.
    pub const MAX_TEXELS: u32 = 256;
    /// A bake's light records are never finer than the texels of a lat-long map this many
    /// columns wide (a cube's: a quarter of it a face): on a larger map each record gathers
    /// the light of a block of texels (`crate::math::lights::record_block`), so that the same
    /// light makes the same records, and costs the same, at any resolution, and
    /// [`MAX_TEXELS`] keeps its meaning (an 8k map's sun is 64 times a 1k map's texels).
    pub const RECORD_WIDTH: u32 = 1024;
    /// Diffuse techniques (SH irradiance, prefiltered irradiance) extract above this many
    /// times the mean luminance, uncapped, and sum the light texels by clusters: a deep
    /// extraction leaves SH 2 only the smooth residual, so the sharp softboxes of a studio
    /// probe stop ringing into it (`cargo xtask lab table` scores SH 2 with lights on the
    /// five table probes).
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
    /// luminance by default (the renderer's chain, summed through the light tree): a shallow
    /// extraction leaves a studio's softboxes in the chain, whose few filtered samples alias
    /// them (`cargo xtask lab table` scores FIS with lights).
    pub const CHAIN_RATIO: f64 = 2.0;
    /// Most light texels of the chain's extraction by default, and the most a scene may ask
    /// for: llvmpipe ends a loop after 65 535 iterations, and a pixel's walk may visit every
    /// texel's four quadrature nodes.
    pub const CHAIN_MAX_TEXELS: u32 = 16384;
    /// The chain's lights grow by this many rings of texels around them (where
    /// [`CHAIN_MAX_TEXELS`] leaves room) and the residual under them is filled from around
    /// them ([`crate::math::lights::ExtractOptions::fill`]): a residual clamped at the
    /// threshold keeps each softbox as a plateau whose edge FIS's few filtered samples alias;
    /// two rings take the plateau's edge into the lights, and a third rarely fits the cap.
    /// A scene whose chain serves footprint lookups alone keeps the clamp: they take light
    /// texels by shares linearised over the pixel, which a fill would count twice.
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
    /// the horizon of a dim lobe. On five 1k probes under GGX α 0.05–0.6 it takes 2–25× fewer
    /// steps than no budget for a worst light-sum error, relative to the pixel, of 2.7e-3
    /// (2.65e-3 without; 3.2e-3 at 3e-2).
    pub const TREE_BUDGET: f64 = 1e-2;
    /// See [`TREE_BUDGET`]: beyond the kernel's scale the sigma points stop being a rule.
    pub const TREE_BUDGET_REACH: f64 = 1.0;
    /// How the light sums' own kernels fade towards their cut (`math::light_tree::
    /// horizon_share`): the cosine and split-sum's GGX (D·G/4, its masking) both linearly.
    pub const KERNEL_FADE: f64 = 1.0;
    /// A light tree's leaves hold at most this many texels.
    pub const LEAF_TEXELS: u32 = 4;
    // The GPU's node pass runs one invocation per record for the nodes below the end node
    // (`prepare_mode::NODES`): at least two texels a leaf keep those fewer than the records.
    const _: () = assert!(LEAF_TEXELS >= 2);
    /// vec4s per light tree node in the GPU's list (math::light_tree::LightTree::gpu_nodes).
    pub const TREE_VEC4S: u32 = 5;
    /// The GPU extraction's state buffer (`passes::extract`): words before its histograms.
    pub const EXTRACT_HEADER_WORDS: u32 = 48;
    /// Most rings of texels a filled extraction's light set grows by (a scene's
    /// `light_fill`): the state buffer holds a count per ring, the set's own ring 0 first.
    pub const FILL_MAX_RINGS: u32 = 8;
    /// Low bits of a filled extraction's per-texel label that hold the member's slot (its
    /// ring above them): the cap must stay below 2^this.
    pub const FILL_SLOT_BITS: u32 = 24;
    /// Words per slot of a filled extraction's light set after its per-texel labels: each
    /// member's texel, its filled luminance, the fill round's next value, and the candidate
    /// listed in that slot.
    pub const FILL_SLOT_ARRAYS: u32 = 4;
    /// Workgroups of a filled extraction's RING step, whose invocations loop over the last
    /// ring's members (a few hundred to thousands: a dispatch sized by the cap would start
    /// hundreds of workgroups with nothing to do).
    pub const FILL_RING_GROUPS: u32 = 16;
    /// Bins of the first histogram: the top 16 bits of a positive float luminance's bits
    /// (sign clear, so 2¹⁵ of them).
    pub const EXTRACT_TOP_BINS: u32 = 32768;
    /// Bins of the second histogram: the low 16 bits, within the top bin the cap falls in.
    pub const EXTRACT_LOW_BINS: u32 = 65536;
    /// Invocations per workgroup of a pass over the extraction's records (its indirect
    /// arguments count workgroups of this many).
    pub const EXTRACT_LIGHT_GROUP: u32 = super::WORKGROUP_1D;
    /// vec4s per light record of the GPU extraction: (file-frame centre direction, ω),
    /// (excess rgb, luminance Y), (layer, i, j, 0) as uints.
    pub const EXTRACT_RECORD_VEC4S: u32 = 3;
    /// Steps of `glsl/extract.comp` (`ExtractPush::mode`), in recording order.
    pub mod extract_mode {
        /// Per texel: τ from L00, the texels above it counted into the top histogram.
        pub const HISTOGRAM: u32 = 0;
        /// One workgroup: the top bin where the cap falls, or τ kept where it does not bind.
        pub const SELECT_TOP: u32 = 1;
        /// Per texel (indirect, none unless the cap binds): that bin's low histogram.
        pub const HISTOGRAM_LOW: u32 = 2;
        /// One workgroup: the exact threshold from the low histogram.
        pub const SELECT_LOW: u32 = 3;
        /// Filled extractions only, per candidate HISTOGRAM listed (indirect: none where the
        /// cap binds and the list is incomplete): those above the threshold that are their
        /// own integration source, ring 0 of the light set, listed and labelled.
        pub const MARK_LIST: u32 = 4;
        /// Filled extractions only, per texel (indirect: none unless the cap binds): ring 0
        /// as MARK_LIST finds it, from every texel.
        pub const MARK: u32 = 5;
        /// Filled extractions only, over the members of ring `grow − 1` (a dispatch per ring
        /// of [`super::FILL_RING_GROUPS`] workgroups, each invocation looping): their 8
        /// neighbours in their layer that hold the sphere, are positive and are no member yet
        /// join ring `grow`.
        pub const RING: u32 = 6;
        /// Filled extractions of angular maps only, per texel: the positions that read
        /// another texel (a rim's) counted by the ring of the texel they read, so that the
        /// cap counts light records, not members.
        pub const RIMS: u32 = 7;
        /// Filled extractions only, one invocation: the rings the cap has room for, whole.
        pub const DECIDE: u32 = 8;
        /// Filled extractions only, one workgroup: the residual luminance under the light
        /// set, round by round from its edge inwards (`math::lights` `fill`).
        pub const FILL: u32 = 9;
        /// Per texel: light records above the threshold (with a fill: wherever the texel
        /// read exceeds its filled residual), the residual everywhere.
        pub const COMPACT: u32 = 10;
    }
    /// Arrays of one u32 per cell at the start of `glsl/extract_clusters.comp`'s sort buffer:
    /// counts, first slots, cursors, places among the non-empty cells.
    pub const CLUSTER_SORT_CELL_ARRAYS: u32 = 4;
    /// Arrays of one u32 per record after them: each record's cell, the records in cell order.
    pub const CLUSTER_SORT_RECORD_ARRAYS: u32 = 2;
    /// Bits of the spatial key's top that bucket `glsl/extract_prepare.comp`'s counting sort
    /// (its key: a Morton code over the octahedral map of the world direction,
    /// 2 · [`TREE_KEY_AXIS_BITS`] bits).
    pub const TREE_BUCKET_BITS: u32 = 16;
    /// Bits a side of the octahedral grid that spatial key interleaves (the key has twice
    /// as many).
    pub const TREE_KEY_AXIS_BITS: u32 = 15;
    // The key fits a u32 and spreads by 16-bit steps; the buckets are its top bits.
    const _: () = assert!(TREE_KEY_AXIS_BITS <= 16 && TREE_BUCKET_BITS <= 2 * TREE_KEY_AXIS_BITS);
    /// Arrays of one u32 per bucket at the start of `glsl/extract_prepare.comp`'s sort
    /// buffer: counts, first slots, cursors; then two of one u32 per record: each record's
    /// key, the records in bucket order.
    pub const TREE_SORT_BUCKET_ARRAYS: u32 = 3;
    /// See [`TREE_SORT_BUCKET_ARRAYS`].
    pub const TREE_SORT_RECORD_ARRAYS: u32 = 2;
    /// Steps of `glsl/extract_prepare.comp` (`ExtractPreparePush::mode`), in recording order.
    pub mod prepare_mode {
        /// Per record (indirect): its spatial key, its bucket counted.
        pub const KEYS: u32 = 0;
        /// One workgroup: each bucket's first slot; and the tree's end node.
        pub const SCAN: u32 = 1;
        /// Per record (indirect): its slot in its bucket's run.
        pub const SCATTER: u32 = 2;
        /// Per record (indirect): its place (bucket's first slot + its rank in the bucket by
        /// key, then texel position) and its texel written there.
        pub const TEXELS: u32 = 3;
        /// Per record (indirect; the nodes below the end, 2·⌈n/LEAF_TEXELS⌉ − 1, never
        /// outnumber the records' invocations): a node's range of texels, its statistics.
        pub const NODES: u32 = 4;
    }
    /// Steps of `glsl/extract_clusters.comp` (`ExtractClustersPush::mode`), in recording
    /// order.
    pub mod clusters_mode {
        /// Per record (indirect): its cell, counted.
        pub const COUNT: u32 = 0;
        /// One workgroup: each cell's first slot.
        pub const SCAN: u32 = 1;
        /// Per record (indirect): its slot in its cell's run.
        pub const SCATTER: u32 = 2;
        /// Per cell: its records summed into its cluster.
        pub const SUM: u32 = 3;
    }
    /// Words of the extraction's header (see `passes::extract::ExtractState`).
    pub mod extract_word {
        /// Workgroups (x, y, z) of the second histogram's indirect dispatch: none unless
        /// the cap binds.
        pub const LOW_ARGS: u32 = 0;
        /// The largest kept light texel's solid angle, f32 bits (the word after LOW_ARGS'
        /// three): its quadrature's cells, as `math::lights::cells_for`.
        pub const OMEGA_MAX: u32 = 3;
        /// Workgroups (x, 1, 1) of 64 invocations for a pass over the light records.
        pub const LIGHT_ARGS: u32 = 4;
        /// Texels above the ratio's threshold τ.
        pub const CANDIDATES: u32 = 8;
        /// Light texels kept (at most the cap).
        pub const KEPT: u32 = 9;
        /// The final threshold's f32 bits (τ, or raised by the cap).
        pub const THRESHOLD: u32 = 10;
        /// The top bin the cap falls in (`u32::MAX` where it does not bind).
        pub const BIN: u32 = 11;
        /// Rank (from the brightest) of the threshold's texel within that bin.
        pub const RANK: u32 = 12;
        /// Texels with a NaN or infinite channel (zero in the residual, never lights).
        pub const NONFINITE: u32 = 13;
        /// τ's f32 bits (ratio × the mean luminance, from the SH projection's L00).
        pub const TAU: u32 = 14;
        /// The records written so far (the compaction's counter).
        pub const COUNTER: u32 = 15;
        /// Filled extractions: members of the light set listed so far, all rings (their
        /// slots; beyond the cap a ring stops being listed and is refused).
        pub const MEMBERS: u32 = 16;
        /// Filled extractions: the members the cap accepted (rings 0 to `GROWN`), the first
        /// slots of the list.
        pub const ACCEPTED: u32 = 17;
        /// Filled extractions: the rings the light set grew by.
        pub const GROWN: u32 = 18;
        /// Filled extractions: the fill's rounds (its depth from the set's edge, plus one).
        pub const ROUNDS: u32 = 19;
        /// Filled extractions: members per ring, `FILL_MAX_RINGS` + 1 words from ring 0.
        pub const RING_COUNT: u32 = 20;
        /// Filled extractions: rim positions reading a member, per ring (as `RING_COUNT`).
        pub const RIMS: u32 = 29;
        /// Filled extractions: workgroups (x, 1, 1) of MARK_LIST, none where the cap binds.
        pub const MARK_LIST_ARGS: u32 = 38;
        /// Filled extractions: workgroups (x, y, z) of the per-texel MARK, none unless the
        /// cap binds.
        pub const MARK_ARGS: u32 = 41;
        /// Clamped extractions: workgroups (x, y, z) of the per-texel COMPACT, none unless
        /// the cap binds (where it does not, HISTOGRAM has written the records and residual).
        pub const COMPACT_ARGS: u32 = 44;
        // The header holds them all.
        const _: () = assert!(RIMS + super::FILL_MAX_RINGS < MARK_LIST_ARGS);
        const _: () = assert!(MARK_ARGS + 3 <= COMPACT_ARGS);
        const _: () = assert!(COMPACT_ARGS + 3 <= super::EXTRACT_HEADER_WORDS);
    }
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

/// Footprint-filtered lookups (mirrors and the background): the pixel's footprint
/// in direction space, from G-buffer differences, read from the dual-paraboloid chain by a
/// row of taps along its major axis ([`crate::math::footprint`]).
pub mod footprint {
    /// Taps across a footprint's minor axis: a tap's trilinear read spreads over about two
    /// texels of its level, so finer taps keep a bright texel beside the footprint out of it.
    pub const MIN_TAPS: u32 = 8;
    /// Most taps along a footprint's major axis; beyond that ratio the taps blur more.
    pub const MAX_TAPS: u32 = 16;
    /// Lod bias of each tap (log2 of the texel side over the tap's spacing): half a level
    /// finer offsets the tent a trilinear read adds to the box (`cargo xtask lab table`
    /// scores the mirror against the pixel-area mean).
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

/// The exact texel sums' rule (`math::exact::ExactFilter::shade` and
/// `glsl/exact_shade.comp`).
pub mod exact {
    /// vec4s a query's lobe takes in the GPU pass's queries buffer.
    pub const QUERY_VEC4S: u32 = 5;
    /// Where the horizon crosses a texel, the lobe's scale is taken this much smaller
    /// (f·cos kinks there, which Gauss points integrate to the square of their cells only).
    pub const HORIZON_SHRINK: f64 = 4.0;
    /// Near a surface's horizon the lobe's scale is at most this many times the tail's
    /// fraction of the horizon's sine: the cosine and Smith's masking vary over that distance
    /// itself (the cosine is its sine, linear; the masking over about α), not over an eighth
    /// of it as a θ⁻⁴ tail does. With the tail's 1/8 it is the sine.
    pub const HORIZON_REACH: f64 = 8.0;
    /// Most cells a side of a texel, per cell a lobe scale (`PER_WIDTH`).
    pub const MAX_CELLS_PER_WIDTH: f64 = 8.0;
}

/// Workgroup size of the exact reference pass (`glsl/exact_shade.comp`, specialization
/// constant 0): its shared-memory tree adds this many lanes' sums.
pub const EXACT_WORKGROUP: u32 = 64;

/// Workgroup size of 2D compute passes (specialization constants 0 and 1).
pub const WORKGROUP_2D: [u32; 2] = [8, 8];
/// Workgroup size of 1D compute passes (specialization constant 0).
pub const WORKGROUP_1D: u32 = 64;
/// Mapping ids, in [`crate::math::Mapping`]'s order.
pub const MAPPING_NAMES: [&str; 4] = ["LATLONG", "ANGULAR", "CUBE", "DUAL_PARABOLOID"];

/// The lat-long → cube and dual-paraboloid conversion by exact footprint areas
/// (`math::convert::area_*`, `glsl/convert_area.comp`).
pub mod area {
    /// Points per edge of a cube texel's footprint polygon in the (U, z) plane: the chords
    /// err by about 1e-4 of a texel's area away from the poles (measured 5e-6 of the power of
    /// a map with suns at the poles and the seam, 1024 x 512 to cube 256).
    pub const EDGE_STEPS: u32 = 2;
    /// Chords per edge of a dual-paraboloid texel's polygon where both of the edge's ends lie
    /// in the disc (away from the poles), each with its sliver: the area between the chord and
    /// the edge's curve (the parabolic segment through the curve's midpoint), given whole to
    /// the source texel under that midpoint. The footprint's area is then its texel's solid
    /// angle to 2.5e-6 of the texel at 1 chord, 3e-8 at 3 (48², worst texel), and the
    /// shared chords and slivers still tile the plane, so power is kept wherever a sun lies.
    /// What fewer chords cost is placement: a sliver that spans several source texels lands
    /// in one, which moves a texel next to a sun by up to 2.5e-2 of its value at 2 chords
    /// (9.8e-2 at 1; the sun sky 512 × 256 to 128², against 8 chords; 1.9e-3 and 4.6e-3 from
    /// 1024 × 512).
    pub const PARABOLOID_EDGE_STEPS: u32 = 2;
    /// Columns the U of a sliver's curve midpoint is moved by before its source texel is found
    /// (`math::convert::cell_under`, glsl/include/convert_area.glsl): off the columns' edges,
    /// where midpoints lie by symmetry, by ~4 float32 ulps of U in a 4k map.
    pub const SLIVER_NUDGE: f64 = 1e-3;
    /// Points per edge of a dual-paraboloid texel's polygon where the edge crosses the rim,
    /// which the polygon is clipped at: each chord takes the part of its sliver inside the
    /// half (`math::convert::sliver_kept`), so that rim footprints cover their solid angles
    /// (to 2.7e-6 of a whole rim texel's at 2 points, 2.1e-7 at 4; 2e-3 without the slivers)
    /// and suns on the equator keep their power (1.1e-8, float64: 1024 x 512 to paraboloid 32).
    pub const PARABOLOID_RIM_STEPS: u32 = 2;
    /// Points per edge whose nearer end is within [`POLE_NEAR`] / size of the pole's axis,
    /// where great circles curve strongly in (U, z).
    pub const POLE_STEPS: u32 = 8;
    /// See [`POLE_STEPS`].
    pub const POLE_NEAR: f64 = 8.0;
    /// Most polygon vertices: four edges of [`POLE_STEPS`] (or fewer) points, and three closing the polygon along a pole's line.
    pub const MAX_VERTICES: u32 = 4 * POLE_STEPS + 3;
    const _: () = assert!(
        PARABOLOID_EDGE_STEPS >= 1
            && PARABOLOID_EDGE_STEPS <= POLE_STEPS
            && PARABOLOID_RIM_STEPS <= POLE_STEPS
            && EDGE_STEPS <= POLE_STEPS
    );
    /// A conversion plan entry's source texel: its column in the low bits, its row shifted
    /// up by this many (math::convert::area_plan writes it, glsl/convert_planned.comp reads
    /// it); sources up to 2^PLAN_ROW_SHIFT texels wide and tall.
    pub const PLAN_ROW_SHIFT: u32 = 16;
    /// Cube outputs at least this large take the fast path (glsl/convert_area.comp, FAST)
    /// away from the poles; smaller ones take the general walk everywhere.
    pub const FAST_MIN_SIZE: u32 = 32;
    /// Lat-long sources at least this many columns wide take the fast path: its points' U
    /// comes from an arctangent valid within 45° of the reference column's edge (a column,
    /// 11.25° here, plus a fast texel's reach, 10.6° at most; glsl/include/convert_area.glsl's
    /// `atan_near`).
    pub const FAST_MIN_SOURCE_WIDTH: u32 = 32;
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
