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
/// went up, bit for bit, with alpha 1, whole or in bands of rows; downloading level 0 of a
/// mipped map the same; and the
/// sanitizing copy of an engine's frame ([`check_sanitize`]); the luminance clamp
/// ([`check_clamp`]).
pub fn check(ctx: &Context) {
    check_sanitize(ctx);
    check_clamp(ctx);
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
            // In bands of one and three rows, and of more rows than the map has.
            for rows in [1, 3, 64] {
                let banded = GpuEnvMap::new(ctx, "banded", mapping, map.width, map.height).unwrap();
                banded
                    .upload_banded(ctx, &map, rows * map.width as u64 * 16)
                    .unwrap();
                let back = banded.download_level(ctx, 0).unwrap();
                assert_eq!(back.len(), map.texels.len(), "{what}");
                for (k, (b, t)) in back.iter().zip(&map.texels).enumerate() {
                    let want = [t[0], t[1], t[2], 1.0];
                    assert!(
                        b.iter().zip(&want).all(|(x, y)| x.to_bits() == y.to_bits()),
                        "{what}, bands of {rows} rows: texel {k} came back {b:?}, went up {want:?}"
                    );
                }
            }
            let mipped = GpuEnvMap::upload_mipped(ctx, &map).unwrap();
            let (w, h) = mapping.extent_for_size(size);
            assert_eq!(mipped.mips(), full_mips(w, h), "{what}");
            assert_eq!(mipped.download(ctx).unwrap().texels, map.texels, "{what}");
        }
    }
}

/// `map` as an engine's frame may hold it, copied into a GPU map as raw RGBA (no upload
/// check): texels that are NaN, infinite or negative included.
pub fn raw_gpu_map(ctx: &Context, map: &EnvMap) -> GpuEnvMap {
    let gpu = GpuEnvMap::new(ctx, "engine frame", map.mapping, map.width, map.height).unwrap();
    write_raw(ctx, &gpu, map);
    gpu
}

/// Writes `map` into `gpu` (same shape) as raw RGBA, as an engine writes its next frame.
pub fn write_raw(ctx: &Context, gpu: &GpuEnvMap, map: &EnvMap) {
    let texels: Vec<[f32; 4]> = map.texels.iter().map(|t| [t[0], t[1], t[2], 1.0]).collect();
    let mut staging = envlight::gpu::Buffer::new(
        ctx,
        "engine frame texels",
        (texels.len() * 16) as u64,
        ash::vk::BufferUsageFlags::TRANSFER_SRC,
        gpu_allocator::MemoryLocation::CpuToGpu,
    )
    .unwrap();
    staging.write(&texels);
    ctx.run("an engine's frame", |rec| {
        rec.copy_buffer_to_image(&staging, &gpu.image, 0, true);
        Ok(())
    })
    .unwrap();
}

/// The u32 at the start of `buffer` (TRANSFER_SRC usage).
pub fn read_u32(ctx: &Context, buffer: &envlight::gpu::Buffer) -> u32 {
    let host = envlight::gpu::Buffer::new(
        ctx,
        "count readback",
        4,
        ash::vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuToCpu,
    )
    .unwrap();
    ctx.run("reading a count", |rec| {
        rec.copy_buffer(buffer, &host, 4);
        rec.use_buffer(&host, envlight::gpu::Usage::HostRead);
        Ok(())
    })
    .unwrap();
    host.read::<u32>(1)[0]
}

/// [`varied`] with a NaN, +∞, −∞ and a negative texel, as an engine's frame may hold them:
/// the sanitizing copy (`passes::map::Sanitizer`, the resident path's first pass) gives
/// `EnvMap::sanitized` bit for bit, and counts its four zeroed texels.
pub fn check_sanitize(ctx: &Context) {
    let pass = envlight::passes::map::Sanitizer::new(ctx).unwrap();
    for mapping in Mapping::ALL {
        let mut map = varied(mapping, 16);
        let n = map.texels.len();
        map.texels[n / 5] = [f32::NAN, 1.0, 1.0];
        map.texels[n / 4] = [1.0, f32::INFINITY, 1.0];
        map.texels[2 * n / 3] = [1.0, 1.0, f32::NEG_INFINITY];
        map.texels[3 * n / 4] = [0.5, -1e-3, 0.5];
        let (want, zeroed) = map.sanitized();
        assert_eq!(zeroed, 4);
        let src = raw_gpu_map(ctx, &map);
        let dst = GpuEnvMap::new(ctx, "sanitized", mapping, map.width, map.height).unwrap();
        let count = envlight::gpu::Buffer::new(
            ctx,
            "zeroed",
            4,
            ash::vk::BufferUsageFlags::STORAGE_BUFFER
                | ash::vk::BufferUsageFlags::TRANSFER_DST
                | ash::vk::BufferUsageFlags::TRANSFER_SRC,
            gpu_allocator::MemoryLocation::GpuOnly,
        )
        .unwrap();
        ctx.run("sanitizing", |rec| pass.record(rec, &src, &dst, &count))
            .unwrap();
        let back = dst.download_level(ctx, 0).unwrap();
        for (k, (b, t)) in back.iter().zip(&want.texels).enumerate() {
            let w = [t[0], t[1], t[2], 1.0];
            assert!(
                b.iter().zip(&w).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{}: texel {k} sanitized to {b:?}, want {w:?}",
                mapping.name()
            );
        }
        assert_eq!(read_u32(ctx, &count), 4, "{}", mapping.name());
    }
}

/// Float32 against the float64 rule's float32 result: the luminance (a dot of three terms,
/// 2 ε), τ's rounding, the ratio and the product (ε/2 each) differ by at most ~4 ε; a texel
/// within that of τ may be clamped by one and not the other, by as little.
pub const CLAMP_BOUND: f64 = 5.0 * f32::EPSILON as f64;

/// The bake's residual on the GPU (`passes::map::LuminanceClamp`) against
/// `math::lights::clamp_residual`, every mapping at sizes 5 and 16 (rims, a cube's six
/// layers), at the light extraction's threshold at 16 (the sun's texel clamped) and at the
/// texels' median luminance (half the sky clamped), within [`CLAMP_BOUND`]; the texels
/// outside an angular or paraboloid domain untouched.
pub fn check_clamp(ctx: &Context) {
    use crate::common::compare::Errors;
    use envlight::math::envmap::luminance;
    use envlight::math::lights::{clamp_residual, extract_lights, ExtractOptions};
    let pass = envlight::passes::map::LuminanceClamp::new(ctx).unwrap();
    for mapping in Mapping::ALL {
        for size in [5, 16] {
            let mut map = varied(mapping, size);
            // A bright texel outside an angular or paraboloid domain (a file's corner), which
            // the clamp must leave as it is.
            let outside = !mapping.texel_in_domain(map.width, map.height, 0, 0);
            if outside {
                map.texels[0] = [5e4, 5e4, 5e4];
            }
            let mut lum: Vec<f64> = map
                .texels
                .iter()
                .map(|t| luminance(t.map(f64::from)))
                .collect();
            lum.sort_by(f64::total_cmp);
            let median = lum[lum.len() / 2];
            let lights = extract_lights(&map, &ExtractOptions::default()).threshold;
            // A 5-texel-wide map's sun holds most of its power: nothing passes ratio × mean.
            let taus = match size {
                16 => vec![lights, median],
                _ => vec![median],
            };
            for tau in taus {
                let what = format!("{} at {size}, τ = {tau:.3e}", mapping.name());
                let want = clamp_residual(&map, tau);
                let clamped = want
                    .texels
                    .iter()
                    .zip(&map.texels)
                    .filter(|(a, b)| a != b)
                    .count();
                assert!(
                    clamped > 0 && clamped < map.texels.len(),
                    "{what}: {clamped} clamped"
                );
                let gpu = raw_gpu_map(ctx, &map);
                ctx.run("clamping", |rec| pass.record(rec, &gpu, tau))
                    .unwrap();
                let back = gpu.download_level(ctx, 0).unwrap();
                assert_eq!(back.len(), want.texels.len(), "{what}");
                let mut errors = Errors::new();
                for (k, (b, t)) in back.iter().zip(&want.texels).enumerate() {
                    for c in 0..3 {
                        errors.rel(b[c], t[c], f32::MIN_POSITIVE as f64, (k, c));
                    }
                    errors.abs(b[3], 1.0, (k, 3));
                }
                errors.assert_within(CLAMP_BOUND, &what);
                if outside {
                    assert_eq!(back[0], [5e4, 5e4, 5e4, 1.0], "{what}: outside the domain");
                }
            }
        }
    }
}
