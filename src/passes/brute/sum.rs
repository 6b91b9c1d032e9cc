//! The sums: each output texel's L·∫K over the source's slots, split into parts and chunks
//! so that small outputs fill the device and no invocation outruns the loop limit.

use super::super::map::GpuEnvMap;
use super::source::{scratch, tile_count, CoarseLevel, PreparedSource};
use super::variants::pipeline_slot;
use super::{check_kernel, BruteFilter};
use crate::abi::{binding, push::BrutePush, ShaderId, BRUTE_TILE, WORKGROUP_2D};
use crate::error::Result;
use crate::gpu::{groups_2d, Bind, Pipeline, Recorder};
use crate::math::filter::{self, Kernel};
use crate::math::Mapping;

impl BruteFilter {
    /// Records the sum into `dst` over the prepared texels, or over a level of the pyramid.
    pub(super) fn convolve(
        &self,
        rec: &mut Recorder,
        prep: &PreparedSource,
        coarse: Option<&CoarseLevel>,
        kernel: Kernel,
        dst: &GpuEnvMap,
    ) -> Result<()> {
        let exponent = check_kernel(kernel)?;
        let (w, h) = (dst.width, dst.height);
        let base = coarse.map_or(prep.push, |c| c.push);
        // A coarse texel may descend to all of its 4^s prepared texels.
        let descent = coarse.map_or(1, |c| 1u32 << (2 * c.push.src_level));
        let outputs = w * h * dst.mapping.layers();
        // Slots: the texels of tiles (walk), or with lanes on a lat-long source its texels,
        // row-major (walk_rows).
        let split_for = |lanes: u32| {
            let rows = lanes > 1 && prep.mapping == Mapping::LatLong;
            let slots = if rows {
                base.src_size[0] * base.src_size[1]
            } else {
                tile_count(&base) * BRUTE_TILE * BRUTE_TILE
            };
            let row = rows.then_some(base.src_size[0]);
            let chunk = self.chunk_size(prep, kernel, descent, lanes, row);
            let target = self.target_invocations.div_ceil(lanes);
            // A row's reach is walked whole in a chunk's first and last row: a chunk must
            // hold a row, or the loop limit could cut it short.
            let fits = row.is_none_or(|w| chunk >= w);
            (
                lanes,
                slots,
                Split::new(outputs, slots, chunk, target),
                fits,
            )
        };
        // Lanes share a part's slots: where the parts are shorter than the lanes (the
        // coarsest Phong levels, a few outputs split into parts of a slot or two), most lanes
        // would idle, and the parts alone fill the device.
        let (lanes, slots, split, _) = match split_for(self.texel_lanes) {
            (lanes, _, split, fits) if split.part_slots < lanes || !fits => split_for(1),
            chosen => chosen,
        };
        let partials = scratch(
            rec,
            "brute partial sums",
            outputs as u64 * split.parts() as u64 * lanes as u64 * 32,
        )?;
        let push = BrutePush {
            dst_size: [w, h],
            dst_mapping: dst.mapping.id(),
            exponent,
            parts: split.grid,
            part_slots: split.part_slots,
            ..base
        };
        let (from, to) = (prep.mapping.id(), dst.mapping.id());
        let moment = coarse.is_some();
        let brute = Pipeline::compute_once(
            &self.brute[pipeline_slot(from, to, moment, self.cells_walk, lanes, self.visit_floor)],
            &self.ctx,
            if self.visit_floor {
                ShaderId::BruteVisits
            } else if matches!(prep.mapping, Mapping::Angular | Mapping::DualParaboloid) {
                ShaderId::BruteDisc
            } else {
                ShaderId::Brute
            },
            &[
                WORKGROUP_2D[0],
                WORKGROUP_2D[1],
                from,
                to,
                moment as u32,
                self.cells_walk as u32,
                lanes,
            ],
        )?;
        // The resolve reads only the destination mapping (constant 2 is unused there).
        let resolve = Pipeline::compute_once(
            &self.resolve[to as usize],
            &self.ctx,
            ShaderId::BruteResolve,
            &[WORKGROUP_2D[0], WORKGROUP_2D[1], 0, to],
        )?;
        let label = match kernel {
            Kernel::Cosine => "brute irradiance",
            Kernel::Phong { .. } => "brute phong",
        };
        let tiles = coarse.map_or(&prep.tiles, |c| &c.tiles);
        // Without a moment source, the level bindings are not read: bind the fine buffers.
        let (coarse_cones, light) =
            coarse.map_or((&prep.cones, &prep.shapes), |c| (&c.cones, &c.light));
        let per_dispatch = split.parts() * split.part_slots;
        rec.discard(&dst.image);
        rec.span(label, |rec| {
            // The first chunk starts the sums (its shader run sees chunk_begin = 0).
            let mut begin = 0;
            while begin < slots {
                let end = slots.min(begin.saturating_add(per_dispatch));
                rec.dispatch(
                    brute,
                    &[
                        (binding::BRUTE_CONES, Bind::Storage(&prep.cones)),
                        (binding::BRUTE_RADIANCE, Bind::Storage(&prep.rad)),
                        (binding::BRUTE_PARTIALS, Bind::Buffer(&partials)),
                        (binding::BRUTE_TILES, Bind::Buffer(tiles)),
                        (binding::BRUTE_SHAPES, Bind::Storage(&prep.shapes)),
                        (binding::BRUTE_COARSE_CONES, Bind::Storage(coarse_cones)),
                        (binding::BRUTE_LIGHT, Bind::Storage(light)),
                    ],
                    &BrutePush {
                        chunk_begin: begin,
                        chunk_end: end,
                        ..push
                    },
                    groups_2d(
                        w * split.grid[0] * lanes,
                        h * split.grid[1],
                        dst.mapping.layers(),
                    ),
                )?;
                begin = end;
            }
            // Each part's lanes are parts of their own to the resolve.
            rec.dispatch(
                resolve,
                &[
                    (binding::BRUTE_RESOLVE_PARTIALS, Bind::Buffer(&partials)),
                    (binding::BRUTE_RESOLVE_DST, Bind::Storage(&dst.image)),
                ],
                &BrutePush {
                    parts: [split.grid[0] * lanes, split.grid[1]],
                    ..push
                },
                groups_2d(w, h, dst.mapping.layers()),
            )
        })?;
        rec.keep(partials);
        Ok(())
    }
}

/// How one convolution splits its source slots among parts, each summed by its own invocation
/// per output texel: as many parts as bring the invocations to the target, at least one slot
/// each, and no part longer than the device's loop chunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Split {
    /// Parts per dispatch, as a grid of output-sized blocks.
    grid: [u32; 2],
    /// Slots each part sums in one dispatch.
    part_slots: u32,
}

impl Split {
    fn new(texels: u32, slots: u32, chunk: u32, target: u32) -> Split {
        let slots = slots.max(1);
        let want = target.div_ceil(texels.max(1)).clamp(1, slots);
        let part_slots = slots.div_ceil(want).min(chunk).max(1);
        let parts = want.min(slots.div_ceil(part_slots));
        let gx = (parts as f64).sqrt().ceil() as u32;
        Split {
            grid: [gx, parts.div_ceil(gx)],
            part_slots,
        }
    }

    fn parts(&self) -> u32 {
        self.grid[0] * self.grid[1]
    }
}

impl BruteFilter {
    /// Source slots per dispatch: all, or where the device cuts long loops short
    /// ([`crate::gpu::DeviceInfo::loop_iteration_limit`]), as many as keep every invocation's
    /// loop iterations within 90% of the limit: one for the texel loop, two where the cells
    /// rule's texels are summed in a second walk over the same slots ([`Self::set_cells_walk`]),
    /// plus, per texel, at most s² cell iterations (s from the rule for the source's widest
    /// texel) or ~130 for a clipped rim texel of an angular or paraboloid source, `descent`
    /// texels a slot (4^s for a coarse level's, which may descend to its prepared texels).
    /// llvmpipe counts the iterations of all loops together. With `lanes` invocations an
    /// output, each takes S/L of a chunk's S slots plus, per group the chunk touches (a tile,
    /// or with `row` a source row of that many texels, walk_rows), one more per piece and
    /// the group loop's own iterations.
    pub(super) fn chunk_size(
        &self,
        src: &PreparedSource,
        kernel: Kernel,
        descent: u32,
        lanes: u32,
        row: Option<u32>,
    ) -> u32 {
        let Some(limit) = self.ctx.info().loop_iteration_limit else {
            return u32::MAX;
        };

        let (w, h) = src.size;
        let mut min_cos: f64 = 1.0;
        // Texel radii vary smoothly: a sparse sample of texels plus the corners suffices,
        // and the 25% margin in the radius already covers the spread between samples.
        let step_i = (w / 64).max(1);
        let step_j = (h / 64).max(1);
        for j in (0..h).step_by(step_j as usize).chain([h - 1]) {
            for i in (0..w).step_by(step_i as usize).chain([w - 1]) {
                min_cos = min_cos.min(filter::texel_cos_radius(src.mapping, w, h, 0, i, j));
            }
        }
        let n = kernel.exponent();
        let rho = min_cos.clamp(-1.0, 1.0).acos();
        // Texels the horizon cuts take at least EDGE_CELLS a side, unless the lobe there is
        // below the cut-off for every texel: x_max ≤ sin ρ at the horizon.
        let straddlers_kept = n <= 1.0 || n * rho.sin().ln() >= filter::LOG_CUTOFF;
        let floor = if straddlers_kept {
            filter::EDGE_CELLS as f64
        } else {
            1.0
        };
        let s = (filter::CELLS_PER_WIDTH * (n * 2.0 * (1.0 - min_cos)).sqrt())
            .ceil()
            .clamp(floor, filter::MAX_CELLS as f64);
        let rim = if matches!(src.mapping, Mapping::Angular | Mapping::DualParaboloid) {
            130.0
        } else {
            0.0
        };
        let walks = if self.cells_walk { 2.0 } else { 1.0 };
        let per_slot = descent as f64 * (walks + (s * s).max(rim));
        let budget = 0.9 * limit as f64;
        // Every slot on one lane: right for one lane, and a bound for few slots on many.
        let whole = ((budget / per_slot) as u32).max(1);
        if lanes == 1 {
            return whole;
        }
        let lanes = lanes as f64;
        if let Some(w) = row {
            // Rows touched R ≤ S/w + 2, each ≤ w/L + 1 iterations (the first and last row's
            // whole reach, not only the chunk's part): ≤ S/L + S/w + 2w/L + 2 in all.
            let w = w as f64;
            let shared = (budget - per_slot * (2.0 * w / lanes + 2.0) - 2.0 * walks)
                / (per_slot / lanes + (per_slot + walks) / w);
            return (shared.max(0.0) as u32).max(1);
        }
        let tile = (BRUTE_TILE * BRUTE_TILE) as f64;
        let shared = (budget - 2.0 * per_slot - 6.0 * walks)
            / (per_slot / lanes + (per_slot + 3.0 * walks) / tile);
        whole.max(shared as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::Split;

    /// Every slot is summed once: the parts of all dispatches cover the slots, no part runs
    /// longer than the loop chunk, and the invocations come within a factor of two of the
    /// target (parts of whole slots round it down, the grid rounds it up).
    #[test]
    fn split_covers_the_slots_within_the_chunk() {
        for (texels, slots, chunk, target) in [
            (6, 8192, u32::MAX, 65536),
            (6, 8192, 1000, 65536),
            (24576, 524288, u32::MAX, 65536),
            (24576, 524288, 1180, 65536),
            (393216, 524288, u32::MAX, 65536),
            (1, 1, u32::MAX, 65536),
            (6, 3, 1, 65536),
            (96, 131072, 7, 1),
        ] {
            let s = Split::new(texels, slots, chunk, target);
            let per_dispatch = s.parts() * s.part_slots;
            assert!(s.part_slots >= 1 && s.part_slots <= chunk, "{s:?}");
            let dispatches = slots.div_ceil(per_dispatch);
            assert!(dispatches * per_dispatch >= slots, "{s:?}");
            if chunk == u32::MAX {
                assert_eq!(dispatches, 1, "{s:?}");
            }
            let invocations = texels as u64 * s.parts() as u64;
            let wanted = (target as u64)
                .max(texels as u64)
                .min(texels as u64 * slots as u64);
            assert!(invocations <= 2 * wanted.max(texels as u64), "{s:?}");
            if chunk == u32::MAX {
                assert!(2 * invocations >= wanted, "{s:?}");
            }
        }
    }
}
