//! The source prepared for the sums: per-texel cones, radiance and shapes, their tiles'
//! bounding cones, and the levels of the power-moment pyramid.

use super::super::map::GpuEnvMap;
use super::{check_kernel, BruteFilter};
use crate::abi::{binding, push::BrutePush, ShaderId, BRUTE_TILE, WORKGROUP_1D};
use crate::error::{Error, Result};
use crate::gpu::{mat3_rows, Bind, Buffer, Context, Image, ImageDesc, Pipeline, Recorder};
use crate::math::filter::Kernel;
use crate::math::{Mapping, Orientation};
use ash::vk;
use std::sync::Arc;

/// The source prepared for the sums: per-texel cones, radiance and shapes, and the tiles.
pub(super) struct PreparedSource {
    pub(super) cones: Arc<Image>,
    pub(super) rad: Arc<Image>,
    pub(super) shapes: Arc<Image>,
    pub(super) tiles: Arc<Buffer>,
    pub(super) push: BrutePush,
    pub(super) mapping: Mapping,
    pub(super) size: (u32, u32),
}

/// One level of the moment pyramid: its cones, light and tiles, and its push block.
pub(super) struct CoarseLevel {
    pub(super) cones: Arc<Image>,
    pub(super) light: Arc<Image>,
    pub(super) tiles: Arc<Buffer>,
    pub(super) push: BrutePush,
}

impl BruteFilter {
    /// Checks the kernel and records the per-texel preparation and its tiles.
    pub(super) fn prepare(
        &self,
        rec: &mut Recorder,
        src: &GpuEnvMap,
        orientation: &Orientation,
        kernel: Kernel,
    ) -> Result<PreparedSource> {
        check_kernel(kernel)?;
        if let Some(worst) =
            crate::math::filter::unresolved(kernel, src.mapping, src.width, src.height)
        {
            return Err(Error::Invalid(format!(
                "the {kernel:?} lobe is too sharp for the {} x {} {} source: n·ρ² reaches \
                 {worst:.3e} where the per-texel rule resolves up to {} (ρ the texel's \
                 radius); convert the source to a larger one first (a cube resolves the back of an \
                 angular probe best: envlight convert --to cube --size N) or use a lower exponent",
                src.width,
                src.height,
                src.mapping.name(),
                crate::math::filter::RESOLVED_N_RHO2
            )));
        }
        let texels = src.width * src.height * src.mapping.layers();
        let ctx = rec.context().clone();
        let (w, h, layers) = (src.width, src.height, src.mapping.layers());
        let cones = texel_image(rec, "brute cones", w, h, layers)?;
        let rad = texel_image(rec, "brute radiance", w, h, layers)?;
        let shapes = texel_image(rec, "brute shapes", w, h, 3 * layers)?;
        let push = BrutePush {
            file_to_world: mat3_rows(orientation.checked_world_to_file()?.transpose()),
            src_size: [src.width, src.height],
            dst_size: [0, 0],
            src_mapping: src.mapping.id(),
            dst_mapping: 0,
            texels,
            exponent: 0.0,
            chunk_begin: 0,
            chunk_end: 0,
            src_layers: src.mapping.layers(),
            src_level: 0,
            parts: [1, 1],
            part_slots: 0,
            pad: 0,
        };
        let from = src.mapping.id();
        // Prepare reads only the source mapping (constant 3 is unused there).
        let prepare = Pipeline::compute_once(
            &self.prepare[from as usize],
            &self.ctx,
            ShaderId::BrutePrepare,
            &[WORKGROUP_1D, 1, from, 0],
        )?;
        rec.span("brute prepare", |rec| {
            rec.dispatch(
                prepare,
                &[
                    (
                        binding::BRUTE_PREP_SRC,
                        Bind::Sampled(&src.image, &self.sampler, false),
                    ),
                    (binding::BRUTE_PREP_CONES, Bind::Storage(&cones)),
                    (binding::BRUTE_PREP_RADIANCE, Bind::Storage(&rad)),
                    (binding::BRUTE_PREP_SHAPES, Bind::Storage(&shapes)),
                ],
                &push,
                grid_1d(&ctx, texels),
            )
        })?;
        let tiles = self.record_tiles(rec, &cones, &push)?;
        Ok(PreparedSource {
            cones,
            rad,
            shapes,
            tiles,
            push,
            mapping: src.mapping,
            size: (src.width, src.height),
        })
    }

    /// Records the tiles' bounding cones over `cones` (a map of `push.src_size`).
    pub(super) fn record_tiles(
        &self,
        rec: &mut Recorder,
        cones: &Image,
        push: &BrutePush,
    ) -> Result<Arc<Buffer>> {
        let ctx = rec.context().clone();
        let tile_count = tile_count(push);
        let tiles = scratch(rec, "brute tiles", tile_count as u64 * 16)?;
        rec.span("brute tiles", |rec| {
            rec.dispatch(
                &self.tiles,
                &[
                    (binding::BRUTE_TILE_CONES, Bind::Storage(cones)),
                    (binding::BRUTE_TILE_OUT, Bind::Buffer(&tiles)),
                ],
                push,
                grid_1d(&ctx, tile_count),
            )
        })?;
        Ok(tiles)
    }

    /// Records level `s` of the moment pyramid of a prepared source, and its tiles.
    pub(super) fn build_level(
        &self,
        rec: &mut Recorder,
        prep: &PreparedSource,
        s: u32,
    ) -> Result<CoarseLevel> {
        let ctx = rec.context().clone();
        let (w, h) = (prep.size.0 >> s, prep.size.1 >> s);
        let texels = w * h * prep.mapping.layers();
        let layers = prep.mapping.layers();
        let cones = texel_image(rec, "brute level cones", w, h, layers)?;
        let light = texel_image(rec, "brute level light", w, h, 9 * layers)?;
        let push = BrutePush {
            src_size: [w, h],
            texels,
            src_level: s,
            ..prep.push
        };
        let from = prep.mapping.id();
        let pipeline = Pipeline::compute_once(
            &self.moments[from as usize],
            &self.ctx,
            ShaderId::BruteMoments,
            &[WORKGROUP_1D, 1, from, 0],
        )?;
        rec.span("brute moments", |rec| {
            rec.dispatch(
                pipeline,
                &[
                    (binding::BRUTE_MOM_RADIANCE, Bind::Storage(&prep.rad)),
                    (binding::BRUTE_MOM_SHAPES, Bind::Storage(&prep.shapes)),
                    (binding::BRUTE_MOM_CONES, Bind::Storage(&cones)),
                    (binding::BRUTE_MOM_LIGHT, Bind::Storage(&light)),
                ],
                &push,
                grid_1d(&ctx, texels),
            )
        })?;
        let tiles = self.record_tiles(rec, &cones, &push)?;
        Ok(CoarseLevel {
            cones,
            light,
            tiles,
            push,
        })
    }
}

/// An rgba32f storage image of `layers` `w` × `h` layers for per-texel data (a scratch image
/// of the recording: reused by the next where a frame cache is in use).
pub(super) fn texel_image(
    rec: &mut Recorder,
    name: &str,
    w: u32,
    h: u32,
    layers: u32,
) -> Result<Arc<Image>> {
    rec.scratch_image(
        name,
        ImageDesc {
            width: w,
            height: h,
            layers,
            format: vk::Format::R32G32B32A32_SFLOAT,
            usage: vk::ImageUsageFlags::STORAGE,
            cube: false,
            mips: 1,
        },
    )
}

/// A GPU-only storage buffer of `bytes` (a scratch buffer of the recording).
pub(super) fn scratch(rec: &mut Recorder, name: &str, bytes: u64) -> Result<Arc<Buffer>> {
    rec.scratch(name, bytes, vk::BufferUsageFlags::STORAGE_BUFFER)
}

/// Tiles of BRUTE_TILE² texels over a map of `push.src_size` and `push.src_layers`.
pub(super) fn tile_count(push: &BrutePush) -> u32 {
    push.src_size[0].div_ceil(BRUTE_TILE) * push.src_size[1].div_ceil(BRUTE_TILE) * push.src_layers
}

/// Workgroups for one invocation per item, folded into y past the x limit.
pub(super) fn grid_1d(ctx: &Context, items: u32) -> [u32; 3] {
    let groups = items.div_ceil(WORKGROUP_1D);
    let gx = groups.min(ctx.info().max_workgroup_count.min(65535)).max(1);
    [gx, groups.div_ceil(gx), 1]
}
