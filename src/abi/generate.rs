//! The GLSL header generated from the shared numbers, and the manifest of the sources each
//! SPIR-V module was built from.

use super::parameters::*;
use super::shaders::{ShaderSource, OPTIMIZATION, SHADER_SOURCES, TARGET_ENV};
use super::{binding, push, record};
use std::fmt::Write as _;
use std::path::Path;

/// The GLSL header carrying the shared numbers: bindings, sizes, the lights' and the area
/// conversion's parameters, the filter rule and other floats, SH constants, ids, the push
/// blocks and the records.
pub fn generated_header() -> String {
    let mut s = String::from(
        "// Generated from src/abi by `cargo xtask shaders`; do not edit.\n\
         #ifndef ENVLIGHT_GENERATED_GLSL\n#define ENVLIGHT_GENERATED_GLSL\n",
    );
    define_sizes_and_lights(&mut s);
    define_area_footprint_and_floats(&mut s);
    define_sh_and_ids(&mut s);
    define_push_blocks(&mut s);
    define_records(&mut s);
    s.push_str("#endif\n");
    s
}

/// `#define NAME v` with `v` as float32 prints it (the shaders' precision).
fn define_f32(s: &mut String, name: &str, v: f64) {
    let _ = writeln!(s, "#define {name} {:?}", v as f32);
}

/// The exact reference pass's workgroup and rule (`glsl/exact_shade.comp`).
fn define_exact(s: &mut String) {
    let _ = writeln!(s, "#define EXACT_WORKGROUP {EXACT_WORKGROUP}u");
    let _ = writeln!(s, "#define EXACT_QUERY_VEC4S {}u", exact::QUERY_VEC4S);
    define_f32(s, "EXACT_HORIZON_SHRINK", exact::HORIZON_SHRINK);
    define_f32(s, "EXACT_HORIZON_REACH", exact::HORIZON_REACH);
    define_f32(s, "EXACT_MAX_CELLS_PER_WIDTH", exact::MAX_CELLS_PER_WIDTH);
}

/// Bindings, SH and tile sizes, the light walk's parameters.
fn define_sizes_and_lights(s: &mut String) {
    for (name, v) in binding::ALL {
        let _ = writeln!(s, "#define BINDING_{name} {v}");
    }
    let _ = writeln!(s, "#define SH_MAX_LMAX {SH_MAX_LMAX}");
    let n = (SH_MAX_LMAX + 1) * (SH_MAX_LMAX + 1);
    let _ = writeln!(s, "#define SH_MAX_COEFFS {n}");
    let _ = writeln!(s, "#define SH_WORKGROUP {SH_WORKGROUP}");
    define_exact(s);
    let _ = writeln!(s, "#define BRUTE_TILE {BRUTE_TILE}u");
    let _ = writeln!(s, "#define LIGHT_HEADER_VEC4S {}u", lights::HEADER_VEC4S);
    let _ = writeln!(s, "#define LIGHT_STEP_NODES {}u", lights::STEP_NODES);
    let _ = writeln!(s, "#define LIGHT_CLUSTER_VEC4S {}u", lights::CLUSTER_VEC4S);
    let _ = writeln!(
        s,
        "#define CLUSTER_SORT_CELL_ARRAYS {}u",
        lights::CLUSTER_SORT_CELL_ARRAYS
    );
    let _ = writeln!(s, "#define LIGHTS_KERNEL_COSINE {}u", lights::KERNEL_COSINE);
    let _ = writeln!(s, "#define LIGHTS_KERNEL_GGX {}u", lights::KERNEL_GGX);
    let _ = writeln!(
        s,
        "#define LIGHTS_KERNEL_CLUSTERS {}u",
        lights::KERNEL_CLUSTERS
    );
    define_f32(s, "LIGHT_PER_WIDTH", lights::PER_WIDTH);
    define_f32(s, "LIGHT_CENTRE_BELOW", lights::CENTRE_BELOW);
    define_f32(s, "LIGHT_TAIL_FRACTION", lights::TAIL_FRACTION);
    define_f32(s, "LIGHT_TREE_BELOW", lights::TREE_BELOW);
    define_f32(s, "LIGHT_TREE_BUDGET", lights::TREE_BUDGET);
    define_f32(s, "LIGHT_TREE_BUDGET_REACH", lights::TREE_BUDGET_REACH);
    define_f32(s, "LIGHT_KERNEL_FADE", lights::KERNEL_FADE);
    let _ = writeln!(s, "#define LIGHT_LEAF_TEXELS {}u", lights::LEAF_TEXELS);
    define_f32(s, "LIGHT_TREE_TAIL", lights::TREE_TAIL);
    let _ = writeln!(s, "#define LIGHT_TREE_VEC4S {}u", lights::TREE_VEC4S);
    let _ = writeln!(
        s,
        "#define EXTRACT_HEADER_WORDS {}u",
        lights::EXTRACT_HEADER_WORDS
    );
    let _ = writeln!(s, "#define EXTRACT_TOP_BINS {}u", lights::EXTRACT_TOP_BINS);
    let _ = writeln!(s, "#define EXTRACT_LOW_BINS {}u", lights::EXTRACT_LOW_BINS);
    let _ = writeln!(s, "#define FILL_MAX_RINGS {}u", lights::FILL_MAX_RINGS);
    let _ = writeln!(s, "#define FILL_SLOT_BITS {}u", lights::FILL_SLOT_BITS);
    let _ = writeln!(s, "#define FILL_SLOT_ARRAYS {}u", lights::FILL_SLOT_ARRAYS);
    let _ = writeln!(
        s,
        "#define EXTRACT_RECORD_VEC4S {}u",
        lights::EXTRACT_RECORD_VEC4S
    );
    let _ = writeln!(
        s,
        "#define EXTRACT_LIGHT_GROUP {}u",
        lights::EXTRACT_LIGHT_GROUP
    );
    use lights::extract_mode as m;
    for (name, v) in [
        ("HISTOGRAM", m::HISTOGRAM),
        ("SELECT_TOP", m::SELECT_TOP),
        ("HISTOGRAM_LOW", m::HISTOGRAM_LOW),
        ("SELECT_LOW", m::SELECT_LOW),
        ("MARK_LIST", m::MARK_LIST),
        ("MARK", m::MARK),
        ("RING", m::RING),
        ("RIMS", m::RIMS),
        ("DECIDE", m::DECIDE),
        ("FILL", m::FILL),
        ("COMPACT", m::COMPACT),
    ] {
        let _ = writeln!(s, "#define EXTRACT_MODE_{name} {v}u");
    }
    use lights::clusters_mode as c;
    for (name, v) in [
        ("COUNT", c::COUNT),
        ("SCAN", c::SCAN),
        ("SCATTER", c::SCATTER),
        ("SUM", c::SUM),
    ] {
        let _ = writeln!(s, "#define CLUSTERS_MODE_{name} {v}u");
    }
    use lights::prepare_mode as pm;
    for (name, v) in [
        ("KEYS", pm::KEYS),
        ("SCAN", pm::SCAN),
        ("SCATTER", pm::SCATTER),
        ("TEXELS", pm::TEXELS),
        ("NODES", pm::NODES),
    ] {
        let _ = writeln!(s, "#define PREPARE_MODE_{name} {v}u");
    }
    let _ = writeln!(s, "#define TREE_BUCKET_BITS {}u", lights::TREE_BUCKET_BITS);
    let _ = writeln!(
        s,
        "#define TREE_KEY_AXIS_BITS {}u",
        lights::TREE_KEY_AXIS_BITS
    );
    let _ = writeln!(
        s,
        "#define TREE_SORT_BUCKET_ARRAYS {}u",
        lights::TREE_SORT_BUCKET_ARRAYS
    );
    use lights::extract_word as w;
    for (name, v) in [
        ("LOW_ARGS", w::LOW_ARGS),
        ("OMEGA_MAX", w::OMEGA_MAX),
        ("LIGHT_ARGS", w::LIGHT_ARGS),
        ("CANDIDATES", w::CANDIDATES),
        ("KEPT", w::KEPT),
        ("THRESHOLD", w::THRESHOLD),
        ("BIN", w::BIN),
        ("RANK", w::RANK),
        ("NONFINITE", w::NONFINITE),
        ("TAU", w::TAU),
        ("COUNTER", w::COUNTER),
        ("MEMBERS", w::MEMBERS),
        ("ACCEPTED", w::ACCEPTED),
        ("GROWN", w::GROWN),
        ("ROUNDS", w::ROUNDS),
        ("RING_COUNT", w::RING_COUNT),
        ("RIMS", w::RIMS),
        ("MARK_LIST_ARGS", w::MARK_LIST_ARGS),
        ("MARK_ARGS", w::MARK_ARGS),
        ("COMPACT_ARGS", w::COMPACT_ARGS),
    ] {
        let _ = writeln!(s, "#define EXTRACT_WORD_{name} {v}u");
    }
}

/// The area conversion's and the footprint's parameters, and every shared float.
fn define_area_footprint_and_floats(s: &mut String) {
    let _ = writeln!(s, "#define AREA_EDGE_STEPS {}u", area::EDGE_STEPS);
    let _ = writeln!(
        s,
        "#define PREFILTER_SAMPLE_VEC4S {}u",
        split_sum::PREFILTER_SAMPLE_VEC4S
    );
    let _ = writeln!(s, "#define AREA_POLE_STEPS {}u", area::POLE_STEPS);
    define_f32(s, "AREA_POLE_NEAR", area::POLE_NEAR);
    let _ = writeln!(s, "#define AREA_MAX_VERTICES {}u", area::MAX_VERTICES);
    let _ = writeln!(
        s,
        "#define AREA_PARABOLOID_EDGE_STEPS {}u",
        area::PARABOLOID_EDGE_STEPS
    );
    let _ = writeln!(
        s,
        "#define AREA_PARABOLOID_RIM_STEPS {}u",
        area::PARABOLOID_RIM_STEPS
    );
    define_f32(s, "AREA_SLIVER_NUDGE", area::SLIVER_NUDGE);
    let _ = writeln!(s, "#define AREA_PLAN_ROW_SHIFT {}u", area::PLAN_ROW_SHIFT);
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
}

/// SH normalisation constants, BRDF, technique and rotation ids, Gauss–Legendre nodes,
/// the horizon fade and mapping ids.
fn define_sh_and_ids(s: &mut String) {
    let f = |x: f64| format!("{:?}", x as f32);
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
        ("OBJECT_SPHERE", object::SPHERE),
        ("OBJECT_PLANE", object::PLANE),
        ("OBJECT_ROTATE", object::ROTATE),
        ("OBJECT_LIGHTS", object::LIGHTS),
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
}

/// The push blocks, generated from the Rust structs' field lists (std430, so the offsets of
/// 4-byte scalars, uvec2/vec4 and scalar arrays match repr(C) without padding).
fn define_push_blocks(s: &mut String) {
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
}

/// The storage-buffer records (std430: vec4s at multiples of 16, checked where they are
/// declared), generated from the Rust structs' field lists.
fn define_records(s: &mut String) {
    for (name, fields) in record::RECORDS {
        let _ = writeln!(s, "struct {name} {{");
        for (field, ty, _) in fields.iter() {
            let _ = writeln!(s, "    {ty} {field};");
        }
        let _ = writeln!(s, "}};");
    }
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
    Ok(fnv1a(&text))
}

/// FNV-1a, 64 bits, of `text`.
pub fn fnv1a(text: &str) -> u64 {
    fnv1a_bytes(text.as_bytes())
}

/// FNV-1a, 64 bits, of `bytes`.
pub fn fnv1a_bytes(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Compute shaders of the examples' own (an engine's, not envlight's): `tools/shaderc`
/// compiles each `<path>.comp` (no includes) into `<path>.spv` beside it and records
/// [`example_hash`] of its source in `<path>.spv.hash`, which a test recomputes.
pub const EXAMPLE_SHADERS: &[&str] = &["examples/support/sky"];

/// What an example shader's SPIR-V is built from: target, optimisation and its source.
pub fn example_hash(source: &str) -> u64 {
    fnv1a(&format!("{TARGET_ENV} {OPTIMIZATION} example\n{source}"))
}

/// The manifest's text for the current sources.
pub fn manifest(glsl_dir: &Path) -> std::io::Result<String> {
    let mut s = String::new();
    for src in SHADER_SOURCES {
        let _ = writeln!(s, "{}.spv {:016x}", src.name, source_hash(glsl_dir, src)?);
    }
    Ok(s)
}
