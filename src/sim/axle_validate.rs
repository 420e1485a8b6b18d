//! Validation of the axle-load model against a recording (docs/models/axle.md): the recorded
//! drive's inputs drive the half-truck model on the recording's time axis, and the simulated bellow
//! pressures (and suspension travel, where recorded) are compared with the CAN-bus signals: MAE
//! (axle-load thesis, eq. 3.7.1, which calls it MSE), RMSE and fit % per axle, over the whole drive
//! and per scenario segment.
//!
//! The model is stable (springs to the static state), so it runs open loop over the whole drive
//! from the steady state of the first row's inputs; there is no drift to re-initialise.
//! Segments, from the acceleration input: `acceleration` where a > `accel_threshold_mps2`,
//! `braking` where a < −threshold, `steady` between.

use super::axle::{AxleTrajectory, HalfTruck, Start};
use super::axle_recorded::{axle_inputs_from_log, AxleRecordConfig, RecordedAxleInputs};
use super::recorded::RecordedError;
use super::validate::error_metrics;
use crate::model::axle::{Axle, AxleParams};
use crate::model::driveline::DrivelineParams;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::{DriveLog, LogView};

/// Validation settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AxleValidationConfig {
    /// Input construction.
    pub record: AxleRecordConfig,
    /// Acceleration separating the segments, m/s² (0.3 m/s²: well above the ±0.05 m/s² of
    /// cruise control holding speed on rolling roads, well below a moderate launch).
    pub accel_threshold_mps2: f64,
}

impl Default for AxleValidationConfig {
    fn default() -> Self {
        Self {
            record: AxleRecordConfig::default(),
            accel_threshold_mps2: 0.3,
        }
    }
}

impl AxleValidationConfig {
    /// Checks the settings: a finite, positive acceleration threshold.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        let a = self.accel_threshold_mps2;
        crate::settings::require(
            a.is_finite() && a > 0.0,
            "accel_threshold_mps2",
            a,
            "must be positive",
        )
    }
}

/// Why a recording cannot be validated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AxleValidationError {
    /// Inputs could not be built.
    #[error(transparent)]
    Inputs(#[from] RecordedError),
    /// Validation needs the bellow pressures.
    #[error("{file}: validation needs the bellow pressures; missing or empty: {}", columns.join(", "))]
    MissingPressures {
        /// Source file.
        file: String,
        /// Missing columns.
        columns: Vec<String>,
    },
}

/// A scenario segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Segment {
    /// The whole drive.
    All,
    /// a > threshold.
    Acceleration,
    /// a < −threshold.
    Braking,
    /// Between.
    Steady,
}

impl Segment {
    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Segment::All => "all",
            Segment::Acceleration => "acceleration",
            Segment::Braking => "braking",
            Segment::Steady => "steady",
        }
    }
}

/// One row of the validation table.
#[derive(Debug, Clone, PartialEq)]
pub struct AxleMetric {
    /// Compared signal (`bellow_pressure_rear`, `suspension_travel_front`, …).
    pub signal: String,
    /// Its unit.
    pub unit: &'static str,
    /// Axle.
    pub axle: Axle,
    /// Segment.
    pub segment: Segment,
    /// Samples compared (both values present).
    pub samples: usize,
    /// Mean absolute error (axle-load thesis, eq. 3.7.1).
    pub mae: f64,
    /// Root-mean-square error.
    pub rmse: f64,
    /// Fit, % (100 = perfect; can be negative).
    pub fit_percent: f64,
    /// Mean of simulated − measured.
    pub bias: f64,
}

/// A simulated drive with its validation metrics.
#[derive(Debug, Clone)]
pub struct AxleValidation {
    /// The inputs used.
    pub recorded: RecordedAxleInputs,
    /// The simulation on the recording's time axis.
    pub trajectory: AxleTrajectory,
    /// Segment of each row.
    pub segment: Vec<Segment>,
    /// The metrics.
    pub metrics: Vec<AxleMetric>,
}

const SEGMENTS: [Segment; 4] = [
    Segment::All,
    Segment::Acceleration,
    Segment::Braking,
    Segment::Steady,
];

/// Simulates `log` with the axle model, its inputs taken from the recording, and compares it
/// with the recorded pressures and travel. `driveline`: the vehicle's driveline parameters, when
/// it has them (the drive torque by inverse dynamics, [`axle_inputs_from_log`]).
///
/// # Errors
/// [`AxleValidationError`] when inputs cannot be built or a bellow pressure column is missing.
#[allow(clippy::too_many_arguments)]
pub fn validate_axle(
    log: &DriveLog,
    p: &AxleParams,
    gear_ratios: &[f64],
    final_drive_ratio: Option<f64>,
    driveline: Option<&DrivelineParams>,
    slope_column: Option<&str>,
    cfg: &AxleValidationConfig,
) -> Result<AxleValidation, AxleValidationError> {
    require_pressures(log)?;
    let rec = axle_inputs_from_log(
        LogView::of(log),
        p.mass_kg(),
        p.wheel_radius_m,
        p.gravity_m_per_s2,
        gear_ratios,
        final_drive_ratio,
        driveline,
        slope_column,
        &cfg.record,
    )?;
    Ok(validate_axle_with(log, p, rec, cfg))
}

/// The bellow-pressure columns validation needs, or the error naming the missing ones.
///
/// # Errors
/// [`AxleValidationError::MissingPressures`].
pub fn require_pressures(log: &DriveLog) -> Result<(), AxleValidationError> {
    let missing: Vec<String> = Axle::ALL
        .iter()
        .map(|a| format!("bellow_pressure_{}", a.name()))
        .filter(|c| {
            log.signal(c)
                .is_none_or(|v| v.iter().all(|x| !x.is_finite()))
        })
        .collect();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(AxleValidationError::MissingPressures {
            file: log.meta.source_file.clone(),
            columns: missing,
        })
    }
}

/// Simulates with the given inputs (on the recording's time axis: `rec.t_s` has one entry per
/// row of `log`) and compares with whatever of the pressures and travel `log` has.
pub fn validate_axle_with(
    log: &DriveLog,
    p: &AxleParams,
    rec: RecordedAxleInputs,
    cfg: &AxleValidationConfig,
) -> AxleValidation {
    let pressure_cols = Axle::ALL.map(|a| format!("bellow_pressure_{}", a.name()));
    let model = HalfTruck::new(p);
    let traj = model.simulate(&rec.inputs, &rec.t_s, Start::Steady);
    let thr = cfg.accel_threshold_mps2;
    let segment: Vec<Segment> = rec
        .accel_mps2
        .iter()
        .map(|&a| {
            if a > thr {
                Segment::Acceleration
            } else if a < -thr {
                Segment::Braking
            } else {
                Segment::Steady
            }
        })
        .collect();
    let mut metrics = Vec::new();
    for (i, a) in Axle::ALL.iter().enumerate() {
        let travel = format!("suspension_travel_{}", a.name());
        let signals: [(&String, &'static str, &Vec<f64>); 2] = [
            (&pressure_cols[i], "Pa", &traj.pressure_pa[i]),
            (&travel, "m", &traj.travel_m[i]),
        ];
        for (name, unit, sim) in signals {
            // raw samples only: a filled gap is not a measurement
            let Some(meas) = log.signal(name) else {
                continue;
            };
            if fill_gaps(meas, Interpolation::Linear).is_none() {
                continue;
            }
            for seg in SEGMENTS {
                let (mut y, mut yh) = (Vec::new(), Vec::new());
                for k in 0..meas.len() {
                    if (seg == Segment::All || segment[k] == seg)
                        && meas[k].is_finite()
                        && sim[k].is_finite()
                    {
                        y.push(meas[k]);
                        yh.push(sim[k]);
                    }
                }
                if y.is_empty() {
                    continue;
                }
                let (rmse, mae, fit_percent) = error_metrics(&y, &yh);
                let bias = yh.iter().zip(&y).map(|(s, m)| s - m).sum::<f64>() / y.len() as f64;
                metrics.push(AxleMetric {
                    signal: name.clone(),
                    unit,
                    axle: *a,
                    segment: seg,
                    samples: y.len(),
                    mae,
                    rmse,
                    fit_percent,
                    bias,
                });
            }
        }
    }
    AxleValidation {
        recorded: rec,
        trajectory: traj,
        segment,
        metrics,
    }
}
