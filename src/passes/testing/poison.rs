//! Poisoned passes (feature `test-hooks`): a test asks a context's passes to corrupt what one
//! of them writes — one NaN, every value scaled, or the output mirrored — and shows that its
//! comparisons catch each corruption (`tests/mutation.rs`). A pass calls [`image`] or
//! `buffer` right after recording its output; with no poison set on the context, and always
//! without the feature, they record nothing.

use crate::error::Result;
use crate::gpu::{Buffer, Image, Recorder};
use std::ops::Range;

/// The passes whose output a test can poison, one per file of `src/passes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassId {
    /// `passes::brute`: the filtered map.
    Brute,
    /// `passes::convert`: the converted map.
    Convert,
    /// `passes::exact`: the exact reference's partial sums.
    Exact,
    /// `passes::extract`: the residual map and the light records.
    Extract,
    /// `passes::gbuffer`: normals, positions and view directions.
    GBuffer,
    /// `passes::lights`: the light sums added to a cube level.
    Lights,
    /// `passes::map`: an uploaded map.
    Map,
    /// `passes::mc`: the Monte Carlo accumulation.
    Mc,
    /// `passes::mip`: the levels below the first.
    Mip,
    /// `passes::sh_brdf`: the BRDF's SH table.
    ShBrdf,
    /// `passes::sh_eval`: the irradiance map.
    ShEval,
    /// `passes::sh_pack`: the packed coefficients.
    ShPack,
    /// `passes::sh_project`: the coefficients.
    ShProject,
    /// `passes::shade`: the shaded frame.
    Shade,
    /// `passes::split_sum`: the DFG table and the prefiltered chain.
    SplitSum,
}

impl PassId {
    /// Every pass, in the order above.
    pub const ALL: [PassId; 15] = [
        PassId::Brute,
        PassId::Convert,
        PassId::Exact,
        PassId::Extract,
        PassId::GBuffer,
        PassId::Lights,
        PassId::Map,
        PassId::Mc,
        PassId::Mip,
        PassId::ShBrdf,
        PassId::ShEval,
        PassId::ShPack,
        PassId::ShProject,
        PassId::Shade,
        PassId::SplitSum,
    ];

    /// The pass's file name in `src/passes`.
    pub fn name(self) -> &'static str {
        match self {
            PassId::Brute => "brute",
            PassId::Convert => "convert",
            PassId::Exact => "exact",
            PassId::Extract => "extract",
            PassId::GBuffer => "gbuffer",
            PassId::Lights => "lights",
            PassId::Map => "map",
            PassId::Mc => "mc",
            PassId::Mip => "mip",
            PassId::ShBrdf => "sh_brdf",
            PassId::ShEval => "sh_eval",
            PassId::ShPack => "sh_pack",
            PassId::ShProject => "sh_project",
            PassId::Shade => "shade",
            PassId::SplitSum => "split_sum",
        }
    }
}

/// How a pass's output is corrupted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Corruption {
    /// One value becomes NaN: the middle texel of the first level written (its colour), or
    /// the middle float of a buffer's region.
    Nan,
    /// Every radiance value (a map's colour, the floats a buffer marks) multiplied by this.
    Scale(f32),
    /// The output mirrored: each layer of each level written left to right; SH coefficients
    /// by x → −x; in a buffer of records, the floats it marks negated.
    Mirror,
}

impl Corruption {
    /// Its name in the mutation matrix.
    pub fn name(self) -> &'static str {
        match self {
            Corruption::Nan => "one NaN",
            Corruption::Scale(_) => "scaled",
            Corruption::Mirror => "mirrored",
        }
    }
}

/// A pass and what it does to its output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Poison {
    /// The pass that corrupts its output.
    pub pass: PassId,
    /// How.
    pub corruption: Corruption,
}

/// Sets the poison of `ctx`, or clears it with `None`: from now on every output `poison.pass`
/// records on `ctx` (its clones included) is corrupted as it says.
#[cfg(feature = "test-hooks")]
pub fn set(ctx: &crate::gpu::Context, poison: Option<Poison>) {
    let value = poison.map(|p| std::sync::Arc::new(p) as std::sync::Arc<_>);
    *ctx.shared
        .test_hook
        .lock()
        .unwrap_or_else(|e| e.into_inner()) = value;
}

/// The floats a pass wrote into a buffer, as a poison reads them: a region of records, and
/// which floats of a record are radiance (scaled) or change sign under the mirror.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Floats {
    /// The region's first float.
    pub first: u32,
    /// Floats in the region.
    pub count: u32,
    /// Floats per record (at most 32).
    pub stride: u32,
    /// Bit k: float k of a record is scaled.
    pub scale_mask: u32,
    /// Bit k: float k of a record changes sign under the mirror.
    pub mirror_mask: u32,
    /// SH coefficients instead: (channels a coefficient, coefficients a record); the mirror
    /// flips the signs x → −x gives them.
    pub sh: Option<(u32, u32)>,
}

impl Floats {
    /// `count` floats of SH coefficients from `first`, `channels` per coefficient and `coeffs`
    /// coefficients per record, every float radiance.
    pub fn sh(first: u32, count: u32, channels: u32, coeffs: u32) -> Floats {
        Floats {
            first,
            count,
            stride: 1,
            scale_mask: 1,
            mirror_mask: 0,
            sh: Some((channels, coeffs)),
        }
    }
}

#[cfg(feature = "test-hooks")]
mod hooked {
    use super::{Corruption, Floats, PassId, Poison};
    use crate::abi::{binding, push::PoisonPush, ShaderId, WORKGROUP_1D};
    use crate::error::Result;
    use crate::gpu::{Bind, Buffer, Image, Pipeline, Recorder};
    use std::ops::Range;

    /// The corruption set on the recorder's context for `pass`, if any.
    fn active(rec: &Recorder, pass: PassId) -> Option<Corruption> {
        let hook = rec
            .context()
            .shared
            .test_hook
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()?;
        let p = hook.downcast_ref::<Poison>()?;
        (p.pass == pass).then_some(p.corruption)
    }

    fn push(c: Corruption) -> PoisonPush {
        PoisonPush {
            mode: match c {
                Corruption::Nan => 0,
                Corruption::Scale(_) => 1,
                Corruption::Mirror => 2,
            },
            factor: match c {
                Corruption::Scale(f) => f,
                _ => 1.0,
            },
            ..Default::default()
        }
    }

    pub(crate) fn image(
        rec: &mut Recorder,
        pass: PassId,
        image: &Image,
        levels: Range<u32>,
    ) -> Result<()> {
        let Some(c) = active(rec, pass) else {
            return Ok(());
        };
        let pipeline = Pipeline::compute(rec.context(), ShaderId::PoisonImage, &[WORKGROUP_1D])?;
        let d = *image.desc();
        for level in levels.clone() {
            let (w, h) = ((d.width >> level).max(1), (d.height >> level).max(1));
            if c == Corruption::Nan && level != levels.start {
                break;
            }
            let p = PoisonPush {
                width: w,
                height: h,
                layers: d.layers,
                nan_at: (h / 2) * w + w / 2,
                ..push(c)
            };
            rec.dispatch(
                &pipeline,
                &[(binding::POISON_IMAGE, Bind::StorageLevel(image, level))],
                &p,
                [w.div_ceil(WORKGROUP_1D), h, d.layers],
            )?;
        }
        rec.keep(pipeline);
        Ok(())
    }

    pub(crate) fn buffer(
        rec: &mut Recorder,
        pass: PassId,
        buffer: &Buffer,
        f: Floats,
    ) -> Result<()> {
        let Some(c) = active(rec, pass) else {
            return Ok(());
        };
        assert!(f.stride >= 1 && f.stride <= 32 && f.count > 0);
        let pipeline = Pipeline::compute(rec.context(), ShaderId::PoisonBuffer, &[WORKGROUP_1D])?;
        let (channels, coeffs) = f.sh.unwrap_or((0, 1));
        let p = PoisonPush {
            width: f.count,
            height: 1,
            layers: 1,
            nan_at: f.count / 2,
            first: f.first,
            stride: f.stride,
            scale_mask: f.scale_mask,
            mirror_mask: f.mirror_mask,
            sh_channels: channels,
            sh_count: coeffs,
            ..push(c)
        };
        rec.dispatch(
            &pipeline,
            &[(binding::POISON_BUFFER, Bind::Buffer(buffer))],
            &p,
            [f.count.div_ceil(WORKGROUP_1D), 1, 1],
        )?;
        rec.keep(pipeline);
        Ok(())
    }
}

/// Corrupts the levels `levels` of `image`, which `pass` has just recorded writing, where a
/// test set a poison for `pass` on the recorder's context (the image needs storage usage).
pub(crate) fn image(
    rec: &mut Recorder,
    pass: PassId,
    image: &Image,
    levels: Range<u32>,
) -> Result<()> {
    #[cfg(feature = "test-hooks")]
    return hooked::image(rec, pass, image, levels);
    #[cfg(not(feature = "test-hooks"))]
    {
        let _ = (rec, pass, image, levels);
        Ok(())
    }
}

/// Corrupts the floats `floats` of `buffer` (a storage buffer), which `pass` has just
/// recorded writing, where a test set a poison for `pass` on the recorder's context.
pub(crate) fn buffer(
    rec: &mut Recorder,
    pass: PassId,
    buffer: &Buffer,
    floats: Floats,
) -> Result<()> {
    #[cfg(feature = "test-hooks")]
    return hooked::buffer(rec, pass, buffer, floats);
    #[cfg(not(feature = "test-hooks"))]
    {
        let _ = (rec, pass, buffer, floats);
        Ok(())
    }
}
