//! The GPU map (`passes::map`): uploads and downloads keep every texel bit for bit (the image
//! is RGBA32F, so the oracle is the input itself), in every mapping, at odd sizes and with a
//! sun 10⁶ × the sky beside texels near f32's smallest normal; bad radiance never reaches the
//! GPU; MIP counts follow Vulkan's rule.

mod common;
#[path = "twins/map.rs"]
mod twin;

use envlight::math::synth::smooth_env;
use envlight::passes::map::full_mips;
use envlight::{EnvMap, GpuEnvMap, Mapping};

/// Every mapping at sizes 1, 5 and 16 (odd, and a cube's six layers): what comes back is what
/// went up, bit for bit, with alpha 1; downloading level 0 of a mipped map the same.
#[test]
fn uploads_come_back_bit_for_bit() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// Vulkan's MIP count: levels until the larger side is 1 (a 256 × 128 map has 9, 5 × 3 has 3).
#[test]
fn full_chains_end_at_one_texel() {
    for (w, h, levels) in [
        (1, 1, 1),
        (2, 1, 2),
        (5, 3, 3),
        (256, 128, 9),
        (300, 1000, 10),
    ] {
        assert_eq!(full_mips(w, h), levels, "{w} × {h}");
        let last = (w >> (levels - 1)).max(h >> (levels - 1));
        assert_eq!(last, 1, "{w} × {h}: the last level is not one texel");
    }
}

/// A NaN or negative texel is refused at upload with its index, so that no pass sees one.
#[test]
fn uploading_nan_or_negative_radiance_is_refused() {
    let ctx = common::ctx();
    {
        let mut map = EnvMap::from_fn(Mapping::LatLong, 8, 4, 1, smooth_env);
        map.texels[3][1] = f32::NAN;
        let e = GpuEnvMap::upload(&ctx, &map).err().unwrap().to_string();
        assert!(e.contains("texel 3") && e.contains("finite"), "{e}");
        map.texels[3][1] = -0.5;
        assert!(GpuEnvMap::upload(&ctx, &map).is_err());
    }
    common::finish(ctx);
}
