//! GPU maps: uploads come back bit for bit.
//! `tests/map.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use envlight::gpu::Context;
use envlight::math::synth::{smooth_env, Sky};
use envlight::passes::map::full_mips;
use envlight::{EnvMap, GpuEnvMap, Mapping};

/// Bit for bit: less than one ulp of float32 (what the mutation matrix sizes its scale by).
pub const BOUND: f64 = f32::EPSILON as f64;

/// A map of `mapping` at `size` whose texels are all different: the analytic sky, a sun at
/// 10⁶ × its mean in one texel and 1e-37 (near f32's smallest normal) in another.
pub fn varied(mapping: Mapping, size: u32) -> EnvMap {
    let sky = Sky::default();
    let (w, h) = mapping.extent_for_size(size);
    let mut map = EnvMap::from_fn(mapping, w, h, 1, |d| {
        let s = smooth_env(d);
        let k = sky.radiance(d);
        [s[0] + k[0], s[1] * k[1], s[2] + 0.5 * k[2]]
    });
    let n = map.texels.len();
    map.texels[n / 3] = [1.0e6, 2.0e6, 3.0e6];
    map.texels[n / 2] = [1.0e-37, 2.0e-37, 0.0];
    map
}

/// Every mapping at sizes 1, 5 and 16 (odd, and a cube's six layers): what comes back is what
/// went up, bit for bit, with alpha 1; downloading level 0 of a mipped map the same.
pub fn check(ctx: &Context) {
    for mapping in Mapping::ALL {
        for size in [1, 5, 16] {
            let map = varied(mapping, size);
            let what = format!("{} at {size}", mapping.name());
            let back = GpuEnvMap::upload(ctx, &map)
                .unwrap()
                .download_level(ctx, 0)
                .unwrap();
            assert_eq!(back.len(), map.texels.len(), "{what}");
            for (k, (b, t)) in back.iter().zip(&map.texels).enumerate() {
                let want = [t[0], t[1], t[2], 1.0];
                assert!(
                    b.iter().zip(&want).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "{what}: texel {k} came back {b:?}, went up {want:?}"
                );
            }
            let mipped = GpuEnvMap::upload_mipped(ctx, &map).unwrap();
            let (w, h) = mapping.extent_for_size(size);
            assert_eq!(mipped.mips(), full_mips(w, h), "{what}");
            assert_eq!(mipped.download(ctx).unwrap().texels, map.texels, "{what}");
        }
    }
}
