//! `envlight bake`'s options: clap's arguments, each enum option's values by the library's
//! names, and the settings they give.

use super::super::named;
use crate::bake::output::{Irradiance, Preset};
use crate::bake::plan::{BakeSettings, Container, LightsKey, LightsMode};
use crate::io::ktx2::Ktx2Format;
use crate::math::split_sum::DfgAxes;
use clap::Args;
use std::path::PathBuf;

/// Bake probes for engines: SH, an irradiance cube and a GGX specular cube per probe (KTX2 or
/// EXR), resumable, shardable across machines
#[derive(Args)]
pub struct BakeArgs {
    /// Probe files, folders (their .hdr, .exr, .dds and .pfm files) or globs
    pub(super) inputs: Vec<String>,
    /// Output folder (one folder per probe, named as its file, and the manifest)
    #[arg(short, long)]
    pub(super) out: PathBuf,
    /// A TOML bake file with the options below (the command line wins)
    #[arg(long)]
    pub(super) config: Option<PathBuf>,
    /// Highest SH band written [default: 2]
    #[arg(long)]
    pub(super) sh_order: Option<u32>,
    /// Irradiance cube face size [default: 32]
    #[arg(long)]
    pub(super) irradiance_size: Option<u32>,
    /// Specular cube face size at level 0 [default: 256]
    #[arg(long)]
    pub(super) specular_size: Option<u32>,
    /// Specular levels: level k holds GGX α = (k/(levels − 1))² [default: 8, or as many as a
    /// smaller cube has]
    #[arg(long)]
    pub(super) specular_levels: Option<u32>,
    /// FIS samples per specular texel [default: 256]
    #[arg(long)]
    pub(super) samples: Option<u32>,
    /// Output container [default: ktx2]
    #[arg(long, value_parser = named(FORMATS, Container::parse))]
    pub(super) format: Option<Container>,
    /// KTX2 texels (texels beyond a format's range are clamped into it and the power clamped
    /// away reported) [default: rgba32f]
    #[arg(long, ignore_case = true, value_parser = named(TEXELS, Ktx2Format::parse))]
    pub(super) texels: Option<Ktx2Format>,
    /// Also write each probe's dual-paraboloid MIP chain (chain.ktx2, RGBA32F premultiplied:
    /// a lookup divides rgb by alpha after filtering), what FIS reads at run time
    #[arg(long)]
    pub(super) chain: bool,
    /// The same as --lights off
    #[arg(long)]
    pub(super) no_lights: bool,
    /// Also write the split-sum DFG table once (dfg.ktx2: A, B per n·v column and √α row)
    #[arg(long)]
    pub(super) dfg: bool,
    /// Where the DFG table's entries sit: endpoints (n·v = i/(size − 1), envlight's lookups) or
    /// centres (texel centres, (i + ½)/size, as a plain texture lookup reads them)
    /// [default: endpoints; khronos: centres]
    #[arg(long, value_parser = named(DFG_AXES, DfgAxes::parse))]
    pub(super) dfg_samples: Option<DfgAxes>,
    /// Bake only the i-th of n deterministic subsets (1-based), e.g. 2/8; or `auto`: the
    /// task of a job array (Slurm, AWS Batch, Google Batch; Kubernetes Indexed Jobs with
    /// `auto/N`), from the scheduler's variables
    #[arg(long)]
    pub(super) shard: Option<String>,
    /// Bake only inputs A to B of the sorted list (1-based, inclusive): a frame range, for
    /// schedulers that hand out ranges (Deadline, OpenCue, OpenJD)
    #[arg(long, conflicts_with = "shard")]
    pub(super) items: Option<String>,
    /// Bake again probes whose inputs and options are unchanged
    #[arg(long)]
    pub(super) force: bool,
    /// Refuse to bake on a CPU implementation of Vulkan (lavapipe, SwiftShader), exiting 75 as
    /// for a missing device, instead of warning and baking ~100× slower
    #[arg(long)]
    pub(super) require_gpu: bool,
    /// Reduce a source wider or taller than this many texels before baking it (the means of
    /// blocks of texels, its power kept; noted in the summary and the manifest) [default:
    /// the device's largest image side, or cube face]
    #[arg(long, value_name = "TEXELS")]
    pub(super) max_source_side: Option<u32>,
    /// Merge the shards' manifests found in OUT into OUT/manifest.json, and bake nothing
    #[arg(long)]
    pub(super) merge: bool,
    /// Texels per cube level checked against float64 exact filters (0: none); the errors go
    /// to the summary and the manifest [default: 2]
    #[arg(long)]
    pub(super) check: Option<u32>,
    /// Write no preview.png per probe (and no files-against-intent check)
    #[arg(long)]
    pub(super) no_preview: bool,
    /// Bake for an engine: bevy (cubes for its (x, y, −z) lookup, irradiance E/π, e5b9g9r9 +
    /// zstd, skybox.ktx2) or khronos (glTF-IBL-Sampler's yaw, E/π, rgba16f, ⌊log2 size⌋
    /// levels). Options given one by one still apply on top
    #[arg(long, value_parser = named(PRESETS, Preset::parse))]
    pub(super) preset: Option<Preset>,
    /// Turn the probe about +Y by this many degrees before baking
    #[arg(long, allow_negative_numbers = true)]
    pub(super) rotate_y: Option<f64>,
    /// Mirror the probe left–right
    #[arg(long)]
    pub(super) flip_u: bool,
    /// Turn the probe upside down
    #[arg(long)]
    pub(super) flip_v: bool,
    /// Irradiance cube normalisation: e (irradiance) or e-over-pi (a white Lambertian
    /// surface's radiance, what engines multiply by albedo) [default: e]
    #[arg(long, value_parser = named(IRRADIANCE, Irradiance::parse))]
    pub(super) irradiance: Option<Irradiance>,
    /// Lights: exact (extract them and add them exactly into the cubes), separate (write them
    /// to lights.json and bake only the residual), or off (filter the whole map) [default: exact]
    #[arg(long, value_parser = named(LIGHTS, LightsMode::parse))]
    pub(super) lights: Option<LightsMode>,
    /// Supercompress the KTX2 levels with Zstandard
    #[arg(long)]
    pub(super) zstd: bool,
}

/// `--format` values.
const FORMATS: &[&str] = &["ktx2", "exr"];
/// `--lights` values.
const LIGHTS: &[&str] = &["exact", "separate", "off"];
/// `--texels` values.
const TEXELS: &[&str] = &["rgba32f", "rgba16f", "b10g11r11", "e5b9g9r9", "bc6h"];
/// `--preset` values.
const PRESETS: &[&str] = &["bevy", "khronos"];
/// `--irradiance` values.
const IRRADIANCE: &[&str] = &["e", "e-over-pi"];
/// `--dfg-samples` values.
const DFG_AXES: &[&str] = &["endpoints", "centres"];

/// The settings the command line gives (each flag absent where not given).
pub(super) fn cli_settings(a: &BakeArgs) -> BakeSettings {
    let flag = |on: bool| on.then_some(true);
    let lights = match (a.lights, a.no_lights) {
        (Some(m), _) => Some(m),
        (None, true) => Some(LightsMode::Off),
        (None, false) => None,
    };
    BakeSettings {
        sh_order: a.sh_order,
        irradiance_size: a.irradiance_size,
        specular_size: a.specular_size,
        specular_levels: a.specular_levels,
        samples: a.samples,
        format: a.format,
        texels: a.texels,
        dfg: flag(a.dfg),
        dfg_samples: a.dfg_samples,
        chain: flag(a.chain),
        lights: lights.map(LightsKey::Mode),
        check: a.check,
        preset: a.preset,
        rotate_y: a.rotate_y,
        flip_u: flag(a.flip_u),
        flip_v: flag(a.flip_v),
        irradiance: a.irradiance,
        zstd: flag(a.zstd),
        preview: a.no_preview.then_some(false),
        max_source_side: a.max_source_side,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each value the command line offers for an enum option is a name the bake file's
    /// parser takes, and together they name every variant.
    #[test]
    fn command_line_values_are_the_bake_file_names() {
        fn all<T: PartialEq + std::fmt::Debug>(
            names: &[&str],
            parse: fn(&str) -> Option<T>,
        ) -> Vec<T> {
            let mut seen: Vec<T> = Vec::new();
            for n in names {
                let v = parse(n).unwrap_or_else(|| panic!("{n} does not parse"));
                assert!(!seen.contains(&v), "{n} names {v:?} twice");
                seen.push(v);
            }
            seen
        }
        let texels = all(TEXELS, Ktx2Format::parse);
        assert_eq!(texels.len(), 5);
        for t in texels {
            assert!(TEXELS.contains(&t.name()));
        }
        assert_eq!(all(PRESETS, Preset::parse), [Preset::Bevy, Preset::Khronos]);
        assert_eq!(
            all(IRRADIANCE, Irradiance::parse),
            [Irradiance::E, Irradiance::EOverPi]
        );
        assert_eq!(
            all(DFG_AXES, DfgAxes::parse),
            [DfgAxes::Endpoints, DfgAxes::Centres]
        );
        assert_eq!(
            all(LIGHTS, LightsMode::parse),
            [LightsMode::Exact, LightsMode::Separate, LightsMode::Off]
        );
        assert_eq!(
            all(FORMATS, Container::parse),
            [Container::Ktx2, Container::Exr]
        );
        for f in [Container::Ktx2, Container::Exr] {
            assert!(FORMATS.contains(&f.name()));
        }
    }
}
