//! Push-constant blocks, one per shader family. GLSL reads them as `pc` through the
//! `PUSH_<Name>` macro of the generated header.

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
        /// SPLIT: the luminance the residual's source texels are clamped at.
        threshold: f32 = "float",
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
    /// `glsl/sanitize.comp`.
    SanitizePush {
        /// Layer size.
        size: [u32; 2] = "uvec2",
        /// Padding.
        pad: [u32; 2] = "uint[2]",
    }
    /// `glsl/clamp.comp`.
    ClampPush {
        /// Layer size.
        size: [u32; 2] = "uvec2",
        /// The map's mapping id.
        mapping: u32 = "uint",
        /// Luminance τ above which a texel is scaled down to it.
        threshold: f32 = "float",
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
    /// `glsl/poison.comp` (both variants).
    PoisonPush {
        /// 0: one NaN, 1: scale, 2: mirror.
        mode: u32 = "uint",
        /// The scale factor (mode 1).
        factor: f32 = "float",
        /// Image: layer width; buffer: floats in the region.
        width: u32 = "uint",
        /// Image: layer height (buffer: 1).
        height: u32 = "uint",
        /// Image: layers (buffer: 1).
        layers: u32 = "uint",
        /// Flat index of the NaN (texel, or float in the region).
        nan_at: u32 = "uint",
        /// Buffer: the region's first float.
        first: u32 = "uint",
        /// Buffer: floats per record.
        stride: u32 = "uint",
        /// Buffer: bit k set where float k of a record is scaled.
        scale_mask: u32 = "uint",
        /// Buffer: bit k set where float k of a record changes sign under the mirror.
        mirror_mask: u32 = "uint",
        /// Buffer: where non-zero, the mirror x → −x of SH coefficients: float f of the region
        /// is channel f % sh_channels of coefficient (f / sh_channels) % sh_count.
        sh_channels: u32 = "uint",
        /// Buffer: coefficients per SH record.
        sh_count: u32 = "uint",
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
    /// `glsl/sh_rows.comp` and `glsl/sh_latlong.comp`.
    ShLatLongPush {
        /// Rows of the rotation the partial sums turn by into the world frame.
        rotation: [[f32; 4]; 3] = "vec4[3]",
        /// Layer size.
        size: [u32; 2] = "uvec2",
        /// Highest band.
        lmax: u32 = "uint",
        /// 1: the odd bands change sign before the rotation (an improper frame change).
        parity: u32 = "uint",
    }
    /// `glsl/sh_pack.comp`.
    ShPackPush {
        /// Packed coefficients.
        count: u32 = "uint",
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
    /// `glsl/exact_shade.comp`.
    ExactShadePush {
        /// Layer size.
        size: [u32; 2] = "uvec2",
        /// Mapping id.
        mapping: u32 = "uint",
        /// Texels in all layers.
        texels: u32 = "uint",
        /// Texels an invocation sums.
        run: u32 = "uint",
        /// Workgroups a query takes (its partial sums).
        groups: u32 = "uint",
        /// The dispatch's first query.
        first: u32 = "uint",
        /// The BRDF's id.
        brdf: u32 = "uint",
        /// The BRDF's first parameter.
        p0: f32 = "float",
        /// Its second.
        p1: f32 = "float",
        /// Gauss cells per lobe scale (`math::exact::PER_WIDTH`).
        per_width: f32 = "float",
        /// Queries in all (the last workgroup's lanes past it write nothing).
        count: u32 = "uint",
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
        /// Samples per texel in the level's table (its FIS samples above the horizon).
        samples: u32 = "uint",
        /// Mapping of the chain written: dual paraboloid (the shading's) or cube (bakes).
        dst_mapping: u32 = "uint",
        /// The first layer written: the dispatch's z counts layers from it (a time slice
        /// refilters some layers of a level).
        layer: u32 = "uint",
    }
    /// `glsl/extract.comp`.
    ExtractPush {
        /// Layer size of the map.
        size: [u32; 2] = "uvec2",
        /// Mapping id of the map.
        mapping: u32 = "uint",
        /// Which step: `passes::extract`'s MODE_* constants.
        mode: u32 = "uint",
        /// Most light texels kept.
        max: u32 = "uint",
        /// Threshold over the mean luminance.
        ratio: f32 = "float",
        /// 1 where the residual is filled under grown lights, 0 where it is clamped.
        fill: u32 = "uint",
        /// Filled extractions: the ring a RING step lists; the most rings elsewhere.
        grow: u32 = "uint",
    }
    /// `glsl/extract_add.comp`.
    ExtractAddPush {
        /// Rows of the file → world rotation/reflection (w unused).
        file_to_world: [[f32; 4]; 3] = "vec4[3]",
        /// Layer size of the map the lights were extracted from.
        map_size: [u32; 2] = "uvec2",
        /// Its mapping id.
        mapping: u32 = "uint",
        /// Side of the cube level written.
        size: u32 = "uint",
        /// `lights::KERNEL_COSINE` or `KERNEL_GGX`.
        kernel: u32 = "uint",
        /// GGX α.
        alpha: f32 = "float",
        /// 1 / ∫ K dω (1 for the cosine).
        inv_norm: f32 = "float",
        /// The first cube face written: the dispatch's z counts faces from it.
        layer: u32 = "uint",
    }
    /// `glsl/extract_clusters.comp`.
    ExtractClustersPush {
        /// Rows of the file → world rotation/reflection (w unused).
        file_to_world: [[f32; 4]; 3] = "vec4[3]",
        /// Which step: `lights::clusters_mode`.
        mode: u32 = "uint",
        /// Columns of the cells' lat-long grid (rows: half as many).
        grid: u32 = "uint",
        /// Where the clusters start in the output, in vec4s.
        at: u32 = "uint",
        /// The extraction's most records.
        max: u32 = "uint",
    }
    /// `glsl/extract_prepare.comp`.
    ExtractPreparePush {
        /// Rows of the file → world rotation/reflection (w unused).
        file_to_world: [[f32; 4]; 3] = "vec4[3]",
        /// Layer size of the map the lights were extracted from.
        map_size: [u32; 2] = "uvec2",
        /// Its mapping id.
        mapping: u32 = "uint",
        /// Cells per side of each texel's quadrature ((2·cells)² nodes).
        cells: u32 = "uint",
        /// vec4s per prepared texel (header and nodes).
        stride: u32 = "uint",
        /// Where the tree's nodes start in the output, in vec4s.
        tree_at: u32 = "uint",
        /// The extraction's most records (the texels' room).
        max: u32 = "uint",
        /// Which step: `lights::prepare_mode`.
        mode: u32 = "uint",
        /// The tree's room in nodes (the end node's skip).
        tree_room: u32 = "uint",
        /// Where the texels' coarser quadratures start in the output, in vec4s (0: none
        /// written): for each texel, in the texels' order, those of 1 … `cells` − 1 cells.
        coarse_at: u32 = "uint",
        /// Padding.
        pad: [u32; 2] = "uint[2]",
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
        /// Where the texels' coarser quadratures start in the buffer, in vec4s (0: none kept;
        /// `math::lights::PreparedLight::coarse`).
        coarse_at: u32 = "uint",
        /// Cells per side of the texels' own quadrature (`nodes` = (2·cells)²).
        cells: u32 = "uint",
        /// Where the light tree's nodes start in the buffer, in vec4s.
        tree_at: u32 = "uint",
        /// The tree's nodes (`math::light_tree::LightTree`).
        tree_nodes: u32 = "uint",
        /// A tree node's allowed error per unit of the level's luminance before the lights
        /// are added, in the sum's units: `lights::TREE_BUDGET` · ∫ K dω (0: the geometric
        /// rule alone).
        budget: f32 = "float",
        /// The first face written: the dispatch's z counts faces from it (a time slice adds
        /// the lights to some faces of a level).
        layer: u32 = "uint",
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
