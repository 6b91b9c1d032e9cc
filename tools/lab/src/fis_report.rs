//! The tables and the plot of `envlight-lab fis` (see [`super::fis`] for the runs).

use crate::fis::{materials, Row};

/// The rows as CSV.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("map,material,size,technique,samples,bias,gpu_ms,relative_rms\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{},{:.4},{:.6}\n",
            r.map, r.material, r.size, r.technique, r.samples, r.bias, r.ms, r.rms
        );
    }
    s
}

/// Plain MC samples needed to match an error, by log-log interpolation of the MC curve, and
/// the time that takes; None when even the largest count does not reach it.
pub fn mc_to_match(mc: &[&Row], target: f64) -> Option<(f64, f64)> {
    for w in mc.windows(2) {
        let (a, b) = (w[0], w[1]);
        if a.rms >= target && b.rms <= target {
            let t = if (a.rms / b.rms).ln().abs() < 1e-12 {
                0.0
            } else {
                (a.rms / target).ln() / (a.rms / b.rms).ln()
            };
            let n =
                (a.samples as f64).ln() + t * ((b.samples as f64).ln() - (a.samples as f64).ln());
            let ms = a.ms.ln() + t * (b.ms.ln() - a.ms.ln());
            return Some((n.exp(), ms.exp()));
        }
    }
    mc.first()
        .filter(|a| a.rms <= target)
        .map(|a| (a.samples as f64, a.ms))
}

/// A markdown report: the full table, the bias sweep, and the headline (MC samples and time
/// to match FIS at 16 and 64).
pub fn markdown(rows: &[Row], device: &str) -> String {
    let mut s = format!("Device: {device}. Relative RMS of luminance over the sphere against MIS Monte Carlo; GPU ms from timestamp queries.\n\n");
    s += "| map | material | size | technique | N | bias | GPU ms | rel. RMS |\n|---|---|---|---|---|---|---|---|\n";
    for r in rows.iter().filter(|r| r.technique != "fis-bias") {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {:.3} | {:.4} |\n",
            r.map,
            r.material,
            r.size,
            r.technique,
            r.samples,
            if r.technique == "fis" {
                format!("{}", r.bias)
            } else {
                "-".into()
            },
            r.ms,
            r.rms
        );
    }
    let sweep: Vec<&Row> = rows.iter().filter(|r| r.technique == "fis-bias").collect();
    if !sweep.is_empty() {
        s += "\n### Lod bias sweep (relative RMS, mean over maps and materials)\n\n| N | bias | mean rel. RMS |\n|---|---|---|\n";
        let mut keys: Vec<(u32, f64)> = sweep.iter().map(|r| (r.samples, r.bias)).collect();
        keys.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        keys.dedup();
        for (n, b) in keys {
            let v: Vec<f64> = sweep
                .iter()
                .filter(|r| r.samples == n && r.bias == b)
                .map(|r| r.rms)
                .collect();
            s += &format!(
                "| {n} | {b} | {:.4} |\n",
                v.iter().sum::<f64>() / v.len() as f64
            );
        }
    }
    s += "\n### Headline: plain MC samples to match FIS\n\n| map | material | size | FIS N | FIS rel. RMS | FIS ms | MC N to match | MC ms | time ratio MC/FIS |\n|---|---|---|---|---|---|---|---|---|\n";
    for f in rows
        .iter()
        .filter(|r| r.technique == "fis" && (r.samples == 16 || r.samples == 64))
    {
        let mc: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                r.technique == "mc"
                    && r.map == f.map
                    && r.material == f.material
                    && r.size == f.size
            })
            .collect();
        match mc_to_match(&mc, f.rms) {
            Some((n, ms)) => {
                s += &format!(
                    "| {} | {} | {} | {} | {:.4} | {:.3} | {:.0} | {:.3} | {:.1} |\n",
                    f.map,
                    f.material,
                    f.size,
                    f.samples,
                    f.rms,
                    f.ms,
                    n,
                    ms,
                    ms / f.ms
                )
            }
            None => {
                s += &format!(
                    "| {} | {} | {} | {} | {:.4} | {:.3} | > {} | - | - |\n",
                    f.map,
                    f.material,
                    f.size,
                    f.samples,
                    f.rms,
                    f.ms,
                    mc.last().map(|r| r.samples).unwrap_or(0)
                )
            }
        }
    }
    s
}

/// Relative RMS error (y, log, a gridline per decade) against GPU ms (x, log, a gridline per
/// decade), one curve per (technique, material, map, size), coloured by material in the
/// accuracy plot's palette: FIS solid with filled points, plain MC dotted with hollow points.
pub fn plot(rows: &[Row]) -> image::RgbImage {
    let (w, h, m) = (720u32, 480u32, 40.0f64);
    let mut img = image::RgbImage::from_pixel(w, h, image::Rgb([255, 255, 255]));
    let pts: Vec<&Row> = rows
        .iter()
        .filter(|r| r.technique != "fis-bias" && r.ms > 0.0 && r.rms > 0.0)
        .collect();
    if pts.is_empty() {
        return img;
    }
    let (lx0, lx1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
        (a.min(r.ms.log10()), b.max(r.ms.log10()))
    });
    let (ly0, ly1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
        (a.min(r.rms.log10()), b.max(r.rms.log10()))
    });
    let (lx0, lx1, ly0, ly1) = (lx0.floor(), lx1.ceil(), ly0.floor(), ly1.ceil());
    let x_of = |ms: f64| m + (ms.log10() - lx0) / (lx1 - lx0).max(1e-9) * (w as f64 - 2.0 * m);
    let y_of = |e: f64| m + (ly1 - e.log10()) / (ly1 - ly0).max(1e-9) * (h as f64 - 2.0 * m);
    let put = |img: &mut image::RgbImage, x: i32, y: i32, c: [u8; 3]| {
        if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
            img.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    };
    for d in lx0 as i32..=lx1 as i32 {
        let x = x_of(10f64.powi(d)) as i32;
        for y in m as i32..(h as i32 - m as i32) {
            put(&mut img, x, y, [225, 225, 225]);
        }
    }
    for d in ly0 as i32..=ly1 as i32 {
        let y = y_of(10f64.powi(d)) as i32;
        for x in m as i32..(w as i32 - m as i32) {
            put(&mut img, x, y, [225, 225, 225]);
        }
    }
    let mut curves: Vec<(String, Vec<&Row>)> = Vec::new();
    for r in &pts {
        let key = format!("{} {} {} {}", r.technique, r.material, r.map, r.size);
        match curves.iter_mut().find(|c| c.0 == key) {
            Some(c) => c.1.push(r),
            None => curves.push((key, vec![r])),
        }
    }
    let mats: Vec<String> = materials().into_iter().map(|m| m.0).collect();
    for (_, c) in &curves {
        let mi = mats.iter().position(|m| *m == c[0].material).unwrap_or(0);
        let colour = crate::accuracy::plot_colour(mi);
        let fis = c[0].technique == "fis";
        for pair in c.windows(2) {
            let (a, b) = (
                (x_of(pair[0].ms), y_of(pair[0].rms)),
                (x_of(pair[1].ms), y_of(pair[1].rms)),
            );
            let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) as usize).max(1);
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                // FIS: solid lines; MC: dotted.
                if fis || (k / 4) % 2 == 0 {
                    put(&mut img, x as i32, y as i32, colour);
                    put(&mut img, x as i32, y as i32 + 1, colour);
                }
            }
        }
        for r in c {
            let (x, y) = (x_of(r.ms) as i32, y_of(r.rms) as i32);
            for dy in -3..=3 {
                for dx in -3..=3 {
                    let edge = dx * dx + dy * dy >= 6;
                    if fis || edge {
                        put(&mut img, x + dx, y + dy, colour);
                    }
                }
            }
        }
    }
    img
}
