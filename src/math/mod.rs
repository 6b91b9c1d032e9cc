//! Pure float64 math: mappings, solid angles, quadrature and analytic test environments.
//!
//! Nothing here knows about Vulkan; these functions are the oracles the GPU passes are tested
//! against.

pub mod area_mean;
pub mod brdf;
pub mod camera;
pub mod convert;
pub mod envmap;
pub mod envsample;
pub mod exact;
pub mod filter;
pub mod fis;
pub mod footprint;
pub mod light_tree;
pub mod lights;
pub mod mapping;
pub mod mc;
pub mod mip;
pub mod moments;
pub mod quadrature;
pub mod sequence;
pub mod sh;
pub mod sh_brdf;
pub mod sh_rotate;
pub mod split_sum;
pub mod synth;

pub use mapping::{Coord, Mapping, Orientation};

/// `row(j)` for every row `j` of `height`, rows dealt to every core in turn, returned in
/// row order (each row computed as on one core).
pub fn rows_on_every_core<T: Send>(height: u32, row: impl Fn(u32) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get()) as u32;
    let row = &row;
    let mut all: Vec<(u32, T)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                scope.spawn(move || {
                    (t..height)
                        .step_by(threads as usize)
                        .map(|j| (j, row(j)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    all.sort_by_key(|(j, _)| *j);
    all.into_iter().map(|(_, r)| r).collect()
}
