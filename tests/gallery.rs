//! The bake's gallery (`OUT/index.html`) opened in a real browser: headless Chromium (Debian's
//! `chromium`, which `cargo xtask setup` installs) loads the gallery of a small bake of three
//! probes, one of them a truncated file, and the page it builds is checked: a card a probe,
//! the failed one flagged with its message, the filters (through the page's fragment) showing
//! what they say, no console message, and a screenshot that is not blank.

mod common;

use common::bake::{probes, temp};
use envlight::bake::plan::{BakePlan, BakeSettings};
use envlight::bake::set::{Part, ProbeSet, SetBake, Silent};
use envlight::bake::Baker;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Chromium: `ENVLIGHT_CHROMIUM`, else `chromium` on the PATH. `None` (noted as a skip) where
/// neither is there, except in CI (`CI` set), where it fails the test.
fn chromium() -> Option<PathBuf> {
    let p = std::env::var_os("ENVLIGHT_CHROMIUM")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("PATH").and_then(|paths| {
                std::env::split_paths(&paths)
                    .map(|d| d.join("chromium"))
                    .find(|p| p.is_file())
            })
        });
    if p.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but chromium is not installed (`cargo xtask setup` installs it)"
        );
        common::skipped("chromium is not installed: the gallery was not opened in a browser");
    }
    p
}

/// Runs headless Chromium on `url` with `args`; returns (stdout, console lines from stderr).
fn browse(chromium: &Path, profile: &Path, url: &str, args: &[&str]) -> (String, Vec<String>) {
    let o = Command::new("timeout")
        .arg("120")
        .arg(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .output()
        .expect("timeout(1) runs chromium");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success(),
        "chromium failed ({}):\n{stderr}",
        o.status
    );
    let console = stderr
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(str::to_string)
        .collect();
    (String::from_utf8_lossy(&o.stdout).into_owned(), console)
}

/// The cards of a dumped DOM: (opening tag, shown).
fn cards(dom: &str) -> Vec<(String, bool)> {
    dom.match_indices("<article class=\"card")
        .map(|(k, _)| {
            let tag = &dom[k..k + dom[k..].find('>').unwrap()];
            (tag.to_string(), !tag.contains(" hidden"))
        })
        .collect()
}

fn shown(dom: &str) -> &str {
    let k = dom.find("id=\"shown\">").expect("the count") + "id=\"shown\">".len();
    &dom[k..k + dom[k..].find('<').unwrap()]
}

#[test]
fn the_gallery_opens_in_chromium_with_every_card_and_working_filters() {
    let Some(chromium) = chromium() else {
        return;
    };
    let dir = temp("gallery");
    let (inputs, out) = (dir.join("in"), dir.join("out"));
    std::fs::create_dir_all(&inputs).unwrap();
    probes(&inputs);
    // The third probe truncated, as a copy cut short leaves it.
    let whole = std::fs::read(inputs.join("p2.exr")).unwrap();
    std::fs::write(inputs.join("p2.exr"), &whole[..whole.len() / 3]).unwrap();

    let ctx = common::ctx();
    {
        let mut s = BakeSettings::default();
        (
            s.specular_size,
            s.specular_levels,
            s.irradiance_size,
            s.samples,
        ) = (Some(16), Some(4), Some(8), Some(16));
        let plan = BakePlan::new(&s).unwrap();
        let set = ProbeSet::new([
            inputs.join("p0.exr"),
            inputs.join("p1.exr"),
            inputs.join("p2.exr"),
        ])
        .unwrap();
        let baker = Baker::new(&ctx).unwrap();
        SetBake::new(&set, &plan, &out, Part::All)
            .unwrap()
            .run(&ctx, &baker, false, &Silent)
            .unwrap();
    }
    common::finish(ctx);
    let page = out.join("index.html");
    assert!(page.is_file());
    let url = format!("file://{}", page.display());
    let profile = dir.join("profile");

    let (dom, console) = browse(&chromium, &profile, &url, &["--dump-dom"]);
    assert!(
        console.is_empty(),
        "console messages:\n{}",
        console.join("\n")
    );
    let all = cards(&dom);
    assert_eq!(all.len(), 3, "{dom}");
    assert!(all.iter().all(|(_, shown)| *shown));
    assert_eq!(shown(&dom), "3 of 3 probes shown");
    let failed: Vec<&(String, bool)> = all
        .iter()
        .filter(|(t, _)| t.contains("card failed"))
        .collect();
    assert_eq!(failed.len(), 1, "{all:?}");
    assert!(failed[0].0.contains("data-name=\"p2.exr\""));
    assert!(
        dom.contains("failed: ") && dom.contains("p2.exr"),
        "the failed card names its error"
    );
    // The good probes show their previews, which exist beside the page.
    for p in ["p0.exr", "p1.exr"] {
        assert!(
            dom.contains(&format!("src=\"{p}/preview.png\"")),
            "{p}'s preview"
        );
        assert!(out.join(p).join("preview.png").is_file());
    }

    // Filters, through the fragment the page reads on load.
    let (dom, console) = browse(
        &chromium,
        &profile,
        &format!("{url}#failed"),
        &["--dump-dom"],
    );
    assert!(console.is_empty(), "{console:?}");
    let visible: Vec<String> = cards(&dom)
        .into_iter()
        .filter(|c| c.1)
        .map(|c| c.0)
        .collect();
    assert_eq!(visible.len(), 1, "{visible:?}");
    assert!(visible[0].contains("p2.exr"));
    assert_eq!(shown(&dom), "1 of 3 probes shown");
    let (dom, _) = browse(&chromium, &profile, &format!("{url}#high"), &["--dump-dom"]);
    assert_eq!(
        shown(&dom),
        "0 of 3 probes shown",
        "a correct bake has no high error"
    );
    let (dom, _) = browse(
        &chromium,
        &profile,
        &format!("{url}#sort=seconds"),
        &["--dump-dom"],
    );
    let order: Vec<String> = cards(&dom).into_iter().map(|c| c.0).collect();
    let seconds: Vec<f64> = order
        .iter()
        .map(|t| {
            let k = t.find("data-seconds=\"").unwrap() + 14;
            t[k..k + t[k..].find('"').unwrap()].parse().unwrap()
        })
        .collect();
    assert!(seconds.windows(2).all(|w| w[0] >= w[1]), "{seconds:?}");

    // A screenshot: the page draws, with its previews.
    let shot = dir.join("shot.png");
    let arg = format!("--screenshot={}", shot.display());
    browse(
        &chromium,
        &profile,
        &url,
        &[&arg, "--window-size=1200,1400", "--hide-scrollbars"],
    );
    let img = image::open(&shot).unwrap().into_rgb8();
    let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(
        colours.len() > 2000,
        "a blank page? {} colours",
        colours.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
