//! What a scene may hold: every value a render depends on checked, with a message that names
//! the object and the setting.

use super::{Scene, SplitSumSettings, Technique, MAX_FIS_SAMPLES};

/// The most times its samples a scene's chain gives its roughest levels
/// (`SplitSumSettings::rough_boost`): beyond a 16² layer's reads nothing more is boosted.
const MAX_ROUGH_BOOST: u32 = 256;
use crate::math::brdf::Brdf;

impl Scene {
    /// Checks every value a render depends on; the message names the object.
    pub fn validate(&self) -> std::result::Result<(), String> {
        self.camera.validate()?;
        self.environment
            .orientation()
            .validate()
            .map_err(|m| format!("environment: {m}"))?;
        if !(self.environment.intensity.is_finite() && self.environment.intensity >= 0.0) {
            return Err(format!(
                "environment intensity {} must be finite and non-negative",
                self.environment.intensity
            ));
        }
        if let Some(r) = self.environment.light_ratio {
            if !(r.is_finite() && r > 0.0) {
                return Err(format!(
                    "environment light_ratio {r} must be positive and finite"
                ));
            }
        }
        if let Some(r) = self.environment.diffuse_light_ratio {
            if !(r.is_finite() && r > 0.0) {
                return Err(format!(
                    "environment diffuse_light_ratio {r} must be positive and finite"
                ));
            }
        }
        if let Some(n) = self.environment.light_texels {
            if !(1..=crate::abi::lights::CHAIN_MAX_TEXELS).contains(&n) {
                return Err(format!(
                    "environment light_texels {n} is outside 1 to {}",
                    crate::abi::lights::CHAIN_MAX_TEXELS
                ));
            }
        }
        if let Some(n) = self.environment.light_fill {
            let most = crate::abi::lights::FILL_MAX_RINGS;
            if n > most {
                return Err(format!(
                    "environment light_fill {n} is outside 0 to {most} (rings of texels around \
                     the lights)"
                ));
            }
        }
        if self.objects.is_empty() {
            return Err("a scene needs at least one object".into());
        }
        if let Some(s) = self.fis.size {
            if !(1..=4096).contains(&s) {
                return Err(format!("fis size {s} is outside 1 to 4096"));
            }
        }
        self.split_sum.validate()?;
        if self.mc.per_frame == 0 {
            return Err("mc per_frame must be at least 1".into());
        }
        for (k, o) in self.objects.iter().enumerate() {
            let what = format!("object {k} ({:?})", o.material.kind);
            o.shape.validate().map_err(|m| format!("object {k}: {m}"))?;
            o.material
                .kind
                .validate()
                .map_err(|m| format!("{what}: {m}"))?;
            if o.material.albedo.iter().any(|a| !a.is_finite() || *a < 0.0) {
                return Err(format!("{what}: albedo must be finite and non-negative"));
            }
            let t = o.material.technique();
            let allowed = match o.material.kind {
                Brdf::Mirror => matches!(t, Technique::Lookup | Technique::Mc { .. }),
                // Split-sum's chain and DFG table are GGX's alone.
                Brdf::Lambert => !matches!(t, Technique::Lookup | Technique::SplitSum),
                Brdf::Phong { .. } => !matches!(
                    t,
                    Technique::Lookup | Technique::Sh { .. } | Technique::SplitSum
                ),
                Brdf::Ggx { .. } => matches!(
                    t,
                    Technique::Fis { .. }
                        | Technique::Mc { .. }
                        | Technique::ShBrdf { .. }
                        | Technique::SplitSum
                ),
                _ => matches!(
                    t,
                    Technique::Fis { .. } | Technique::Mc { .. } | Technique::ShBrdf { .. }
                ),
            };
            if !allowed {
                return Err(format!(
                    "{what}: technique {} does not apply to it",
                    t.name()
                ));
            }
            match t {
                Technique::Fis { samples, bias, .. } => {
                    if !(1..=MAX_FIS_SAMPLES).contains(&samples) {
                        return Err(format!(
                            "{what}: fis samples {samples} outside 1 to {MAX_FIS_SAMPLES}"
                        ));
                    }
                    if bias.is_some_and(|b| !b.is_finite() || b.abs() > 16.0) {
                        return Err(format!("{what}: fis bias must be within ±16"));
                    }
                }
                Technique::Sh { order } if order > crate::abi::SH_MAX_LMAX => {
                    return Err(format!("{what}: SH order {order} is above 8"));
                }
                Technique::ShBrdf {
                    order,
                    grid,
                    window,
                } => {
                    if order > crate::abi::SH_MAX_LMAX {
                        return Err(format!("{what}: SH order {order} is above 8"));
                    }
                    let max = crate::abi::sh_brdf::MAX_GRID;
                    if !(2..=max).contains(&grid) {
                        return Err(format!("{what}: sh_brdf grid {grid} outside 2 to {max}"));
                    }
                    if window.is_some_and(|w| !(w.is_finite() && w > 0.0)) {
                        return Err(format!("{what}: sh_brdf window must be a positive width"));
                    }
                }
                Technique::Prefiltered { size } if !(4..=4096).contains(&size) || size % 2 == 1 => {
                    return Err(format!(
                        "{what}: prefiltered size {size} must be even, 4 to 4096"
                    ));
                }
                Technique::Prefiltered { .. } => {
                    if let Brdf::Phong { n } = o.material.kind {
                        if n < 1.0 {
                            return Err(format!("{what}: a prefiltered Phong map needs n ≥ 1"));
                        }
                    }
                }
                Technique::Mc { samples, error } => {
                    if samples == 0 || samples > 1 << 24 {
                        return Err(format!("{what}: mc samples {samples} outside 1 to 2^24"));
                    }
                    if error.is_some_and(|e| !(e > 0.0 && e.is_finite())) {
                        return Err(format!("{what}: mc error target must be positive"));
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }
}

impl SplitSumSettings {
    /// Checks that every setting is within what the passes accept.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if let Some(size) = self.size {
            if !(1..=4096).contains(&size) {
                return Err(format!("split_sum size {size} is outside 1 to 4096"));
            }
        }
        if !(1..=16).contains(&self.levels) {
            return Err(format!("split_sum levels {} outside 1 to 16", self.levels));
        }
        if !(1..=MAX_FIS_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "split_sum samples {} outside 1 to {MAX_FIS_SAMPLES}",
                self.samples
            ));
        }
        if !(1..=MAX_ROUGH_BOOST).contains(&self.rough_boost) {
            return Err(format!(
                "split_sum rough_boost {} outside 1 to {MAX_ROUGH_BOOST}",
                self.rough_boost
            ));
        }
        if self.bias.is_some_and(|b| !b.is_finite() || b.abs() > 16.0) {
            return Err("split_sum bias must be within ±16".into());
        }
        let max_dfg = crate::abi::split_sum::MAX_DFG_SIZE;
        if !(2..=max_dfg).contains(&self.dfg_size) {
            return Err(format!(
                "split_sum dfg_size {} outside 2 to {max_dfg}",
                self.dfg_size
            ));
        }
        let max_taps = crate::abi::split_sum::MAX_TAPS;
        if !(1..=max_taps).contains(&self.taps) {
            return Err(format!(
                "split_sum taps {} outside 1 to {max_taps}",
                self.taps
            ));
        }
        Ok(())
    }
}
