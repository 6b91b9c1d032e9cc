//! Context creation, device selection, timing and clean teardown.

mod common;

use envlight::gpu::{Context, ContextOptions, DeviceSelector, Timed};
use envlight::passes::testing::diagnostics::Diagnostics;

#[test]
fn costly_dispatch_after_graphics_work_measures_nonzero_time() {
    let ctx = common::ctx();
    {
        let diag = Diagnostics::new(&ctx).unwrap();
        // Warm up once so any lazy compilation is out of the way, then measure twice: the
        // second run has graphics work before it in the same submission and in earlier ones.
        let (cheap, _) = diag.draw_then_busy(64, 1, 64).unwrap();
        let (costly, sum) = diag.draw_then_busy(64, 4000, 64 * 64).unwrap();
        let (costly2, _) = diag.draw_then_busy(64, 4000, 64 * 64).unwrap();
        assert!(sum.is_finite());
        assert_eq!(costly.len(), 2);
        assert_eq!(costly[1].label, "busy");
        // With the lavapipe reordering bug the span would close before the dispatch and
        // measure about nothing, less than even the 1-iteration dispatch (4000× less work).
        for t in [&costly[1], &costly2[1]] {
            assert!(t.ms > 0.0, "costly dispatch measured {} ms", t.ms);
            assert!(
                t.ms > cheap[1].ms,
                "costly {} ms vs cheap {} ms",
                t.ms,
                cheap[1].ms
            );
        }
        eprintln!(
            "draw {:.3} ms, busy {:.3} ms (cheap busy {:.3} ms)",
            costly[0].ms, costly[1].ms, cheap[1].ms
        );
    }
    common::finish(ctx);
}

#[test]
fn cpu_device_can_be_forced() {
    let ctx = Context::new(&validated(DeviceSelector::Cpu)).unwrap();
    assert_eq!(ctx.info().device_type, ash::vk::PhysicalDeviceType::CPU);
    let by_name = Context::new(&validated(DeviceSelector::Name("llvmpipe".into()))).unwrap();
    assert_eq!(by_name.info().device_type, ash::vk::PhysicalDeviceType::CPU);
    common::finish(by_name);
    let missing = Context::new(&validated(DeviceSelector::Name("no such gpu".into())));
    let e = missing.err().unwrap().to_string();
    assert!(e.contains("no such gpu") && e.contains("devices:"), "{e}");
    // By its UUID, as `envlight devices` prints it (nvidia-smi's form, GPU- prefix and all).
    let uuid = envlight::gpu::uuid_text(&ctx.info().uuid);
    let sel = DeviceSelector::parse(&format!("GPU-{uuid}"));
    assert_eq!(sel, DeviceSelector::Uuid(ctx.info().uuid));
    let by_uuid = Context::new(&validated(sel)).unwrap();
    assert_eq!(by_uuid.info().uuid, ctx.info().uuid);
    common::finish(by_uuid);
    let mut other = ctx.info().uuid;
    other[15] ^= 1;
    let e = Context::new(&validated(DeviceSelector::Uuid(other)))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains(&envlight::gpu::uuid_text(&other)) && e.contains("UUID"),
        "{e}"
    );
    common::finish(ctx);
}

#[test]
fn selector_parses_env_syntax() {
    assert_eq!(DeviceSelector::parse("lavapipe"), DeviceSelector::Cpu);
    assert_eq!(DeviceSelector::parse(" 1 "), DeviceSelector::Index(1));
    assert_eq!(DeviceSelector::parse(""), DeviceSelector::Auto);
    assert_eq!(
        DeviceSelector::parse("H100"),
        DeviceSelector::Name("H100".into())
    );
    let u = [
        0x6d, 0x65, 0x73, 0x61, 0x32, 0x32, 0x2e, 0x33, 0x2e, 0x36, 0, 0, 0, 0, 0, 0xab,
    ];
    for s in [
        "GPU-6d657361-3232-2e33-2e36-0000000000ab",
        "gpu-6D657361-3232-2E33-2E36-0000000000AB",
        "6d65736132322e332e360000000000ab",
    ] {
        assert_eq!(DeviceSelector::parse(s), DeviceSelector::Uuid(u), "{s}");
    }
    assert_eq!(
        envlight::gpu::uuid_text(&u),
        "6d657361-3232-2e33-2e36-0000000000ab"
    );
    // One digit short is a name.
    assert!(matches!(
        DeviceSelector::parse("GPU-6d657361-3232-2e33-2e36-0000000000a"),
        DeviceSelector::Name(_)
    ));
}

#[test]
fn live_objects_return_to_zero() {
    let ctx = common::ctx();
    {
        let conv = envlight::passes::Converter::new(&ctx).unwrap();
        let map = envlight::EnvMap::from_fn(
            envlight::Mapping::Cube,
            4,
            4,
            1,
            envlight::math::synth::smooth_env,
        );
        let g = envlight::GpuEnvMap::upload(&ctx, &map).unwrap();
        assert!(ctx.live_objects() > 0);
        let opts = envlight::passes::ConvertOptions::new(envlight::Mapping::LatLong, 8);
        let Timed { value: out, .. } = conv.run(&g, &opts).unwrap();
        drop(g);
        let back = out.download(&ctx).unwrap();
        assert_eq!(back.width, 8);
    }
    common::finish(ctx);
}

/// The layer reports objects still alive when the device is destroyed; `common::finish`
/// reads the log after teardown, so such a leak fails a test. Here a buffer made behind
/// envlight's back (so `live_objects` cannot see it) is left alive on purpose.
#[test]
fn a_leak_reported_at_teardown_reaches_the_log() {
    let ctx = common::ctx();
    let info = ash::vk::BufferCreateInfo::default()
        .size(256)
        .usage(ash::vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: valid device and create info; the buffer is deliberately never destroyed.
    let _leaked = unsafe { ctx.device().create_buffer(&info, None) }.unwrap();
    assert_eq!(ctx.live_objects(), 0);
    let log = ctx.validation_log();
    assert!(log.messages().is_empty());
    drop(ctx);
    assert!(log.complete());
    let messages = log.messages();
    assert!(
        messages.iter().any(|m| m.contains("VkBuffer")),
        "no leak reported at teardown: {messages:?}"
    );
}

/// A program's `ValidationRecord` keeps each validated context's log past the context: a
/// leak left at teardown of one context is in its messages afterwards, and a context made
/// without validation adds nothing.
#[test]
fn a_validation_record_keeps_the_logs_of_contexts_gone() {
    use envlight::gpu::{ContextOptions, DeviceSelector, ValidationRecord};
    let record = ValidationRecord::new();
    let mut opts = ContextOptions::new(DeviceSelector::from_env());
    opts.validation = true;
    let ctx = record.context(&opts).unwrap();
    let info = ash::vk::BufferCreateInfo::default()
        .size(256)
        .usage(ash::vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: valid device and create info; the buffer is deliberately never destroyed.
    let _leaked = unsafe { ctx.device().create_buffer(&info, None) }.unwrap();
    assert!(record.messages().is_empty());
    drop(ctx);
    let messages = record.messages();
    assert!(
        messages.iter().any(|m| m.contains("VkBuffer")),
        "the record lost the leak: {messages:?}"
    );
    opts.validation = false;
    drop(record.context(&opts).unwrap());
    assert_eq!(record.messages(), messages);
}

/// A context envlight creates says what its creation cost, phase by phase (the floor `envlight
/// devices` and `cargo xtask lab peers` report): every phase finite and non-negative, the instance and
/// device together above zero (a driver does work there).
#[test]
fn an_owned_context_reports_its_start_up() {
    let ctx = common::ctx();
    let s = ctx
        .startup()
        .expect("an owned context records its start-up");
    for ms in [s.loader_ms, s.instance_ms, s.device_ms, s.rest_ms] {
        assert!(ms.is_finite() && ms >= 0.0, "{s:?}");
    }
    assert!(s.instance_ms + s.device_ms > 0.0, "{s:?}");
    common::finish(ctx);
}

/// Options for `device` with validation on.
fn validated(device: DeviceSelector) -> ContextOptions {
    let mut o = ContextOptions::new(device);
    o.validation = true;
    o
}

/// The one file a pipeline cache folder holds, and its bytes.
fn cache_file(dir: &std::path::Path) -> (std::path::PathBuf, Vec<u8>) {
    let files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let name = files[0].file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with("pipelines-") && name.ends_with(".bin"),
        "{name}"
    );
    let bytes = std::fs::read(&files[0]).unwrap();
    (files[0].clone(), bytes)
}

/// A context with validation and its pipelines cached in `dir`, one pipeline built (the
/// MIP chain's); how many cached bytes it started from.
fn context_with_cache(dir: &std::path::Path) -> usize {
    let mut o = validated(DeviceSelector::Cpu);
    o.pipeline_cache = Some(dir.to_path_buf());
    let ctx = Context::new(&o).unwrap();
    let loaded = ctx.pipeline_cache_loaded();
    drop(envlight::passes::MipChain::new(&ctx).unwrap());
    common::finish(ctx);
    loaded
}

/// Compiled pipelines kept between runs (`ContextOptions::pipeline_cache`): the first context
/// writes one file named for the device, holding the header `vkGetPipelineCacheData` writes
/// (its length, version one); the next starts from all of it. A file from another driver (the
/// pipelineCacheUUID changed) or a truncated one is not handed to the driver — the context
/// starts empty, with no validation message — and is replaced by this device's; a folder
/// that cannot be written leaves pipelines working.
#[test]
fn compiled_pipelines_are_kept_between_contexts() {
    let dir = std::env::temp_dir().join(format!("envlight-pipelines-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(context_with_cache(&dir), 0, "a new folder holds nothing");
    let (file, first) = cache_file(&dir);
    let word = |b: &[u8], k: usize| u32::from_le_bytes(b[k..k + 4].try_into().unwrap());
    assert!(
        first.len() >= 32 && word(&first, 0) >= 32,
        "{} bytes",
        first.len()
    );
    assert_eq!(word(&first, 4), 1, "header version one");
    assert_eq!(
        context_with_cache(&dir),
        first.len(),
        "the second run reads it whole"
    );
    let mut other = first.clone();
    other[31] ^= 0x5a;
    for (what, bytes) in [
        ("another driver's", other),
        ("a truncated", first[..20].to_vec()),
    ] {
        std::fs::write(&file, &bytes).unwrap();
        assert_eq!(context_with_cache(&dir), 0, "{what} file was read");
        let (_, now) = cache_file(&dir);
        assert_eq!(now[..32], first[..32], "{what} file was not replaced");
    }
    // A file where the folder should be: nothing written, nothing fails.
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::write(&dir, b"not a folder").unwrap();
    assert_eq!(context_with_cache(&dir), 0);
    assert_eq!(std::fs::read(&dir).unwrap(), b"not a folder");
    std::fs::remove_file(&dir).unwrap();
}
