//! Compiles `glsl/` into `spirv/` with shaderc, writes the generated GLSL header and the
//! manifest of source hashes that the library's tests check for staleness.
//!
//! Kept out of the library so that building envlight never builds shaderc (a ten-minute C++
//! build). Run it through `cargo xtask shaders`.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

#[path = "../../../src/abi/mod.rs"]
// The library's re-exports and items this tool does not use.
#[allow(dead_code, unused_imports)]
mod layout;

fn main() -> Result<()> {
    let root: PathBuf = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    let glsl = root.join("glsl");
    let spirv = root.join("spirv");
    std::fs::create_dir_all(&spirv)?;
    std::fs::write(
        root.join(layout::GENERATED_HEADER),
        layout::generated_header(),
    )
    .context("writing the generated header")?;

    let compiler = shaderc::Compiler::new().context("shaderc unavailable")?;
    for src in layout::SHADER_SOURCES {
        let mut opts = shaderc::CompileOptions::new().context("shaderc options")?;
        assert_eq!(layout::TARGET_ENV, "vulkan1.2");
        opts.set_target_env(
            shaderc::TargetEnv::Vulkan,
            shaderc::EnvVersion::Vulkan1_2 as u32,
        );
        assert_eq!(layout::OPTIMIZATION, "performance");
        opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
        opts.set_warnings_as_errors();
        for (k, v) in src.defines {
            opts.add_macro_definition(k, Some(v));
        }
        let include_dir = glsl.join("include");
        opts.set_include_callback(move |name, _ty, _from, _depth| {
            let p = include_dir.join(name);
            let content =
                std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
            Ok(shaderc::ResolvedInclude {
                resolved_name: p.display().to_string(),
                content,
            })
        });
        let kind = match src.stage {
            layout::Stage::Compute => shaderc::ShaderKind::Compute,
            layout::Stage::Vertex => shaderc::ShaderKind::Vertex,
            layout::Stage::Fragment => shaderc::ShaderKind::Fragment,
        };
        let path = glsl.join(src.file);
        let text = std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
        let out = match compiler.compile_into_spirv(&text, kind, src.file, "main", Some(&opts)) {
            Ok(o) => o,
            Err(e) => bail!("{} ({}): {e}", src.name, src.file),
        };
        std::fs::write(spirv.join(format!("{}.spv", src.name)), out.as_binary_u8())?;
        println!("compiled {} -> spirv/{}.spv", src.file, src.name);
    }
    std::fs::write(root.join(layout::MANIFEST), layout::manifest(&glsl)?)?;
    println!("wrote {}", layout::MANIFEST);
    for path in layout::EXAMPLE_SHADERS {
        let src = root.join(format!("{path}.comp"));
        let text = std::fs::read_to_string(&src).with_context(|| src.display().to_string())?;
        let mut opts = shaderc::CompileOptions::new().context("shaderc options")?;
        opts.set_target_env(
            shaderc::TargetEnv::Vulkan,
            shaderc::EnvVersion::Vulkan1_2 as u32,
        );
        opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
        opts.set_warnings_as_errors();
        let kind = shaderc::ShaderKind::Compute;
        let name = format!("{path}.comp");
        let out = match compiler.compile_into_spirv(&text, kind, &name, "main", Some(&opts)) {
            Ok(o) => o,
            Err(e) => bail!("{name}: {e}"),
        };
        std::fs::write(root.join(format!("{path}.spv")), out.as_binary_u8())?;
        let hash = format!("{:016x}\n", layout::example_hash(&text));
        std::fs::write(root.join(format!("{path}.spv.hash")), hash)?;
        println!("compiled {name} -> {path}.spv");
    }
    Ok(())
}
