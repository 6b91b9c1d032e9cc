//! The bake's gallery, `OUT/index.html`: a card per probe of the folder's manifests (its
//! preview, status, seconds, the preview's and the spot check's errors, clamped power,
//! separated lights and file sizes), sortable and filterable (failed, clamped, high error).
//! One self-contained page: inline style and script, images by relative path, nothing from
//! the network; previews load lazily, so a set of thousands opens at once. A failed probe's
//! card shows its error. The page's state is also read from its address's fragment
//! (`index.html#failed&sort=error`), so a link or a headless browser can open it filtered.

use super::manifest::{read_manifests, Entry, Manifest};
use super::preview::reference::COMPARED;
use super::preview::{PREVIEW_FILE, PREVIEW_SIZE, SPHERES};
use crate::error::Result;
use crate::io::write_atomic;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The gallery's file name in the output folder.
pub const GALLERY_FILE: &str = "index.html";

/// A card's "high error": the preview's files against intent above this (the bound a correct
/// bake keeps, `bake::preview`).
pub const HIGH_ERROR: f64 = 0.01;

/// Every probe the folder's manifests hold, one entry each (a baked or skipped one before a
/// failed one), failed probes first, then by name (the page's first order).
pub fn gallery_entries(manifests: &[Manifest]) -> Vec<Entry> {
    let mut probes: Vec<Entry> = manifests
        .iter()
        .flat_map(|m| m.probes.iter().cloned())
        .collect();
    probes.sort_by(|a, b| {
        (name(a), &a.input, a.status == "failed").cmp(&(name(b), &b.input, b.status == "failed"))
    });
    probes.dedup_by(|later, kept| later.input == kept.input);
    probes.sort_by_key(|e| (e.status != "failed", name(e)));
    probes
}

/// A probe's name: its input's file name, which is also its folder's.
fn name(e: &Entry) -> String {
    Path::new(&e.input)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| e.input.clone())
}

/// Writes `out/index.html` from the manifests in `out`; returns its path.
pub fn write_gallery(out: &Path) -> Result<PathBuf> {
    let manifests = read_manifests(out);
    let html = gallery_html(&gallery_entries(&manifests), manifests.first());
    let path = out.join(GALLERY_FILE);
    write_atomic(&path, html.as_bytes())?;
    Ok(path)
}

/// `s` with HTML's special characters escaped.
fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

fn percent(x: f64) -> String {
    format!("{:.3}%", 100.0 * x)
}

fn bytes(n: u64) -> String {
    match n {
        n if n >= 1 << 20 => format!("{:.1} MB", n as f64 / (1 << 20) as f64),
        n if n >= 1 << 10 => format!("{:.1} kB", n as f64 / 1024.0),
        n => format!("{n} B"),
    }
}

/// A number for a data attribute (sorting): finite, or −1 where absent.
fn num(x: Option<f64>) -> String {
    match x {
        Some(x) if x.is_finite() => format!("{x:e}"),
        Some(_) => "1e300".into(),
        None => "-1".into(),
    }
}

/// One probe's card.
fn card(e: &Entry) -> String {
    let name = name(e);
    let error = e.preview.as_ref().map(|p| p.worst);
    let check = e
        .check
        .as_ref()
        .map(|c| super::worse(c.irradiance, c.specular_worst()));
    let clamped = e.clamped.as_ref().map(|c| c.worst()).unwrap_or(0.0);
    let high = error.is_some_and(|x| x > HIGH_ERROR || x.is_nan());
    let mut h = String::new();
    let _ = write!(
        h,
        "<article class=\"card {status}\" data-name=\"{n}\" data-status=\"{status}\" \
         data-seconds=\"{s}\" data-error=\"{err}\" data-check=\"{chk}\" data-clamped=\"{cl}\" \
         data-high=\"{hi}\">\n<h2>{n}</h2>\n",
        status = esc(&e.status),
        n = esc(&name),
        s = num(Some(e.seconds)),
        err = num(error),
        chk = num(check),
        cl = num(Some(clamped)),
        hi = high as u8,
    );
    let preview = e
        .outputs
        .iter()
        .find(|o| o.file.ends_with(&format!("/{PREVIEW_FILE}")));
    match (preview, &e.error) {
        (_, Some(msg)) => {
            let _ = writeln!(h, "<p class=\"error\">failed: {}</p>", esc(msg));
        }
        (Some(p), None) => {
            let _ = writeln!(
                h,
                "<a href=\"{f}\"><img src=\"{f}\" alt=\"preview of {n}\" loading=\"lazy\" \
                 width=\"{w}\" height=\"{h}\"></a>",
                w = PREVIEW_SIZE.0,
                h = PREVIEW_SIZE.1,
                f = esc(&p.file),
                n = esc(&name)
            );
        }
        (None, None) => h.push_str("<p class=\"nopreview\">no preview (baked without one)</p>\n"),
    }
    h.push_str("<dl>\n");
    let mut row = |k: &str, v: String| {
        let _ = writeln!(h, "<dt>{k}</dt><dd>{v}</dd>");
    };
    row("status", esc(&e.status));
    row(
        "seconds",
        format!("{:.2} (GPU {:.1} ms)", e.seconds, e.gpu_ms),
    );
    if let Some(p) = &e.preview {
        let parts: Vec<String> = SPHERES
            .iter()
            .zip(&p.files_vs_intent)
            .map(|(s, x)| format!("{} {}", s.label().to_lowercase(), percent(*x)))
            .collect();
        row(
            "files vs intent",
            format!(
                "<b>{}</b> worst sphere ({})",
                percent(p.worst),
                parts.join(", ")
            ),
        );
        if !p.recipe_vs_reference.is_empty() {
            let parts: Vec<String> = COMPARED
                .iter()
                .zip(&p.recipe_vs_reference)
                .map(|(s, x)| format!("{} {:.1}%", s.label().to_lowercase(), 100.0 * x))
                .collect();
            row("recipe vs reference", parts.join(", "));
        }
    }
    if let Some(c) = &e.check {
        row(
            "spot check",
            format!(
                "irradiance {:.2e}, specular {:.2e} (worst level; {} texels a level)",
                c.irradiance,
                c.specular_worst(),
                c.texels
            ),
        );
    }
    row(
        "power clamped",
        if clamped > 0.0 {
            percent(clamped)
        } else {
            "0".into()
        },
    );
    if let Some(s) = e.separated {
        row(
            "power in lights.json",
            format!(
                "{} / {} / {} (r/g/b)",
                percent(s[0]),
                percent(s[1]),
                percent(s[2])
            ),
        );
    }
    if !e.outputs.is_empty() {
        let files: Vec<String> = e
            .outputs
            .iter()
            .map(|o| {
                let short = o.file.rsplit('/').next().unwrap_or(&o.file);
                format!("{} {}", esc(short), bytes(o.bytes))
            })
            .collect();
        row("files", files.join(", "));
    }
    h.push_str("</dl>\n</article>\n");
    h
}

const STYLE: &str = "body{font-family:sans-serif;margin:1em;background:#f4f4f4;color:#222}\
header{margin-bottom:1em}#controls{display:flex;gap:1em;flex-wrap:wrap;align-items:center}\
#cards{display:flex;flex-wrap:wrap;gap:1em}\
.card{background:#fff;border:1px solid #ccc;border-radius:6px;padding:.6em;width:480px}\
.card.failed{border:2px solid #c0392b;background:#fdecea}.card h2{font-size:1.05em;margin:.2em 0}\
.card img{max-width:100%;height:auto;display:block}.error{color:#c0392b;font-weight:bold}\
dl{display:grid;grid-template-columns:max-content 1fr;gap:.1em .8em;font-size:.85em;margin:.4em 0}\
dt{color:#666}dd{margin:0}";

const SCRIPT: &str = r#"(function () {
  var main = document.getElementById('cards');
  var cards = Array.prototype.slice.call(main.querySelectorAll('article.card'));
  var sort = document.getElementById('sort');
  var boxes = ['failed', 'clamped', 'high'].map(function (k) { return document.getElementById('only-' + k); });
  var count = document.getElementById('shown');
  function keep(c) {
    if (boxes[0].checked && c.dataset.status !== 'failed') return false;
    if (boxes[1].checked && !(parseFloat(c.dataset.clamped) > 0)) return false;
    if (boxes[2].checked && c.dataset.high !== '1') return false;
    return true;
  }
  function apply() {
    var key = sort.value, shown = 0;
    cards.forEach(function (c) { var k = keep(c); c.hidden = !k; if (k) shown++; });
    cards.slice().sort(function (a, b) {
      if (key === 'name') {
        var fa = a.dataset.status === 'failed' ? 0 : 1, fb = b.dataset.status === 'failed' ? 0 : 1;
        return fa !== fb ? fa - fb : a.dataset.name.localeCompare(b.dataset.name);
      }
      var d = parseFloat(b.dataset[key]) - parseFloat(a.dataset[key]);
      return d !== 0 ? d : a.dataset.name.localeCompare(b.dataset.name);
    }).forEach(function (c) { main.appendChild(c); });
    count.textContent = shown + ' of ' + cards.length + ' probes shown';
    var parts = boxes.filter(function (b) { return b.checked; }).map(function (b) { return b.id.slice(5); });
    if (key !== 'name') parts.push('sort=' + key);
    var hash = parts.length ? '#' + parts.join('&') : '';
    if (location.hash !== hash && history.replaceState) history.replaceState(null, '', hash || location.pathname);
  }
  location.hash.slice(1).split('&').forEach(function (p) {
    if (p.indexOf('sort=') === 0) { sort.value = p.slice(5); return; }
    boxes.forEach(function (b) { if (b.id === 'only-' + p) b.checked = true; });
  });
  if (!sort.value) sort.value = 'name';
  sort.addEventListener('change', apply);
  boxes.forEach(function (b) { b.addEventListener('change', apply); });
  apply();
})();"#;

/// The gallery's HTML for `entries` (from `manifest`'s settings where given).
pub fn gallery_html(entries: &[Entry], manifest: Option<&Manifest>) -> String {
    let failed = entries.iter().filter(|e| e.status == "failed").count();
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>envlight bake: {n} probes</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
         <header>\n<h1>envlight bake: {n} probes, {failed} failed</h1>\n",
        n = entries.len()
    );
    if let Some(m) = manifest {
        let s = &m.settings;
        let _ = writeln!(
            h,
            "<p>envlight {v}; {fmt} ({texels}{zstd}); preset {preset}; specular {ss}² × {lv} \
             levels, irradiance {is}²; lights {lights}.</p>",
            v = esc(&s.envlight),
            fmt = esc(&s.format),
            texels = esc(&s.texels),
            zstd = if s.zstd { ", zstd" } else { "" },
            preset = s
                .preset
                .map(|p| format!("{p:?}").to_lowercase())
                .unwrap_or_else(|| "none".into()),
            ss = s.options.specular_size,
            lv = s.options.specular_levels,
            is = s.options.irradiance_size,
            lights = format!("{:?}", s.lights).to_lowercase(),
        );
    }
    let _ = write!(
        h,
        "<p>Each preview is rendered from the files as written, read as the consumer reads \
         them: the skybox behind a mirror, white GGX metals of α 0.1, 0.3 and 0.6 (split-sum) \
         and a white diffuse sphere. <em>Files vs intent</em> is the relative RMS of those \
         spheres against the same spheres from envlight's float data before writing; above \
         {hi} a card counts as high error. <em>Recipe vs reference</em> is what the engine's \
         split-sum (and E/π) itself costs on the probe against envlight's reference, in the \
         report's view.</p>\n\
         <div id=\"controls\">\n<label>sort by <select id=\"sort\">\
         <option value=\"name\">failed first, then name</option><option value=\"error\">files vs intent</option>\
         <option value=\"check\">spot check</option><option value=\"clamped\">power clamped</option>\
         <option value=\"seconds\">seconds</option></select></label>\n\
         <label><input type=\"checkbox\" id=\"only-failed\"> failed</label>\n\
         <label><input type=\"checkbox\" id=\"only-clamped\"> clamped</label>\n\
         <label><input type=\"checkbox\" id=\"only-high\"> high error</label>\n\
         <span id=\"shown\">{n} probes</span>\n</div>\n</header>\n<main id=\"cards\">\n",
        hi = percent(HIGH_ERROR),
        n = entries.len()
    );
    for e in entries {
        h.push_str(&card(e));
    }
    let _ = write!(
        h,
        "</main>\n<script>\n{SCRIPT}\n</script>\n</body>\n</html>\n"
    );
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::manifest::Output;
    use crate::bake::preview::PreviewCheck;

    fn entry(input: &str, status: &str) -> Entry {
        let mut e = Entry::new(input.into(), "00".into(), status);
        if status == "failed" {
            e.error = Some("truncated <file> & \"more\"".into());
        } else {
            e.outputs.push(Output {
                file: format!(
                    "{}/{PREVIEW_FILE}",
                    input.rsplit('/').next().unwrap_or(input)
                ),
                bytes: 1234,
                sha256: "ab".into(),
            });
            e.preview = Some(PreviewCheck {
                files_vs_intent: vec![1e-3; 5],
                worst: 1e-3,
                exposure: 0.0,
                recipe_vs_reference: vec![0.1, 0.05, 0.03, 0.01],
            });
        }
        e
    }

    #[test]
    fn one_card_a_probe_failed_flagged_and_escaped() {
        let mut older = entry("a/x.hdr", "failed");
        older.seconds = 1.0;
        let entries = gallery_entries(&[
            Manifest {
                settings: crate::bake::manifest::Settings::of(
                    &crate::bake::plan::BakePlan::new(&Default::default()).unwrap(),
                ),
                settings_sha256: String::new(),
                shard: None,
                items: None,
                inputs: Vec::new(),
                probes: vec![entry("b/y.exr", "baked"), older],
            },
            Manifest {
                settings: crate::bake::manifest::Settings::of(
                    &crate::bake::plan::BakePlan::new(&Default::default()).unwrap(),
                ),
                settings_sha256: String::new(),
                shard: Some("2/2".into()),
                items: None,
                inputs: Vec::new(),
                probes: vec![entry("a/x.hdr", "baked"), entry("c/z.hdr", "failed")],
            },
        ]);
        // x baked in one part, failed in another: the baked entry is kept; failed first.
        let names: Vec<(String, &str)> = entries
            .iter()
            .map(|e| (name(e), e.status.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("z.hdr".into(), "failed"),
                ("x.hdr".into(), "baked"),
                ("y.exr".into(), "baked")
            ]
        );
        let html = gallery_html(&entries, None);
        assert_eq!(html.matches("<article class=\"card").count(), 3);
        assert_eq!(html.matches("<article class=\"card failed\"").count(), 1);
        assert!(html.contains("failed: truncated &lt;file&gt; &amp; &quot;more&quot;"));
        assert!(html.contains("<img src=\"x.hdr/preview.png\""));
        // The failed card has its message and no picture.
        let failed = &html[html.find("card failed").unwrap()..];
        let failed = &failed[..failed.find("</article>").unwrap()];
        assert!(failed.contains("class=\"error\"") && !failed.contains("<img"));
        // Nothing reaches the network.
        assert!(!html.contains("http:") && !html.contains("https:") && !html.contains("//cdn"));
    }

    /// A set of a thousand probes: one card each, every picture loaded lazily with its size
    /// given (so the page lays out before any loads), in a page of well under 2 MB.
    #[test]
    fn a_thousand_probes_make_one_light_page() {
        let entries: Vec<Entry> = (0..1000)
            .map(|k| {
                entry(
                    &format!("in/p{k:04}.hdr"),
                    if k % 97 == 0 { "failed" } else { "baked" },
                )
            })
            .collect();
        let html = gallery_html(&entries, None);
        assert_eq!(html.matches("<article class=\"card").count(), 1000);
        let imgs = html.matches("<img ").count();
        assert_eq!(imgs, 1000 - 11);
        assert_eq!(html.matches("loading=\"lazy\" width=").count(), imgs);
        assert!(html.len() < 2 << 20, "{} bytes", html.len());
    }
}
