//! SH coefficients packed for the shade pass on the GPU (`glsl/sh_pack.comp`, float64 twin
//! `math::sh::pack`): from the projection's output ([`super::ShProjector::record_into`], RGB
//! f32 triples in the world frame) each SH object's set as the shade pass reads it, one vec4 a
//! coefficient: irradiance (Â_l folded in) of the map less its light texels' coefficients, or
//! an SH-BRDF object's windowed radiance. Between projection and shading nothing comes back
//! to the host.

use crate::abi::{binding, push::ShPackPush, ShaderId, WORKGROUP_1D};
use crate::error::Result;
use crate::gpu::{groups, Bind, Buffer, Context, Pipeline, Recorder, Timed, Usage};
pub use crate::math::sh::{irradiance_entries, windowed_entries, PackEntry, Window};
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// The packing pass.
pub struct ShPacker {
    ctx: Context,
    pipeline: Pipeline,
}

/// `entries` as the shader reads them: (source, scale's bits, minus + 1 or 0, 0).
fn entry_words(entries: &[PackEntry]) -> Vec<[u32; 4]> {
    entries
        .iter()
        .map(|e| {
            [
                e.source,
                (e.scale as f32).to_bits(),
                e.minus.map_or(0, |j| j + 1),
                0,
            ]
        })
        .collect()
}

impl ShPacker {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<ShPacker> {
        Ok(ShPacker {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::ShPack, &[WORKGROUP_1D])?,
        })
    }

    /// Bytes of `count` packed coefficients (vec4 each).
    pub fn output_bytes(count: usize) -> u64 {
        count.max(1) as u64 * 16
    }

    /// Records the packing of `entries` from `radiance` (the projection's output, at least
    /// as many coefficients as the entries read) and `minus` (vec4 each; `None` where no entry
    /// subtracts) into the start of `out` (a storage buffer of at least
    /// [`ShPacker::output_bytes`]). The entries' list is kept by the recorder. Span: "sh pack".
    pub fn record(
        &self,
        rec: &mut Recorder,
        radiance: &Buffer,
        entries: &[PackEntry],
        minus: Option<&Buffer>,
        out: &Buffer,
    ) -> Result<()> {
        assert!(out.size() >= Self::output_bytes(entries.len()));
        assert!(
            minus.is_some() || entries.iter().all(|e| e.minus.is_none()),
            "an entry subtracts from a set that is not given"
        );
        if entries.is_empty() {
            return Ok(());
        }
        let list = rec.upload("sh pack entries", &entry_words(entries))?;
        // An unused binding still needs a buffer.
        let none = match minus {
            Some(_) => None,
            None => Some(rec.upload("sh pack: nothing subtracted", &[[0f32; 4]])?),
        };
        let minus = minus
            .or(none.as_deref())
            .unwrap_or_else(|| unreachable!("set above"));
        let count = entries.len() as u32;
        rec.span("sh pack", |rec| {
            rec.dispatch(
                &self.pipeline,
                &[
                    (binding::SH_PACK_RADIANCE, Bind::Buffer(radiance)),
                    (binding::SH_PACK_ENTRIES, Bind::Buffer(&list)),
                    (binding::SH_PACK_MINUS, Bind::Buffer(minus)),
                    (binding::SH_PACK_OUT, Bind::Buffer(out)),
                ],
                &ShPackPush { count, pad: [0; 3] },
                [groups(count, WORKGROUP_1D), 1, 1],
            )
        })?;
        // Mirrored as one run of coefficients (exactly the first set's x → −x).
        poison::buffer(
            rec,
            PassId::ShPack,
            out,
            poison::Floats::sh(0, 4 * count, 4, count),
        )
    }

    /// Packs `entries` from host coefficients and waits (for tests and one-off jobs): the
    /// radiance and the subtracted set are uploaded, the packed set read back.
    pub fn run(
        &self,
        radiance: &[[f64; 3]],
        minus: &[[f64; 3]],
        entries: &[PackEntry],
    ) -> Result<Timed<Vec<[f32; 3]>>> {
        let flat: Vec<f32> = radiance.iter().flatten().map(|&v| v as f32).collect();
        let radiance = Buffer::storage(&self.ctx, "sh pack radiance", &flat)?;
        let quads: Vec<[f32; 4]> = minus
            .iter()
            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
            .collect();
        let minus = (!quads.is_empty())
            .then(|| Buffer::storage(&self.ctx, "sh pack minus", &quads))
            .transpose()?;
        let out = Buffer::new(
            &self.ctx,
            "sh packed",
            Self::output_bytes(entries.len()),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        let t = self
            .ctx
            .run("packing SH coefficients", |rec| {
                self.record(rec, &radiance, entries, minus.as_ref(), &out)?;
                rec.use_buffer(&out, Usage::HostRead);
                Ok(())
            })?
            .timings;
        let packed: Vec<[f32; 4]> = out.read(entries.len());
        Ok(Timed::new(
            packed.into_iter().map(|q| [q[0], q[1], q[2]]).collect(),
            t,
        ))
    }
}
