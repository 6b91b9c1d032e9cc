//! The shading pass (`glsl/shade.frag`; its FIS estimator's float64 twin is
//! `crate::math::fis`): one fullscreen draw that shades each G-buffer pixel by its
//! material's technique (mirror lookup, SH irradiance, prefiltered maps, filtered importance
//! sampling, or the Monte Carlo accumulation) and shows the environment behind.

use super::gbuffer::{target, GBuffer};
use super::lights::GpuLights;
use super::map::GpuEnvMap;
pub use super::sh_brdf::Rotation;
pub use super::sh_project::Subgroups;
use crate::abi::{binding, push::ShadePush, ShadeVariant, ShaderId};
use crate::error::Result;
use crate::gpu::{mat3_rows, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timed, Usage};
use crate::math::{Mapping, Orientation};
use crate::passes::testing::poison::{self, PassId};
use std::sync::{Arc, Mutex};

/// What the shading reads besides the G-buffer; techniques no material uses are `None`.
pub struct ShadeInputs<'a> {
    /// The environment in its own mapping (background and mirror lookups).
    pub env: &'a GpuEnvMap,
    /// How its file is oriented.
    pub orientation: Orientation,
    /// SH coefficient sets, concatenated (each object's record holds its offset): irradiance
    /// (Â_l folded in) for SH objects, radiance for SH-BRDF objects.
    pub sh: Option<ShCoeffs<'a>>,
    /// The dual-paraboloid MIP chain (FIS).
    pub dp: Option<&'a GpuEnvMap>,
    /// Prefiltered lat-long maps, concatenated, one vec4 per texel.
    pub prefiltered: Option<&'a Buffer>,
    /// The Monte Carlo accumulation and its sample count.
    pub mc: Option<(&'a GpuEnvMap, u32)>,
    /// SH-BRDF tables, concatenated (each object's record holds its offset).
    pub brdf_sh: Option<&'a Buffer>,
    /// How SH-BRDF vectors are rotated per pixel.
    pub sh_rotation: Rotation,
    /// Split-sum: the prefiltered chain and the DFG tables (each object's record holds its
    /// table's offset).
    pub split: Option<(&'a GpuEnvMap, &'a Buffer)>,
    /// Trace shadow rays.
    pub shadows: bool,
    /// Extracted lights (`crate::math::lights`): texels that FIS, split-sum and footprint
    /// lookups add, clusters whose irradiance SH and prefiltered irradiance objects marked for
    /// them add to their residual's.
    pub lights: Option<&'a GpuLights>,
    /// Which lookups are filtered over the pixel's footprint (they read `dp`).
    pub footprint: Footprint,
}

/// Where the shade pass reads SH coefficient sets from.
#[derive(Clone, Copy)]
pub enum ShCoeffs<'a> {
    /// From the host: uploaded by the recording.
    Host(&'a [[f64; 3]]),
    /// From a GPU buffer, one vec4 a coefficient (rgb used), as
    /// [`crate::passes::ShPacker`] writes them: nothing comes back to the host.
    Gpu(&'a Buffer),
}

/// Which lookups read the dual-paraboloid chain over the pixel's footprint
/// (`crate::math::footprint`) instead of one texel of the environment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Footprint {
    /// Mirror (`lookup`) materials.
    pub mirror: bool,
    /// The background.
    pub background: bool,
    /// The chain holds the residual: footprint lookups add the light texels they cover.
    pub lights: bool,
}

impl Footprint {
    /// The push constant's flags.
    pub fn flags(self) -> u32 {
        use crate::abi::footprint::{BACKGROUND, LIGHTS, MIRROR};
        (self.mirror as u32 * MIRROR)
            | (self.background as u32 * BACKGROUND)
            | (self.lights as u32 * LIGHTS)
    }
}

/// Which of shade.frag's code a draw of `gbuf` with `inputs` runs (its specialisation
/// constant 0): a bit per technique whose inputs are bound (`dp` stands for FIS), mirrors'
/// lookups always, the footprint lookups and shadow rays where asked, and the BRDFs of
/// `gbuf`'s objects. The rest folds away, so that llvmpipe builds a one-technique shade in
/// about a third of the whole one's time (an object whose technique's inputs are missing
/// would draw black), and runs a light tree walk's steps without the code of BRDFs and
/// shadows the scene lacks (llvmpipe runs a loop's whole body at every step).
pub fn code_mask(inputs: &ShadeInputs<'_>, gbuf: &GBuffer) -> u32 {
    code_bits(&ShadeCode {
        fis: inputs.dp.is_some(),
        sh: inputs.sh.is_some(),
        prefiltered: inputs.prefiltered.is_some(),
        mc: inputs.mc.is_some(),
        sh_brdf: inputs.brdf_sh.is_some(),
        split_sum: inputs.split.is_some(),
        footprint: inputs.footprint.mirror || inputs.footprint.background,
        shadows: inputs.shadows,
        brdfs: gbuf.brdfs,
    })
}

/// Which inputs a draw will bind, known before they exist (to build its pipeline early with
/// [`Shade::prepare_code`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadeCode {
    /// The dual-paraboloid chain (FIS).
    pub fis: bool,
    /// SH coefficients.
    pub sh: bool,
    /// Prefiltered maps.
    pub prefiltered: bool,
    /// The Monte Carlo accumulation.
    pub mc: bool,
    /// SH-BRDF tables.
    pub sh_brdf: bool,
    /// The split-sum chain.
    pub split_sum: bool,
    /// Footprint-filtered mirrors or background.
    pub footprint: bool,
    /// Shadow rays.
    pub shadows: bool,
    /// The BRDFs the objects use ([`super::gbuffer::brdf_bits`]).
    pub brdfs: u32,
}

/// The code mask of a draw with `code`'s inputs (see [`code_mask`]).
pub fn code_bits(code: &ShadeCode) -> u32 {
    use crate::abi::brdf::technique as t;
    let bit = |on: bool, tech: u32| (on as u32) << tech;
    bit(true, t::LOOKUP)
        | bit(code.fis, t::FIS)
        | bit(code.sh, t::SH)
        | bit(code.prefiltered, t::PREFILTERED)
        | bit(code.mc, t::MC)
        | bit(code.sh_brdf, t::SH_BRDF)
        | bit(code.split_sum, t::SPLIT_SUM)
        | if code.footprint {
            crate::abi::footprint::CODE
        } else {
            0
        }
        | if code.shadows {
            crate::abi::shade_code::SHADOWS
        } else {
            0
        }
        | (code.brdfs & ((1 << BRDF_IDS) - 1)) << crate::abi::shade_code::BRDF_SHIFT
}

/// BRDF ids the code mask has room for (bits BRDF_SHIFT… of 32).
const BRDF_IDS: u32 = 32 - crate::abi::shade_code::BRDF_SHIFT;
const _: () = assert!(
    crate::abi::brdf::ids::WARD < BRDF_IDS,
    "a BRDF id past the mask"
);

/// shade.frag's variants for scenes of one technique (the shader table's `shade_variants`
/// list). SH-BRDF keeps SH, whose projection it reads, and split-sum FIS, whose chain it
/// reads: their masks hold both.
const VARIANTS: &[ShadeVariant] = crate::abi::SHADE_VARIANTS;

/// Every fragment module the shading pass may build: the whole shader and its variants,
/// plain and with vote, whole and lean (what a render's plan allows it to create).
pub(crate) const MODULES: [ShaderId; 2 + 4 * VARIANTS.len()] = {
    let mut m = [ShaderId::Shade; 2 + 4 * VARIANTS.len()];
    m[1] = ShaderId::ShadeVote;
    let mut k = 0;
    while k < 4 * VARIANTS.len() {
        m[2 + k] = VARIANTS[k / 4].modules[k % 4];
        k += 1;
    }
    m
};

/// The fragment module a draw with code `mask` takes: where the mask keeps the techniques of
/// a variant (besides the lookup, the background's), that variant, whose other techniques'
/// code is gone before the driver compiles it (so it compiles faster), and its LEAN module
/// where the mask has no footprint or shadow bits; else the whole shader, which folds them
/// by the constant (`envlight render` prints each pipeline's build time).
/// `vote`: walks end on a subgroup vote.
pub(crate) fn module(vote: bool, mask: u32) -> ShaderId {
    use crate::abi::brdf::technique as t;
    let techs = VARIANTS.iter().fold(1 << t::LOOKUP, |m, v| m | v.techs);
    let kept = mask & techs & !(1 << t::LOOKUP);
    let lean = (mask & (crate::abi::footprint::CODE | crate::abi::shade_code::SHADOWS)) == 0;
    match VARIANTS.iter().find(|v| v.techs == kept) {
        Some(v) => v.modules[vote as usize + 2 * lean as usize],
        None if vote => ShaderId::ShadeVote,
        None => ShaderId::Shade,
    }
}

/// The shading pass.
pub struct Shade {
    ctx: Context,
    /// Whether light tree walks end on a subgroup vote (shade_vote and its variants).
    vote: bool,
    /// Whether a mask of one technique takes shade.frag's variant for it ([`module`]).
    variants: bool,
    /// One pipeline per code mask ([`code_mask`]), built at the first draw that needs it.
    pipelines: Mutex<Vec<(u32, Arc<Pipeline>)>>,
    plain: Sampler,
    trilinear: Sampler,
    border: Sampler,
    dummy_image: GpuEnvMap,
    dummy_buffer: Buffer,
    x90: Buffer,
}

impl Shade {
    /// Builds the pipeline: the light tree walks end on a subgroup vote where the device
    /// has vote operations in fragment shaders.
    pub fn new(ctx: &Context) -> Result<Shade> {
        Shade::with_subgroups(ctx, Subgroups::Auto)
    }

    /// [`Shade::new`], or without subgroup operations ([`Subgroups::Off`]: the same sums;
    /// on llvmpipe each walk then runs to its bound, e.g. to test the fallback).
    pub fn with_subgroups(ctx: &Context, subgroups: Subgroups) -> Result<Shade> {
        let dummy_buffer = Buffer::storage(ctx, "shade: unused buffer", &[0.0f32; 4])?;
        let vote = subgroups == Subgroups::Auto && ctx.info().fragment_vote;
        Ok(Shade {
            ctx: ctx.clone(),
            vote,
            variants: true,
            pipelines: Mutex::new(Vec::new()),
            plain: Sampler::linear_clamp(ctx, "shade sampler")?,
            trilinear: Sampler::trilinear_clamp(ctx, "shade trilinear sampler")?,
            border: Sampler::trilinear_border(ctx, "shade paraboloid chain sampler")?,
            dummy_image: GpuEnvMap::new(ctx, "shade: unused image", Mapping::LatLong, 1, 1)?,
            dummy_buffer,
            x90: super::sh_brdf::x90_buffer(ctx)?,
        })
    }

    /// Builds the whole shader for every mask from now on, where a mask of one technique
    /// would take that technique's variant (they give the same frames: tests compare them).
    /// Pipelines already built stay.
    pub fn whole_shader_only(&mut self) {
        self.variants = false;
    }

    /// The pipeline specialised on `mask`, built the first time it is asked for.
    fn pipeline(&self, mask: u32) -> Result<Arc<Pipeline>> {
        let mut built = self
            .pipelines
            .lock()
            .map_err(|_| crate::Error::Invalid("shade: a pipeline build panicked".into()))?;
        if let Some((_, p)) = built.iter().find(|(m, _)| *m == mask) {
            return Ok(p.clone());
        }
        let frag = match self.variants {
            true => module(self.vote, mask),
            false => module(self.vote, u32::MAX),
        };
        let p = Arc::new(Pipeline::fullscreen_with(
            &self.ctx,
            ShaderId::FullscreenVert,
            frag,
            &[super::gbuffer::FORMAT],
            &[mask],
        )?);
        built.push((mask, p.clone()));
        Ok(p)
    }

    /// Builds the pipeline a draw with `code`'s inputs will take now rather than at that draw
    /// (from another thread while the host works, say).
    pub fn prepare_code(&self, code: &ShadeCode) -> Result<()> {
        self.pipeline(code_bits(code)).map(|_| ())
    }

    /// Records the shading of `gbuf` into `frame` (a colour target of the G-buffer's size,
    /// see [`target`]). Span: "shade".
    pub fn record(
        &self,
        rec: &mut Recorder,
        gbuf: &GBuffer,
        inputs: &ShadeInputs<'_>,
        frame: &GpuEnvMap,
    ) -> Result<()> {
        assert_eq!((frame.width, frame.height), (gbuf.width, gbuf.height));
        let uploaded = match inputs.sh {
            Some(ShCoeffs::Host(c)) if !c.is_empty() => {
                let data: Vec<[f32; 4]> = c
                    .iter()
                    .map(|v| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0])
                    .collect();
                Some(rec.upload("shade SH coefficients", &data)?)
            }
            _ => None,
        };
        let coeffs = match inputs.sh {
            Some(ShCoeffs::Gpu(b)) => Some(b),
            _ => uploaded.as_deref(),
        };
        // The unused image is bound but never read; it only needs a defined layout.
        if self.dummy_image.image.usage() == Usage::Undefined {
            rec.clear(&self.dummy_image.image, [0.0; 4]);
        }
        let dp = inputs.dp.unwrap_or(&self.dummy_image);
        let mc = inputs.mc.map(|m| m.0).unwrap_or(&self.dummy_image);
        let split_chain = inputs
            .split
            .map(|s| &s.0.image)
            .unwrap_or(&self.dummy_image.image);
        let push = ShadePush {
            world_to_file: mat3_rows(inputs.orientation.checked_world_to_file()?),
            env_size: [inputs.env.width, inputs.env.height],
            env_mapping: inputs.env.mapping.id(),
            count: gbuf.count,
            dp_size: dp.width,
            max_lod: (dp.mips() - 1) as f32,
            shadows: inputs.shadows as u32,
            mc_samples: inputs.mc.map(|m| m.1).unwrap_or(0),
            sh_rotation: inputs.sh_rotation.id(),
            lights: inputs.lights.map_or(0, |l| l.count()),
            light_stride: inputs.lights.map_or(0, |l| l.stride()),
            clusters: inputs.lights.map_or(0, |l| l.clusters()),
            cluster_at: inputs.lights.map_or(0, |l| l.cluster_at()),
            tree_nodes: inputs.lights.map_or(0, |l| l.tree_nodes()),
            tree_at: inputs.lights.map_or(0, |l| l.tree_at()),
            footprint: inputs.footprint.flags(),
        };
        let camera = match (inputs.footprint.flags(), gbuf.camera) {
            (0, _) => None,
            (_, Some(c)) => Some(rec.upload("shade camera", &super::gbuffer::camera_record(&c))?),
            (_, None) => {
                return Err(crate::Error::Invalid(
                    "footprint lookups need the G-buffer's camera (GBuffer::camera)".into(),
                ))
            }
        };
        let pipeline = self.pipeline(code_mask(inputs, gbuf))?;
        rec.span("shade", |rec| {
            rec.draw_fullscreen(
                &pipeline,
                &[
                    (
                        binding::SHADE_NORMAL,
                        Bind::Sampled(&gbuf.normal.image, &self.plain, false),
                    ),
                    (
                        binding::SHADE_VIEW,
                        Bind::Sampled(&gbuf.view.image, &self.plain, false),
                    ),
                    (binding::SHADE_OBJECTS, Bind::Buffer(&gbuf.objects)),
                    (
                        binding::SHADE_COEFFS,
                        Bind::Buffer(coeffs.unwrap_or(&self.dummy_buffer)),
                    ),
                    (
                        binding::SHADE_ENV,
                        Bind::Sampled(&inputs.env.image, &self.plain, false),
                    ),
                    (
                        binding::SHADE_POSITION,
                        Bind::Sampled(&gbuf.position.image, &self.plain, false),
                    ),
                    (
                        binding::SHADE_DP,
                        Bind::Sampled(&dp.image, &self.border, false),
                    ),
                    (
                        binding::SHADE_PREFILTERED,
                        Bind::Buffer(inputs.prefiltered.unwrap_or(&self.dummy_buffer)),
                    ),
                    (
                        binding::SHADE_MC,
                        Bind::Sampled(&mc.image, &self.plain, false),
                    ),
                    (
                        binding::SHADE_BRDF_SH,
                        Bind::Buffer(inputs.brdf_sh.unwrap_or(&self.dummy_buffer)),
                    ),
                    (binding::SHADE_X90, Bind::Buffer(&self.x90)),
                    (
                        binding::SHADE_SPLIT,
                        Bind::Sampled(split_chain, &self.trilinear, false),
                    ),
                    (
                        binding::SHADE_DFG,
                        Bind::Buffer(inputs.split.map(|s| s.1).unwrap_or(&self.dummy_buffer)),
                    ),
                    (
                        binding::SHADE_LIGHTS,
                        Bind::Buffer(inputs.lights.map_or(&self.dummy_buffer, |l| l.buffer())),
                    ),
                    (
                        binding::SHADE_CAMERA,
                        Bind::Buffer(camera.as_deref().unwrap_or(&self.dummy_buffer)),
                    ),
                ],
                &push,
                &[&frame.image],
            )
        })?;
        poison::image(rec, PassId::Shade, &frame.image, 0..1)
    }

    /// Shades `gbuf` into a new frame and waits; returns the frame (linear RGB) and its GPU
    /// time ("shade").
    pub fn run(&self, gbuf: &GBuffer, inputs: &ShadeInputs<'_>) -> Result<Timed<GpuEnvMap>> {
        let frame = target(&self.ctx, "shaded frame", gbuf.width, gbuf.height)?;
        Ok(self
            .ctx
            .run("shading", |rec| self.record(rec, gbuf, inputs, &frame))?
            .map(|()| frame))
    }
}

#[cfg(test)]
mod tests {
    use super::super::gbuffer::{brdf_bits, ObjectRecord};
    use super::*;
    use crate::abi::brdf::{ids, technique};
    use crate::abi::shade_code::{BRDF_SHIFT, SHADOWS};

    /// The code mask keeps the shadow rays' code only where asked and one bit per BRDF the
    /// objects use, in bits no technique or footprint bit shares.
    #[test]
    fn code_mask_keeps_shadows_and_the_objects_brdfs() {
        let object = |id: u32| ObjectRecord {
            brdf: id,
            params: [0.3, 1.0],
            samples: 64,
            ..Default::default()
        };
        let objects = [object(ids::GGX), object(ids::LAMBERT), object(ids::GGX)];
        let brdfs = brdf_bits(objects.iter().map(|o| o.brdf));
        assert_eq!(brdfs, (1 << ids::GGX) | (1 << ids::LAMBERT));
        let code = ShadeCode {
            fis: true,
            brdfs,
            ..Default::default()
        };
        let bits = code_bits(&code);
        assert_eq!(bits >> BRDF_SHIFT, brdfs);
        assert_eq!(bits & SHADOWS, 0);
        assert_ne!(bits & (1 << technique::FIS), 0);
        let shadowed = code_bits(&ShadeCode {
            shadows: true,
            ..code
        });
        assert_eq!(shadowed, bits | SHADOWS);
        // The layout: techniques below the footprint bit, below SHADOWS, below the BRDFs.
        let techniques = (1 << (technique::SPLIT_SUM + 1)) - 1;
        let fixed = techniques | crate::abi::footprint::CODE | SHADOWS;
        assert_eq!(fixed & (u32::MAX << BRDF_SHIFT), 0);
        assert_eq!(techniques & (crate::abi::footprint::CODE | SHADOWS), 0);
    }

    /// Each variant's ONLY_TECHS define evaluates to exactly the techniques its VARIANTS
    /// entry keeps (through the generated header's TECH_ constants), in its four modules, which
    /// define USE_VOTE and LEAN as their places say; a mask of those techniques takes it, its
    /// LEAN modules unless the mask has footprint or shadow bits; a mask of two variants'
    /// techniques, and the whole mask, take the whole shader.
    #[test]
    fn variants_keep_the_techniques_their_masks_name() {
        let header = crate::abi::generated_header();
        let value = |name: &str| -> u32 {
            let line = header
                .lines()
                .find(|l| l.starts_with(&format!("#define {name} ")))
                .unwrap_or_else(|| panic!("{name} is not in the header"));
            line.rsplit(' ')
                .next()
                .unwrap()
                .trim_end_matches('u')
                .parse()
                .unwrap()
        };
        for v in VARIANTS {
            for (k, &id) in v.modules.iter().enumerate() {
                let define = id
                    .source()
                    .defines
                    .iter()
                    .find(|(k, _)| *k == "ONLY_TECHS")
                    .map(|d| d.1)
                    .unwrap_or_else(|| panic!("{id:?} has no ONLY_TECHS"));
                // The define's value, evaluated: terms "0u" or "(Nu << TECH_NAME)", or'ed.
                let number = |t: &str| t.trim().trim_end_matches('u').parse::<u32>().unwrap();
                let named = define
                    .split('|')
                    .map(|term| {
                        let term = term.trim().trim_start_matches('(').trim_end_matches(')');
                        match term.split_once("<<") {
                            Some((n, tech)) => number(n) << value(tech.trim()),
                            None => number(term),
                        }
                    })
                    .fold(0, |m, b| m | b);
                assert_eq!(named, v.techs, "{id:?}: {define}");
                let defines = |name| id.source().defines.iter().any(|d| d.0 == name);
                assert_eq!(defines("USE_VOTE"), k % 2 == 1, "{id:?}");
                assert_eq!(defines("LEAN"), k >= 2, "{id:?}");
            }
            // Footprint or shadow code takes the whole variant; a BRDF or the lookup, either.
            let ggx = 1 << (BRDF_SHIFT + ids::GGX);
            for (extra, lean) in [
                (0, true),
                (1 << technique::LOOKUP | ggx, true),
                (crate::abi::footprint::CODE, false),
                (SHADOWS | ggx, false),
            ] {
                for vote in [false, true] {
                    let want = v.modules[vote as usize + 2 * lean as usize];
                    assert_eq!(module(vote, v.techs | extra), want);
                }
            }
        }
        let fis_and_sh = 1 << technique::FIS | 1 << technique::SH;
        assert_eq!(module(true, fis_and_sh), ShaderId::ShadeVote);
        assert_eq!(module(false, u32::MAX), ShaderId::Shade);
    }
}
