//! What GLSL and Rust must agree on, written once: binding numbers, workgroup sizes, mapping
//! ids, the list of shaders and how they are built.
//!
//! This file is self-contained (std only) because `tools/shaderc` includes it by path to write
//! `glsl/include/generated.glsl` and `spirv/manifest.txt` without building the library.

use std::fmt::Write as _;
use std::path::Path;

/// Descriptor binding numbers, per pass (all in set 0).
pub mod binding {
    /// convert: the source map (sampler2DArray, or samplerCube for cube sources).
    pub const CONVERT_SRC: u32 = 0;
    /// convert: the destination map (rgba32f image2DArray).
    pub const CONVERT_DST: u32 = 1;
    /// mapping_probe: input directions (vec4 storage buffer).
    pub const PROBE_IN: u32 = 0;
    /// mapping_probe: results (vec4 storage buffer).
    pub const PROBE_OUT: u32 = 1;
    /// copy: the source image (sampler2DArray, read with texelFetch).
    pub const COPY_SRC: u32 = 0;
    /// copy: the destination image (rgba32f image2DArray).
    pub const COPY_DST: u32 = 1;
    /// busy: the buffer the costly loop writes to.
    pub const BUSY_OUT: u32 = 0;
    /// sh_project: the map (sampler2DArray, read with texelFetch).
    pub const SH_SRC: u32 = 0;
    /// sh_project: per-workgroup partial sums (storage buffer).
    pub const SH_PARTIALS: u32 = 1;
    /// sh_reduce: partial sums in.
    pub const SH_REDUCE_IN: u32 = 0;
    /// sh_reduce: partial sums out.
    pub const SH_REDUCE_OUT: u32 = 1;
    /// brute_prepare: the source map (sampler2DArray, read with texelFetch).
    pub const BRUTE_PREP_SRC: u32 = 0;
    /// brute_prepare: per-texel centre direction and cos of angular radius (vec4 buffer).
    pub const BRUTE_PREP_CONES: u32 = 1;
    /// brute_prepare: per-texel radiance and solid angle (vec4 buffer).
    pub const BRUTE_PREP_RADIANCE: u32 = 2;
    /// brute: the cones written by brute_prepare.
    pub const BRUTE_CONES: u32 = 0;
    /// brute: the radiance and solid angles written by brute_prepare.
    pub const BRUTE_RADIANCE: u32 = 1;
    /// brute: the output map (rgba32f image2DArray), accumulated over chunks.
    pub const BRUTE_DST: u32 = 2;
    /// brute: the Kahan compensation per output texel, carried between chunks (vec4 buffer).
    pub const BRUTE_COMP: u32 = 3;
    /// sh_eval: the coefficients, Â_l and window folded in (vec4 buffer).
    pub const SH_EVAL_COEFFS: u32 = 0;
    /// sh_eval: the output map (rgba32f image2DArray).
    pub const SH_EVAL_DST: u32 = 1;
    /// gbuffer: the scene's objects (storage buffer of `Object`).
    pub const GBUF_OBJECTS: u32 = 0;
    /// shade_sh: G-buffer normals and object indices.
    pub const SHADE_NORMAL: u32 = 0;
    /// shade_sh: G-buffer directions to the eye.
    pub const SHADE_VIEW: u32 = 1;
    /// shade_sh: the scene's objects (albedo).
    pub const SHADE_OBJECTS: u32 = 2;
    /// shade_sh: SH irradiance coefficients (vec4 buffer).
    pub const SHADE_COEFFS: u32 = 3;
    /// shade: the environment map in its own mapping (background, mirror lookups).
    pub const SHADE_ENV: u32 = 4;
    /// shade: G-buffer hit positions (shadow rays).
    pub const SHADE_POSITION: u32 = 5;
    /// shade: the dual-paraboloid MIP chain (FIS).
    pub const SHADE_DP: u32 = 6;
    /// shade: prefiltered lat-long maps, texel after texel (vec4 buffer).
    pub const SHADE_PREFILTERED: u32 = 7;
    /// shade: the Monte Carlo accumulation (rgb sum, luminance² sum), read for MC pixels.
    pub const SHADE_MC: u32 = 8;
    /// mip: the finer level (storage image, read).
    pub const MIP_SRC: u32 = 0;
    /// mip: the coarser level (storage image, written).
    pub const MIP_DST: u32 = 1;
    /// mc: G-buffer normals and object indices.
    pub const MC_NORMAL: u32 = 0;
    /// mc: G-buffer directions to the eye.
    pub const MC_VIEW: u32 = 1;
    /// mc: G-buffer hit positions.
    pub const MC_POSITION: u32 = 2;
    /// mc: the scene's objects and materials.
    pub const MC_OBJECTS: u32 = 3;
    /// mc: the full-resolution lat-long map (texelFetch).
    pub const MC_ENV: u32 = 4;
    /// mc: the environment sampling tables (float buffer, see `math::envsample`).
    pub const MC_TABLES: u32 = 5;
    /// mc: the accumulation image (rgba32f storage: rgb sum, luminance² sum).
    pub const MC_ACCUM: u32 = 6;
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
    }
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
    /// Lobe values below this fraction of the peak are dropped (ln 1e-10).
    pub const LOG_CUTOFF: f64 = -23.025_850_929_940_457;
}

/// Highest SH band the GPU projection supports.
pub const SH_MAX_LMAX: u32 = 8;
/// Workgroup size of the SH passes: one texel (or partial sum) per invocation.
pub const SH_WORKGROUP: u32 = 64;

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

/// Every shader the library uses.
pub const SHADER_SOURCES: &[ShaderSource] = &[
    ShaderSource {
        name: "convert_2d",
        file: "convert.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "convert_cube",
        file: "convert.comp",
        stage: Stage::Compute,
        defines: &[("SRC_CUBE", "1")],
    },
    ShaderSource {
        name: "mapping_probe",
        file: "mapping_probe.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "copy",
        file: "copy.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "busy",
        file: "busy.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "fullscreen_vert",
        file: "fullscreen.vert",
        stage: Stage::Vertex,
        defines: &[],
    },
    ShaderSource {
        name: "flat_frag",
        file: "flat.frag",
        stage: Stage::Fragment,
        defines: &[],
    },
    ShaderSource {
        name: "sh_project_subgroup",
        file: "sh_project.comp",
        stage: Stage::Compute,
        defines: &[("USE_SUBGROUPS", "1")],
    },
    ShaderSource {
        name: "sh_project_shared",
        file: "sh_project.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "sh_reduce_subgroup",
        file: "sh_reduce.comp",
        stage: Stage::Compute,
        defines: &[("USE_SUBGROUPS", "1")],
    },
    ShaderSource {
        name: "sh_reduce_shared",
        file: "sh_reduce.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "brute_prepare",
        file: "brute.comp",
        stage: Stage::Compute,
        defines: &[("PREPARE", "1")],
    },
    ShaderSource {
        name: "brute",
        file: "brute.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "gbuffer",
        file: "gbuffer.frag",
        stage: Stage::Fragment,
        defines: &[],
    },
    ShaderSource {
        name: "shade",
        file: "shade.frag",
        stage: Stage::Fragment,
        defines: &[],
    },
    ShaderSource {
        name: "mip",
        file: "mip.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "mc",
        file: "mc.comp",
        stage: Stage::Compute,
        defines: &[],
    },
    ShaderSource {
        name: "sh_eval",
        file: "sh_eval.comp",
        stage: Stage::Compute,
        defines: &[],
    },
];

/// The GLSL header carrying the constants above.
pub fn generated_header() -> String {
    let mut s = String::from(
        "// Generated from src/gpu/layout.rs by `cargo xtask shaders`; do not edit.\n\
         #ifndef ENVLIGHT_GENERATED_GLSL\n#define ENVLIGHT_GENERATED_GLSL\n",
    );
    let b = [
        ("CONVERT_SRC", binding::CONVERT_SRC),
        ("CONVERT_DST", binding::CONVERT_DST),
        ("PROBE_IN", binding::PROBE_IN),
        ("PROBE_OUT", binding::PROBE_OUT),
        ("COPY_SRC", binding::COPY_SRC),
        ("COPY_DST", binding::COPY_DST),
        ("BUSY_OUT", binding::BUSY_OUT),
        ("SH_SRC", binding::SH_SRC),
        ("SH_PARTIALS", binding::SH_PARTIALS),
        ("SH_REDUCE_IN", binding::SH_REDUCE_IN),
        ("SH_REDUCE_OUT", binding::SH_REDUCE_OUT),
        ("BRUTE_PREP_SRC", binding::BRUTE_PREP_SRC),
        ("BRUTE_PREP_CONES", binding::BRUTE_PREP_CONES),
        ("BRUTE_PREP_RADIANCE", binding::BRUTE_PREP_RADIANCE),
        ("BRUTE_CONES", binding::BRUTE_CONES),
        ("BRUTE_RADIANCE", binding::BRUTE_RADIANCE),
        ("BRUTE_DST", binding::BRUTE_DST),
        ("BRUTE_COMP", binding::BRUTE_COMP),
        ("SH_EVAL_COEFFS", binding::SH_EVAL_COEFFS),
        ("SH_EVAL_DST", binding::SH_EVAL_DST),
        ("GBUF_OBJECTS", binding::GBUF_OBJECTS),
        ("SHADE_NORMAL", binding::SHADE_NORMAL),
        ("SHADE_VIEW", binding::SHADE_VIEW),
        ("SHADE_OBJECTS", binding::SHADE_OBJECTS),
        ("SHADE_COEFFS", binding::SHADE_COEFFS),
        ("SHADE_ENV", binding::SHADE_ENV),
        ("SHADE_POSITION", binding::SHADE_POSITION),
        ("SHADE_DP", binding::SHADE_DP),
        ("SHADE_PREFILTERED", binding::SHADE_PREFILTERED),
        ("SHADE_MC", binding::SHADE_MC),
        ("MIP_SRC", binding::MIP_SRC),
        ("MIP_DST", binding::MIP_DST),
        ("MC_NORMAL", binding::MC_NORMAL),
        ("MC_VIEW", binding::MC_VIEW),
        ("MC_POSITION", binding::MC_POSITION),
        ("MC_OBJECTS", binding::MC_OBJECTS),
        ("MC_ENV", binding::MC_ENV),
        ("MC_TABLES", binding::MC_TABLES),
        ("MC_ACCUM", binding::MC_ACCUM),
    ];
    for (name, v) in b {
        let _ = writeln!(s, "#define BINDING_{name} {v}");
    }
    let _ = writeln!(s, "#define SH_MAX_LMAX {SH_MAX_LMAX}");
    let n = (SH_MAX_LMAX + 1) * (SH_MAX_LMAX + 1);
    let _ = writeln!(s, "#define SH_MAX_COEFFS {n}");
    let _ = writeln!(s, "#define SH_WORKGROUP {SH_WORKGROUP}");
    let _ = writeln!(s, "#define FILTER_EDGE_CELLS {}u", filter_rule::EDGE_CELLS);
    let _ = writeln!(s, "#define FILTER_MAX_CELLS {}u", filter_rule::MAX_CELLS);
    let _ = writeln!(
        s,
        "#define FILTER_CELLS_PER_WIDTH {:?}",
        filter_rule::CELLS_PER_WIDTH
    );
    let _ = writeln!(
        s,
        "#define FILTER_CENTRE_LIMIT {:e}",
        filter_rule::CENTRE_LIMIT
    );
    let _ = writeln!(
        s,
        "#define FILTER_LOG_CUTOFF {:?}",
        filter_rule::LOG_CUTOFF as f32
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
    ];
    for (name, v) in ids {
        let _ = writeln!(s, "#define {name} {v}u");
    }
    let _ = writeln!(s, "#define GGX_ALPHA_MIN {:e}", brdf::GGX_ALPHA_MIN);
    for (i, name) in MAPPING_NAMES.iter().enumerate() {
        let _ = writeln!(s, "#define MAPPING_{name} {i}u");
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
