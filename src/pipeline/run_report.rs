//! The run report of a pipeline run (`OUT/_reports/<pipeline>/model_version=<M>[/shard-i-of-N]/`):
//!
//! - `drive_validation.parquet`: one row per input of the run (ok, reused and failed), with its
//!   status, the failed stage and error, the validation metrics and each simulation stage's
//!   status (ran / skipped: reason);
//! - `fleet_validation.parquet`: the distribution of every metric across the drives that have
//!   it: one row per statistic (`drives`, `mean`, `min`, `p05`, `p50`, `p95`, `max`; percentiles
//!   linear between order statistics, like numpy's default), one column per metric with its unit;
//! - `fleet_spectrum.parquet` and `fleet_spectrum.svg` (with the `spectrum` stage): the `road
//!   study` analysis over the fleet's recorded roads — PSD percentile bands across drives, the
//!   mean PSD and its knees, the slope filter's response (schema `road_study_psd`);
//! - `slope_shuffle_by_gear.svg`: per gear, all drives pooled, the shuffle the slope filter
//!   removes (raw-slope minus filtered-slope simulation, [`crate::sim::slope_shuffle`]) beside
//!   all shuffle with the raw slope;
//! - `shuffle_energy.svg`: per drive, the mean square shuffle indicator with the raw sensor slope
//!   and with the filtered slope (Myklebust & Eriksson (2012), §3 and §5: quantisation steps
//!   excite spurious shuffle);
//! - `error_metrics.svg`: empirical distribution functions of the fit metrics across drives;
//! - `summary.md`: counts, throughput, failures, skipped stages, slowest drives, the metric
//!   distribution table and the plots; `run_report.json`: everything, machine-readable.
//!
//! The Parquet tables and SVG plots are a function of the inputs and configuration only (the same
//! bytes for any `--jobs`, for a resumed run, for the union of shards re-reported); `summary.md`
//! and `run_report.json` also hold wall-clock timings.

use super::record::{DriveMetrics, DriveOutcome, DriveStatus, RunError, RunReport};
use super::run_summary::Distribution;
use super::spec::{PipelineStage, Plan};
use crate::io::{write_table, AtomicFile, OutColumn, OutData, TableMeta};
use crate::road::study::{filter_response, percentile_sorted};
use crate::signal::{cumulative_power, knee_frequency};
use crate::sim::slope_shuffle::pool;
use plotters::prelude::*;
use std::path::Path;

/// A fleet metric: column name, unit, accessor.
type MetricDef = (&'static str, &'static str, fn(&DriveMetrics) -> Option<f64>);

/// Every metric of the fleet tables, in column order.
pub const METRICS: [MetricDef; 17] = [
    ("duration", "s", |m| Some(m.duration_s)),
    ("distance", "m", |m| m.distance_m),
    ("slope_quantization_step", "1", |m| {
        m.slope_quantization_step
    }),
    ("vehicle_speed_rmse", "m/s", |m| m.vehicle_speed_rmse_mps),
    ("vehicle_speed_fit", "%", |m| m.vehicle_speed_fit_percent),
    ("engine_speed_rmse", "rad/s", |m| {
        m.engine_speed_rmse_rad_per_s
    }),
    ("engine_speed_fit", "%", |m| m.engine_speed_fit_percent),
    ("shuffle_ms", "m^2/s^2", |m| m.shuffle_ms_m2_per_s2),
    ("shuffle_ms_raw_slope", "m^2/s^2", |m| {
        m.shuffle_ms_raw_slope_m2_per_s2
    }),
    ("bellow_pressure_mae_front", "Pa", |m| {
        m.bellow_pressure_mae_pa[0]
    }),
    ("bellow_pressure_mae_rear", "Pa", |m| {
        m.bellow_pressure_mae_pa[1]
    }),
    ("bellow_pressure_mae_tag", "Pa", |m| {
        m.bellow_pressure_mae_pa[2]
    }),
    ("bellow_pressure_fit_front", "%", |m| {
        m.bellow_pressure_fit_percent[0]
    }),
    ("bellow_pressure_fit_rear", "%", |m| {
        m.bellow_pressure_fit_percent[1]
    }),
    ("bellow_pressure_fit_tag", "%", |m| {
        m.bellow_pressure_fit_percent[2]
    }),
    ("slope_knee_90", "1/m", |m| m.slope_knee_90_per_m),
    ("slope_knee_99", "1/m", |m| m.slope_knee_99_per_m),
];

const STATISTICS: [&str; 7] = ["drives", "mean", "min", "p05", "p50", "p95", "max"];

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RunError + '_ {
    move |source| RunError::Report {
        path: path.to_path_buf(),
        source,
    }
}

fn meta(table: &str, report: &RunReport, plan: &Plan) -> TableMeta {
    TableMeta {
        table: table.into(),
        drive_id: String::new(),
        vehicle_id: None,
        source_file: plan.file.clone(),
        config_hash: crate::io::config_hash(&[plan.fingerprint.as_bytes()]),
        extra: vec![
            ("pipeline".into(), report.pipeline.clone()),
            ("model_version".into(), report.model_version.clone()),
        ],
    }
}

fn strings(name: &str, v: Vec<String>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::Str(v),
    }
}

fn status_of(d: &DriveOutcome, stage: PipelineStage) -> String {
    d.record
        .as_ref()
        .and_then(|r| r.stages.iter().find(|n| n.stage == stage.name()))
        .map_or_else(String::new, |n| match &n.reason {
            Some(r) => format!("skipped: {r}"),
            None => n.status.clone(),
        })
}

/// Rows with a value of metric `k`: (drive id, value).
fn values_of(report: &RunReport, f: fn(&DriveMetrics) -> Option<f64>) -> Vec<(String, f64)> {
    report
        .drives
        .iter()
        .filter_map(|d| {
            let r = d.record.as_ref()?;
            f(&r.metrics)
                .filter(|x| x.is_finite())
                .map(|x| (r.drive_id.clone(), x))
        })
        .collect()
}

fn drive_validation(report: &RunReport) -> Vec<OutColumn> {
    let ds = &report.drives;
    let s = |f: &dyn Fn(&DriveOutcome) -> String| ds.iter().map(f).collect::<Vec<_>>();
    let mut cols = vec![
        strings("input", s(&|d| d.input.clone())),
        strings("drive_id", s(&|d| d.drive_id.clone())),
        strings(
            "vehicle_id",
            s(&|d| {
                d.record
                    .as_ref()
                    .map_or_else(String::new, |r| r.vehicle_id.clone())
            }),
        ),
        strings(
            "date",
            s(&|d| {
                d.record
                    .as_ref()
                    .map_or_else(String::new, |r| r.date.clone())
            }),
        ),
        strings(
            "status",
            s(&|d| {
                // reused and ok are one state of the dataset: a drive's results
                if d.status == DriveStatus::Failed {
                    "failed".into()
                } else {
                    "ok".into()
                }
            }),
        ),
        strings(
            "failed_stage",
            s(&|d| d.failed_stage.unwrap_or("").to_string()),
        ),
        strings("error", s(&|d| d.error.clone().unwrap_or_default())),
    ];
    for (name, unit, f) in METRICS {
        cols.push(OutColumn::f64(
            name,
            unit,
            ds.iter()
                .map(|d| {
                    d.record
                        .as_ref()
                        .and_then(|r| f(&r.metrics))
                        .unwrap_or(f64::NAN)
                })
                .collect(),
        ));
    }
    for st in [
        PipelineStage::Shuffle,
        PipelineStage::Axle,
        PipelineStage::Spectrum,
    ] {
        cols.push(strings(
            &format!("{}_status", st.name()),
            s(&|d| status_of(d, st)),
        ));
    }
    cols
}

/// Distribution of a metric: drives, mean, min, p05, p50, p95, max (NaN without values).
fn distribution(mut v: Vec<f64>) -> [f64; 7] {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return [
            0.0,
            f64::NAN,
            f64::NAN,
            f64::NAN,
            f64::NAN,
            f64::NAN,
            f64::NAN,
        ];
    }
    // a fixed summation order: sorted values, so the mean does not depend on drive order
    let mean = v.iter().sum::<f64>() / n as f64;
    [
        n as f64,
        mean,
        v[0],
        percentile_sorted(&v, 5.0),
        percentile_sorted(&v, 50.0),
        percentile_sorted(&v, 95.0),
        v[n - 1],
    ]
}

fn fleet_validation(report: &RunReport) -> (Vec<OutColumn>, Vec<Distribution>) {
    let mut cols = vec![strings(
        "statistic",
        STATISTICS.iter().map(|s| s.to_string()).collect(),
    )];
    let mut table = Vec::new();
    for (name, unit, f) in METRICS {
        let d = distribution(values_of(report, f).into_iter().map(|x| x.1).collect());
        cols.push(OutColumn::f64(name, unit, d.to_vec()));
        table.push((name, unit, d));
    }
    (cols, table)
}

/// Fleet PSD bands when every spectrum shares one frequency grid (one step and segment length).
struct FleetSpectrum {
    freq: Vec<f64>,
    p05: Vec<f64>,
    p50: Vec<f64>,
    p95: Vec<f64>,
    mean: Vec<f64>,
    drives: usize,
}

fn fleet_spectrum(report: &RunReport) -> Option<FleetSpectrum> {
    let spectra: Vec<&DriveMetrics> = report
        .drives
        .iter()
        .filter_map(|d| d.record.as_ref().map(|r| &r.metrics))
        .filter(|m| !m.spectrum_psd.is_empty())
        .collect();
    let first = spectra.first()?;
    let freq = first.spectrum_freq_per_m.clone();
    let same: Vec<&&DriveMetrics> = spectra
        .iter()
        .filter(|m| m.spectrum_freq_per_m == freq)
        .collect();
    let n = freq.len();
    let mut out = FleetSpectrum {
        freq,
        p05: vec![0.0; n],
        p50: vec![0.0; n],
        p95: vec![0.0; n],
        mean: vec![0.0; n],
        drives: same.len(),
    };
    for k in 0..n {
        let mut col: Vec<f64> = same.iter().map(|m| m.spectrum_psd[k]).collect();
        col.sort_by(f64::total_cmp);
        out.p05[k] = percentile_sorted(&col, 5.0);
        out.p50[k] = percentile_sorted(&col, 50.0);
        out.p95[k] = percentile_sorted(&col, 95.0);
        out.mean[k] = col.iter().sum::<f64>() / col.len() as f64;
    }
    Some(out)
}

/// Per-drive points on a log y axis (one series per label), x = drive in input order.
fn per_drive_svg(
    title: &str,
    y_desc: &str,
    ids: &[String],
    series: &[(&str, Vec<Option<f64>>)],
) -> Result<String, String> {
    let vals: Vec<f64> = series
        .iter()
        .flat_map(|s| s.1.iter().flatten().copied())
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    if vals.is_empty() {
        return Err("nothing positive to draw".into());
    }
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min) / 3.0;
    let hi = vals.iter().copied().fold(0.0f64, f64::max) * 3.0;
    let n = ids.len();
    let mut svg = String::new();
    {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let root = SVGBackend::with_string(&mut svg, (1000, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(90)
            .y_label_area_size(80)
            .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), (lo..hi).log_scale())
            .map_err(|x| e(&x))?;
        let labels = ids.to_vec();
        chart
            .configure_mesh()
            .x_labels(n.min(40))
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
                    labels[i as usize].clone()
                } else {
                    String::new()
                }
            })
            .x_label_style(
                ("sans-serif", 11)
                    .into_font()
                    .transform(FontTransform::Rotate90),
            )
            .y_desc(y_desc)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|x| e(&x))?;
        let colours = [
            RGBColor(200, 60, 40),
            RGBColor(20, 90, 170),
            RGBColor(40, 140, 60),
        ];
        for (k, (label, v)) in series.iter().enumerate() {
            let c = colours[k % colours.len()];
            let pts: Vec<(f64, f64)> = v
                .iter()
                .enumerate()
                .filter_map(|(i, x)| x.filter(|x| *x > 0.0).map(|x| (i as f64, x)))
                .collect();
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 5, c.filled())))
                .map_err(|x| e(&x))?
                .label(label.to_string())
                .legend(move |(x, y)| Circle::new((x + 7, y), 5, c.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(svg)
}

/// Empirical distribution functions of fit metrics (%), one line per metric.
fn ecdf_svg(title: &str, series: &[(&str, Vec<f64>)]) -> Result<String, String> {
    let all: Vec<f64> = series.iter().flat_map(|s| s.1.iter().copied()).collect();
    if all.is_empty() {
        return Err("no values".into());
    }
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min).min(0.0) - 5.0;
    let hi = all
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
        .max(100.0)
        + 5.0;
    let mut svg = String::new();
    {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let root = SVGBackend::with_string(&mut svg, (1000, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(lo..hi, 0.0f64..1.0)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("fit [%] (100 = perfect)")
            .y_desc("fraction of drives")
            .draw()
            .map_err(|x| e(&x))?;
        let colours = [
            RGBColor(20, 90, 170),
            RGBColor(200, 60, 40),
            RGBColor(40, 140, 60),
            RGBColor(120, 60, 160),
            RGBColor(90, 90, 90),
        ];
        for (k, (label, v)) in series.iter().enumerate() {
            let mut v = v.clone();
            v.sort_by(f64::total_cmp);
            let n = v.len() as f64;
            let mut pts = vec![(lo, 0.0)];
            for (i, &x) in v.iter().enumerate() {
                pts.push((x, i as f64 / n));
                pts.push((x, (i + 1) as f64 / n));
            }
            pts.push((hi, 1.0));
            let c = colours[k % colours.len()];
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                .map_err(|x| e(&x))?
                .label(format!("{label} ({} drives)", v.len()))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], c));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(svg)
}

/// Writes every file of the run report into `dir` (see the module doc).
///
/// # Errors
/// [`RunError`] when a file cannot be written.
pub fn write_run_report(dir: &Path, plan: &Plan, report: &RunReport) -> Result<(), RunError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    // leftovers of an interrupted report write (this report folder belongs to this run)
    crate::io::remove_stale_temps(dir).map_err(io_err(dir))?;
    let mut written: Vec<&str> = Vec::new();
    write_table(
        &dir.join("drive_validation.parquet"),
        &meta("drive_validation", report, plan),
        &drive_validation(report),
    )?;
    written.push("drive_validation.parquet");
    let (cols, dist) = fleet_validation(report);
    write_table(
        &dir.join("fleet_validation.parquet"),
        &meta("fleet_validation", report, plan),
        &cols,
    )?;
    written.push("fleet_validation.parquet");

    let ids: Vec<String> = report
        .drives
        .iter()
        .filter(|d| d.record.is_some())
        .map(|d| d.drive_id.clone())
        .collect();
    let recs: Vec<&DriveMetrics> = report
        .drives
        .iter()
        .filter_map(|d| d.record.as_ref().map(|r| &r.metrics))
        .collect();
    let mut plots: Vec<(&str, &str)> = Vec::new();
    if recs.iter().any(|m| m.shuffle_ms_m2_per_s2.is_some()) {
        let svg = per_drive_svg(
            "Shuffle excited by the road slope: mean square shuffle indicator (1-5 Hz band of the simulated speed)",
            "mean square shuffle indicator [m²/s²]",
            &ids,
            &[
                (
                    "raw sensor slope",
                    recs.iter().map(|m| m.shuffle_ms_raw_slope_m2_per_s2).collect(),
                ),
                (
                    "configured slope input (filtered)",
                    recs.iter().map(|m| m.shuffle_ms_m2_per_s2).collect(),
                ),
            ],
        );
        if let Ok(svg) = svg {
            let p = dir.join("shuffle_energy.svg");
            AtomicFile::write_all(&p, svg.as_bytes()).map_err(io_err(&p))?;
            written.push("shuffle_energy.svg");
            plots.push(("shuffle_energy.svg", "Shuffle before/after slope filtering"));
        }
    }
    let by_gear = pool(recs.iter().map(|m| m.slope_shuffle_by_gear.as_slice()));
    if !by_gear.is_empty() {
        let gears: Vec<String> = by_gear.iter().map(|g| format!("gear {}", g.gear)).collect();
        let svg = per_drive_svg(
            "Shuffle the slope filter removes, per gear: 1-5 Hz mean square of raw-slope minus filtered-slope simulated speed",
            "mean square shuffle indicator [m²/s²]",
            &gears,
            &[
                (
                    "removed by the filter (raw - filtered slope run)",
                    by_gear.iter().map(|g| Some(g.ms_slope_m2_per_s2)).collect(),
                ),
                (
                    "all shuffle, raw sensor slope",
                    by_gear.iter().map(|g| Some(g.ms_total_m2_per_s2)).collect(),
                ),
            ],
        );
        if let Ok(svg) = svg {
            let p = dir.join("slope_shuffle_by_gear.svg");
            AtomicFile::write_all(&p, svg.as_bytes()).map_err(io_err(&p))?;
            written.push("slope_shuffle_by_gear.svg");
            plots.push((
                "slope_shuffle_by_gear.svg",
                "Shuffle the slope filter removes, per gear",
            ));
        }
    }
    let fits: Vec<(&str, Vec<f64>)> = [
        ("vehicle speed fit", 4usize),
        ("engine speed fit", 6),
        ("bellow pressure fit, front", 12),
        ("bellow pressure fit, rear", 13),
        ("bellow pressure fit, tag", 14),
    ]
    .into_iter()
    .map(|(label, k)| {
        (
            label,
            values_of(report, METRICS[k].2)
                .into_iter()
                .map(|x| x.1)
                .collect::<Vec<f64>>(),
        )
    })
    .filter(|s| !s.1.is_empty())
    .collect();
    if !fits.is_empty() {
        if let Ok(svg) = ecdf_svg("Model fit across the fleet (empirical distribution)", &fits) {
            let p = dir.join("error_metrics.svg");
            AtomicFile::write_all(&p, svg.as_bytes()).map_err(io_err(&p))?;
            written.push("error_metrics.svg");
            plots.push(("error_metrics.svg", "Error-metric distribution"));
        }
    }
    let mut spectrum_line = None;
    if plan.has(PipelineStage::Spectrum) {
        if let Some(fs) = fleet_spectrum(report) {
            let step = plan.spec.resample.step_m;
            let filter = filter_response(&fs.freq, step).ok();
            let cum = cumulative_power(&fs.freq, &fs.mean);
            let knees = [0.5, 0.9, 0.99].map(|q| knee_frequency(&fs.freq, &fs.mean, q));
            if let Some(filter) = &filter {
                let cols = vec![
                    OutColumn::f64("frequency", "1/m", fs.freq.clone()),
                    OutColumn::f64("psd_p05", "(1)^2/(1/m)", fs.p05.clone()),
                    OutColumn::f64("psd_p50", "(1)^2/(1/m)", fs.p50.clone()),
                    OutColumn::f64("psd_p95", "(1)^2/(1/m)", fs.p95.clone()),
                    OutColumn::f64("psd_mean", "(1)^2/(1/m)", fs.mean.clone()),
                    OutColumn::f64("cumulative_power_mean", "1", cum),
                    OutColumn::f64("filter_zero_phase_gain", "dB", filter.zero_phase_db.clone()),
                    OutColumn::f64("filter_causal_gain", "dB", filter.causal_db.clone()),
                ];
                let mut m = meta("road_study_psd", report, plan);
                m.extra.push(("drives".into(), fs.drives.to_string()));
                for (q, k) in ["50", "90", "99"].iter().zip(knees) {
                    m.extra
                        .push((format!("knee_{q}_of_mean_per_m"), format!("{k:e}")));
                }
                write_table(&dir.join("fleet_spectrum.parquet"), &m, &cols)?;
                written.push("fleet_spectrum.parquet");
                let plot = crate::report::road_plot::PsdPlot {
                    title: format!(
                        "Road slope PSD across {} recorded drives ({} model {})",
                        fs.drives, report.pipeline, report.model_version
                    ),
                    freq_per_m: &fs.freq,
                    band: (&fs.p05, &fs.p95, "5-95 % of drives".into()),
                    lines: vec![
                        (&fs.p50, "median".into(), false),
                        (&fs.mean, "mean".into(), true),
                    ],
                    knees: vec![
                        (knees[1], "90 % knee of the mean".into()),
                        (knees[2], "99 % knee of the mean".into()),
                    ],
                    filter,
                };
                if let Ok(svg) = crate::report::road_plot::render_psd_svg(&plot) {
                    let p = dir.join("fleet_spectrum.svg");
                    AtomicFile::write_all(&p, svg.as_bytes()).map_err(io_err(&p))?;
                    written.push("fleet_spectrum.svg");
                    plots.push(("fleet_spectrum.svg", "Road slope spectrum of the fleet"));
                }
                spectrum_line = Some(format!(
                    "Fleet road spectrum over {} drives: half the slope power below {:.3e} 1/m, 90 % below {:.3e} 1/m, 99 % below {:.3e} 1/m (the slope filter's cut-off is {} 1/m).",
                    fs.drives, knees[0], knees[1], knees[2], plan.spec.slope.cutoff_per_m
                ));
            }
        }
    }

    let md = super::run_summary::summary_md(
        plan,
        report,
        &dist,
        &by_gear,
        &plots,
        spectrum_line.as_deref(),
    );
    let p = dir.join("summary.md");
    AtomicFile::write_all(&p, md.as_bytes()).map_err(io_err(&p))?;
    written.push("summary.md");
    let json = serde_json::to_string_pretty(report).map_err(std::io::Error::other);
    let p = dir.join("run_report.json");
    let json = json.map_err(io_err(&p))?;
    AtomicFile::write_all(&p, format!("{json}\n").as_bytes()).map_err(io_err(&p))?;
    written.push("run_report.json");
    // plots of an earlier run of this report folder that this run did not make
    for stale in [
        "shuffle_energy.svg",
        "slope_shuffle_by_gear.svg",
        "error_metrics.svg",
        "fleet_spectrum.svg",
        "fleet_spectrum.parquet",
    ] {
        if !written.contains(&stale) {
            let _ = std::fs::remove_file(dir.join(stale));
        }
    }
    Ok(())
}
