//! The diagnosis report (docs/diagnosis/method.md, "show"): `report.md` with the verdict, the noise
//! floors, the located mismatches, one paragraph per finding (its sentence, parameters with
//! confidence intervals and units, before/after errors on training and held-out parts), and
//! one SVG per compared signal with the residual before (nominal model) and after (with the
//! accepted findings), the located stretches shaded. Everything is written atomically.

use super::axle_plot::PlotError;
use super::contract::{signal_unit, Diagnosis};
use super::plot_points::m4_points;
use crate::diagnose::explain::{BeforeAfter, SignalMetrics};
use crate::io::AtomicFile;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// One signal's residuals for the plot, on the recording's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualSeries<'a> {
    /// Canonical column.
    pub signal: &'a str,
    /// Times, s from the first row.
    pub t_s: &'a [f64],
    /// Residual of the nominal model (NaN where not compared).
    pub before: &'a [f64],
    /// Residual with the accepted findings.
    pub after: &'a [f64],
}

/// Scale of a signal for display: (factor, unit label).
fn display(signal: &str) -> (f64, &'static str) {
    match signal_unit(signal) {
        "Pa" => (1e-3, "kPa"),
        "rad/s" => (30.0 / std::f64::consts::PI, "rpm"),
        "m/s" => (3.6, "km/h"),
        "N" => (1e-3, "kN"),
        _ => (1.0, "1"),
    }
}

/// Size of a residual plot, pixels (width, height).
const PLOT_SIZE: (u32, u32) = (1000, 420);

/// Plots the residual before and after of one signal with the mismatch stretches `[start_s,
/// end_s]` shaded, into `path` (SVG). Each line holds the points an M4 aggregation over twice
/// the plot's width in columns keeps ([`m4_points`]): the same drawing at up to twice the size,
/// at most 8 000 points a line whatever the drive's length.
///
/// # Errors
/// [`PlotError`] when nothing is finite, drawing fails or the file cannot be written.
pub fn plot_residuals(
    path: &Path,
    title: &str,
    r: &ResidualSeries<'_>,
    stretches: &[(f64, f64)],
) -> Result<(), PlotError> {
    let draw = |message: String| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    };
    let (k, unit) = display(r.signal);
    let pts = |v: &[f64]| -> Vec<(f64, f64)> {
        r.t_s
            .iter()
            .zip(v)
            .filter(|(t, y)| t.is_finite() && y.is_finite())
            .map(|(t, y)| (*t, y * k))
            .collect()
    };
    let (b, a) = (pts(r.before), pts(r.after));
    let all = b.iter().chain(&a);
    let (x0, x1, y0, y1) = all.fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(p, q, s, u), &(x, y)| (p.min(x), q.max(x), s.min(y), u.max(y)),
    );
    if !(x0.is_finite() && y0.is_finite()) {
        return Err(PlotError::Empty {
            path: path.to_path_buf(),
        });
    }
    let pad = (0.05 * (y1 - y0)).max(1e-9);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
    let columns = 2 * PLOT_SIZE.0 as usize;
    let (b, a) = (
        m4_points(b, (x0, x1), columns),
        m4_points(a, (x0, x1), columns),
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| draw(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .y_desc(format!("residual measured − simulated [{unit}]"))
            .draw()
            .map_err(|e| draw(e.to_string()))?;
        let shade = RGBColor(255, 200, 120).mix(0.35);
        chart
            .draw_series(
                stretches.iter().map(|&(s, e)| {
                    Rectangle::new([(s.max(x0), y0), (e.min(x1), y1)], shade.filled())
                }),
            )
            .map_err(|e| draw(e.to_string()))?;
        let grey = RGBColor(150, 150, 150);
        chart
            .draw_series(LineSeries::new(b, grey.stroke_width(1)))
            .map_err(|e| draw(e.to_string()))?
            .label("nominal model")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], grey));
        chart
            .draw_series(LineSeries::new(a, BLUE.stroke_width(1)))
            .map_err(|e| draw(e.to_string()))?
            .label("with the findings")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], BLUE));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| draw(e.to_string()))?;
        root.present().map_err(|e| draw(e.to_string()))?;
    }
    AtomicFile::write_all(path, svg.as_bytes()).map_err(|source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// What the Markdown report shows beside the contract's content.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReportParts<'a> {
    /// Each finding's RMSE, MAE and fit % per signal (same order as the findings; may be
    /// shorter).
    pub metrics: &'a [BTreeMap<String, SignalMetrics>],
    /// Per mismatched signal, its residual's shape in words ([`super::sentences::statement_text`]),
    /// the best first.
    pub shapes: &'a [(String, Vec<String>)],
    /// (signal, file name) of the residual plots beside the report.
    pub plots: &'a [(String, String)],
}

/// The Markdown report of `d` with `parts`.
pub fn report_markdown(d: &Diagnosis, parts: &ReportParts<'_>) -> String {
    let (metrics, plots) = (parts.metrics, parts.plots);
    let mut s = String::new();
    let _ = writeln!(s, "# Diagnosis of drive {}\n", d.drive_id);
    let _ = writeln!(s, "**Verdict: {}**\n", d.verdict.as_str());
    let _ = writeln!(s, "## Noise floor\n\n| signal | floor |\n|---|---|");
    for (sig, v) in &d.noise_floor {
        let (k, unit) = display(sig);
        let _ = writeln!(s, "| {sig} | {:.4} {unit} |", v * k);
    }
    let _ = writeln!(s, "\n## Where the model and the recording differ\n");
    if d.mismatch.is_empty() {
        let _ = writeln!(s, "Nowhere above the noise floor.");
    } else {
        let _ = writeln!(
            s,
            "| signal | time [s] | distance [m] | band [Hz] | condition | RMS residual | p (corrected) |\n|---|---|---|---|---|---|---|"
        );
        for m in &d.mismatch {
            let (k, unit) = display(&m.signal);
            let _ = writeln!(
                s,
                "| {} | {:.1}–{:.1} | {:.0}–{:.0} | {:.2}–{:.2} | {} | {:.3} {unit} | {:.1e} |",
                m.signal,
                m.start_s,
                m.end_s,
                m.start_m,
                m.end_m,
                m.band_hz[0],
                m.band_hz[1],
                m.condition,
                m.rms_residual * k,
                m.significance
            );
        }
    }
    if !parts.shapes.is_empty() {
        let _ = writeln!(s, "\nWhat the residual looks like:\n");
        for (sig, words) in parts.shapes {
            let _ = writeln!(s, "- {sig}: {}", words.join("; "));
        }
    }
    let _ = writeln!(s, "\n## Findings\n");
    if d.findings.is_empty() {
        let _ = writeln!(s, "No catalogue effect passed the acceptance rule.");
    }
    for (i, f) in d.findings.iter().enumerate() {
        let _ = writeln!(s, "### {}. `{}`\n\n{}\n", i + 1, f.effect, f.sentence);
        if !f.ambiguous_with.is_empty() {
            let _ = writeln!(
                s,
                "Not isolable with the available signals from: {}.\n",
                f.ambiguous_with
                    .iter()
                    .map(|a| format!("`{a}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        let _ = writeln!(
            s,
            "| parameter | value | 95 % interval | unit |\n|---|---|---|---|"
        );
        for (n, p) in &f.parameters {
            let _ = writeln!(
                s,
                "| {n} | {:.5} | {:.5} … {:.5} | {} |",
                p.value, p.ci_low, p.ci_high, p.unit
            );
        }
        if let Some(m) = metrics.get(i) {
            let _ = writeln!(
                s,
                "\n| signal | metric | train before | train after | held-out before | held-out after |\n|---|---|---|---|---|---|"
            );
            for (sig, sm) in m {
                let (k, unit) = display(sig);
                let rows: [(&str, &BeforeAfter, f64, &str); 3] = [
                    ("RMSE", &sm.rmse, k, unit),
                    ("MAE", &sm.mae, k, unit),
                    ("fit", &sm.fit_percent, 1.0, "%"),
                ];
                for (name, v, k, unit) in rows {
                    let _ = writeln!(
                        s,
                        "| {sig} | {name} [{unit}] | {:.4} | {:.4} | {:.4} | {:.4} |",
                        v.train_before * k,
                        v.train_after * k,
                        v.heldout_before * k,
                        v.heldout_after * k
                    );
                }
            }
        } else {
            let _ = writeln!(
            s,
            "\n| signal | train before | train after | held-out before | held-out after |\n|---|---|---|---|---|"
        );
            for (sig, e) in &f.fit {
                let (k, unit) = display(sig);
                let _ = writeln!(
                    s,
                    "| {sig} ({} {unit}) | {:.4} | {:.4} | {:.4} | {:.4} |",
                    e.metric,
                    e.train_before * k,
                    e.train_after * k,
                    e.heldout_before * k,
                    e.heldout_after * k
                );
            }
        }
        let _ = writeln!(s);
    }
    if !d.estimates.is_empty() {
        let _ = writeln!(
            s,
            "## Consistent with the vehicle file

Fitted, but within the file's tolerance \
             band, so not named:\n\n| parameter | value | 95 % interval | file's band | unit |\n\
             |---|---|---|---|---|"
        );
        for e in &d.estimates {
            let _ = writeln!(
                s,
                "| {} | {:.5} | {:.5} … {:.5} | {:.5} … {:.5} | {} |",
                e.parameter,
                e.value,
                e.ci_low,
                e.ci_high,
                e.tolerance_low,
                e.tolerance_high,
                e.unit
            );
        }
        let _ = writeln!(s);
    }
    if !plots.is_empty() {
        let _ = writeln!(s, "## Residuals before and after\n");
        for (sig, file) in plots {
            let _ = writeln!(s, "![{sig}]({file})\n");
        }
    }
    s
}

/// Writes `report.md` (atomically).
///
/// # Errors
/// The I/O error.
pub fn write_report(path: &Path, d: &Diagnosis, parts: &ReportParts<'_>) -> std::io::Result<()> {
    AtomicFile::write_all(path, report_markdown(d, parts).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::contract::{MismatchEntry, Verdict};
    /// Plots a vehicle-speed residual into `dir`, returning the file's path.
    fn plot_speed(
        dir: &Path,
        t: &[f64],
        before: &[f64],
        after: &[f64],
        stretches: &[(f64, f64)],
    ) -> std::path::PathBuf {
        let svg = dir.join("residual_vehicle_speed.svg");
        plot_residuals(
            &svg,
            "vehicle speed",
            &ResidualSeries {
                signal: "vehicle_speed",
                t_s: t,
                before,
                after,
            },
            stretches,
        )
        .unwrap();
        svg
    }

    #[test]
    fn a_ten_hour_residual_plot_holds_its_extremes_in_a_bounded_file() {
        // 10 h at 50 Hz: 1.8 million rows, a spike of 9 km/h at one row
        let dir = tempfile::tempdir().unwrap();
        let n = 1_800_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.02).collect();
        let mut before: Vec<f64> = t.iter().map(|x| 0.1 * (x * 0.05).sin()).collect();
        before[1_234_567] = 2.5;
        let after: Vec<f64> = before.iter().map(|x| 0.5 * x).collect();
        let svg = plot_speed(dir.path(), &t, &before, &after, &[]);
        let bytes = std::fs::metadata(&svg).unwrap().len();
        // two lines of at most 8 000 points, about 12 bytes each, and the axes: under 250 kB
        // (every row drawn: tens of MB, 27 MB a signal on the benchmarks' 10-hour drive)
        assert!(bytes < 250_000, "{bytes} bytes");
        // the spike is drawn: the lines' topmost vertex lies within the top fifth of the
        // 420-pixel plot (the rest of the residual stays within ±0.36 km/h of zero, below the
        // middle of an axis that reaches 9 km/h)
        let text = std::fs::read_to_string(&svg).unwrap();
        let top = text
            .split("points=\"")
            .skip(1)
            .filter_map(|s| s.split('"').next())
            .flat_map(|pts| pts.split(' ').filter_map(|p| p.split(',').nth(1)))
            .filter_map(|y| y.parse::<f64>().ok())
            .fold(f64::INFINITY, f64::min);
        assert!(top < 84.0, "topmost vertex at y = {top} px");
    }

    #[test]
    fn report_and_plot_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let t: Vec<f64> = (0..500).map(|i| i as f64 * 0.1).collect();
        let before: Vec<f64> = t.iter().map(|x| (x * 0.3).sin()).collect();
        let after: Vec<f64> = t.iter().map(|x| 0.1 * (x * 0.3).sin()).collect();
        let svg = plot_speed(dir.path(), &t, &before, &after, &[(10.0, 20.0)]);
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg") && text.contains("with the findings"));
        let d = Diagnosis {
            drive_id: "d".into(),
            verdict: Verdict::Unexplained,
            noise_floor: [("vehicle_speed".to_string(), 0.05)].into_iter().collect(),
            mismatch: vec![MismatchEntry {
                signal: "vehicle_speed".into(),
                start_s: 10.0,
                end_s: 20.0,
                start_m: 100.0,
                end_m: 300.0,
                band_hz: [0.0, 0.5],
                condition: "gear 6".into(),
                rms_residual: 0.5,
                significance: 1e-5,
            }],
            findings: vec![],
            estimates: Vec::new(),
        };
        let md = report_markdown(
            &d,
            &ReportParts {
                metrics: &[],
                shapes: &[(
                    "vehicle_speed".into(),
                    vec!["grows with speed² (explains 64 % of the residual energy)".into()],
                )],
                plots: &[("vehicle_speed".into(), "residual_vehicle_speed.svg".into())],
            },
        );
        assert!(md.contains("**Verdict: unexplained**"));
        assert!(
            md.contains(
                "- vehicle_speed: grows with speed² (explains 64 % of the residual energy)"
            ),
            "{md}"
        );
        // 0.5 m/s shown as 1.800 km/h
        assert!(md.contains("1.800 km/h"), "{md}");
        assert!(md.contains("No catalogue effect passed"));
    }
}
