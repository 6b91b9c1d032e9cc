//! The lab's commands end to end, each as `cargo xtask lab` runs it: `accuracy`, `scale`
//! (which bakes with the `envlight` program beside the lab), `formats`, `dynamic` and
//! `peers`' refusal without a map.

use envlight::math::synth::smooth_env;
use envlight::math::Mapping;
use envlight::EnvMap;
use std::path::PathBuf;
use std::process::{Command, Output};

fn lab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_envlight-lab"))
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn temp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("lab-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The page section `envlight-lab ARGS --out PAGE` writes into a fresh page (the command must
/// succeed).
fn lab_page(tag: &str, args: &[&str]) -> String {
    let page = temp(tag).join("page.md");
    let o = lab().args(args).arg("--out").arg(&page).output().unwrap();
    ok(&o);
    std::fs::read_to_string(&page).unwrap()
}

/// `accuracy` on a smooth map: one unwindowed row per order it reports (0, 1, 2, 4, 6, 8),
/// every RMS error finite and order 8's under a tenth of order 0's, and its three files.
#[test]
fn accuracy_writes_a_row_per_order() {
    let dir = temp("accuracy");
    let input = dir.join("smooth.exr");
    let map = EnvMap::from_fn(Mapping::LatLong, 48, 24, 2, smooth_env);
    envlight::io::save_exr(&map, &input).unwrap();
    let acc = dir.join("acc");
    let o = lab()
        .args(["--validation", "accuracy"])
        .arg(&input)
        .args(["--size", "2", "--out"])
        .arg(&acc)
        .output()
        .unwrap();
    ok(&o);
    let csv = std::fs::read_to_string(acc.join("accuracy.csv")).unwrap();
    let rms: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[4] == "0")
        .map(|f| f[5].parse().unwrap())
        .collect();
    assert_eq!(rms.len(), [0, 1, 2, 4, 6, 8].len());
    assert!(
        rms.iter().all(|r| r.is_finite()) && rms[5] < 0.1 * rms[0],
        "{rms:?}"
    );
    assert!(acc.join("accuracy.png").is_file());
    assert!(acc.join("accuracy.md").is_file());
}

/// `peers` reads the user's map from a flag, never from a path of the developers' checkout:
/// without `--map` it says what it needs.
#[test]
fn peers_needs_a_map() {
    let o = lab().arg("peers").output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--map"), "{err}");
}

/// `scale` on the bundled sky at ×1 and ×2 writes its page section: a row per factor with the
/// source's size, and every figure in it a finite number (seconds, peak RSS and bytes a texel
/// positive: the child's `wait4` figures were read).
#[test]
fn scale_writes_a_row_per_factor() {
    let sky = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/sky_latlong.exr");
    let sky = sky.to_str().unwrap();
    let text = lab_page(
        "scale",
        &["--device", "cpu", "scale", sky, "--factors", "1,2"],
    );
    assert!(text.contains("<!-- bench:bake-scale -->"), "{text}");
    for size in ["512 × 256", "1024 × 512"] {
        let row = text
            .lines()
            .find(|l| l.starts_with(&format!("| {size} |")))
            .unwrap_or_else(|| panic!("no row for {size}: {text}"));
        let cells: Vec<&str> = row
            .split('|')
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .collect();
        assert_eq!(cells.len(), 12, "{row}");
        let number = |c: &str| c.split_whitespace().next().unwrap().parse::<f64>().unwrap();
        for c in &cells[1..4] {
            let v = number(c);
            assert!(v.is_finite() && v > 0.0, "{row}: {c}");
        }
        for c in &cells[4..] {
            for part in c.split('/') {
                let v = number(part.trim());
                assert!(v.is_finite() && v >= 0.0, "{row}: {c}");
            }
        }
    }
}

/// `formats` on a small probe: a performance page (device, CPU, the job's section with its
/// command) with a section per format and the probe's row, sizes in the ratios the formats'
/// texel sizes give (rgba16f one half of rgba32f, the packed formats and BC6H about a quarter
/// and a sixteenth, headers aside), and rgba16f's errors within half an ulp (2⁻¹¹ relative).
#[test]
fn formats_reports_every_format() {
    let dir = temp("formats");
    let p = dir.join("smooth.exr");
    envlight::io::save_exr(
        &EnvMap::from_fn(Mapping::LatLong, 64, 32, 1, smooth_env),
        &p,
    )
    .unwrap();
    let p = p.to_str().unwrap();
    let md = lab_page(
        "formats-page",
        &[
            "--validation",
            "--device",
            "cpu",
            "formats",
            p,
            "--specular-size",
            "32",
            "--specular-levels",
            "4",
            "--irradiance-size",
            "8",
        ],
    );
    assert!(
        md.starts_with("# envlight on ") && md.contains("\nDevice: "),
        "{md}"
    );
    assert!(
        md.contains("<!-- bench:formats -->\n## KTX2 texel formats"),
        "{md}"
    );
    assert!(
        md.contains("\nCommit ")
            && md.contains("`cargo xtask lab --validation --device cpu formats"),
        "{md}"
    );
    for (format, ratio) in [
        ("rgba16f", 0.5),
        ("b10g11r11", 0.25),
        ("e5b9g9r9", 0.25),
        ("bc6h", 0.0625),
    ] {
        let section = md.split(&format!("### {format}\n")).nth(1).unwrap();
        let row = section
            .lines()
            .find(|l| l.starts_with("| smooth.exr"))
            .unwrap();
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let of_full: f64 = cells[3].parse().unwrap();
        assert!((of_full - ratio).abs() < 0.03, "{format}: {row}");
        if format == "rgba16f" {
            let worst: f64 = cells[5].split('/').nth(1).unwrap().trim().parse().unwrap();
            assert!(worst <= 2f64.powi(-11) * 1.01, "{row}");
        }
    }
}

/// `dynamic --slices 2` writes the library's report (what `envlight bench dynamic` prints)
/// as the page's "dynamic-sliced" section: its title, its command, its method and, per
/// input, its six rows.
#[test]
fn dynamic_writes_the_programs_tables_as_its_section() {
    let text = lab_page(
        "dynamic",
        &[
            "--validation",
            "--device",
            "cpu",
            "dynamic",
            "--cubes",
            "16",
            "--widths",
            "64",
            "--chain",
            "64",
            "--reps",
            "1",
            "--slices",
            "2",
        ],
    );
    assert!(
        text.contains("<!-- bench:dynamic-sliced -->\n## An environment that changes every frame, its chain time-sliced"),
        "{text}"
    );
    assert!(
        text.contains("Method: Three frames, the sun 25° further round each")
            && text.contains("Time-sliced:"),
        "{text}"
    );
    assert!(
        text.contains("`cargo xtask lab --validation --device cpu dynamic --cubes 16"),
        "{text}"
    );
    for input in ["cube 16x16", "latlong 64x32"] {
        let rows = text
            .lines()
            .filter(|l| l.starts_with(&format!("| {input} |")));
        assert_eq!(rows.count(), 6, "{text}");
    }
}
