//! Bad files and a missing driver get clear errors naming the file and the problem; never a
//! panic, a hang or a silently wrong image.

mod common;

use envlight::io::{self, LoadOptions, Sanitize};
use envlight::math::synth::smooth_env;
use envlight::math::Mapping;
use envlight::EnvMap;
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bad_input");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Loads and expects an error whose text names the file and contains every `words`.
fn expect_error(path: &Path, opts: &LoadOptions, words: &[&str]) {
    match io::load(path, opts) {
        Ok(m) => panic!(
            "{} loaded ({}x{}) but should not",
            path.display(),
            m.width,
            m.height
        ),
        Err(e) => {
            let text = e.to_string();
            assert!(
                text.contains(&path.display().to_string()),
                "error does not name the file: {text}"
            );
            for w in words {
                assert!(
                    text.to_lowercase().contains(&w.to_lowercase()),
                    "error '{text}' lacks '{w}'"
                );
            }
        }
    }
}

fn good_map() -> EnvMap {
    EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, smooth_env)
}

#[test]
fn truncated_and_corrupt_exr() {
    let p = tmp("good.exr");
    io::save_exr(&good_map(), &p).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert!(io::load(&p, &LoadOptions::default()).is_ok());
    for cut in [8, 100, bytes.len() / 2, bytes.len() - 10] {
        let q = tmp(&format!("truncated_{cut}.exr"));
        std::fs::write(&q, &bytes[..cut]).unwrap();
        expect_error(&q, &LoadOptions::default(), &["exr"]);
    }
    let mut corrupt = bytes.clone();
    for b in corrupt.iter_mut().skip(300).step_by(7) {
        *b ^= 0x5a;
    }
    let q = tmp("corrupt.exr");
    std::fs::write(&q, &corrupt).unwrap();
    // The scrambled body (offset table and compressed blocks) is refused outright.
    expect_error(&q, &LoadOptions::default(), &["exr"]);
    // A header that claims more than the file holds (the fuzzer found such tables and
    // blocks of gigabytes) is refused before anything is allocated; so is an invalid enum.
    for (name, words) in [
        ("chunk_table", &["offset table"][..]),
        ("line_order", &["exr"][..]),
    ] {
        let mut b = bytes.clone();
        let at = |b: &[u8], key: &[u8]| b.windows(key.len()).position(|w| w == key).unwrap();
        if name == "chunk_table" {
            // dataWindow's box2i: make the window 2^28 rows tall (the offset table grows
            // with it while the file does not).
            let k = at(&b, b"dataWindow\0box2i\0") + 17 + 4;
            b[k + 12..k + 16].copy_from_slice(&(1i32 << 28).to_le_bytes());
            let opts = {
                let mut o = LoadOptions::default();
                o.max_texels = u64::MAX;
                o
            };
            let q = tmp(&format!("{name}.exr"));
            std::fs::write(&q, &b).unwrap();
            expect_error(&q, &opts, words);
        } else {
            // A line order of 255 is not one of the three the format defines.
            let k = at(&b, b"lineOrder\0lineOrder\0") + 20 + 4;
            b[k] = 255;
            let q = tmp(&format!("{name}.exr"));
            std::fs::write(&q, &b).unwrap();
            expect_error(&q, &LoadOptions::default(), words);
        }
    }
}

fn write_hdr_header(w: &str) -> Vec<u8> {
    format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{w}\n").into_bytes()
}

#[test]
fn exr_with_luminance_only_or_bgr_half_channels_loads() {
    let (w, h) = (16u32, 8u32);
    let y: Vec<f32> = (0..w * h).map(|i| 0.25 + i as f32 / 64.0).collect();
    let g: Vec<f32> = y.iter().map(|v| v * 2.0).collect();
    let b: Vec<f32> = y.iter().map(|v| v * 3.0).collect();
    // Half precision keeps 11 significant bits.
    let close = |a: f32, e: f32| (a - e).abs() <= e * 1e-3;

    let p = tmp("luminance.exr");
    io::write_exr_half_channels(&p, w, h, &[("Y", &y)]).unwrap();
    let m = io::load(&p, &LoadOptions::default()).unwrap();
    assert_eq!((m.width, m.height, m.mapping), (w, h, Mapping::LatLong));
    for (t, v) in m.texels.iter().zip(&y) {
        assert!(close(t[0], *v) && t[0] == t[1] && t[1] == t[2]);
    }

    let p = tmp("bgr_half.exr");
    io::write_exr_half_channels(&p, w, h, &[("B", &b), ("G", &g), ("R", &y), ("A", &y)]).unwrap();
    let m = io::load(&p, &LoadOptions::default()).unwrap();
    for (k, t) in m.texels.iter().enumerate() {
        assert!(
            close(t[0], y[k]) && close(t[1], g[k]) && close(t[2], b[k]),
            "texel {k}: {t:?}"
        );
    }

    let p = tmp("uv.exr");
    io::write_exr_half_channels(&p, w, h, &[("U", &y), ("V", &y)]).unwrap();
    expect_error(&p, &LoadOptions::default(), &["channels", "R, G and B"]);
}

#[test]
fn truncated_and_absurd_radiance_hdr() {
    let good = tmp("good.hdr");
    // A small valid file: flat RGBE scanlines (width < 8 is never run-length encoded).
    let mut bytes = write_hdr_header("-Y 2 +X 4");
    for _ in 0..8 {
        bytes.extend_from_slice(&[128, 64, 32, 129]);
    }
    std::fs::write(&good, &bytes).unwrap();
    let m = io::load(&good, &LoadOptions::default()).unwrap();
    assert_eq!((m.width, m.height, m.mapping), (4, 2, Mapping::LatLong));
    assert!((m.texel(0, 0, 0)[0] - 1.0).abs() < 1e-6);

    let cut = tmp("truncated.hdr");
    std::fs::write(&cut, &bytes[..bytes.len() - 12]).unwrap();
    expect_error(&cut, &LoadOptions::default(), &["radiance"]);

    let absurd = tmp("absurd.hdr");
    std::fs::write(&absurd, write_hdr_header("-Y 1000000 +X 1000000")).unwrap();
    expect_error(&absurd, &LoadOptions::default(), &["1000000", "limit"]);

    let zero = tmp("zero.hdr");
    std::fs::write(&zero, write_hdr_header("-Y 0 +X 4")).unwrap();
    assert!(io::load(&zero, &LoadOptions::default()).is_err());

    let garbage = tmp("garbage.hdr");
    std::fs::write(&garbage, b"#?RADIANCE\nthis is not a header\x00\x01\x02").unwrap();
    expect_error(&garbage, &LoadOptions::default(), &[]);
}

#[test]
fn truncated_and_absurd_dds() {
    let n = 8;
    let faces = envlight::math::synth::bake(Mapping::Cube, n, n, 2, smooth_env);
    let good = tmp("good.dds");
    io::write_dds_cube(&good, n, &faces).unwrap();
    let m = io::load(&good, &LoadOptions::default()).unwrap();
    assert_eq!(m.mapping, Mapping::Cube);
    // Half floats: 11 bits of mantissa.
    for (a, b) in m.texels.iter().zip(&faces) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= b[k].abs() * 1e-3);
        }
    }
    let bytes = std::fs::read(&good).unwrap();
    for cut in [0usize, 50, 128, bytes.len() - 1] {
        let q = tmp(&format!("truncated_{cut}.dds"));
        std::fs::write(&q, &bytes[..cut]).unwrap();
        expect_error(
            &q,
            &LoadOptions::default(),
            &[if cut == 0 { "empty" } else { "dds" }],
        );
    }
    let mut absurd = bytes.clone();
    absurd[12..16].copy_from_slice(&1_000_000u32.to_le_bytes());
    absurd[16..20].copy_from_slice(&1_000_000u32.to_le_bytes());
    let q = tmp("absurd.dds");
    std::fs::write(&q, &absurd).unwrap();
    expect_error(&q, &LoadOptions::default(), &["1000000", "limit"]);
    let mut zero = bytes.clone();
    zero[16..20].copy_from_slice(&0u32.to_le_bytes());
    let q = tmp("zero.dds");
    std::fs::write(&q, &zero).unwrap();
    expect_error(&q, &LoadOptions::default(), &["zero size"]);
    // Half-float overflow: a sun of 1e5 stored as RGBA16F becomes infinite; it is refused
    // (or zeroed on request), never passed on.
    // The writer refuses to make such a file (docs/CONTRIBUTING.md "Hard cases": half-float overflow on
    // write is refused, naming the count and the largest value) ...
    let mut hot = faces.clone();
    hot[10] = [1e5, 9e4, 8e4];
    let q = tmp("overflow.dds");
    let e = io::write_dds_cube(&q, n, &hot).unwrap_err().to_string();
    assert!(
        e.contains("3 values overflow half float") && e.contains("1e5"),
        "{e}"
    );
    // ... so the reader's refusal is checked on a file whose texel 10 holds half +Inf.
    io::write_dds_cube(&q, n, &faces).unwrap();
    let mut inf = std::fs::read(&q).unwrap();
    let at = inf.len() - (faces.len() - 10) * 8;
    inf[at..at + 2].copy_from_slice(&0x7c00u16.to_le_bytes());
    std::fs::write(&q, &inf).unwrap();
    expect_error(&q, &LoadOptions::default(), &["1 infinite", "--sanitize"]);
    let fixed = io::load(&q, &zeroing()).unwrap();
    // Only the infinite channel is replaced.
    assert_eq!(fixed.texels[10][0], 0.0);
    assert!(fixed.texels[10].iter().all(|c| c.is_finite()));
    let mut fmt = bytes;
    fmt[84..88].copy_from_slice(&71u32.to_le_bytes());
    let q = tmp("bc1.dds");
    std::fs::write(&q, &fmt).unwrap();
    expect_error(&q, &LoadOptions::default(), &["unsupported"]);
}

/// Radiance .hdr and 8-bit PNG files load each texel in place: a 4 × 2 RGBE file (flat
/// scanlines) of distinct texels against c·2^(e−136) (within 0.5%: decoders differ by half a
/// mantissa step, and the mantissas here are ≥ 128), and a 2 × 2 PNG against the sRGB
/// transfer function of its bytes (1e-6).
#[test]
fn hdr_and_png_load_each_texel_in_place() {
    let (w, h) = (4u32, 2u32);
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    let rgbe = |k: u32| [128 + 10 * k, 250 - 20 * k, 140 + 7 * k, 126 + k].map(|v| v as u8);
    let mut want = Vec::new();
    for k in 0..w * h {
        let p = rgbe(k);
        bytes.extend(p);
        let scale = 2f32.powi(p[3] as i32 - 136);
        want.push([0, 1, 2].map(|c| p[c] as f32 * scale));
    }
    let p = tmp("texels.hdr");
    std::fs::write(&p, &bytes).unwrap();
    let map = io::load(&p, &LoadOptions::default()).unwrap();
    assert_eq!((map.width, map.height), (w, h));
    for (k, (got, want)) in map.texels.iter().zip(&want).enumerate() {
        for c in 0..3 {
            assert!(
                (got[c] / want[c] - 1.0).abs() < 5e-3,
                "texel {k}: {got:?} vs {want:?}"
            );
        }
    }
    let px: Vec<u8> = (0..12).map(|k| (k * 21 + 3) as u8).collect();
    let png = image::RgbImage::from_raw(2, 2, px.clone()).unwrap();
    let q = tmp("texels.png");
    png.save(&q).unwrap();
    let map = io::load(&q, &LoadOptions::default()).unwrap();
    let srgb = |v: u8| {
        let c = v as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    for (k, got) in map.texels.iter().enumerate() {
        for c in 0..3 {
            let want = srgb(px[3 * k + c]);
            assert!((got[c] as f64 - want).abs() < 1e-6, "texel {k}: {got:?}");
        }
    }
}

#[test]
fn pfm_round_trip_and_truncation() {
    let map = good_map();
    let p = tmp("good.pfm");
    io::write_pfm(&p, map.width, map.height, &map.texels).unwrap();
    let back = io::load(&p, &LoadOptions::default()).unwrap();
    assert_eq!(back, map);
    let bytes = std::fs::read(&p).unwrap();
    let q = tmp("truncated.pfm");
    std::fs::write(&q, &bytes[..bytes.len() - 4]).unwrap();
    expect_error(&q, &LoadOptions::default(), &["truncated"]);
    let q = tmp("absurd.pfm");
    std::fs::write(&q, b"PF\n1000000 1000000\n-1.0\n").unwrap();
    expect_error(&q, &LoadOptions::default(), &["limit"]);
    let q = tmp("badheader.pfm");
    std::fs::write(&q, b"PF\nabc 3\n-1.0\n").unwrap();
    expect_error(&q, &LoadOptions::default(), &["width"]);
}

#[test]
fn nan_inf_and_negative_texels_are_refused_or_sanitised() {
    let mut map = good_map();
    map.texels[5][0] = f32::NAN;
    map.texels[6][1] = f32::INFINITY;
    map.texels[7][2] = -1.0;
    map.texels[8] = [f32::NEG_INFINITY; 3];
    let p = tmp("invalid.pfm");
    io::write_pfm(&p, map.width, map.height, &map.texels).unwrap();
    expect_error(
        &p,
        &LoadOptions::default(),
        &["1 NaN", "2 infinite", "2 negative", "--sanitize"],
    );
    let opts = zeroing();
    let clean = io::load(&p, &opts).unwrap();
    let s = clean.stats();
    assert_eq!(s.nan + s.inf + s.negative, 0);
    assert_eq!(clean.texels[5], [0.0, map.texels[5][1], map.texels[5][2]]);
    assert_eq!(clean.texels[8], [0.0; 3]);
}

#[test]
fn unknown_format_and_shape_and_missing_file() {
    let p = tmp("notes.txt");
    std::fs::write(&p, b"hello").unwrap();
    expect_error(&p, &LoadOptions::default(), &["unrecognised"]);
    let q = tmp("odd.pfm");
    io::write_pfm(&q, 5, 3, &[[1.0; 3]; 15]).unwrap();
    expect_error(&q, &LoadOptions::default(), &["--mapping"]);
    let ok = io::load(&q, &LoadOptions::new(Some(Mapping::LatLong)));
    assert!(ok.is_ok());
    let bad = io::load(&q, &LoadOptions::new(Some(Mapping::Cube)));
    assert!(bad.unwrap_err().to_string().contains("cannot hold a cube"));
    expect_error(&tmp("does_not_exist.exr"), &LoadOptions::default(), &[]);
}

#[test]
fn saved_cube_and_paraboloid_load_back_with_their_mapping() {
    for m in [Mapping::Cube, Mapping::DualParaboloid, Mapping::Angular] {
        let map = EnvMap::from_fn(m, 8, 8, 2, smooth_env);
        let p = tmp(&format!("saved_{}.exr", m.name()));
        io::save_exr(&map, &p).unwrap();
        let back = io::load(&p, &LoadOptions::default()).unwrap();
        assert_eq!(back, map);
    }
}

/// A scene a renderer cannot draw is refused with the field named: a camera without a view
/// direction or with up along it, angles and sizes out of range, degenerate shapes,
/// non-finite numbers (TOML writes them as `nan` and `inf`) and misspelt keys.
#[test]
fn degenerate_scenes_are_refused() {
    let good = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/frame.toml"),
    )
    .unwrap();
    assert!(envlight::scene::Scene::parse(&good).is_ok());
    let cases: &[(&str, &str, &str)] = &[
        ("eye = [0.0, 1.0, 8.0]", "eye = [0.0, 0.0, 0.0]", "coincide"),
        (
            "eye = [0.0, 1.0, 8.0]",
            "eye = [0.0, 8.0, 0.0]",
            "along the view",
        ),
        (
            "eye = [0.0, 1.0, 8.0]",
            "eye = [0.0, nan, 8.0]",
            "not finite",
        ),
        ("fov_y = 30.0", "fov_y = 0.0", "fov_y"),
        ("fov_y = 30.0", "fov_y = 180.0", "fov_y"),
        ("fov_y = 30.0", "fov_y = nan", "fov_y"),
        ("width = 64", "width = 0", "resolution"),
        ("width = 64", "width = 100000", "resolution"),
        (
            "radius = 1.0\nmaterial = { type = \"mirror\" }",
            "radius = 0.0\nmaterial = { type = \"mirror\" }",
            "radius",
        ),
        (
            "radius = 1.0\nmaterial = { type = \"mirror\" }",
            "radius = nan\nmaterial = { type = \"mirror\" }",
            "radius",
        ),
        (
            "radius = 1.0\nmaterial = { type = \"mirror\" }",
            "radius = -1.0\nmaterial = { type = \"mirror\" }",
            "radius",
        ),
        (
            "center = [-1.1, 0.0, 0.0]",
            "center = [-1.1, inf, 0.0]",
            "center",
        ),
        (
            "rotate_y = 30.0",
            "rotate_y = inf",
            "finite number of degrees",
        ),
        (
            "rotate_y = 30.0",
            "rotate_y = 30.0\nintensity = nan",
            "intensity",
        ),
        ("alpha = 0.3", "alpha = nan", "alpha"),
        (
            "rotate_y = 30.0",
            "rotate_y = 30.0\nlight_ratio = 0.0",
            "light_ratio",
        ),
        (
            "rotate_y = 30.0",
            "rotate_y = 30.0\nlight_texels = 0",
            "light_texels",
        ),
        (
            "rotate_y = 30.0",
            "rotate_y = 30.0\nlights = \"some\"",
            "lights",
        ),
        // A misspelt key is refused where it stands: in an object as in a material.
        (
            "center = [-1.1, 0.0, 0.0]",
            "center = [-1.1, 0.0, 0.0]\ncolour = [1.0, 0.0, 0.0]",
            "colour",
        ),
        (
            "alpha = 0.3",
            "alpha = 0.3, albedoo = [1.0, 1.0, 1.0]",
            "albedoo",
        ),
    ];
    for (from, to, word) in cases {
        assert!(good.contains(from), "{from}");
        let bad = good.replacen(from, to, 1);
        let e = envlight::scene::Scene::parse(&bad)
            .err()
            .unwrap_or_else(|| panic!("accepted: {to}"));
        assert!(e.to_string().contains(word), "{to}: '{e}' lacks '{word}'");
    }
    let plane = format!(
        "{good}\n[[objects]]\nshape = \"plane\"\nnormal = [0.0, 0.0, 0.0]\noffset = -1.0\n\
         material = {{ type = \"diffuse\" }}\n"
    );
    let e = match envlight::scene::Scene::parse(&plane) {
        Ok(_) => panic!("zero normal"),
        Err(e) => e,
    };
    assert!(e.to_string().contains("normal"), "{e}");
    for boost in [0, 257] {
        let chain = format!("{good}\n[split_sum]\nrough_boost = {boost}\n");
        let e = match envlight::scene::Scene::parse(&chain) {
            Ok(_) => panic!("rough_boost {boost}"),
            Err(e) => e,
        };
        assert!(e.to_string().contains("rough_boost"), "{e}");
    }
    let boosted = format!("{good}\n[split_sum]\nrough_boost = 8\n");
    assert_eq!(
        envlight::scene::Scene::parse(&boosted)
            .map(|s| s.split_sum.rough_boost)
            .ok(),
        Some(8)
    );
}

/// Sizes beyond the device are refused with the limit named, before anything is created:
/// an image wider than maxImageDimension2D, a storage buffer over maxStorageBufferRange.
#[test]
fn sizes_beyond_the_device_are_refused() {
    let ctx = common::ctx();
    {
        let max = ctx.info().max_image_dimension_2d;
        let wide = EnvMap::new(
            Mapping::LatLong,
            max + 1,
            1,
            vec![[1.0; 3]; max as usize + 1],
        );
        let e = match envlight::GpuEnvMap::upload(&ctx, &wide) {
            Ok(_) => panic!("too wide"),
            Err(e) => e,
        };
        assert!(e.to_string().contains("largest image side"), "{e}");
        let range = ctx.info().max_storage_buffer_range;
        let e = match envlight::gpu::Buffer::new(
            &ctx,
            "too large",
            range + 1,
            ash::vk::BufferUsageFlags::STORAGE_BUFFER,
            gpu_allocator::MemoryLocation::GpuOnly,
        ) {
            Ok(_) => panic!("too large"),
            Err(e) => e,
        };
        assert!(e.to_string().contains("maxStorageBufferRange"), "{e}");
    }
    common::finish(ctx);
}

/// Load options that replace NaN, infinite and negative texels by zero.
fn zeroing() -> LoadOptions {
    let mut o = LoadOptions::default();
    o.sanitize = Sanitize::Zero;
    o
}
