//! The brute-force pipelines' variant cache: one pipeline per source and destination
//! mapping, source kind, walk structure, lanes per output and visit floor, each specialised.

use super::MAX_TEXEL_LANES;
use ash::vk;

/// Lane counts (powers of two up to [`MAX_TEXEL_LANES`]) times the 64 other variants, with
/// the rule or the visit floor.
pub(super) const PIPELINE_SLOTS: usize = 2 * 64 * (MAX_TEXEL_LANES.trailing_zeros() as usize + 1);

/// The brute pipeline's slot for source and destination mapping ids, source kind, walk
/// structure, lanes per output (a power of two) and the visit floor.
pub(super) fn pipeline_slot(
    from: u32,
    to: u32,
    moment: bool,
    cells_walk: bool,
    lanes: u32,
    visit_floor: bool,
) -> usize {
    (PIPELINE_SLOTS / 2) * visit_floor as usize
        + 64 * lanes.trailing_zeros() as usize
        + 4 * (4 * from + to) as usize
        + 2 * cells_walk as usize
        + moment as usize
}

/// The lanes per output a device takes by default: its subgroup size (a power of two at
/// most [`MAX_TEXEL_LANES`]) on CPU devices, whose subgroups are SIMD lanes of neighbouring
/// invocations, so that one output's lanes run as one group; 1 elsewhere.
pub(super) fn default_texel_lanes(info: &crate::gpu::DeviceInfo) -> u32 {
    if info.device_type != vk::PhysicalDeviceType::CPU || info.subgroup_size < 2 {
        return 1;
    }
    lane_count(info.subgroup_size)
}

/// `lanes` clamped to 1 … [`MAX_TEXEL_LANES`] and rounded down to a power of two (the
/// pipelines are cached per power).
pub(super) fn lane_count(lanes: u32) -> u32 {
    1 << (31 - lanes.clamp(1, MAX_TEXEL_LANES).leading_zeros())
}
