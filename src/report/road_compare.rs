//! Outputs of `fleetdyn road compare` ([`crate::road::compare`]): three Parquet tables with
//! units (schemas `road_compare`, `road_compare_psd`, `road_compare_resonances` in
//! `schemas/outputs/`) and one SVG figure. All or nothing, as the other road outputs.
//!
//! The figure draws every item's PSD divided by its total slope power (unit m, so that a
//! rougher road and a smoother one are compared by where their power lies, not by how much they
//! have), the paper's two frequencies 3·10⁻⁴ and 10⁻³ 1/m, the slope filter's cut-off f_co and
//! −30 dB frequency f_lo, the filter's zero-phase gain on the right axis, and each gear's
//! driveline resonance at its top speed as a red tick labelled with the gear (the axis reaches
//! past the grid's Nyquist frequency when a resonance lies beyond it).

use super::road_plot::{draw_filter_marks, plot_indices, psd_chart, MAX_PLOT_POINTS};
use super::road_spectra::{
    all_or_nothing, filter_text, write_svg, RoadReportError, Step, SLOPE_PSD_UNIT,
};
use crate::io::{config_hash, write_table, OutColumn, OutData, TableMeta};
use crate::road::compare::{Comparison, Kind};
use crate::road::road_table::GENERATOR;
use crate::signal::cumulative_power;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

fn str_col(name: &str, v: Vec<String>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::Str(v),
    }
}

fn u64_col(name: &str, v: Vec<u64>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::U64(v),
    }
}

/// Total power of a one-sided PSD by the trapezoid rule.
fn total_power(freq: &[f64], psd: &[f64]) -> f64 {
    (1..freq.len())
        .map(|i| 0.5 * (psd[i] + psd[i - 1]) * (freq[i] - freq[i - 1]))
        .sum()
}

/// Item colours (red is kept for the filter and the resonances).
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(0, 0, 0),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Renders the figure (module doc) to an SVG string.
///
/// # Errors
/// A message when there is nothing positive to draw or the backend fails.
pub fn render_compare_svg(c: &Comparison) -> Result<String, String> {
    let f = &c.freq_per_m;
    let idx = plot_indices(f.len(), MAX_PLOT_POINTS);
    if idx.is_empty() {
        return Err("fewer than two frequency bins".into());
    }
    let norm: Vec<Vec<f64>> = c
        .items
        .iter()
        .map(|it| {
            let t = total_power(f, &it.psd);
            it.psd.iter().map(|p| p / t).collect()
        })
        .collect();
    let y_hi = norm
        .iter()
        .flat_map(|v| idx.iter().map(move |&i| v[i]))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let res_max = c
        .resonances
        .iter()
        .filter_map(|r| r.peak_per_m)
        .fold(0.0f64, f64::max);
    let (x0, x1) = (f[idx[0]], f[f.len() - 1].max(1.25 * res_max));
    if !(y_hi > 0.0 && x1 > x0) {
        return Err("no positive PSD value to draw".into());
    }
    let (y_top, y_floor) = (y_hi * 3.0, y_hi * 1e-9);
    let clamp = |v: f64| {
        if v.is_finite() {
            v.max(y_floor)
        } else {
            y_floor
        }
    };
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 680)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let title = format!(
            "Slope PSD / total slope power: {} rule set(s) ({} roads x {:.0} km each) and {} measured profile(s); Welch segments of {:.0} m",
            c.items.iter().filter(|i| i.kind == Kind::Rules).count(),
            c.config.roads.n_roads,
            c.config.roads.length_m / 1000.0,
            c.items.iter().filter(|i| i.kind == Kind::Profile).count(),
            c.nperseg as f64 * c.config.roads.step_m
        );
        let mut chart = psd_chart(
            &root,
            &title,
            15,
            (x0, x1),
            (y_floor, y_top),
            "slope PSD / slope power [m]",
        )?;
        for (k, (it, v)) in c.items.iter().zip(&norm).enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let pts: Vec<(f64, f64)> = idx.iter().map(|&i| (f[i], clamp(v[i]))).collect();
            let label = format!(
                "{} {} ({}): 50/90 % knee {:.2e} / {:.2e}",
                it.kind.as_str(),
                it.name,
                if it.class.is_empty() { "-" } else { &it.class },
                it.knees[0].value,
                it.knees[1].value
            );
            let style = colour.stroke_width(if it.kind == Kind::Rules { 3 } else { 2 });
            let anno = if it.kind == Kind::Rules {
                chart
                    .draw_series(LineSeries::new(pts, style))
                    .map_err(|x| e(&x))?
            } else {
                chart
                    .draw_series(DashedLineSeries::new(pts, 7, 4, style))
                    .map_err(|x| e(&x))?
            };
            anno.label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], style));
        }
        let vline = |f: f64| vec![(f, y_floor), (f, y_top)];
        let grey = RGBColor(120, 120, 120);
        for (fp, label) in [
            (3e-4, "3e-4 1/m (paper: highways' power below)"),
            (1e-3, "1e-3 1/m (paper: city roads' power below)"),
        ] {
            chart
                .draw_series(DashedLineSeries::new(vline(fp), 3, 3, grey.stroke_width(1)))
                .map_err(|x| e(&x))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], grey));
        }
        let fc = c.filter.config;
        draw_filter_marks(&mut chart, &fc, (x0, x1), (y_floor, y_top))?;
        let red = RGBColor(200, 30, 30);
        let gain: Vec<(f64, f64)> = idx
            .iter()
            .map(|&i| (f[i], c.filter.zero_phase_db[i].max(-150.0)))
            .collect();
        chart
            .draw_secondary_series(LineSeries::new(gain, red.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label(format!(
                "zero-phase filter |H|^2 (order {}, right axis)",
                fc.order
            ))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], red.stroke_width(2)));
        let marks: Vec<(f64, usize)> = c
            .resonances
            .iter()
            .filter_map(|r| Some((r.peak_per_m?, r.gear)))
            .collect();
        if !marks.is_empty() {
            let lowest = marks.iter().map(|m| m.0).fold(f64::INFINITY, f64::min);
            let band = (y_top / 30.0, y_top);
            chart
                .draw_series(marks.iter().map(|&(fr, _)| {
                    PathElement::new(vec![(fr, band.0), (fr, band.1)], red.stroke_width(2))
                }))
                .map_err(|x| e(&x))?
                .label(format!(
                    "driveline resonance of gear n at its top speed (F_dr -> v, open loop; lowest {lowest:.3} 1/m)"
                ))
                .legend(move |(x, y)| PathElement::new(vec![(x + 7, y - 6), (x + 7, y + 6)], red.stroke_width(2)));
            chart
                .draw_series(marks.iter().enumerate().map(|(k, &(fr, g))| {
                    Text::new(
                        format!("{g}"),
                        (fr, band.0 / (1.0 + 0.8 * (k % 2) as f64) / 1.6),
                        ("sans-serif", 11).into_font().color(&red),
                    )
                }))
                .map_err(|x| e(&x))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(svg)
}

/// Writes `road_compare.parquet`, `road_compare_psd.parquet`, `road_compare_resonances.parquet`
/// and `road_compare.svg` into `dir`.
///
/// # Errors
/// [`RoadReportError`]; no output is left behind on error.
pub fn write_comparison(dir: &Path, c: &Comparison) -> Result<Vec<PathBuf>, RoadReportError> {
    let paths = [
        dir.join("road_compare.parquet"),
        dir.join("road_compare_psd.parquet"),
        dir.join("road_compare_resonances.parquet"),
        dir.join("road_compare.svg"),
    ];
    let svg = render_compare_svg(c).map_err(|message| RoadReportError::Plot {
        path: paths[3].clone(),
        message,
    })?;
    let cfg = &c.config;
    let fp = crate::io::canonical(
        "road-compare:v1",
        &serde_json::json!({
            "generator": GENERATOR,
            "rules": cfg.rules.iter().map(|r| (r.class.clone(), r.rules.canonical_toml())).collect::<Vec<_>>(),
            "profiles": cfg.profiles.iter().map(|p| (p.name.clone(), p.class.clone(), p.origin.clone())).collect::<Vec<_>>(),
            "roads": cfg.roads.n_roads,
            "length_m": cfg.roads.length_m,
            "seed": cfg.roads.seed,
            "step_m": cfg.roads.step_m,
            "spectrum": cfg.roads.spectrum,
            "resonances": c.resonances.iter().map(|r| (r.gear, r.peak_per_m)).collect::<Vec<_>>(),
        }),
    );
    let hash = config_hash(&[fp.as_bytes()]);
    let extra = vec![
        ("generator".into(), GENERATOR.to_string()),
        ("roads_per_rule_set".into(), cfg.roads.n_roads.to_string()),
        ("road_length_m".into(), cfg.roads.length_m.to_string()),
        ("seed_first".into(), cfg.roads.seed.to_string()),
        ("step_m".into(), cfg.roads.step_m.to_string()),
        (
            "segment_length_m".into(),
            cfg.roads.spectrum.segment_length_m.to_string(),
        ),
        ("nperseg".into(), c.nperseg.to_string()),
        (
            "knee_ranges".into(),
            "rule sets: 5th-95th percentile across roads; profiles: 90 % bootstrap over Welch segments"
                .into(),
        ),
        (
            "bootstrap".into(),
            format!(
                "{} draws, seed {}",
                crate::road::compare::BOOTSTRAP_DRAWS,
                crate::road::compare::BOOTSTRAP_SEED
            ),
        ),
        (
            "filter".into(),
            filter_text(c.filter.causal_order, &c.filter.config),
        ),
    ];
    let meta = |table: &str| TableMeta {
        table: table.into(),
        drive_id: "road-compare".into(),
        vehicle_id: None,
        source_file: String::new(),
        config_hash: hash.clone(),
        extra: extra.clone(),
    };
    let it = &c.items;
    let fcol = |name: &str, unit: &str, g: &dyn Fn(&crate::road::compare::Item) -> f64| {
        OutColumn::f64(name, unit, it.iter().map(g).collect())
    };
    let mut item_cols = vec![
        str_col("item", it.iter().map(|i| i.name.clone()).collect()),
        str_col("kind", it.iter().map(|i| i.kind.as_str().into()).collect()),
        str_col("road_class", it.iter().map(|i| i.class.clone()).collect()),
        str_col("origin", it.iter().map(|i| i.origin.clone()).collect()),
        fcol("length", "m", &|i| i.length_m),
        u64_col("roads", it.iter().map(|i| i.roads as u64).collect()),
        u64_col("segments", it.iter().map(|i| i.segments as u64).collect()),
    ];
    for (k, pct) in ["50", "90", "99"].iter().enumerate() {
        item_cols.push(fcol(&format!("knee_{pct}"), "1/m", &|i| i.knees[k].value));
        item_cols.push(fcol(&format!("knee_{pct}_lo"), "1/m", &|i| i.knees[k].lo));
        item_cols.push(fcol(&format!("knee_{pct}_hi"), "1/m", &|i| i.knees[k].hi));
    }
    item_cols.extend([
        fcol("share_below_3e-4", "1", &|i| i.share_below_paper[0]),
        fcol("share_below_1e-3", "1", &|i| i.share_below_paper[1]),
        fcol("power_removed_zero_phase", "1", &|i| i.removed_zero_phase),
        fcol("power_removed_causal", "1", &|i| i.removed_causal),
        fcol("cutoff_margin", "1", &|i| i.cutoff_margin(&c.filter)),
        fcol("slope_rms", "1", &|i| i.slope_rms),
    ]);
    let f = &c.freq_per_m;
    let (mut name, mut freq, mut psd, mut share, mut cum) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in it {
        let t = total_power(f, &i.psd);
        name.extend(std::iter::repeat_n(i.name.clone(), f.len()));
        freq.extend_from_slice(f);
        psd.extend_from_slice(&i.psd);
        share.extend(i.psd.iter().map(|p| p / t));
        cum.extend(cumulative_power(f, &i.psd));
    }
    let psd_cols = vec![
        str_col("item", name),
        OutColumn::f64("frequency", "1/m", freq),
        OutColumn::f64("psd", SLOPE_PSD_UNIT, psd),
        OutColumn::f64("psd_normalised", "m", share),
        OutColumn::f64("cumulative_power", "1", cum),
    ];
    let r = &c.resonances;
    let opt = |v: Option<f64>| v.unwrap_or(f64::NAN);
    let stop = c.filter.config.stop_per_m;
    let res_cols = vec![
        u64_col("gear", r.iter().map(|g| g.gear as u64).collect()),
        OutColumn::f64("top_speed", "m/s", r.iter().map(|g| g.v_top_mps).collect()),
        OutColumn::f64(
            "peak_frequency",
            "Hz",
            r.iter().map(|g| opt(g.peak_hz)).collect(),
        ),
        OutColumn::f64(
            "peak_spatial_frequency",
            "1/m",
            r.iter().map(|g| opt(g.peak_per_m)).collect(),
        ),
        OutColumn::f64(
            "filter_zero_phase_gain",
            "dB",
            r.iter().map(|g| opt(g.zero_phase_db)).collect(),
        ),
        OutColumn::f64(
            "filter_causal_gain",
            "dB",
            r.iter().map(|g| opt(g.causal_db)).collect(),
        ),
        OutColumn::f64(
            "ratio_to_f_lo",
            "1",
            r.iter().map(|g| opt(g.peak_per_m) / stop).collect(),
        ),
    ];
    let [p_items, p_psd, p_res, p_svg] = paths;
    let (m_items, m_psd, m_res) = (
        meta("road_compare"),
        meta("road_compare_psd"),
        meta("road_compare_resonances"),
    );
    let steps: Vec<Step<'_>> = vec![
        (
            p_items,
            Box::new(move |p: &Path| write_table(p, &m_items, &item_cols).map_err(Into::into)),
        ),
        (
            p_psd,
            Box::new(move |p: &Path| write_table(p, &m_psd, &psd_cols).map_err(Into::into)),
        ),
        (
            p_res,
            Box::new(move |p: &Path| write_table(p, &m_res, &res_cols).map_err(Into::into)),
        ),
        (p_svg, Box::new(move |p: &Path| write_svg(p, &svg))),
    ];
    all_or_nothing(steps)
}
