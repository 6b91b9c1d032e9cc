//! What each fuzz target does with one input. `tests/fuzz_corpus.rs` in the main crate replays
//! the committed corpora through the same library calls, so a crash found here stays fixed.

use envlight::io::{self, LoadOptions};
use envlight::render::plan;
use envlight::scene::Scene;
use envlight::{EnvMap, Mapping};

/// The targets: one per loader, and the scene parser.
pub const TARGETS: &[&str] = &["exr", "hdr", "pfm", "dds", "png", "jpeg", "scene"];

/// A texel budget small enough that an accepted header never makes a run slow, large enough
/// for every seed.
pub const FUZZ_MAX_TEXELS: u64 = 1 << 16;

/// Runs one input through target `name`. Errors are expected; panics, hangs and unbounded
/// allocations are what the fuzzer looks for. What a loader accepts must be usable: finite,
/// non-negative texels of a consistent size.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "scene" => {
            let Ok(text) = std::str::from_utf8(data) else {
                return;
            };
            if let Ok(scene) = Scene::parse(text) {
                // A scene the parser accepts renders: its camera has a frame and its plan exists.
                let f = scene.camera.frame();
                for v in [f.forward, f.right, f.up] {
                    assert!(v.is_finite(), "accepted scene has camera frame {f:?}");
                }
                let env = EnvMap::new(Mapping::LatLong, 8, 4, vec![[1.0; 3]; 32]);
                let _ = plan(&scene, &env);
            }
        }
        ext => {
            let mut opts = LoadOptions::default();
            opts.max_texels = FUZZ_MAX_TEXELS;
            if let Ok(map) = io::load_bytes(format!("fuzz.{ext}"), data, &opts) {
                assert_eq!(
                    map.texels.len() as u64,
                    map.width as u64 * map.height as u64 * map.layers() as u64
                );
                assert!(map
                    .texels
                    .iter()
                    .flatten()
                    .all(|c| c.is_finite() && *c >= 0.0));
            }
        }
    }
}
