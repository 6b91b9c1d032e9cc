//! The per-object record the G-buffer, shade and Monte Carlo passes read from a storage
//! buffer (`Object` in the generated header), written once: the Rust struct and its GLSL
//! struct come from the same field list, as the push blocks do. Ids and offsets are integers;
//! each field means one thing for every technique (zero where a technique takes none).
//! `passes::gbuffer::ObjectRecord::new` fills it from a shape, a material and a
//! `passes::gbuffer::Shading`.

macro_rules! records {
    ($( $(#[$m:meta])* $name:ident as $glsl_name:literal { $( $(#[$fm:meta])* $field:ident : $ty:ty = $glsl:literal ),* $(,)? } )*) => {
        $(
            $(#[$m])*
            #[repr(C)]
            #[derive(Clone, Copy, Debug, Default, PartialEq)]
            pub struct $name { $( $(#[$fm])* pub $field: $ty, )* }

            // No padding, and a size std430 strides an array of it by (its vec4s set the
            // struct's alignment to 16).
            const _: () = assert!(
                std::mem::size_of::<$name>() == 0 $(+ std::mem::size_of::<$ty>())*
                    && std::mem::size_of::<$name>() % 16 == 0
            );

            impl $name {
                /// (name, GLSL type, byte offset) of each field, in order.
                pub const FIELDS: &'static [(&'static str, &'static str, usize)] =
                    &[$( (stringify!($field), $glsl, std::mem::offset_of!($name, $field)) ),*];
            }
        )*

        /// Every record: (GLSL struct name, fields).
        pub const RECORDS: &[(&str, &[(&str, &str, usize)])] =
            &[$( ($glsl_name, $name::FIELDS) ),*];
    };
}

records! {
    /// An object of a scene as the passes read it: its shape, its material, the technique that
    /// shades it and that technique's data.
    ObjectRecord as "Object" {
        /// Sphere: centre, radius. Plane: unit normal, offset along it.
        shape: [f32; 4] = "vec4",
        /// Albedo (diffuse) or specular colour, RGB; w unused.
        albedo: [f32; 4] = "vec4",
        /// `abi::object::SPHERE` or `abi::object::PLANE`.
        kind: u32 = "uint",
        /// A plane's extent about its point nearest the origin (0: unbounded).
        extent: f32 = "float",
        /// The technique (`abi::brdf::technique`).
        technique: u32 = "uint",
        /// The BRDF (`abi::brdf::ids`).
        brdf: u32 = "uint",
        /// The BRDF's parameters: Phong and Blinn (n, 0), GGX (α, 1 if height-correlated),
        /// Ward (αx, αy).
        params: [f32; 2] = "float[2]",
        /// FIS: samples a pixel. Split-sum: the lobe's taps a pixel (below 2: one lookup
        /// along the reflected direction).
        samples: u32 = "uint",
        /// FIS: the lod bias added to each sample's lod.
        lod_bias: f32 = "float",
        /// Split-sum: the chain's last lod (its levels − 1).
        last_lod: f32 = "float",
        /// Extracted lights added under the BRDF itself (FIS, a prefiltered Phong map): the
        /// lobe's angular scale.
        lobe: f32 = "float",
        /// Split-sum with extracted lights: 1/∫K at the material's α.
        light_norm: f32 = "float",
        /// SH and SH-BRDF: the environment's coefficients' first index; prefiltered: the
        /// map's first texel; split-sum: the DFG table's first entry.
        data_offset: u32 = "uint",
        /// SH and SH-BRDF: the order lmax; prefiltered: the map's width; split-sum: the DFG
        /// table's side.
        size: u32 = "uint",
        /// SH-BRDF: the BRDF table's first float.
        table_offset: u32 = "uint",
        /// SH-BRDF: the BRDF table's grid side.
        grid: u32 = "uint",
        /// `abi::object::ROTATE` and `abi::object::LIGHTS` bits.
        flags: u32 = "uint",
    }
}

const _: () = {
    use std::mem::offset_of;
    // std430 places a vec4 at a multiple of 16 and a float[2] at a multiple of 4.
    assert!(
        offset_of!(ObjectRecord, shape) % 16 == 0 && offset_of!(ObjectRecord, albedo) % 16 == 0
    );
};
