//! `envlight bake` end to end: its KTX2 files read back by an independent reader, packed formats
//! to their precision, shards byte-identical to one run, reruns that resume and fail alone.

mod common;

use common::bake::{probes, small_options, temp, walk};
use common::compare::{abs_err, Errors};

use envlight::bake::{BakeOptions, Baker};
use envlight::math::Orientation;
use std::path::Path;
use std::process::{Command, Output};

const SMALL: [&str; 8] = [
    "--specular-size",
    "16",
    "--specular-levels",
    "4",
    "--irradiance-size",
    "8",
    "--samples",
    "16",
];

/// Runs `envlight bake` with [`SMALL`] sizes; when it succeeds, every KTX2 file in its output
/// folder must pass Khronos' `ktx validate`.
fn bake(args: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["--validation", "--device", "cpu", "bake"])
        .args(SMALL)
        .args(args)
        .output()
        .unwrap();
    if o.status.success() {
        if let Some(k) = args.iter().position(|a| *a == "-o" || *a == "--out") {
            common::ktx_validate_all(Path::new(args[k + 1]));
        }
    }
    o
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn statuses(out: &Path, manifest: &str) -> Vec<(String, String)> {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join(manifest)).unwrap()).unwrap();
    m["probes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["input"]
                    .as_str()
                    .unwrap()
                    .rsplit('/')
                    .next()
                    .unwrap()
                    .to_string(),
                e["status"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// Each KTX2 file loads in the `ktx2` crate with R32G32B32A32_SFLOAT (or R16G16B16A16_SFLOAT),
/// six faces, the levels asked, a linear BT.709 RGBSDA descriptor, and level data bit for bit
/// equal to what `Baker` returns for the same map (half floats: their rounding of it); with
/// `--chain`, the paraboloid MIP chain as a two-layer array with every level.
#[test]
fn ktx2_files_load_in_an_independent_reader_with_the_gpu_images() {
    let dir = temp("ktx2-in");
    let out = temp("ktx2-out");
    let maps = probes(&dir);
    ok(&bake(&[
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--dfg",
        "--chain",
    ]));
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let ctx = common::ctx();
    {
        let baker = Baker::new(&ctx).unwrap();
        let opts = small_options();
        for (k, map) in maps.iter().enumerate() {
            let baked = baker.bake(map, &Orientation::default(), &opts).unwrap();
            assert!(
                baked.chain.is_empty(),
                "a chain nobody asked for was read back"
            );
            same_check(&manifest, &format!("p{k}.exr"), map, &baked);
            // The paraboloid chain: a 2-layer array, every level, premultiplied RGBA32F as
            // the GPU holds it.
            let chained = baker
                .bake(map, &Orientation::default(), &with_chain(opts))
                .unwrap();
            let side = envlight::bake::dp_size(map, &opts);
            let bytes = std::fs::read(out.join(format!("p{k}.exr/chain.ktx2"))).unwrap();
            let r = ktx2::Reader::new(&bytes[..]).unwrap();
            let h = r.header();
            assert_eq!(h.format, Some(ktx2::Format::R32G32B32A32_SFLOAT));
            assert_eq!(
                (h.pixel_width, h.pixel_height, h.layer_count, h.face_count),
                (side, side, 2, 1)
            );
            assert_eq!(h.level_count, side.ilog2() + 1);
            assert_eq!(chained.chain.len(), h.level_count as usize);
            for (level, want) in r.levels().zip(&chained.chain) {
                let got: Vec<u32> = level
                    .data
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                    .collect();
                let want: Vec<u32> = want.iter().flatten().map(|v| v.to_bits()).collect();
                assert_eq!(got, want);
            }
            assert_eq!(chained.specular, baked.specular);
            for (file, levels, size) in [
                ("specular.ktx2", baked.specular.clone(), 16u32),
                ("irradiance.ktx2", vec![baked.irradiance.clone()], 8),
            ] {
                let bytes = std::fs::read(out.join(format!("p{k}.exr")).join(file)).unwrap();
                let r = ktx2::Reader::new(&bytes[..]).unwrap();
                let h = r.header();
                assert_eq!(h.format, Some(ktx2::Format::R32G32B32A32_SFLOAT));
                assert_eq!(
                    (h.pixel_width, h.pixel_height, h.face_count),
                    (size, size, 6)
                );
                assert_eq!((h.layer_count, h.pixel_depth), (0, 0));
                assert_eq!(h.level_count as usize, levels.len());
                let (dfd, type_size) =
                    ktx2::dfd::Basic::from_format(ktx2::Format::R32G32B32A32_SFLOAT).unwrap();
                assert_eq!((r.basic_dfd(), h.type_size), (Some(&dfd), type_size));
                assert_eq!(r.color_model(), Some(ktx2::ColorModel::RGBSDA));
                assert_eq!(r.transfer_function(), Some(ktx2::TransferFunction::Linear));
                for (level, want) in r.levels().zip(&levels) {
                    let got: Vec<f32> = level
                        .data
                        .chunks_exact(4)
                        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                        .collect();
                    let want: Vec<f32> = want.iter().flatten().copied().collect();
                    assert_eq!(got.len(), want.len());
                    assert!(got
                        .iter()
                        .zip(&want)
                        .all(|(a, b)| a.to_bits() == b.to_bits()));
                }
            }
        }
        // The DFG table: 2D, one level, A + B in (0, 1].
        let bytes = std::fs::read(out.join("dfg.ktx2")).unwrap();
        let r = ktx2::Reader::new(&bytes[..]).unwrap();
        assert_eq!(r.header().face_count, 1);
        let t: Vec<f32> = r
            .levels()
            .next()
            .unwrap()
            .data
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert!(t
            .chunks_exact(4)
            .all(|v| v[0] + v[1] > 0.0 && v[0] + v[1] <= 1.0 + 1e-5));
        // Half floats: the same images rounded to half.
        let out16 = temp("ktx2-out16");
        ok(&bake(&[
            dir.to_str().unwrap(),
            "-o",
            out16.to_str().unwrap(),
            "--texels",
            "rgba16f",
        ]));
        let baked = baker
            .bake(&maps[0], &Orientation::default(), &opts)
            .unwrap();
        let bytes = std::fs::read(out16.join("p0.exr/specular.ktx2")).unwrap();
        let r = ktx2::Reader::new(&bytes[..]).unwrap();
        assert_eq!(r.header().format, Some(ktx2::Format::R16G16B16A16_SFLOAT));
        let (dfd, type_size) =
            ktx2::dfd::Basic::from_format(ktx2::Format::R16G16B16A16_SFLOAT).unwrap();
        assert_eq!(
            (r.basic_dfd(), r.header().type_size),
            (Some(&dfd), type_size)
        );
        let level0: Vec<u16> = r
            .levels()
            .next()
            .unwrap()
            .data
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        let want: Vec<u16> = baked.specular[0]
            .iter()
            .flatten()
            .map(|&v| half::f16::from_f32(v).to_bits())
            .collect();
        assert_eq!(level0, want);
        let _ = std::fs::remove_dir_all(&out16);
    }
    common::finish(ctx);
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&out);
}

/// B10G11R11 and E5B9G9R9 files: the `ktx2` crate reads them with that format, six faces and
/// the levels asked; their header's typeSize and their whole descriptor equal what the crate
/// itself generates for the format (its own tables, written from the Khronos Data Format
/// specification); and each texel, decoded here from the formats' definitions, is the GPU's
/// image to the format's precision: half an ulp of the channel (2⁻⁷ of it for R and G's 6
/// mantissa bits, 2⁻⁶ for B's 5), or half a step of the shared exponent (the largest channel
/// / 511) for E5B9G9R9, with 2⁻²⁴ absolute where the 10- and 11-bit floats are subnormal.
#[test]
fn packed_ktx2_files_hold_the_gpu_images_to_their_precision() {
    let dir = temp("packed-in");
    let maps = probes(&dir);
    let ctx = common::ctx();
    {
        let baker = Baker::new(&ctx).unwrap();
        let baked = baker
            .bake(&maps[1], &Orientation::default(), &small_options())
            .unwrap();
        for (name, format) in [
            ("b10g11r11", ktx2::Format::B10G11R11_UFLOAT_PACK32),
            ("e5b9g9r9", ktx2::Format::E5B9G9R9_UFLOAT_PACK32),
        ] {
            let out = temp(&format!("packed-{name}"));
            ok(&bake(&[
                dir.join("p1.exr").to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--texels",
                name,
            ]));
            let bytes = std::fs::read(out.join("p1.exr/specular.ktx2")).unwrap();
            let r = ktx2::Reader::new(&bytes[..]).unwrap();
            let h = r.header();
            assert_eq!(h.format, Some(format));
            assert_eq!((h.pixel_width, h.face_count, h.level_count), (16, 6, 4));
            let (want_dfd, type_size) = ktx2::dfd::Basic::from_format(format).unwrap();
            assert_eq!(h.type_size, type_size);
            assert_eq!(r.basic_dfd(), Some(&want_dfd));
            let unfloat = |bits: u32, m: u32| -> f64 {
                let (e, q) = ((bits >> m) as i32, (bits & ((1 << m) - 1)) as f64);
                let one = (1u32 << m) as f64;
                if e == 0 {
                    2f64.powi(-14) * q / one
                } else {
                    2f64.powi(e - 15) * (1.0 + q / one)
                }
            };
            let mut worst = Errors::new();
            for (level, want) in r.levels().zip(&baked.specular) {
                assert_eq!(level.data.len(), 4 * want.len());
                for (w, t) in level.data.chunks_exact(4).zip(want) {
                    let w = u32::from_le_bytes(w.try_into().unwrap());
                    let (got, tol) = if name == "b10g11r11" {
                        let got = [
                            unfloat(w & 0x7ff, 6),
                            unfloat((w >> 11) & 0x7ff, 6),
                            unfloat(w >> 22, 5),
                        ];
                        let tol = [0, 1, 2].map(|c| {
                            t[c] as f64 * if c == 2 { 2f64.powi(-6) } else { 2f64.powi(-7) }
                                + 2f64.powi(-24)
                        });
                        (got, tol)
                    } else {
                        let scale = 2f64.powi((w >> 27) as i32 - 15 - 9);
                        let got =
                            [w & 511, (w >> 9) & 511, (w >> 18) & 511].map(|q| q as f64 * scale);
                        let top = t[0].max(t[1]).max(t[2]) as f64;
                        (got, [top / 511.0 + 1e-30; 3])
                    };
                    for c in 0..3 {
                        let e = abs_err(got[c], t[c], (&name, c));
                        assert!(e <= tol[c], "{name}: {got:?} vs {t:?}");
                        worst.add(e / (t[c] as f64).max(1e-30), c);
                    }
                }
            }
            assert!(worst.count() > 0);
            eprintln!("{name}: worst relative error {:.2e}", worst.worst());
            let _ = std::fs::remove_dir_all(&out);
        }
    }
    common::finish(ctx);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Shards 1/2 and 2/2 write every probe file byte for byte as one unsharded run does, and
/// `--merge` joins their manifests.
#[test]
fn shards_are_byte_identical_to_one_run_and_merge() {
    let dir = temp("shard-in");
    probes(&dir);
    let one = temp("shard-one");
    let two = temp("shard-two");
    let d = dir.to_str().unwrap();
    ok(&bake(&[d, "-o", one.to_str().unwrap()]));
    ok(&bake(&[d, "-o", two.to_str().unwrap(), "--shard", "1/2"]));
    ok(&bake(&[d, "-o", two.to_str().unwrap(), "--shard", "2/2"]));
    for k in 0..3 {
        for f in ["sh.json", "irradiance.ktx2", "specular.ktx2"] {
            let a = std::fs::read(one.join(format!("p{k}.exr")).join(f)).unwrap();
            let b = std::fs::read(two.join(format!("p{k}.exr")).join(f)).unwrap();
            assert!(
                a == b,
                "p{k}.exr/{f} differs between the sharded and the single run"
            );
        }
    }
    assert_eq!(statuses(&two, "manifest-shard-1-of-2.json").len(), 2);
    assert_eq!(statuses(&two, "manifest-shard-2-of-2.json").len(), 1);
    let o = Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["bake", "--merge", "-o", two.to_str().unwrap()])
        .output()
        .unwrap();
    ok(&o);
    let merged = statuses(&two, "manifest.json");
    assert_eq!(
        merged.iter().map(|m| m.0.as_str()).collect::<Vec<_>>(),
        ["p0.exr", "p1.exr", "p2.exr"]
    );
    for p in [&dir, &one, &two] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// Each baked probe's `stages` in the manifest: every host stage a finite, non-negative
/// number of seconds, at least one of them positive, the GPU's two parts adding up to its
/// `gpu_ms` (to 1e-9 relative: the same timestamps summed two ways); a skipped probe has
/// none.
fn check_stages(out: &Path) {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    for e in m["probes"].as_array().unwrap() {
        let st = &e["stages"];
        if e["status"] != "baked" {
            assert!(st.is_null(), "{e}");
            continue;
        }
        let secs = ["read", "lights", "upload", "gpu_wait", "check", "write"]
            .map(|k| st[k].as_f64().unwrap_or(f64::NAN));
        assert!(secs.iter().all(|s| s.is_finite() && *s >= 0.0), "{st}");
        assert!(secs.iter().any(|s| *s > 0.0), "{st}");
        let parts = st["gpu_convert_ms"].as_f64().unwrap() + st["gpu_filter_ms"].as_f64().unwrap();
        let whole = e["gpu_ms"].as_f64().unwrap();
        assert!(whole > 0.0, "{e}");
        let err = common::compare::rel_err(parts, whole, 1e-300, "gpu_ms");
        assert!(err < 1e-9, "{st}: {parts} ms against gpu_ms {whole}");
    }
}

/// An interrupted bake (here: one that only reached p0) resumes without redoing p0; a re-run
/// skips everything; a corrupt probe fails alone, named, with a failing exit status; --force
/// bakes again; no temporary file is left behind.
#[test]
fn reruns_resume_skip_and_fail_alone() {
    let dir = temp("rerun-in");
    probes(&dir);
    let out = temp("rerun-out");
    let o = out.to_str().unwrap();
    let first = dir.join("p0.exr");
    ok(&bake(&[first.to_str().unwrap(), "-o", o]));
    let when = std::fs::metadata(out.join("p0.exr/specular.ktx2"))
        .unwrap()
        .modified()
        .unwrap();
    ok(&bake(&[dir.to_str().unwrap(), "-o", o]));
    let s = statuses(&out, "manifest.json");
    assert_eq!(s[0], ("p0.exr".into(), "skipped".into()));
    assert!(s[1..].iter().all(|e| e.1 == "baked"), "{s:?}");
    check_stages(&out);
    assert_eq!(
        std::fs::metadata(out.join("p0.exr/specular.ktx2"))
            .unwrap()
            .modified()
            .unwrap(),
        when
    );
    // A truncated Radiance file among them.
    std::fs::write(
        dir.join("broken.hdr"),
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n\x02\x02",
    )
    .unwrap();
    let r = bake(&[dir.to_str().unwrap(), "-o", o]);
    // Only a bad input failed: retrying cannot help, and the code says so (EX_DATAERR).
    assert_eq!(r.status.code(), Some(65));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("broken.hdr") && err.contains("1 of 4 probes failed"),
        "{err}"
    );
    let s = statuses(&out, "manifest.json");
    assert_eq!(s.iter().filter(|e| e.1 == "skipped").count(), 3, "{s:?}");
    assert_eq!(s.iter().find(|e| e.0 == "broken.hdr").unwrap().1, "failed");
    std::fs::remove_file(dir.join("broken.hdr")).unwrap();
    let forced = bake(&[dir.to_str().unwrap(), "-o", o, "--force", "--check", "2"]);
    ok(&forced);
    assert!(statuses(&out, "manifest.json")
        .iter()
        .all(|e| e.1 == "baked"));
    // The summary and the manifest carry each probe's spot-checked errors.
    let summary = String::from_utf8_lossy(&forced.stdout);
    assert!(summary.contains("irradiance error"), "{summary}");
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    for e in m["probes"].as_array().unwrap() {
        let c = &e["check"];
        assert_eq!(c["texels"], 2, "{e}");
        let irr = c["irradiance"].as_f64().unwrap();
        let spec = c["specular"].as_array().unwrap();
        assert_eq!(spec.len(), 4);
        assert!(irr.is_finite() && spec.iter().all(|v| v.as_f64().unwrap().is_finite()));
    }
    let leftovers: Vec<_> = walk(&out)
        .into_iter()
        .filter(|p| p.to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    for p in [&dir, &out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// The spot check `envlight bake` recorded for `name` (its exact filters computed while the
/// GPU baked) is the library's `spot_check` of the same bake in this process: the same texels,
/// filters and cubes (a bake is deterministic), so equal but for the order in which the
/// exact filters' threads add their sums (1e-12 relative).
fn same_check(
    manifest: &serde_json::Value,
    name: &str,
    map: &envlight::EnvMap,
    baked: &envlight::bake::Baked,
) {
    let entry = manifest["probes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["input"].as_str().unwrap().ends_with(name))
        .unwrap_or_else(|| panic!("{name} is not in the manifest"));
    let got = &entry["check"];
    let want = envlight::bake::spot_check(map, &Orientation::default(), &small_options(), baked, 2);
    assert_eq!(got["texels"], 2, "{name}");
    let mut errors = Errors::new();
    let pairs = std::iter::once((&got["irradiance"], want.irradiance)).chain(
        got["specular"]
            .as_array()
            .unwrap()
            .iter()
            .zip(want.specular.iter().copied()),
    );
    for (k, (g, w)) in pairs.enumerate() {
        let g = g.as_f64().unwrap();
        errors.add(abs_err(g, w, k) / w.abs().max(1e-300), k);
    }
    assert_eq!(errors.count(), 1 + want.specular.len(), "{name}");
    errors.assert_within(1e-12, &format!("{name}: the manifest's spot check"));
}

/// `opts` with the paraboloid chain written too.
fn with_chain(mut opts: BakeOptions) -> BakeOptions {
    opts.chain = true;
    opts
}

/// Runs `envlight bake` as a job array's task: [`SMALL`] sizes, the scheduler's variables in
/// its environment (none of the others).
fn bake_as_task(args: &[&str], vars: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_envlight"));
    c.args(["--validation", "--device", "cpu", "bake"])
        .args(SMALL)
        .args(args);
    for v in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_MAX",
        "SLURM_ARRAY_TASK_STEP",
        "JOB_COMPLETION_INDEX",
        "AWS_BATCH_JOB_ARRAY_INDEX",
        "AWS_BATCH_JOB_ARRAY_SIZE",
        "BATCH_TASK_INDEX",
        "BATCH_TASK_COUNT",
    ] {
        c.env_remove(v);
    }
    c.envs(vars.iter().copied()).output().unwrap()
}

fn merge_into(out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["bake", "--merge", "-o", out.to_str().unwrap()])
        .output()
        .unwrap()
}

/// What a scheduler sees: `--shard auto` takes the task from Slurm's variables, then from a
/// Kubernetes index with the split the first shard recorded; a merge before the second shard
/// names the probe it lacks and exits 75 (retry), after it 0; a shard of another split into
/// the same folder is refused; a set whose only failure is a truncated input merges with 65
/// (retrying cannot help) and names it.
#[test]
fn scheduled_shards_merge_and_say_what_is_missing() {
    let dir = temp("sched-in");
    probes(&dir);
    let out = temp("sched-out");
    let (d, o) = (dir.to_str().unwrap(), out.to_str().unwrap());
    let slurm = [
        ("SLURM_ARRAY_TASK_ID", "0"),
        ("SLURM_ARRAY_TASK_COUNT", "2"),
    ];
    ok(&bake_as_task(&[d, "-o", o, "--shard", "auto"], &slurm));
    assert_eq!(statuses(&out, "manifest-shard-1-of-2.json").len(), 2);
    let early = merge_into(&out);
    let said = String::from_utf8_lossy(&early.stdout);
    assert_eq!(early.status.code(), Some(75), "{said}");
    assert!(
        said.contains("missing: ") && said.contains("p1.exr (shard 2"),
        "{said}"
    );
    // Another split into the same folder is refused, naming the one there.
    let other = bake_as_task(&[d, "-o", o, "--shard", "1/3"], &[]);
    let err = String::from_utf8_lossy(&other.stderr);
    assert_eq!(other.status.code(), Some(1), "{err}");
    assert!(err.contains("split into 2"), "{err}");
    // Kubernetes gives only the index: n comes from the shard manifest already there.
    ok(&bake_as_task(
        &[d, "-o", o, "--shard", "auto"],
        &[("JOB_COMPLETION_INDEX", "1")],
    ));
    ok(&merge_into(&out));
    assert_eq!(statuses(&out, "manifest.json").len(), 3);

    // A set with a truncated probe, sharded by AWS Batch's variables.
    let bad = temp("sched-bad-in");
    std::fs::copy(dir.join("p0.exr"), bad.join("p0.exr")).unwrap();
    std::fs::write(
        bad.join("broken.hdr"),
        b"#?RADIANCE\n\n-Y 8 +X 16\n\x02\x02",
    )
    .unwrap();
    let bad_out = temp("sched-bad-out");
    let (bd, bo) = (bad.to_str().unwrap(), bad_out.to_str().unwrap());
    for index in ["0", "1"] {
        let aws = [
            ("AWS_BATCH_JOB_ARRAY_INDEX", index),
            ("AWS_BATCH_JOB_ARRAY_SIZE", "2"),
        ];
        let r = bake_as_task(&[bd, "-o", bo, "--shard", "auto"], &aws);
        // broken.hdr sorts first: shard 1 holds it alone.
        let want = if index == "0" { Some(65) } else { Some(0) };
        assert_eq!(
            r.status.code(),
            want,
            "{}",
            String::from_utf8_lossy(&r.stderr)
        );
    }
    let m = merge_into(&bad_out);
    let said = String::from_utf8_lossy(&m.stdout);
    assert_eq!(m.status.code(), Some(65), "{said}");
    assert!(
        said.contains("failed: ") && said.contains("broken.hdr (bad input)"),
        "{said}"
    );
    for p in [&dir, &out, &bad, &bad_out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// A bake that lands on a CPU implementation without being asked (a farm's container
/// without the GPU's graphics driver) says so and why; `--require-gpu` refuses it with 75,
/// as for a missing device. On a machine whose loader sees a GPU, both bake on the GPU.
#[test]
fn a_cpu_device_is_named_or_refused() {
    let dir = temp("gpu-in");
    probes(&dir);
    let out = temp("gpu-out");
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_envlight"))
            .env_remove("ENVLIGHT_DEVICE")
            .args(["--validation", "bake"])
            .args(SMALL)
            .args([
                dir.join("p0.exr").to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .args(["--force"])
            .args(extra)
            .output()
            .unwrap()
    };
    let devices = Command::new(env!("CARGO_BIN_EXE_envlight"))
        .env_remove("ENVLIGHT_DEVICE")
        .arg("devices")
        .output()
        .unwrap();
    let on_cpu = String::from_utf8_lossy(&devices.stdout).contains("(CPU)");
    let plain = run(&[]);
    let required = run(&["--require-gpu"]);
    let (warned, refused) = (
        String::from_utf8_lossy(&plain.stderr).to_string(),
        String::from_utf8_lossy(&required.stderr).to_string(),
    );
    if on_cpu {
        ok(&plain);
        assert!(
            warned.contains("CPU implementation") && warned.contains("NVIDIA_DRIVER_CAPABILITIES"),
            "{warned}"
        );
        assert_eq!(required.status.code(), Some(75), "{refused}");
        assert!(refused.contains("--require-gpu"), "{refused}");
    } else {
        ok(&plain);
        ok(&required);
        assert!(!warned.contains("CPU implementation"), "{warned}");
    }
    for p in [&dir, &out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// Frame-range schedulers (Deadline, OpenCue, OpenJD) hand out `--items A-B`: a range past
/// the inputs is refused; after 1-2 a merge names the third probe as missing (75); after
/// 3 as well the set is complete (0), each probe once.
#[test]
fn item_ranges_bake_parts_that_merge() {
    let dir = temp("items-in");
    probes(&dir);
    let out = temp("items-out");
    let (d, o) = (dir.to_str().unwrap(), out.to_str().unwrap());
    let past = bake(&[d, "-o", o, "--items", "2-4"]);
    let err = String::from_utf8_lossy(&past.stderr);
    assert_eq!(past.status.code(), Some(1), "{err}");
    assert!(err.contains("only 3 inputs"), "{err}");
    ok(&bake(&[d, "-o", o, "--items", "1-2"]));
    assert_eq!(statuses(&out, "manifest-items-1-2.json").len(), 2);
    let early = merge_into(&out);
    let said = String::from_utf8_lossy(&early.stdout);
    assert_eq!(early.status.code(), Some(75), "{said}");
    assert!(said.contains("p2.exr (item 3"), "{said}");
    ok(&bake(&[d, "-o", o, "--items", "3"]));
    ok(&merge_into(&out));
    let merged = statuses(&out, "manifest.json");
    assert_eq!(
        merged.iter().map(|m| m.0.as_str()).collect::<Vec<_>>(),
        ["p0.exr", "p1.exr", "p2.exr"]
    );
    for p in [&dir, &out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// The farm recipes docs/bake.md points to, run as their schedulers would run them on this
/// machine: docs/farm/slurm.sbatch once per task of its `#SBATCH --array` (the task's
/// SLURM_ARRAY_* variables set as Slurm sets them, small sizes through ENVLIGHT_BAKE_FLAGS in
/// place of its default --require-gpu: this machine's device is a CPU), then the merge; and
/// docs/farm/indexed-job.yaml's container command once per completion index (its paths mapped
/// to folders here, --require-gpu dropped for the same reason). Both sets merge complete
/// (exit 0) and their files are byte-identical. (A real Slurm or Kubernetes is not run.)
#[test]
fn farm_recipes_in_the_docs_bake_a_set() {
    let dir = temp("farm-in");
    probes(&dir);
    let bin = Path::new(env!("CARGO_BIN_EXE_envlight"));
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/farm");
    let script = std::fs::read_to_string(docs.join("slurm.sbatch")).unwrap();
    let array = script
        .lines()
        .find_map(|l| l.strip_prefix("#SBATCH --array="))
        .expect("an #SBATCH --array line");
    let (lo, hi) = array.split_once('-').unwrap();
    let (lo, hi): (u32, u32) = (lo.parse().unwrap(), hi.parse().unwrap());
    let slurm_out = temp("farm-slurm");
    for task in lo..=hi {
        let o = Command::new("bash")
            .arg(docs.join("slurm.sbatch"))
            .env("PATH", &path)
            .env("ENVLIGHT_DEVICE", "cpu")
            .env("ENVLIGHT_BAKE_FLAGS", SMALL.join(" "))
            .env("PROBES", &dir)
            .env("OUT", &slurm_out)
            .env("SLURM_ARRAY_TASK_ID", task.to_string())
            .env("SLURM_ARRAY_TASK_MIN", lo.to_string())
            .env("SLURM_ARRAY_TASK_MAX", hi.to_string())
            .env("SLURM_ARRAY_TASK_COUNT", (hi - lo + 1).to_string())
            .output()
            .unwrap();
        ok(&o);
    }
    ok(&merge_into(&slurm_out));
    assert_eq!(statuses(&slurm_out, "manifest.json").len(), 3);

    let job = std::fs::read_to_string(docs.join("indexed-job.yaml")).unwrap();
    let completions: u32 = job
        .lines()
        .find_map(|l| l.trim().strip_prefix("completions:"))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let command: Vec<String> = job
        .lines()
        .find_map(|l| l.trim().strip_prefix("command:"))
        .map(|c| serde_json::from_str(c.trim()).unwrap())
        .expect("a container command");
    assert!(
        command.contains(&format!("auto/{completions}")),
        "{command:?}"
    );
    let k8s_out = temp("farm-k8s");
    for index in 0..completions {
        let args: Vec<String> = command[1..]
            .iter()
            .filter(|a| *a != "--require-gpu")
            .map(|a| match a.as_str() {
                "/probes" => dir.display().to_string(),
                "/out" => k8s_out.display().to_string(),
                _ => a.clone(),
            })
            .collect();
        let o = Command::new(bin)
            .args(["--device", "cpu"])
            .args(&args)
            .args(SMALL)
            .env("JOB_COMPLETION_INDEX", index.to_string())
            .output()
            .unwrap();
        ok(&o);
    }
    ok(&merge_into(&k8s_out));
    for k in 0..3 {
        for f in ["sh.json", "irradiance.ktx2", "specular.ktx2"] {
            let p = format!("p{k}.exr/{f}");
            let a = std::fs::read(slurm_out.join(&p)).unwrap();
            assert!(a == std::fs::read(k8s_out.join(&p)).unwrap(), "{p} differs");
        }
    }
    for p in [&dir, &slurm_out, &k8s_out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// A source past `--max-source-side` (or the device's largest image) is reduced before its
/// bake, never refused: with a limit of 32, the two 64 × 32 probes bake at 32 × 16 and the
/// 48 × 24 one at 24 × 12 (the means of 2 × 2 blocks), each noted in the manifest and the
/// summary, and their files are byte-identical to bakes of those block means written as
/// float32 EXR; the limit is a setting, so a run without it bakes them again.
#[test]
fn sources_past_the_largest_side_are_reduced_not_refused() {
    let dir = temp("reduce-in");
    let maps = probes(&dir);
    let out = temp("reduce-out");
    let o = bake(&[
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--max-source-side",
        "32",
    ]);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let want = [
        ([64, 32], [32, 16]),
        ([64, 32], [32, 16]),
        ([48, 24], [24, 12]),
    ];
    let means = temp("reduce-means");
    for (k, (e, (from, to))) in m["probes"].as_array().unwrap().iter().zip(want).enumerate() {
        let r = &e["reduced"];
        assert_eq!(r["from"], serde_json::json!(from), "{e}");
        assert_eq!(r["to"], serde_json::json!(to), "{e}");
        assert_eq!(r["how"], "blocks 2", "{e}");
        assert!(
            stdout.contains(&format!("p{k}.exr baked at {} × {}", to[0], to[1])),
            "{stdout}"
        );
        let (small, _) = envlight::math::lights::block_means(&maps[k], 2, f64::INFINITY).unwrap();
        envlight::io::save_exr(&small, means.join(format!("p{k}.exr"))).unwrap();
    }
    let direct = temp("reduce-direct");
    ok(&bake(&[
        means.to_str().unwrap(),
        "-o",
        direct.to_str().unwrap(),
    ]));
    for k in 0..3 {
        for f in ["sh.json", "irradiance.ktx2", "specular.ktx2"] {
            let p = format!("p{k}.exr/{f}");
            let a = std::fs::read(out.join(&p)).unwrap();
            assert!(a == std::fs::read(direct.join(&p)).unwrap(), "{p} differs");
        }
    }
    ok(&bake(&[dir.to_str().unwrap(), "-o", out.to_str().unwrap()]));
    let s = statuses(&out, "manifest.json");
    assert!(s.iter().all(|e| e.1 == "baked"), "{s:?}");
    for p in [&dir, &out, &means, &direct] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// Large probes (over 4 Mi texels) bake one at a time, the next read only once the last is
/// finished, and small ones between them still overlap: a set of a large, a small and a
/// large map bakes all three, and the first's files are byte-identical to its bake alone.
#[test]
fn large_probes_bake_alone_in_a_set() {
    use envlight::math::synth::Sky;
    use envlight::{EnvMap, Mapping};
    let dir = temp("large-in");
    let sky = Sky::default();
    for (name, w) in [("a.exr", 2900), ("b.exr", 64), ("c.exr", 2900)] {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 1, move |d| sky.radiance(d));
        envlight::io::save_exr(&map, dir.join(name)).unwrap();
    }
    let out = temp("large-out");
    ok(&bake(&[
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--check",
        "0",
    ]));
    let s = statuses(&out, "manifest.json");
    assert_eq!(s.len(), 3, "{s:?}");
    assert!(s.iter().all(|e| e.1 == "baked"), "{s:?}");
    let alone = temp("large-alone");
    let a = dir.join("a.exr");
    ok(&bake(&[
        a.to_str().unwrap(),
        "-o",
        alone.to_str().unwrap(),
        "--check",
        "0",
    ]));
    for f in ["sh.json", "irradiance.ktx2", "specular.ktx2"] {
        let p = format!("a.exr/{f}");
        let x = std::fs::read(out.join(&p)).unwrap();
        assert!(x == std::fs::read(alone.join(&p)).unwrap(), "{p} differs");
    }
    for p in [&dir, &out, &alone] {
        let _ = std::fs::remove_dir_all(p);
    }
}
