//! The report's chart: error against time, one panel per material, labels placed apart.

use crate::bench::pareto::{front, material_names, points, Point};
use crate::bench::report::Row;
use anyhow::{anyhow, Result};
use std::path::Path;

/// Colour of a technique family.
fn colour(technique: &str) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match technique {
        "lookup" => RGBColor(0, 0, 0),
        "sh" => RGBColor(31, 119, 180),
        "prefiltered" => RGBColor(140, 86, 75),
        "fis" => RGBColor(44, 160, 44),
        "mc" => RGBColor(214, 39, 40),
        "sh_brdf" => RGBColor(148, 103, 189),
        crate::bench::cubes::PEER => RGBColor(127, 127, 127),
        _ => RGBColor(255, 127, 14),
    }
}

/// The chart's point labels: their font size, and their height and width in pixels (DejaVu
/// Sans averages under 0.6 em a character; the estimate errs wide).
const LABEL_PX: i32 = 12;
const LABEL_H: i32 = 14;

fn label_width(label: &str) -> i32 {
    (label.chars().count() as f64 * 0.6 * LABEL_PX as f64).ceil() as i32 + 2
}

/// Where each point's label goes, as the offset of its top-left corner from the point: the
/// first of twelve places around the point where it overlaps no label placed before it and no
/// marker and stays inside `area` (x0, y0, x1, y1); where none is free, the place that
/// overlaps least.
fn place_labels(
    points: &[(i32, i32)],
    widths: &[i32],
    area: (i32, i32, i32, i32),
) -> Vec<(i32, i32)> {
    type Rect = (i32, i32, i32, i32);
    let overlap = |a: Rect, b: Rect| {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0);
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0);
        w * h
    };
    let markers: Vec<Rect> = points
        .iter()
        .map(|&(x, y)| (x - 6, y - 6, x + 6, y + 6))
        .collect();
    let mut placed: Vec<Rect> = Vec::new();
    let mut out = Vec::with_capacity(points.len());
    for (&(x, y), &w) in points.iter().zip(widths) {
        let h = LABEL_H;
        let tries = [
            (7, -h),
            (7, 2),
            (-7 - w, -h),
            (-7 - w, 2),
            (-w / 2, -h - 6),
            (-w / 2, 7),
            (7, -2 * h),
            (-7 - w, 2 + h),
            (7, 2 + h),
            (-7 - w, -2 * h),
            (-w / 2, -2 * h - 6),
            (-w / 2, 7 + h),
        ];
        let cost = |&(dx, dy): &(i32, i32)| {
            let r = (x + dx, y + dy, x + dx + w, y + dy + h);
            let outside = (area.0 - r.0).max(0)
                + (r.2 - area.2).max(0)
                + (area.1 - r.1).max(0)
                + (r.3 - area.3).max(0);
            let hits: i32 = placed.iter().chain(&markers).map(|&o| overlap(r, o)).sum();
            hits + outside * h
        };
        let best = tries
            .iter()
            .copied()
            .min_by_key(|t| cost(t))
            .unwrap_or((7, -h));
        let r = (x + best.0, y + best.1, x + best.0 + w, y + best.1 + h);
        placed.push(r);
        out.push(best);
    }
    out
}

pub(super) fn plot(path: &Path, rows: &[Row], device: &str) -> Result<()> {
    use plotters::prelude::*;
    let e = |e: &dyn std::fmt::Display| anyhow!("report.png: {e}");
    // Text comes from the DejaVu Sans the `dejavu` crate ships; no system font is read.
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow!("report.png: the bundled font did not load"))?;
    let mats = material_names(rows);
    let cols = mats.len().clamp(1, 3);
    let rows_n = mats.len().div_ceil(cols).max(1);
    let (w, h) = (620 * cols as u32, 520 * rows_n as u32 + 90);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let root = root
        .titled(
            "envlight: error against the reference vs GPU time (mean over the probes)",
            ("sans-serif", 22),
        )
        .map_err(|x| e(&x))?;
    let (legend, body) = root.split_vertically(56);
    legend
        .draw(&Text::new(
            format!("device: {device}; black line: the Pareto front"),
            (20, 34),
            ("sans-serif", 14),
        ))
        .map_err(|x| e(&x))?;
    let families = [
        "lookup",
        "sh",
        "prefiltered",
        "fis",
        "mc",
        "sh_brdf",
        "split_sum",
        crate::bench::cubes::PEER,
    ];
    for (k, f) in families.iter().enumerate() {
        let x = 20 + k as i32 * 150;
        legend
            .draw(&Circle::new((x, 12), 6, colour(f).filled()))
            .map_err(|x| e(&x))?;
        legend
            .draw(&Text::new(*f, (x + 12, 4), ("sans-serif", 16)))
            .map_err(|x| e(&x))?;
    }
    let panels = body.split_evenly((rows_n, cols));
    for (panel, m) in panels.iter().zip(&mats) {
        let p = points(rows, m);
        let f = front(&p);
        let floor = 1e-4;
        let (x0, x1) = p.iter().fold((f64::INFINITY, 0.0f64), |a, q| {
            (a.0.min(q.ms.max(1e-3)), a.1.max(q.ms.max(1e-3)))
        });
        let y1 = p.iter().map(|q| q.rms).fold(floor * 10.0, f64::max);
        let mut chart = ChartBuilder::on(panel)
            .caption(m, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(
                (x0 / 2.0..x1 * 2.0).log_scale(),
                (floor..y1 * 2.0).log_scale(),
            )
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("GPU ms per render (precomputation included)")
            .y_desc("relative RMS vs the reference")
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(|x| e(&x))?;
        let at = |q: &Point| (q.ms.max(1e-3), q.rms.max(floor));
        chart
            .draw_series(LineSeries::new(
                f.iter().map(|&i| at(&p[i])),
                ShapeStyle::from(&BLACK).stroke_width(2),
            ))
            .map_err(|x| e(&x))?;
        let pixels: Vec<(i32, i32)> = p.iter().map(|q| chart.backend_coord(&at(q))).collect();
        let widths: Vec<i32> = p.iter().map(|q| label_width(&q.label)).collect();
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let area = (xs.start, ys.start, xs.end, ys.end);
        let offsets = place_labels(&pixels, &widths, area);
        for (q, offset) in p.iter().zip(offsets) {
            let c = colour(q.technique);
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at(at(q))
                        + Circle::new((0, 0), 5, c.filled())
                        + Text::new(q.label.clone(), offset, ("sans-serif", LABEL_PX)),
                ))
                .map_err(|x| e(&x))?;
        }
    }
    root.present().map_err(|x| e(&x))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Labels of points in a cluster (the chart's worst case: equal times, near errors) and at
    /// the plot's right edge overlap no other label and no marker and stay inside.
    #[test]
    fn labels_of_clustered_points_do_not_overlap() {
        let points = [
            (100, 100),
            (104, 103),
            (108, 98),
            (300, 200),
            (395, 60),
            (392, 64),
        ];
        let widths: Vec<i32> = [
            "sh l=2 (no lights)",
            "sh_brdf l=2",
            "mc N=64",
            "x",
            "split_sum (no lights)",
            "split_sum",
        ]
        .iter()
        .map(|l| label_width(l))
        .collect();
        let area = (0, 0, 400, 300);
        let at = place_labels(&points, &widths, area);
        let rect = |k: usize| {
            let (x, y) = (points[k].0 + at[k].0, points[k].1 + at[k].1);
            (x, y, x + widths[k], y + LABEL_H)
        };
        for a in 0..points.len() {
            let r = rect(a);
            assert!(
                r.0 >= 0 && r.1 >= 0 && r.2 <= 400 && r.3 <= 300,
                "label {a} outside: {r:?}"
            );
            for (b, &m) in points.iter().enumerate() {
                let o = rect(b);
                let apart = |p: (i32, i32, i32, i32), q: (i32, i32, i32, i32)| {
                    p.2 <= q.0 || q.2 <= p.0 || p.3 <= q.1 || q.3 <= p.1
                };
                assert!(
                    apart(r, (m.0 - 5, m.1 - 5, m.0 + 5, m.1 + 5)),
                    "label {a} on marker {b}"
                );
                if a != b {
                    assert!(apart(r, o), "labels {a} and {b} overlap: {r:?} {o:?}");
                }
            }
        }
    }
}
