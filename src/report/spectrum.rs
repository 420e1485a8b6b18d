//! Spectra of drive signals: Welch PSD (scipy conventions, see [`crate::signal::welch`]) of one
//! column in the distance domain (1/m, on the resampled grid) or the time domain (Hz, on the
//! drive's uniform time base), with confidence bounds, cumulative power and the "knee"
//! frequencies below which 90 % and 99 % of the power lies (Myklebust & Eriksson (2012), §4).

use crate::io::{config_hash, write_table, OutColumn, OutputError, TableMeta};
use crate::schema::{drive_log, Interpolation};
use crate::signal::distance::{fill_gaps, DistanceLog};
use crate::signal::{cumulative_power, knee_frequency, welch, SignalError, WelchConfig, WelchPsd};
use crate::table::{DriveLog, DriveMeta};
use std::path::Path;
use thiserror::Error;

/// Why a spectrum could not be computed.
#[derive(Debug, Error)]
pub enum SpectrumError {
    /// Column absent.
    #[error("{file}: no column {column}")]
    NoColumn {
        /// Source file.
        file: String,
        /// Column.
        column: String,
    },
    /// Missing values in the analysed column.
    #[error("{file}: column {column} has {count} missing values; a PSD needs a gap-free signal")]
    Missing {
        /// Source file.
        file: String,
        /// Column.
        column: String,
        /// Number of NaN.
        count: usize,
    },
    /// Time base not uniform (time-domain spectra need uniform sampling).
    #[error("{file}: sample times are not uniform (period {min_ns} … {max_ns} ns); use the distance domain or a multi-rate source aligned at ingest")]
    NonUniform {
        /// Source file.
        file: String,
        /// Smallest period.
        min_ns: i64,
        /// Largest period.
        max_ns: i64,
    },
    /// Welch failed.
    #[error("{file}: {source}")]
    Welch {
        /// Source file.
        file: String,
        /// Cause.
        #[source]
        source: SignalError,
    },
}

/// A spectrum with its units and knees.
#[derive(Debug, Clone)]
pub struct Spectrum {
    /// Column analysed.
    pub column: String,
    /// Unit of the column.
    pub unit: String,
    /// `1/m` or `Hz`.
    pub freq_unit: &'static str,
    /// The Welch estimate.
    pub psd: WelchPsd,
    /// Cumulative fraction of power at each frequency (0 … 1).
    pub cumulative: Vec<f64>,
    /// Frequency below which 90 % of the power lies.
    pub knee_90: f64,
    /// Frequency below which 99 % of the power lies.
    pub knee_99: f64,
}

#[allow(clippy::too_many_arguments)]
fn compute(
    file: &str,
    column: &str,
    unit: &str,
    values: &[f64],
    fs: f64,
    freq_unit: &'static str,
    nperseg: Option<usize>,
    confidence: f64,
) -> Result<Spectrum, SpectrumError> {
    let count = values.iter().filter(|v| !v.is_finite()).count();
    if count > 0 {
        return Err(SpectrumError::Missing {
            file: file.into(),
            column: column.into(),
            count,
        });
    }
    let cfg = WelchConfig {
        fs_hz: fs,
        nperseg,
        noverlap: None,
        confidence,
    };
    let psd = welch(values, &cfg).map_err(|e| SpectrumError::Welch {
        file: file.into(),
        source: e,
    })?;
    let cumulative = cumulative_power(&psd.freq_hz, &psd.psd);
    Ok(Spectrum {
        column: column.into(),
        unit: unit.into(),
        freq_unit,
        knee_90: knee_frequency(&psd.freq_hz, &psd.psd, 0.9),
        knee_99: knee_frequency(&psd.freq_hz, &psd.psd, 0.99),
        psd,
        cumulative,
    })
}

fn interpolation_of(column: &str) -> Interpolation {
    drive_log()
        .column(column)
        .map_or(Interpolation::Linear, |c| c.interpolation)
}

/// Canonical text of a spectrum's settings, for the config hash: the column, the segment length
/// (`None`: the default), the confidence level and, for a spectrum of a road profile, the
/// profile's grid step in m.
pub fn fingerprint(
    profile_step_m: Option<f64>,
    column: &str,
    nperseg: Option<usize>,
    confidence: f64,
) -> String {
    crate::io::canonical(
        "spectrum:v2",
        &serde_json::json!({
            "profile_step_m": profile_step_m,
            "column": column,
            "nperseg": nperseg,
            "confidence": confidence,
        }),
    )
}

/// Spectrum of a column of a distance log (frequency in 1/m). Short gaps (those ingest accepted)
/// are filled per the column's interpolation kind; a column without any value is an error.
///
/// # Errors
/// [`SpectrumError`].
pub fn of_distance_log(
    d: &DistanceLog,
    column: &str,
    nperseg: Option<usize>,
    confidence: f64,
) -> Result<Spectrum, SpectrumError> {
    let s = d
        .signals
        .iter()
        .find(|s| s.name == column)
        .ok_or_else(|| SpectrumError::NoColumn {
            file: d.meta.source_file.clone(),
            column: column.into(),
        })?;
    let values = fill_gaps(&s.values, interpolation_of(column)).unwrap_or_else(|| s.values.clone());
    compute(
        &d.meta.source_file,
        column,
        &s.unit,
        &values,
        1.0 / d.step_m,
        "1/m",
        nperseg,
        confidence,
    )
}

/// Spectrum of a signal already on a uniform distance grid of `step_m` (frequency in 1/m), e.g.
/// a column of a road profile ([`crate::road::profile_table::read_profile_column`]). The signal must
/// be gap-free.
///
/// # Errors
/// [`SpectrumError::Missing`] for NaN values; [`SpectrumError::Welch`].
pub fn of_grid(
    file: &str,
    column: &str,
    unit: &str,
    values: &[f64],
    step_m: f64,
    nperseg: Option<usize>,
    confidence: f64,
) -> Result<Spectrum, SpectrumError> {
    compute(
        file,
        column,
        unit,
        values,
        1.0 / step_m,
        "1/m",
        nperseg,
        confidence,
    )
}

/// Spectrum of a column of a drive log in time (Hz); the time base must be uniform within 1 %.
/// Short gaps are filled as in [`of_distance_log`].
///
/// # Errors
/// [`SpectrumError`].
pub fn of_drive_log(
    log: &DriveLog,
    column: &str,
    nperseg: Option<usize>,
    confidence: f64,
) -> Result<Spectrum, SpectrumError> {
    let file = log.meta.source_file.clone();
    let s = log
        .signals
        .iter()
        .find(|s| s.name == column)
        .ok_or_else(|| SpectrumError::NoColumn {
            file: file.clone(),
            column: column.into(),
        })?;
    let dts: Vec<i64> = log.timestamp_ns.windows(2).map(|w| w[1] - w[0]).collect();
    let (min_ns, max_ns) = (
        dts.iter().copied().min().unwrap_or(0),
        dts.iter().copied().max().unwrap_or(0),
    );
    if min_ns <= 0 || (max_ns - min_ns) as f64 > 0.01 * min_ns as f64 {
        return Err(SpectrumError::NonUniform {
            file,
            min_ns,
            max_ns,
        });
    }
    let fs = 1e9 / (log.duration_s() * 1e9 / dts.len() as f64);
    let values = fill_gaps(&s.values, interpolation_of(column)).unwrap_or_else(|| s.values.clone());
    compute(
        &file, column, &s.unit, &values, fs, "Hz", nperseg, confidence,
    )
}

/// Writes a spectrum table (schema `spectrum`), knees and Welch settings in the metadata.
///
/// # Errors
/// [`OutputError`].
pub fn write(path: &Path, meta: &DriveMeta, sp: &Spectrum, fp: &str) -> Result<(), OutputError> {
    let psd_unit = format!("({})^2/({})", sp.unit, sp.freq_unit);
    let cols = vec![
        OutColumn::f64("frequency", sp.freq_unit, sp.psd.freq_hz.clone()),
        OutColumn::f64("psd", &psd_unit, sp.psd.psd.clone()),
        OutColumn::f64("psd_lower", &psd_unit, sp.psd.lower.clone()),
        OutColumn::f64("psd_upper", &psd_unit, sp.psd.upper.clone()),
        OutColumn::f64("cumulative_power", "1", sp.cumulative.clone()),
    ];
    let tm = TableMeta {
        table: "spectrum".into(),
        drive_id: meta.drive_id.clone(),
        vehicle_id: meta.vehicle_id.clone(),
        source_file: meta.source_file.clone(),
        config_hash: config_hash(&[fp.as_bytes()]),
        extra: vec![
            ("column".into(), sp.column.clone()),
            ("nperseg".into(), sp.psd.nperseg.to_string()),
            ("noverlap".into(), sp.psd.noverlap.to_string()),
            ("n_segments".into(), sp.psd.n_segments.to_string()),
            ("equivalent_dof".into(), format!("{:.3}", sp.psd.dof)),
            ("knee_90".into(), format!("{:e}", sp.knee_90)),
            ("knee_99".into(), format!("{:e}", sp.knee_99)),
            ("window".into(), "hann (periodic)".into()),
            ("detrend".into(), "constant".into()),
            ("scaling".into(), "density, one-sided".into()),
        ],
    };
    write_table(path, &tm, &cols)
}
