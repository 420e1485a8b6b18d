//! The axle-load stage (docs/models/axle.md): simulate a recorded drive with the half-truck model
//! and validate it against the recorded bellow pressures (and travel, where recorded); write
//! `axle_sim.parquet` and `axle_validation.parquet`, both or neither.
//!
//! Longitudinal inputs come from the recording (torques, acceleration from speed or IMU) or, for
//! an end-to-end simulation, from the driveline model run open loop over the whole drive on the
//! recorded engine torque, gear, clutch, slope and brake (`sim::axle_coupling`); the driveline
//! model has no retarder, so in that mode the auxiliary brake is not an input.

use crate::io::{OutputError, TableMeta};
use crate::model::vehicle::VehicleFile;
use crate::report::axle_sim::{write_axle_sim, AxleSimExtra, TimeAxis};
use crate::report::axle_validation::{axle_meta, write_axle_validation};
use crate::sim::axle_coupling::axle_inputs_from_samples;
use crate::sim::axle_recorded::RecordedAxleInputs;
use crate::sim::axle_validate::{
    require_pressures, validate_axle, validate_axle_with, AxleValidation, AxleValidationConfig,
    AxleValidationError,
};
use crate::sim::recorded::scenario_from_log;
use crate::sim::validate::{validate_shuffle, ValidationConfig, ValidationError};
use crate::table::DriveLog;
use std::path::Path;

/// Where the axle model's longitudinal inputs come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum LongitudinalSource {
    /// The recording's torques and acceleration.
    Recorded,
    /// The driveline simulation of the recording (end to end).
    Driveline,
}

/// Stage settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AxleStageConfig {
    /// Validation and input construction.
    pub validation: AxleValidationConfig,
    /// Longitudinal input source.
    pub longitudinal: LongitudinalSource,
    /// Slope column to use (e.g. the filtered slope added by the caller), else `road_slope`.
    pub slope_column: Option<String>,
}

impl AxleStageConfig {
    /// Canonical text of the settings and the axle parameters `p`, for the config hash of a
    /// single-drive simulation.
    pub fn fingerprint(&self, p: &crate::model::axle::AxleParams) -> String {
        crate::io::canonical("axle:v2", &(p, self))
    }
}

/// Why the stage failed for a drive.
#[derive(Debug, thiserror::Error)]
pub enum AxleStageError {
    /// The vehicle file lacks a section.
    #[error(transparent)]
    Vehicle(#[from] crate::model::vehicle::VehicleError),
    /// Inputs or pressures missing.
    #[error(transparent)]
    Validation(#[from] AxleValidationError),
    /// The driveline simulation failed.
    #[error(transparent)]
    Driveline(#[from] ValidationError),
    /// A driveline trajectory that cannot become inputs.
    #[error("{file}: driveline output cannot drive the axle model: {why}")]
    Coupling {
        /// Source file.
        file: String,
        /// Why.
        why: String,
    },
}

/// Simulates and validates one drive.
///
/// # Errors
/// [`AxleStageError`]: no `[axles]` (or, end to end, no `[driveline]`), missing pressures or
/// inputs, a failed driveline simulation.
pub fn run(
    log: &DriveLog,
    v: &VehicleFile,
    vehicle_file: &str,
    cfg: &AxleStageConfig,
) -> Result<AxleValidation, AxleStageError> {
    let p = v.axles(vehicle_file)?;
    let slope = cfg.slope_column.as_deref();
    match cfg.longitudinal {
        LongitudinalSource::Recorded => Ok(validate_axle(
            log,
            p,
            &v.gearbox.ratios,
            v.final_drive_ratio(),
            v.driveline.as_ref(),
            slope,
            &cfg.validation,
        )?),
        LongitudinalSource::Driveline => {
            require_pressures(log)?;
            let d = v.driveline(vehicle_file)?;
            let file = log.meta.source_file.clone();
            let t0 = log.timestamp_ns[0];
            let duration = (log.timestamp_ns[log.len() - 1] - t0) as f64 * 1e-9;
            // open loop over the whole drive: one window
            let dcfg = ValidationConfig {
                window_s: duration + 1.0,
                ..Default::default()
            };
            let sim = validate_shuffle(log, d, &v.gearbox.ratios, slope, &dcfg)?;
            // the axle model's brake force is the brakes' (and the retarder's) alone: the cold
            // tyres' extra rolling resistance, which the driveline simulation above carries,
            // joins the warm one in the remainder the axle model takes at the resistance height
            let sc = scenario_from_log(
                log,
                v.gearbox.ratios.len(),
                slope,
                Some(d.final_drive_ratio / d.wheel_radius_m),
                d.engine_torque_lag_s,
                None,
            )
            .map_err(|e| AxleStageError::Driveline(e.into()))?;
            let t: Vec<f64> = sim
                .timestamp_ns
                .iter()
                .map(|&x| (x - t0) as f64 * 1e-9)
                .collect();
            if t.len() != log.len() {
                return Err(AxleStageError::Coupling {
                    file,
                    why: format!(
                        "{} driveline samples for {} recorded rows",
                        t.len(),
                        log.len()
                    ),
                });
            }
            let half = cfg.validation.record.speed_derivative_half_window_s;
            let (inputs, accel) = axle_inputs_from_samples(
                &t,
                &sim.vehicle_speed,
                &sim.shaft_torques[2],
                sc.scenario.slope.clone(),
                sc.scenario.brake_n.clone(),
                half,
            )
            .map_err(|e| AxleStageError::Coupling {
                file: file.clone(),
                why: e.to_string(),
            })?;
            let rec = RecordedAxleInputs {
                inputs,
                t_s: t.into(),
                accel_mps2: accel,
                accel_source: "driveline simulation (d v_sim / dt)",
                slope_column: sc.slope_column,
                torque_inputs: true,
            };
            Ok(validate_axle_with(log, p, rec, &cfg.validation))
        }
    }
}

/// Writes `axle_sim.parquet` and `axle_validation.parquet` into `dir`: both or neither.
///
/// # Errors
/// [`OutputError`].
pub fn write(
    dir: &Path,
    log: &DriveLog,
    v: &AxleValidation,
    gravity_m_per_s2: f64,
    fp: &str,
) -> Result<(), OutputError> {
    let (a, b) = (
        dir.join("axle_sim.parquet"),
        dir.join("axle_validation.parquet"),
    );
    let speed = log.signal("vehicle_speed");
    let meta: TableMeta = axle_meta("axle_sim", log, fp, v);
    write_axle_sim(
        &a,
        &v.trajectory,
        &AxleSimExtra {
            time: TimeAxis::Recorded {
                timestamp_ns: &log.timestamp_ns,
            },
            inputs: &v.recorded.inputs,
            vehicle_speed_mps: speed,
            gravity_m_per_s2,
        },
        &meta,
    )?;
    write_axle_validation(&b, log, v, fp).inspect_err(|_| {
        let _ = std::fs::remove_file(&a);
    })
}
