//! Outputs of `fleetdyn road spectrum` and `fleetdyn road study`: Parquet tables with units
//! (schemas `road_spectrum`, `road_study_psd`, `road_study_knees` in `schemas/outputs/`) and the
//! SVG plot of [`crate::report::road_plot`]. Each output set is all or nothing: the plot is
//! rendered in memory first, every file is written atomically, and when a later file fails the
//! ones already written by the same call are removed.

use super::road_plot::{render_psd_svg, PsdPlot};
use crate::io::{config_hash, write_table, AtomicFile, OutColumn, OutData, OutputError, TableMeta};
use crate::road::road_table::{DistanceColumn, GENERATOR};
use crate::road::study::{RoadSpectrum, SpectrumSettings, Study};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// PSD unit of a slope (unit `1`) over spatial frequency (1/m), as in the `spectrum` table.
pub const SLOPE_PSD_UNIT: &str = "(1)^2/(1/m)";

/// Why an output set could not be written.
#[derive(Debug, Error)]
pub enum RoadReportError {
    /// A Parquet table.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The plot could not be drawn.
    #[error("plot {path}: {message}")]
    Plot {
        /// Target.
        path: PathBuf,
        /// Backend message.
        message: String,
    },
    /// The plot could not be written.
    #[error("writing {path}: {source}")]
    Io {
        /// Target.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

pub(crate) fn write_svg(path: &Path, svg: &str) -> Result<(), RoadReportError> {
    let io = |source| RoadReportError::Io {
        path: path.to_path_buf(),
        source,
    };
    AtomicFile::write_all(path, svg.as_bytes()).map_err(io)
}

/// One output file: its path and the writer that puts it there.
pub(crate) type Step<'a> = (
    PathBuf,
    Box<dyn FnOnce(&Path) -> Result<(), RoadReportError> + 'a>,
);

/// Runs the writers in order; on the first error removes the files the earlier ones wrote.
pub(crate) fn all_or_nothing(steps: Vec<Step<'_>>) -> Result<Vec<PathBuf>, RoadReportError> {
    let mut done: Vec<PathBuf> = Vec::new();
    for (path, write) in steps {
        if let Err(e) = write(&path) {
            for p in &done {
                let _ = std::fs::remove_file(p);
            }
            return Err(e);
        }
        done.push(path);
    }
    Ok(done)
}

fn fmt_knee(f: f64) -> String {
    format!("{f:.3e}")
}

/// Writes `road_spectrum.parquet` and `road_spectrum.svg` into `dir` for one road's slope.
///
/// # Errors
/// [`RoadReportError`]; no output is left behind on error.
pub fn write_road_spectrum(
    dir: &Path,
    col: &DistanceColumn,
    sp: &RoadSpectrum,
    settings: &SpectrumSettings,
) -> Result<Vec<PathBuf>, RoadReportError> {
    let (pq, svg_path) = (
        dir.join("road_spectrum.parquet"),
        dir.join("road_spectrum.svg"),
    );
    let label = col
        .kv
        .get("rule_set")
        .map(|r| {
            format!(
                "synthetic {r}, seed {}",
                col.kv.get("seed").map_or("?", |s| s.as_str())
            )
        })
        .unwrap_or_else(|| col.file.display().to_string());
    let road_km = (col.values.len() - 1) as f64 * sp.step_m / 1000.0;
    let title = format!(
        "Slope PSD of {label} ({road_km:.1} km, {} Welch segments of {:.0} m)",
        sp.psd.n_segments,
        sp.psd.nperseg as f64 * sp.step_m
    );
    let plot = PsdPlot {
        title,
        freq_per_m: &sp.psd.freq_hz,
        band: (
            &sp.psd.lower,
            &sp.psd.upper,
            format!("{:.0} % confidence band", settings.confidence * 100.0),
        ),
        lines: vec![(&sp.psd.psd, "Welch PSD".into(), false)],
        knees: vec![
            (
                sp.knee_50,
                format!("50 % of power below {}", fmt_knee(sp.knee_50)),
            ),
            (
                sp.knee_90,
                format!("90 % of power below {}", fmt_knee(sp.knee_90)),
            ),
            (
                sp.knee_99,
                format!("99 % of power below {}", fmt_knee(sp.knee_99)),
            ),
        ],
        filter: &sp.filter,
    };
    let svg = render_psd_svg(&plot).map_err(|message| RoadReportError::Plot {
        path: svg_path.clone(),
        message,
    })?;
    let fc = sp.filter.config;
    let fp = crate::io::canonical(
        "road-spectrum:v2",
        &serde_json::json!({
            "column": col.column,
            "step_m": sp.step_m,
            "settings": settings,
            "filter": fc,
        }),
    );
    let meta = TableMeta {
        table: "road_spectrum".into(),
        drive_id: col.kv.get("drive_id").cloned().unwrap_or_default(),
        vehicle_id: None,
        source_file: col.file.display().to_string(),
        config_hash: config_hash(&[fp.as_bytes()]),
        extra: vec![
            ("column".into(), col.column.clone()),
            ("step_m".into(), sp.step_m.to_string()),
            (
                "segment_length_m".into(),
                settings.segment_length_m.to_string(),
            ),
            ("nperseg".into(), sp.psd.nperseg.to_string()),
            ("noverlap".into(), sp.psd.noverlap.to_string()),
            ("n_segments".into(), sp.psd.n_segments.to_string()),
            ("equivalent_dof".into(), format!("{:.3}", sp.psd.dof)),
            ("confidence".into(), settings.confidence.to_string()),
            ("knee_50_per_m".into(), format!("{:e}", sp.knee_50)),
            ("knee_90_per_m".into(), format!("{:e}", sp.knee_90)),
            ("knee_99_per_m".into(), format!("{:e}", sp.knee_99)),
            (
                "share_below_3e-4_per_m".into(),
                format!("{:e}", sp.share_below_paper[0]),
            ),
            (
                "share_below_1e-3_per_m".into(),
                format!("{:e}", sp.share_below_paper[1]),
            ),
            ("window".into(), "hann (periodic)".into()),
            ("detrend".into(), "constant".into()),
            ("scaling".into(), "density, one-sided".into()),
            ("filter".into(), filter_text(sp.filter.causal_order, &fc)),
        ],
    };
    let cols = vec![
        OutColumn::f64("frequency", "1/m", sp.psd.freq_hz.clone()),
        OutColumn::f64("psd", SLOPE_PSD_UNIT, sp.psd.psd.clone()),
        OutColumn::f64("psd_lower", SLOPE_PSD_UNIT, sp.psd.lower.clone()),
        OutColumn::f64("psd_upper", SLOPE_PSD_UNIT, sp.psd.upper.clone()),
        OutColumn::f64("cumulative_power", "1", sp.cumulative.clone()),
        OutColumn::f64(
            "filter_zero_phase_gain",
            "dB",
            sp.filter.zero_phase_db.clone(),
        ),
        OutColumn::f64("filter_causal_gain", "dB", sp.filter.causal_db.clone()),
    ];
    all_or_nothing(vec![
        (
            pq,
            Box::new(move |p: &Path| write_table(p, &meta, &cols).map_err(Into::into)),
        ),
        (svg_path, Box::new(move |p: &Path| write_svg(p, &svg))),
    ])
}

pub(crate) fn filter_text(
    causal_order: usize,
    fc: &crate::road::slope_filter::SlopeFilterConfig,
) -> String {
    format!(
        "Butterworth low-pass, cut-off {} 1/m; zero-phase order {} (|H|^2), causal order {} (|H|); -{} dB required at {} 1/m (Myklebust & Eriksson 2012, §5)",
        fc.cutoff_per_m, fc.order, causal_order, fc.required_attenuation_db, fc.stop_per_m
    )
}

/// Writes `road_study_psd.parquet`, `road_study_knees.parquet` and `road_study.svg` into `dir`.
/// `rules_origin` names where the rules came from (bundled name or file).
///
/// # Errors
/// [`RoadReportError`]; no output is left behind on error.
pub fn write_study(
    dir: &Path,
    study: &Study,
    rules_origin: &str,
) -> Result<Vec<PathBuf>, RoadReportError> {
    let cfg = &study.config;
    let (psd_path, knees_path, svg_path) = (
        dir.join("road_study_psd.parquet"),
        dir.join("road_study_knees.parquet"),
        dir.join("road_study.svg"),
    );
    let last_seed = cfg.seed + cfg.n_roads as u64 - 1;
    let title = format!(
        "Slope PSD, {}: {} roads x {:.0} km (seeds {}-{}), Welch segments of {:.0} m",
        cfg.rules.name,
        cfg.n_roads,
        cfg.length_m / 1000.0,
        cfg.seed,
        last_seed,
        study.nperseg as f64 * cfg.step_m
    );
    let plot = PsdPlot {
        title,
        freq_per_m: &study.freq_per_m,
        band: (&study.psd_p05, &study.psd_p95, "5-95 % of roads".into()),
        lines: vec![
            (&study.psd_p50, "median PSD".into(), false),
            (&study.psd_mean, "mean PSD".into(), true),
        ],
        knees: [
            ("50", &study.knee_50),
            ("90", &study.knee_90),
            ("99", &study.knee_99),
        ]
        .into_iter()
        .map(|(pct, k)| {
            (
                k.p50,
                format!(
                    "{pct} % knee: median {} (5-95 %: {} - {}) 1/m",
                    fmt_knee(k.p50),
                    fmt_knee(k.p05),
                    fmt_knee(k.p95)
                ),
            )
        })
        .collect(),
        filter: &study.filter,
    };
    let svg = render_psd_svg(&plot).map_err(|message| RoadReportError::Plot {
        path: svg_path.clone(),
        message,
    })?;
    let rules_toml = cfg.rules.canonical_toml();
    let fp = format!(
        "{}\n{rules_toml}",
        crate::io::canonical(
            "road-study:v2",
            &serde_json::json!({
                "generator": GENERATOR,
                "roads": cfg.n_roads,
                "seed": cfg.seed,
                "length_m": cfg.length_m,
                "step_m": cfg.step_m,
                "spectrum": cfg.spectrum,
            }),
        )
    );
    let hash = config_hash(&[fp.as_bytes()]);
    let pct = |name: &str, p: &crate::road::study::Percentiles| {
        vec![
            (format!("{name}_p05_per_m"), format!("{:e}", p.p05)),
            (format!("{name}_p50_per_m"), format!("{:e}", p.p50)),
            (format!("{name}_p95_per_m"), format!("{:e}", p.p95)),
        ]
    };
    let mut extra = vec![
        ("generator".into(), GENERATOR.to_string()),
        ("rule_set".into(), cfg.rules.name.clone()),
        ("rules_origin".into(), rules_origin.to_string()),
        ("rules_source".into(), cfg.rules.source.clone()),
        ("rules_toml".into(), rules_toml),
        ("roads".into(), cfg.n_roads.to_string()),
        ("seed_first".into(), cfg.seed.to_string()),
        ("seed_last".into(), last_seed.to_string()),
        ("length_m".into(), cfg.length_m.to_string()),
        ("step_m".into(), cfg.step_m.to_string()),
        (
            "segment_length_m".into(),
            cfg.spectrum.segment_length_m.to_string(),
        ),
        ("nperseg".into(), study.nperseg.to_string()),
        ("n_segments".into(), study.n_segments.to_string()),
        ("equivalent_dof".into(), format!("{:.3}", study.dof)),
        (
            "percentiles".into(),
            "numpy linear: value at rank p*(n-1) of the sorted roads".into(),
        ),
        (
            "share_below_3e-4_per_m".into(),
            format!("{:e}", study.share_below_paper[0]),
        ),
        (
            "share_below_1e-3_per_m".into(),
            format!("{:e}", study.share_below_paper[1]),
        ),
        (
            "knee_50_of_mean_per_m".into(),
            format!("{:e}", study.knee_50_of_mean),
        ),
        (
            "knee_90_of_mean_per_m".into(),
            format!("{:e}", study.knee_90_of_mean),
        ),
        (
            "knee_99_of_mean_per_m".into(),
            format!("{:e}", study.knee_99_of_mean),
        ),
        (
            "filter".into(),
            filter_text(study.filter.causal_order, &study.filter.config),
        ),
        (
            "filter_power_removed_zero_phase".into(),
            format!("{:.6}", study.removed_by_zero_phase),
        ),
        (
            "filter_power_removed_causal".into(),
            format!("{:.6}", study.removed_by_causal),
        ),
    ];
    extra.extend(pct("knee_50", &study.knee_50));
    extra.extend(pct("knee_90", &study.knee_90));
    extra.extend(pct("knee_99", &study.knee_99));
    let meta = |table: &str| TableMeta {
        table: table.into(),
        drive_id: format!("study-{}-seeds-{}-{}", cfg.rules.name, cfg.seed, last_seed),
        vehicle_id: None,
        source_file: String::new(),
        config_hash: hash.clone(),
        extra: extra.clone(),
    };
    let (psd_meta, knees_meta) = (meta("road_study_psd"), meta("road_study_knees"));
    let psd_cols = vec![
        OutColumn::f64("frequency", "1/m", study.freq_per_m.clone()),
        OutColumn::f64("psd_p05", SLOPE_PSD_UNIT, study.psd_p05.clone()),
        OutColumn::f64("psd_p50", SLOPE_PSD_UNIT, study.psd_p50.clone()),
        OutColumn::f64("psd_p95", SLOPE_PSD_UNIT, study.psd_p95.clone()),
        OutColumn::f64("psd_mean", SLOPE_PSD_UNIT, study.psd_mean.clone()),
        OutColumn::f64("cumulative_power_mean", "1", study.cumulative_mean.clone()),
        OutColumn::f64(
            "filter_zero_phase_gain",
            "dB",
            study.filter.zero_phase_db.clone(),
        ),
        OutColumn::f64("filter_causal_gain", "dB", study.filter.causal_db.clone()),
    ];
    let r = &study.roads;
    let u64_col = |name: &str, v: Vec<u64>| OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::U64(v),
    };
    let knee_cols = vec![
        u64_col("seed", r.iter().map(|k| k.seed).collect()),
        OutColumn::f64("knee_50", "1/m", r.iter().map(|k| k.knee_50).collect()),
        OutColumn::f64("knee_90", "1/m", r.iter().map(|k| k.knee_90).collect()),
        OutColumn::f64("knee_99", "1/m", r.iter().map(|k| k.knee_99).collect()),
        OutColumn::f64("slope_rms", "1", r.iter().map(|k| k.slope_rms).collect()),
        OutColumn::f64(
            "max_abs_slope",
            "1",
            r.iter().map(|k| k.max_abs_slope).collect(),
        ),
        u64_col(
            "grade_segments",
            r.iter().map(|k| k.grade_segments as u64).collect(),
        ),
        u64_col(
            "lengthened_segments",
            r.iter().map(|k| k.lengthened_segments as u64).collect(),
        ),
    ];
    all_or_nothing(vec![
        (
            psd_path,
            Box::new(move |p: &Path| write_table(p, &psd_meta, &psd_cols).map_err(Into::into)),
        ),
        (
            knees_path,
            Box::new(move |p: &Path| write_table(p, &knees_meta, &knee_cols).map_err(Into::into)),
        ),
        (svg_path, Box::new(move |p: &Path| write_svg(p, &svg))),
    ])
}
