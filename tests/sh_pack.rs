//! The SH packing pass (`passes::sh_pack`): the shade pass's coefficient sets built on the GPU
//! from the projection's output, against the float64 twin.

mod common;
#[path = "twins/sh_pack.rs"]
mod twin;

use envlight::math::sh;
use envlight::passes::sh_pack::{irradiance_entries, windowed_entries, Window};

/// Three sets from one projection (see the twin): within 1e-6 of the largest packed value.
#[test]
fn packed_sets_match_the_float64_twin() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// The entries say what the float64 helpers do: an irradiance set is `irradiance_coeffs`, of
/// the radiance less the second set where asked; a windowed set is `Window::apply`.
#[test]
fn entries_are_the_helpers_sums() {
    let radiance: Vec<[f64; 3]> = (0..81).map(|k| [k as f64, 1.0 - k as f64, 0.5]).collect();
    let minus: Vec<[f64; 3]> = (0..81).map(|k| [0.25 * k as f64, 2.0, -1.0]).collect();
    let residual: Vec<[f64; 3]> = radiance
        .iter()
        .zip(&minus)
        .map(|(a, b)| [0, 1, 2].map(|c| a[c] - b[c]))
        .collect();
    assert_eq!(
        sh::pack(&radiance, &minus, &irradiance_entries(4, true)),
        sh::irradiance_coeffs(&residual[..25])
    );
    assert_eq!(
        sh::pack(&radiance, &minus, &irradiance_entries(8, false)),
        sh::irradiance_coeffs(&radiance)
    );
    let w = Window::Hanning { width: 5.0 };
    assert_eq!(
        sh::pack(&radiance, &minus, &windowed_entries(6, w)),
        w.apply(&radiance[..49])
    );
}

/// A frame cache hands a recording the buffers an earlier one uploaded only where the contents
/// are the same: packing three different entry lists in turn, then the first again, into one
/// output through one `FrameCache` gives each list's float64 sums (1e-6 of the largest), never
/// a stale list; the repeat reuses the first list's upload (no new object).
#[test]
fn a_frame_cache_never_serves_stale_uploads() {
    use common::compare::Errors;
    use envlight::gpu::{Buffer, FrameCache, Usage};
    use envlight::math::synth::Sky;
    use envlight::passes::sh_pack::ShPacker;
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let map =
            envlight::EnvMap::from_fn(envlight::Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
        let radiance = envlight::math::sh::project(&map, 8);
        let flat: Vec<f32> = radiance.iter().flatten().map(|&v| v as f32).collect();
        let gpu_radiance = Buffer::storage(&ctx, "radiance", &flat).unwrap();
        let lists = [
            irradiance_entries(2, false),
            irradiance_entries(8, false),
            windowed_entries(8, Window::Hanning { width: 6.0 }),
            irradiance_entries(2, false),
        ];
        let most = lists.iter().map(|l| l.len()).max().unwrap();
        let out = Buffer::new(
            &ctx,
            "packed",
            ShPacker::output_bytes(most),
            ash::vk::BufferUsageFlags::STORAGE_BUFFER,
            gpu_allocator::MemoryLocation::GpuToCpu,
        )
        .unwrap();
        let packer = ShPacker::new(&ctx).unwrap();
        let cache = FrameCache::new();
        for (k, entries) in lists.iter().enumerate() {
            let made = ctx
                .run_untimed("packing through a frame cache", |rec| {
                    rec.use_frame_cache(&cache);
                    let before = ctx.objects_created();
                    packer.record(rec, &gpu_radiance, entries, None, &out)?;
                    rec.use_buffer(&out, Usage::HostRead);
                    Ok(ctx.objects_created() - before)
                })
                .unwrap();
            let got: Vec<[f32; 4]> = out.read(entries.len());
            let want = envlight::math::sh::pack(&radiance, &[], entries);
            let top = common::compare::max_abs(want.iter().flatten().copied());
            let mut errors = Errors::new();
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                for c in 0..3 {
                    errors.abs(g[c], w[c], (k, i, c));
                }
            }
            let worst = errors.worst() / top;
            assert!(worst < 1e-6, "list {k}: {worst:e} at {:?}", errors.at());
            if k == 3 {
                assert_eq!(made, 0, "the repeated list made new objects");
            } else {
                assert!(made > 0, "list {k} made nothing: a stale upload served it");
            }
        }
        drop((out, gpu_radiance, packer, cache));
    }
    common::finish(ctx);
}
