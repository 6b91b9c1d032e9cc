//! What a scene asks of the passes that light it, read from the scene alone: its environment
//! loaded, the FIS dual paraboloid's size, how that paraboloid is converted and which
//! lookups are footprint-filtered. `render` plans by these; an engine that drives the passes
//! itself (`examples/frame.rs`) asks the same questions here.

use super::{LookupFilter, Scene, Technique, DEFAULT_FIS_BIAS, DEFAULT_FIS_BIAS_RESIDUAL};
use crate::error::{Error, Result};
use crate::math::camera::Projection;
use crate::math::envmap::EnvMap;
use crate::math::fis::default_dp_size_of;
use crate::math::Mapping;
use crate::passes::shade::Footprint;
use std::path::Path;

/// What a plan reads of its environment: its mapping and size, never its texels (the
/// resident path plans for an image on the GPU).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapShape {
    /// The mapping.
    pub mapping: Mapping,
    /// Width in texels (of one face or half where there are several).
    pub width: u32,
    /// Height in texels.
    pub height: u32,
}

impl MapShape {
    /// The shape of `env`.
    pub fn of(env: &EnvMap) -> MapShape {
        MapShape {
            mapping: env.mapping,
            width: env.width,
            height: env.height,
        }
    }
}

impl Scene {
    /// Loads the scene's environment (its file relative to `base`), with its intensity
    /// applied.
    pub fn load_environment(&self, base: &Path) -> Result<EnvMap> {
        let env = &self.environment;
        let mapping = match &env.mapping {
            Some(m) => Some(Mapping::parse(m).ok_or_else(|| {
                Error::Invalid(format!(
                    "environment mapping '{m}' is not one of latlong, angular, cube, dual-paraboloid"
                ))
            })?),
            None => None,
        };
        let path = base.join(&env.file);
        let mut map = crate::io::load(
            &path,
            &crate::io::LoadOptions {
                mapping,
                ..Default::default()
            },
        )?;
        if env.intensity != 1.0 {
            let k = env.intensity as f32;
            for t in &mut map.texels {
                *t = t.map(|c| c * k);
            }
        }
        Ok(map)
    }

    /// Side of the scene's FIS dual paraboloid for an environment of shape `env`: the
    /// scene's `[fis] size`; else only as fine as its lobes read
    /// (`crate::math::fis::dp_size_for`, at most `default_dp_size`) where nothing else reads
    /// the chain's fine levels (no split-sum, no footprint-filtered mirror, no background
    /// filtered by request or seen through a perspective camera) and the lat-long source
    /// converts to that size by exact footprint areas, so that its power is kept; else
    /// `default_dp_size`.
    pub fn fis_dp_size(&self, env: MapShape) -> u32 {
        if let Some(s) = self.fis.size {
            return s;
        }
        let full = default_dp_size_of(env.width, env.height, env.mapping.layers());
        // The footprint lookups a chain would serve (mirrors, the background) read its finest
        // levels.
        let footprint = self.footprint(true, false);
        let split_sum = self
            .objects
            .iter()
            .any(|o| matches!(o.material.technique(), Technique::SplitSum));
        let Ok(world_to_file) = self.environment.orientation().checked_world_to_file() else {
            return full;
        };
        if split_sum || footprint.mirror || footprint.background || env.mapping != Mapping::LatLong
        {
            return full;
        }
        let lobes = self
            .objects
            .iter()
            .filter_map(|o| match o.material.technique() {
                Technique::Fis { samples, bias, .. } => {
                    // The residual's default bias reads finer than the whole map's.
                    let bias = bias.unwrap_or(DEFAULT_FIS_BIAS.min(DEFAULT_FIS_BIAS_RESIDUAL));
                    Some(crate::math::fis::dp_size_for(
                        &o.material.kind,
                        samples,
                        bias,
                    ))
                }
                _ => None,
            })
            .max();
        let Some(mut size) = lobes else {
            return full;
        };
        while size < full
            && !crate::math::convert::area_serves(
                env.width,
                env.height,
                Mapping::DualParaboloid,
                size,
                world_to_file,
            )
        {
            size *= 2;
        }
        size.min(full)
    }

    /// Whether the scene's dual paraboloid is converted with nearest-texel reads (the means
    /// of the source's texels): where footprint-filtered mirrors read it, or the background
    /// is asked to be; a bilinear reconstruction spreads a bright texel into its neighbours'
    /// pixels.
    pub fn chain_of_texel_means(&self) -> bool {
        let filter = self.environment.filter;
        filter == LookupFilter::Footprint || (filter == LookupFilter::Auto && self.has_mirrors())
    }

    /// Which lookups of the scene are footprint-filtered, given whether the render builds
    /// the dual-paraboloid chain and whether that chain holds the residual of extracted
    /// lights (the mirror flag only where a mirror is drawn, so that the shade pipeline keeps
    /// no footprint code it would not run). Under `filter = "auto"` an orthographic camera's
    /// background reads the map itself: each of its pixels sees one direction, so there is
    /// no footprint to filter.
    pub fn footprint(&self, chain: bool, residual: bool) -> Footprint {
        let filter = self.environment.filter;
        let ortho = matches!(self.camera.projection, Projection::Orthographic { .. });
        Footprint {
            mirror: chain && self.has_mirrors() && filter != LookupFilter::Point,
            background: chain
                && (filter == LookupFilter::Footprint || (filter == LookupFilter::Auto && !ortho)),
            lights: chain && residual,
        }
    }

    /// Whether any object is a mirror shaded by lookups.
    fn has_mirrors(&self) -> bool {
        self.objects
            .iter()
            .any(|o| matches!(o.material.technique(), Technique::Lookup))
    }
}
