//! The lights stage: extracts what the plan asks for from the environment, decides which
//! objects add the lights back (by what the extraction found and whether its texels' nodes
//! resolve each lobe), and makes the residual maps the passes filter instead of the map.

use super::plan::Plan;
use crate::error::Result;
use crate::gpu::Context;
use crate::math::convert::{latlong_halved, paraboloid_source_halves};
use crate::math::envmap::EnvMap;
use crate::math::lights::{extract_each, light_sh, resolves, Extraction};
use crate::math::{Mapping, Orientation};
use crate::passes::{GpuEnvMap, GpuLights};
use std::time::Instant;

/// What the lights stage found and made.
pub(super) struct Lit {
    /// The chain's extraction, where the paraboloid or a Phong map takes its residual.
    pub chain: Option<Extraction>,
    /// The diffuse extraction, where it found lights.
    pub diffuse: Option<Extraction>,
    /// The lights on the GPU, for the shader to add back.
    pub gpu: Option<GpuLights>,
    /// The paraboloid holds the chain's residual: lights were found and its lobes resolve them.
    pub dp: bool,
    /// The chain would have taken the residual, but no texel is above the lights' threshold:
    /// the whole map is as sunless as a residual.
    pub below_threshold: bool,
    /// Per object: a prefiltered Phong map of the residual, the light texels added per pixel.
    pub phong: Vec<bool>,
    /// SH irradiance objects add the light clusters' irradiance.
    pub sh: bool,
    /// Prefiltered irradiance maps are of the diffuse residual and add it.
    pub prefiltered: bool,
    /// The light texels' SH coefficients, to subtract from the whole map's.
    pub sh_coeffs: Option<Vec<[f64; 3]>>,
    /// Where the diffuse residual's own projection sits in the SH output, in coefficients
    /// (the resident path projects it on the GPU instead of subtracting the lights').
    pub sh_residual_at: Option<u32>,
    /// Host milliseconds extracting, then preparing the lights, where any were extracted.
    pub ms: Option<[f64; 2]>,
    /// The paraboloid's source where it is the residual halved.
    pub dp_source: Option<(EnvMap, GpuEnvMap)>,
    /// The whole chain residual, where a Phong map or the paraboloid reads it.
    pub chain_residual: Option<GpuEnvMap>,
    /// The diffuse residual, where prefiltered irradiance maps are filtered from it.
    pub diffuse_residual: Option<GpuEnvMap>,
}

impl Lit {
    /// Nothing extracted (a scene without lights, or rendered from a GPU image).
    pub(super) fn none(plan: &Plan) -> Lit {
        Lit {
            chain: None,
            diffuse: None,
            gpu: None,
            dp: false,
            below_threshold: false,
            phong: vec![false; plan.objects.len()],
            sh: false,
            prefiltered: false,
            sh_coeffs: None,
            sh_residual_at: None,
            ms: None,
            dp_source: None,
            chain_residual: None,
            diffuse_residual: None,
        }
    }
}

/// Runs the lights stage of `plan` on `env`.
pub(super) fn extract(
    ctx: &Context,
    plan: &Plan,
    env: &EnvMap,
    orientation: &Orientation,
) -> Result<Lit> {
    let lp = &plan.lights;
    let file_to_world = orientation.checked_world_to_file()?.transpose();
    let asked: Vec<_> = [lp.chain, lp.diffuse].into_iter().flatten().collect();
    let started = Instant::now();
    let each = extract_each(env, &asked);
    let extract_ms = 1e3 * started.elapsed().as_secs_f64();
    let lights_started = Instant::now();
    let mut each = each.into_iter();
    let chain = lp
        .chain
        .and_then(|_| each.next())
        .filter(|e| !e.lights.is_empty());
    let below_threshold = lp.dp && chain.is_none();
    let dp = lp.dp && chain.as_ref().is_some_and(|e| resolves(e, lp.finest_chain));
    // The prefiltered Phong objects that add the light texels: lobes the nodes resolve.
    let phong: Vec<bool> = plan
        .objects
        .iter()
        .map(|o| {
            o.phong_prefiltered()
                && chain
                    .as_ref()
                    .is_some_and(|e| o.lobe.is_some_and(|s| resolves(e, s)))
        })
        .collect();
    let chain = chain.filter(|_| dp || phong.contains(&true));
    // The finest lobe that reads the light texels.
    let finest = plan
        .objects
        .iter()
        .zip(&phong)
        .filter(|&(o, &lit)| lit || (dp && o.on_chain))
        .filter_map(|(o, _)| o.lobe)
        .fold(1.0, f64::min);
    let diffuse = each.next().filter(|e| !e.lights.is_empty());
    let found = diffuse.is_some();
    let gpu = GpuLights::of_extractions(
        ctx,
        env,
        chain.as_ref(),
        diffuse.as_ref(),
        file_to_world,
        finest,
    )?;
    let ms =
        (!asked.is_empty()).then(|| [extract_ms, 1e3 * lights_started.elapsed().as_secs_f64()]);
    let mut lit = Lit {
        sh_coeffs: None,
        sh_residual_at: None,
        sh: lp.sh && found,
        prefiltered: lp.prefiltered && found,
        chain,
        diffuse,
        gpu,
        dp,
        below_threshold,
        phong,
        ms,
        dp_source: None,
        chain_residual: None,
        diffuse_residual: None,
    };
    residuals(ctx, plan, env, &mut lit)?;
    lit.sh_coeffs = match &lit.diffuse {
        // SH objects need no projection of the residual: the whole map's coefficients less
        // the light texels' are its coefficients.
        Some(ex) if lit.sh => Some(light_sh(env, ex, file_to_world, plan.lmax)),
        _ => None,
    };
    Ok(lit)
}

/// The residual maps on the GPU. The paraboloid's source is the residual where the chain takes
/// the lights, else the map; the residual is halved where that is still as fine as the
/// paraboloid's finest texels ([`paraboloid_source_halves`]), since its brightest texels are
/// the lights' threshold, whereas a sun left in the chain moves within its 2 × 2 block.
fn residuals(ctx: &Context, plan: &Plan, env: &EnvMap, lit: &mut Lit) -> Result<()> {
    let residual_map = |name| GpuEnvMap::new(ctx, name, env.mapping, env.width, env.height);
    lit.dp_source = match (&plan.dp, &lit.chain) {
        (Some(opts), Some(ex))
            if lit.dp
                && env.mapping == Mapping::LatLong
                && paraboloid_source_halves(env.width, env.height, opts.size) =>
        {
            let map = latlong_halved(&ex.residual);
            let gpu = GpuEnvMap::new(
                ctx,
                "fis paraboloid source",
                map.mapping,
                map.width,
                map.height,
            )?;
            Some((map, gpu))
        }
        _ => None,
    };
    if lit.chain.is_some() && (lit.phong.contains(&true) || (lit.dp && lit.dp_source.is_none())) {
        lit.chain_residual = Some(residual_map("environment residual")?);
    }
    if lit.diffuse.is_some() && lit.prefiltered {
        lit.diffuse_residual = Some(residual_map("diffuse residual")?);
    }
    Ok(())
}
