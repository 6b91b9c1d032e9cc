//! A report's Pareto fronts: each technique's mean time and error per material, the
//! techniques no faster one beats, and the markdown that tabulates them (report.md).

use super::report::Row;
use std::fmt::Write as _;

/// A technique's summary over the probes for one material: (label, mean GPU ms, mean
/// relative RMS, worst relative RMS, mean |bias|, worst tile, mean precompute ms).
pub struct Point {
    /// The technique and its parameters.
    pub label: String,
    /// The technique's name.
    pub technique: &'static str,
    /// Mean GPU ms over the probes.
    pub ms: f64,
    /// Mean relative RMS.
    pub rms: f64,
    /// Worst relative RMS.
    pub worst: f64,
    /// Mean |bias|.
    pub bias: f64,
    /// Worst tile.
    pub tile: f64,
    /// Mean precomputation GPU ms.
    pub pre: f64,
    /// Mean whole-process seconds.
    pub process: f64,
    /// Mean per-frame GPU ms when the environment changes every frame.
    pub frame: f64,
    /// Its mean error.
    pub frame_rms: f64,
}

/// The techniques' points for `material`, in the order the rows first name them.
pub fn points(rows: &[Row], material: &str) -> Vec<Point> {
    let mut labels: Vec<(String, &'static str)> = Vec::new();
    for r in rows.iter().filter(|r| r.material == material) {
        if !labels.iter().any(|l| l.0 == r.label()) {
            labels.push((r.label(), r.technique));
        }
    }
    labels
        .into_iter()
        .map(|(label, technique)| {
            let v: Vec<&Row> = rows
                .iter()
                .filter(|r| r.material == material && r.label() == label)
                .collect();
            let n = v.len() as f64;
            Point {
                ms: v.iter().map(|r| r.gpu_ms).sum::<f64>() / n,
                rms: v.iter().map(|r| r.rms).sum::<f64>() / n,
                worst: v.iter().map(|r| r.rms).fold(0.0, f64::max),
                bias: v.iter().map(|r| r.bias.abs()).sum::<f64>() / n,
                tile: v.iter().map(|r| r.tile).fold(0.0, f64::max),
                pre: v.iter().map(|r| r.pre_ms).sum::<f64>() / n,
                process: finite_mean(v.iter().map(|r| r.process_s)),
                frame: v.iter().map(|r| r.frame_ms).sum::<f64>() / n,
                frame_rms: v.iter().map(|r| r.frame_rms).sum::<f64>() / n,
                label,
                technique,
            }
        })
        .collect()
}

/// The mean of the finite values (a process is timed on the first probe only); NaN where
/// there is none.
fn finite_mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v
        .filter(|x| x.is_finite())
        .fold((0.0, 0u32), |(s, n), x| (s + x, n + 1));
    sum / n as f64
}

/// Seconds to 3 decimals, "—" for NaN (not measured).
fn seconds(s: f64) -> String {
    match s.is_nan() {
        true => "—".to_string(),
        false => format!("{s:.3}"),
    }
}

/// Indices of the Pareto front, fastest first: each is more accurate than everything faster.
pub fn front(p: &[Point]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..p.len()).collect();
    idx.sort_by(|&a, &b| {
        p[a].ms
            .total_cmp(&p[b].ms)
            .then(p[a].rms.total_cmp(&p[b].rms))
    });
    let mut best = f64::INFINITY;
    idx.into_iter()
        .filter(|&i| {
            let keep = p[i].rms < best;
            best = best.min(p[i].rms);
            keep
        })
        .collect()
}

/// The front of `p` as "≥ T ms: **label** (E%)" steps.
pub fn front_line(p: &[Point]) -> String {
    front(p)
        .iter()
        .map(|&i| {
            format!(
                "≥ {:.2} ms: **{}** ({:.2}%)",
                p[i].ms,
                p[i].label,
                100.0 * p[i].rms
            )
        })
        .collect::<Vec<_>>()
        .join(" → ")
}

/// The materials, in the order the rows first name them.
pub fn material_names(rows: &[Row]) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in rows {
        if !v.contains(&r.material) {
            v.push(r.material.clone());
        }
    }
    v
}

/// What `material`'s rows were scored against, in a sentence.
fn reference_note(rows: &[Row], material: &str) -> String {
    let of: Vec<&Row> = rows.iter().filter(|r| r.material == material).collect();
    let worst = |f: fn(&Row) -> f64| of.iter().map(|r| f(r)).fold(0.0, f64::max);
    use super::report::Reference;
    let kind = of.first().map_or("", |r| r.reference);
    match kind {
        k if k == Reference::ExactGpu.name() => format!(
            "Reference: no sampling noise (exact texel sums on the GPU; against their float64 \
             twin at {} pixels a probe, worst {:.1e} relative; their own error, the texel \
             rule's, estimated by doubling its cells at {} pixels a probe: worst {:.1e}).",
            super::report::TWIN_PIXELS,
            worst(|r| r.twin),
            super::report::REFINED_PIXELS,
            worst(|r| r.noise)
        ),
        k if k == Reference::ExactHost.name() => format!(
            "Reference: no sampling noise (exact texel sums in float64 on the host; their own \
             error, the texel rule's, estimated by doubling its cells at {} pixels a probe: \
             worst {:.1e} relative).",
            super::report::REFINED_PIXELS,
            worst(|r| r.noise)
        ),
        k if k == Reference::PixelAreaMean.name() => format!(
            "Reference: the pixel-area mean, what a footprint lookup estimates: each pixel's \
             share of every texel its reflection covers, by area (the pixel cut into cells, \
             each cell's corners mapped into the map and the quad they span clipped against \
             its texel grid, cells split until their children agree within {:.0e} of the \
             pixel); its own error, estimated as its change from a tolerance 10 times coarser: \
             {:.1e} relative RMS on the worst probe. \"point\" reads the one texel at the \
             pixel's centre and errs by the pixel's aliasing.",
            super::report::MIRROR_TOL,
            worst(|r| r.noise)
        ),
        _ => format!(
            "Reference noise (worst probe): {:.3}% relative RMS; errors near it are at the \
             reference's floor.",
            100.0 * worst(|r| r.noise)
        ),
    }
}

/// An accuracy goal: (goal, material, technique, parameters, bound on the relative RMS,
/// bound on |bias| if any).
type Goal = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    f64,
    Option<f64>,
);

/// The accuracy goals read from a report's rows, per probe.
const GOALS: [Goal; 6] = [
    (
        "Diffuse by SH order 2 plus lights ≤ 1.5%",
        "diffuse",
        "sh",
        "l=2",
        0.015,
        None,
    ),
    (
        "GGX α 0.05 by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%",
        "ggx 0.05",
        "fis",
        "N=64",
        0.03,
        Some(0.01),
    ),
    (
        "GGX α 0.1 by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%",
        "ggx 0.1",
        "fis",
        "N=64",
        0.03,
        Some(0.01),
    ),
    (
        "GGX α 0.3 by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%",
        "ggx 0.3",
        "fis",
        "N=64",
        0.03,
        Some(0.01),
    ),
    (
        "GGX α 0.6 by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%",
        "ggx 0.6",
        "fis",
        "N=64",
        0.03,
        Some(0.01),
    ),
    (
        "Mirror, footprint lookup plus lights, ≤ 3% against the pixel-area mean",
        "mirror",
        "lookup",
        "",
        0.03,
        None,
    ),
];

/// The accuracy goals checked on `rows`, each per probe: met or
/// not, with each probe's error and bias; a goal whose rows the run lacks (a quick run's
/// materials) is said to be unmeasured.
pub fn goals_markdown(rows: &[Row]) -> String {
    let mut md = String::from("\n## Goals, read from this run\n\n");
    for (goal, material, technique, params, bound, bias) in GOALS {
        let of: Vec<&Row> = rows
            .iter()
            .filter(|r| r.material == material && r.technique == technique && r.params == params)
            .collect();
        if of.is_empty() {
            let _ = writeln!(md, "- {goal}: not measured in this run");
            continue;
        }
        let met = of
            .iter()
            .all(|r| r.rms <= bound && bias.is_none_or(|b| r.bias.abs() <= b));
        let each: Vec<String> = of
            .iter()
            .map(|r| {
                format!(
                    "{} {:.2}% ({:+.2}%)",
                    r.probe,
                    100.0 * r.rms,
                    100.0 * r.bias
                )
            })
            .collect();
        let verdict = if met { "met" } else { "not met" };
        let _ = writeln!(md, "- {goal}: **{verdict}**: {}", each.join(", "));
    }
    md.push_str("\nIn parentheses: the mean bias.\n");
    md
}

/// report.md: the headline, a table and a front per material, under `settings`.
pub fn markdown(rows: &[Row], settings: &str) -> String {
    let mut md = String::from("# envlight report: accuracy against time\n\n");
    let _ = writeln!(md, "{settings}\n");
    md.push_str("## Headline: what to use at which time budget\n\n");
    md.push_str(
        "**The environment changes every frame** (a time of day, a moving sun, a probe the \
         engine renders): the Pareto front per material by the GPU time of a whole frame \
         through the resident path (`Renderer::record_resident`: SH projection, light \
         extraction, the paraboloid and its chains, prefiltered maps and the shading, all on \
         the GPU, one submission, nothing read back), mean over the probes, against its mean \
         relative RMS. Monte Carlo counts its host render's GPU time (its sampling tables, \
         rebuilt on the host at each change, are not counted); a peer's bake counts its whole \
         process, since a changed environment must be baked again, plus split-sum's shading.\n\n",
    );
    let mats = material_names(rows);
    for m in &mats {
        let mut p = points(rows, m);
        for q in &mut p {
            (q.ms, q.rms) = (q.frame, q.frame_rms);
        }
        let _ = writeln!(md, "- **{m}**: {}", front_line(&p));
    }
    md.push_str(
        "\n**One environment, many frames** (the precomputation amortised): the front by the \
         per-frame GPU time alone (G-buffer, shading, Monte Carlo frames) of the host path's \
         render; a peer's cube costs split-sum's shading.\n\n",
    );
    for m in &mats {
        let mut p = points(rows, m);
        for q in &mut p {
            q.ms -= q.pre;
        }
        let _ = writeln!(md, "- **{m}**: {}", front_line(&p));
    }
    md.push_str(
        "\nRows marked \"(no lights)\" leave the probe's lights in the map; the others extract \
         them (the default) and add them exactly where the technique can (the resident path \
         clamps the chain's residual where the host path fills it). \
         split_sum taps=8 is the lobe taps recipe. gltf-ibl-sampler rows are \
         glTF-IBL-Sampler's GGX cube of the probe (its defaults, N samples) shaded by \
         split-sum in float64. \"GPU ms\" below is the host path's whole render, \
         precomputation included (\"of it precompute\"), as the chart plots it. A \
         technique's materials are drawn together, as a renderer shades several materials \
         from one environment's precomputation: one sphere per material side by side in one \
         frame, each in a cell whose pixels see it as the sphere alone; what the spheres \
         share (conversions, chains, SH projection, lights, prefiltered maps) counts whole in \
         each row, the passes over pixels (G-buffer, shading, Monte Carlo) and the SH-BRDF \
         tables (one per BRDF) a share per sphere. \"Whole process s\" and the render's \
         wall time are that frame's, all its spheres together; the process is timed on the \
         first probe only (it renders the frame again, and takes about as long on each 1k \
         probe), with the lights extracted as a user's render does by default (a dash \
         elsewhere).\n\n\
         ![Pareto chart](report.png)\n",
    );
    for m in &mats {
        let p = points(rows, m);
        let f = front(&p);
        let _ = writeln!(
            md,
            "\n## {m}\n\n| technique | mean rel. RMS | worst probe | mean abs bias | worst tile | GPU ms | of it precompute | whole process s | changing env: frame ms | its rel. RMS | front |\n|---|---|---|---|---|---|---|---|---|---|---|"
        );
        for (i, q) in p.iter().enumerate() {
            let _ = writeln!(
                md,
                "| {} | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2} | {:.2} | {} | {:.2} | {:.2}% | {} |",
                q.label,
                100.0 * q.rms,
                100.0 * q.worst,
                100.0 * q.bias,
                100.0 * q.tile,
                q.ms,
                q.pre,
                seconds(q.process),
                q.frame,
                100.0 * q.frame_rms,
                if f.contains(&i) { "yes" } else { "" }
            );
        }
        let _ = writeln!(md, "\n{}", reference_note(rows, m));
    }
    md.push_str("\n## Per probe\n\n| probe | kind | material | technique | rel. RMS | bias | worst tile | GPU ms | render wall s | whole process s |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {:.2}% | {:+.2}% | {:.2}% | {:.2} | {:.3} | {} |",
            r.probe,
            r.kind,
            r.material,
            r.label(),
            100.0 * r.rms,
            100.0 * r.bias,
            100.0 * r.tile,
            r.gpu_ms,
            r.wall_s,
            seconds(r.process_s)
        );
    }
    md
}

/// table.md: the accuracy table, a view of the same rows as report.md: per material, each
/// technique's relative RMS, bias and worst tile on each probe (the probes as columns), then
/// the goals read from them. `settings` is report.md's first paragraph.
pub fn table_markdown(rows: &[Row], settings: &str) -> String {
    let mut md = String::from("# envlight report: accuracy on each probe\n\n");
    let _ = writeln!(
        md,
        "The accuracy table: a view of [report.md](report.md)'s run (report.csv), each \
         technique's error on each probe instead of its mean and time. {settings}\n\n\
         Each cell: per-pixel relative RMS · mean bias · worst 8×8 tile's |ratio − 1|. Rows \
         marked \"(no lights)\" leave the probe's lights in the map."
    );
    let mut probes: Vec<&str> = Vec::new();
    for r in rows {
        if !probes.contains(&r.probe.as_str()) {
            probes.push(&r.probe);
        }
    }
    for m in material_names(rows) {
        let _ = write!(md, "\n## {m}\n\n| technique |");
        for p in &probes {
            let _ = write!(md, " {p} |");
        }
        md.push_str(" mean GPU ms |\n|---|");
        md.push_str(&"---|".repeat(probes.len() + 1));
        md.push('\n');
        for point in points(rows, &m) {
            let _ = write!(md, "| {} |", point.label);
            for p in &probes {
                let cell = rows
                    .iter()
                    .find(|r| r.material == m && r.label() == point.label && r.probe == *p)
                    .map(|r| {
                        format!(
                            "{:.2}% · {:+.2}% · {:.1}%",
                            100.0 * r.rms,
                            100.0 * r.bias,
                            100.0 * r.tile
                        )
                    })
                    .unwrap_or_else(|| "—".to_string());
                let _ = write!(md, " {cell} |");
            }
            let _ = writeln!(md, " {:.2} |", point.ms);
        }
        let _ = writeln!(md, "\n{}", reference_note(rows, &m));
    }
    md.push_str(&goals_markdown(rows));
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(label: &str, ms: f64, rms: f64) -> Point {
        Point {
            label: label.into(),
            technique: "mc",
            ms,
            rms,
            worst: rms,
            bias: 0.0,
            tile: 0.0,
            pre: 0.0,
            process: 0.0,
            frame: ms,
            frame_rms: rms,
        }
    }

    fn row(material: &str, technique: &'static str, params: &str, probe: &str, rms: f64) -> Row {
        Row {
            probe: probe.into(),
            kind: "sun",
            material: material.into(),
            technique,
            params: params.into(),
            rms,
            bias: 0.001,
            tile: 0.0,
            gpu_ms: 1.0,
            pre_ms: 0.0,
            wall_s: 0.0,
            process_s: 0.0,
            noise: 0.0,
            twin: 0.0,
            reference: "exact (gpu)",
            frame_ms: 1.0,
            frame_rms: rms,
        }
    }

    #[test]
    fn goals_are_read_per_probe_from_the_rows() {
        let rows = vec![
            row("diffuse", "sh", "l=2", "a", 0.010),
            row("diffuse", "sh", "l=2 (no lights)", "a", 0.100),
            row("diffuse", "sh", "l=2", "b", 0.020),
            row("ggx 0.3", "fis", "N=64", "a", 0.020),
            row("ggx 0.3", "fis", "N=64", "b", 0.025),
        ];
        let md = goals_markdown(&rows);
        // One probe over 1.5% fails the diffuse goal; the no-lights row is not its row.
        assert!(
            md.contains("SH order 2 plus lights ≤ 1.5%: **not met**: a 1.00% (+0.10%), b 2.00%"),
            "{md}"
        );
        assert!(
            md.contains("GGX α 0.3 by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%: **met**"),
            "{md}"
        );
        assert!(md.contains("GGX α 0.05 by FIS-64 plus lights ≤ 3%, |bias| ≤ 1%: not measured"));
    }

    #[test]
    fn the_front_keeps_what_beats_everything_faster() {
        let p = vec![
            point("slow and bad", 10.0, 0.5),
            point("fast", 1.0, 0.3),
            point("better", 2.0, 0.1),
            point("worse, slower", 3.0, 0.2),
            point("best", 20.0, 0.01),
        ];
        let labels: Vec<&str> = front(&p).iter().map(|&i| p[i].label.as_str()).collect();
        assert_eq!(labels, ["fast", "better", "best"]);
    }
}
