//! The SPIR-V modules (committed in `spirv/`, built by `cargo xtask shaders`) and the interface
//! each pipeline expects of them. A test checks the interface against the SPIR-V itself.

use super::layout::{binding, ShaderSource, SHADER_SOURCES};
use ash::vk;

/// A shader module envlight uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShaderId {
    /// Resampling between mappings from a 2D-array source.
    Convert2d,
    /// Resampling between mappings from a cube source.
    ConvertCube,
    /// Mapping functions exposed for tests.
    MappingProbe,
    /// A plain texel copy (the benchmark floor).
    Copy,
    /// A deliberately costly dispatch (timestamp test).
    Busy,
    /// Fullscreen triangle vertex shader.
    FullscreenVert,
    /// Flat colour fragment shader.
    FlatFrag,
    /// SH projection, first level, with subgroup arithmetic.
    ShProjectSubgroup,
    /// SH projection, first level, shared-memory tree.
    ShProjectShared,
    /// SH partial-sum reduction with subgroup arithmetic.
    ShReduceSubgroup,
    /// SH partial-sum reduction, shared-memory tree.
    ShReduceShared,
    /// Brute-force convolution: per-texel cones, radiance and solid angles.
    BrutePrepare,
    /// Brute-force convolution with the cosine or a Phong lobe.
    Brute,
    /// Irradiance from SH coefficients into a map.
    ShEval,
    /// G-buffer of analytic spheres and planes.
    GBuffer,
    /// Shading of every material but the Monte Carlo ones, and the frame's composite.
    Shade,
    /// One level of the dual-paraboloid MIP chain.
    Mip,
    /// One progressive frame of the Monte Carlo reference.
    Mc,
}

/// The kind of a descriptor binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DescriptorKind {
    /// A combined image sampler.
    SampledImage,
    /// A storage image.
    StorageImage,
    /// A storage buffer.
    StorageBuffer,
}

impl DescriptorKind {
    /// The Vulkan descriptor type.
    pub fn vk(self) -> vk::DescriptorType {
        match self {
            DescriptorKind::SampledImage => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            DescriptorKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
            DescriptorKind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
        }
    }
}

/// Descriptor bindings (set 0) and push-constant size a module expects.
#[derive(Clone, Copy, Debug)]
pub struct Interface {
    /// (binding, kind) pairs.
    pub bindings: &'static [(u32, DescriptorKind)],
    /// Size in bytes of the push-constant block (0 for none).
    pub push_size: u32,
}

macro_rules! spv {
    ($name:literal) => {
        include_bytes!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/spirv/",
            $name,
            ".spv"
        ))
    };
}

impl ShaderId {
    /// Every module.
    pub const ALL: [ShaderId; 18] = [
        ShaderId::Convert2d,
        ShaderId::ConvertCube,
        ShaderId::MappingProbe,
        ShaderId::Copy,
        ShaderId::Busy,
        ShaderId::FullscreenVert,
        ShaderId::FlatFrag,
        ShaderId::ShProjectSubgroup,
        ShaderId::ShProjectShared,
        ShaderId::ShReduceSubgroup,
        ShaderId::ShReduceShared,
        ShaderId::BrutePrepare,
        ShaderId::Brute,
        ShaderId::ShEval,
        ShaderId::GBuffer,
        ShaderId::Shade,
        ShaderId::Mip,
        ShaderId::Mc,
    ];

    /// The build recipe of this module.
    pub fn source(self) -> &'static ShaderSource {
        let name = match self {
            ShaderId::Convert2d => "convert_2d",
            ShaderId::ConvertCube => "convert_cube",
            ShaderId::MappingProbe => "mapping_probe",
            ShaderId::Copy => "copy",
            ShaderId::Busy => "busy",
            ShaderId::FullscreenVert => "fullscreen_vert",
            ShaderId::FlatFrag => "flat_frag",
            ShaderId::ShProjectSubgroup => "sh_project_subgroup",
            ShaderId::ShProjectShared => "sh_project_shared",
            ShaderId::ShReduceSubgroup => "sh_reduce_subgroup",
            ShaderId::ShReduceShared => "sh_reduce_shared",
            ShaderId::BrutePrepare => "brute_prepare",
            ShaderId::Brute => "brute",
            ShaderId::ShEval => "sh_eval",
            ShaderId::GBuffer => "gbuffer",
            ShaderId::Shade => "shade",
            ShaderId::Mip => "mip",
            ShaderId::Mc => "mc",
        };
        SHADER_SOURCES
            .iter()
            .find(|s| s.name == name)
            .unwrap_or_else(|| panic!("{name} missing from SHADER_SOURCES"))
    }

    /// The committed SPIR-V.
    pub fn spirv(self) -> &'static [u8] {
        match self {
            ShaderId::Convert2d => spv!("convert_2d"),
            ShaderId::ConvertCube => spv!("convert_cube"),
            ShaderId::MappingProbe => spv!("mapping_probe"),
            ShaderId::Copy => spv!("copy"),
            ShaderId::Busy => spv!("busy"),
            ShaderId::FullscreenVert => spv!("fullscreen_vert"),
            ShaderId::FlatFrag => spv!("flat_frag"),
            ShaderId::ShProjectSubgroup => spv!("sh_project_subgroup"),
            ShaderId::ShProjectShared => spv!("sh_project_shared"),
            ShaderId::ShReduceSubgroup => spv!("sh_reduce_subgroup"),
            ShaderId::ShReduceShared => spv!("sh_reduce_shared"),
            ShaderId::BrutePrepare => spv!("brute_prepare"),
            ShaderId::Brute => spv!("brute"),
            ShaderId::ShEval => spv!("sh_eval"),
            ShaderId::GBuffer => spv!("gbuffer"),
            ShaderId::Shade => spv!("shade"),
            ShaderId::Mip => spv!("mip"),
            ShaderId::Mc => spv!("mc"),
        }
    }

    /// What the pipeline built on this module binds.
    pub fn interface(self) -> Interface {
        use crate::passes::copy::CopyPush;
        use crate::passes::filter::{BrutePush, ShEvalPush};
        use crate::passes::gbuffer::GBufferPush;
        use crate::passes::mc::McPush;
        use crate::passes::mip::MipPush;
        use crate::passes::sh_project::{ShProjectPush, ShReducePush};
        use crate::passes::shade::ShadePush;
        use crate::passes::{convert::ConvertPush, diagnostics::BusyPush, probe::ProbePush};
        use DescriptorKind::*;
        let size = |n: usize| n as u32;
        match self {
            ShaderId::Convert2d | ShaderId::ConvertCube => Interface {
                bindings: &[
                    (binding::CONVERT_SRC, SampledImage),
                    (binding::CONVERT_DST, StorageImage),
                ],
                push_size: size(std::mem::size_of::<ConvertPush>()),
            },
            ShaderId::MappingProbe => Interface {
                bindings: &[
                    (binding::PROBE_IN, StorageBuffer),
                    (binding::PROBE_OUT, StorageBuffer),
                ],
                push_size: size(std::mem::size_of::<ProbePush>()),
            },
            ShaderId::Copy => Interface {
                bindings: &[
                    (binding::COPY_SRC, SampledImage),
                    (binding::COPY_DST, StorageImage),
                ],
                push_size: size(std::mem::size_of::<CopyPush>()),
            },
            ShaderId::Busy => Interface {
                bindings: &[(binding::BUSY_OUT, StorageBuffer)],
                push_size: size(std::mem::size_of::<BusyPush>()),
            },
            ShaderId::ShProjectSubgroup | ShaderId::ShProjectShared => Interface {
                bindings: &[
                    (binding::SH_SRC, SampledImage),
                    (binding::SH_PARTIALS, StorageBuffer),
                ],
                push_size: size(std::mem::size_of::<ShProjectPush>()),
            },
            ShaderId::ShReduceSubgroup | ShaderId::ShReduceShared => Interface {
                bindings: &[
                    (binding::SH_REDUCE_IN, StorageBuffer),
                    (binding::SH_REDUCE_OUT, StorageBuffer),
                ],
                push_size: size(std::mem::size_of::<ShReducePush>()),
            },
            ShaderId::BrutePrepare => Interface {
                bindings: &[
                    (binding::BRUTE_PREP_SRC, SampledImage),
                    (binding::BRUTE_PREP_CONES, StorageBuffer),
                    (binding::BRUTE_PREP_RADIANCE, StorageBuffer),
                ],
                push_size: size(std::mem::size_of::<BrutePush>()),
            },
            ShaderId::Brute => Interface {
                bindings: &[
                    (binding::BRUTE_CONES, StorageBuffer),
                    (binding::BRUTE_RADIANCE, StorageBuffer),
                    (binding::BRUTE_DST, StorageImage),
                    (binding::BRUTE_COMP, StorageBuffer),
                ],
                push_size: size(std::mem::size_of::<BrutePush>()),
            },
            ShaderId::ShEval => Interface {
                bindings: &[
                    (binding::SH_EVAL_COEFFS, StorageBuffer),
                    (binding::SH_EVAL_DST, StorageImage),
                ],
                push_size: size(std::mem::size_of::<ShEvalPush>()),
            },
            ShaderId::GBuffer => Interface {
                bindings: &[(binding::GBUF_OBJECTS, StorageBuffer)],
                push_size: size(std::mem::size_of::<GBufferPush>()),
            },
            ShaderId::Shade => Interface {
                bindings: &[
                    (binding::SHADE_NORMAL, SampledImage),
                    (binding::SHADE_VIEW, SampledImage),
                    (binding::SHADE_OBJECTS, StorageBuffer),
                    (binding::SHADE_COEFFS, StorageBuffer),
                    (binding::SHADE_ENV, SampledImage),
                    (binding::SHADE_POSITION, SampledImage),
                    (binding::SHADE_DP, SampledImage),
                    (binding::SHADE_PREFILTERED, StorageBuffer),
                    (binding::SHADE_MC, SampledImage),
                ],
                push_size: size(std::mem::size_of::<ShadePush>()),
            },
            ShaderId::Mip => Interface {
                bindings: &[
                    (binding::MIP_SRC, StorageImage),
                    (binding::MIP_DST, StorageImage),
                ],
                push_size: size(std::mem::size_of::<MipPush>()),
            },
            ShaderId::Mc => Interface {
                bindings: &[
                    (binding::MC_NORMAL, SampledImage),
                    (binding::MC_VIEW, SampledImage),
                    (binding::MC_POSITION, SampledImage),
                    (binding::MC_OBJECTS, StorageBuffer),
                    (binding::MC_ENV, SampledImage),
                    (binding::MC_TABLES, StorageBuffer),
                    (binding::MC_ACCUM, StorageImage),
                ],
                push_size: size(std::mem::size_of::<McPush>()),
            },
            ShaderId::FullscreenVert | ShaderId::FlatFrag => Interface {
                bindings: &[],
                push_size: 0,
            },
        }
    }
}
