//! Setting up the diagnosis of one recording: which models the recording can drive (the signals
//! present decide), the nominal parameters and the rows that count.
//!
//! - Longitudinal/driveline: needs a vehicle `[driveline]` and the columns `vehicle_speed`,
//!   `engine_speed`, `engine_torque`, `gear`. Rows count while the measured speed is at least
//!   1 m/s (the model has no creep mode), the speed sample is real (not a filled gap) and no
//!   clutch transition is near ([`super::rows::longitudinal_rows`]).
//! - Axle loads: needs a vehicle `[axles]` and the three bellow pressures. Rows with a real
//!   pressure sample count, away from shifts ([`super::rows::axle_rows`]).
//! - The slope sensor's resolution is estimated from the recording
//!   ([`crate::signal::quantization`]; an unquantised slope counts as the nominal);
//!   `slope_quantization`'s nominal value is the vehicle file's `[sensors]
//!   road_slope_resolution` ([`crate::model::vehicle::Sensors`]).

use super::extended::{AxleModel, ExtendedError, LongitudinalConfig, LongitudinalModel, Theta};
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::model::vehicle::VehicleFile;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::signal::quantization::estimate_quantization;
use crate::table::DriveLog;

/// Speed below which longitudinal rows do not count, m/s.
pub const MIN_SPEED_MPS: f64 = 1.0;

/// Which models apply, and what they need.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The nominal vehicle as a truth model (no effect).
    pub nominal_truth: ExtendedVehicle,
    /// Gear ratios.
    pub ratios: Vec<f64>,
    /// The nominal parameters.
    pub nominal: Theta,
    /// Estimated slope-sensor resolution, tan α per step.
    pub slope_resolution: f64,
    /// The longitudinal model applies.
    pub longitudinal: bool,
    /// Why not, when it does not.
    pub longitudinal_reason: Option<String>,
    /// The axle model applies.
    pub axle: bool,
    /// Why not, when it does not.
    pub axle_reason: Option<String>,
}

fn column(log: &DriveLog, name: &str, interp: Interpolation) -> Option<Vec<f64>> {
    log.signal(name).and_then(|v| fill_gaps(v, interp))
}

impl Setup {
    /// The explain step's problem for `log` with this setup: the diagnosis' models, 20 s
    /// windows and alternating split ([`super::problem::Problem::new`] with the default
    /// [`LongitudinalConfig`]), with the clutch-actuation view when `actuation_variance` (the
    /// noise floor's per-row null variance of the clutch-actuated engine speed) is given
    /// ([`super::problem::Problem::with_actuation`]). The diagnosis and the proof's oracle
    /// check both build it here, so they score the same split and views.
    ///
    /// # Errors
    /// [`super::problem::ExplainError`] from [`super::problem::Problem::new`].
    pub fn problem<'a>(
        &'a self,
        log: &'a DriveLog,
        actuation_variance: Option<&[f64]>,
    ) -> Result<super::problem::Problem<'a>, super::problem::ExplainError> {
        let p = super::problem::Problem::new(
            log,
            &self.nominal_truth,
            &self.ratios,
            self.nominal,
            LongitudinalConfig::default(),
            None,
        )?;
        Ok(match actuation_variance {
            Some(v) => p.with_actuation(v),
            None => p,
        })
    }

    /// Sets up the diagnosis of `log` with the nominal `vehicle`.
    ///
    /// # Errors
    /// [`ExtendedError::NoModel`] when neither model applies (the message lists why each does
    /// not).
    pub fn new(log: &DriveLog, vehicle: &VehicleFile) -> Result<Setup, ExtendedError> {
        let file = log.meta.source_file.clone();
        let n = log.len();
        let speed = column(log, "vehicle_speed", Interpolation::Linear);
        let missing = |cols: &[&str]| -> Vec<String> {
            cols.iter()
                .filter(|c| column(log, c, Interpolation::Linear).is_none())
                .map(|c| c.to_string())
                .collect()
        };
        let long_missing = missing(&["vehicle_speed", "engine_speed", "engine_torque", "gear"]);
        let longitudinal_reason = if vehicle.driveline.is_none() {
            Some("the vehicle file has no [driveline] section".to_string())
        } else if !long_missing.is_empty() {
            Some(format!("the recording lacks {}", long_missing.join(", ")))
        } else {
            None
        };
        let pressures = ["front", "rear", "tag"].map(|a| format!("bellow_pressure_{a}"));
        let axle_missing = missing(&pressures.iter().map(String::as_str).collect::<Vec<_>>());
        let axle_reason = if vehicle.axles.is_none() {
            Some("the vehicle file has no [axles] section".to_string())
        } else if vehicle.driveline.is_none() {
            Some("the axle model's torque input needs the vehicle's [driveline]".to_string())
        } else if !axle_missing.is_empty() {
            Some(format!("the recording lacks {}", axle_missing.join(", ")))
        } else if speed.is_none() {
            Some("the recording lacks vehicle_speed".to_string())
        } else {
            None
        };
        let d = match vehicle.driveline.as_ref() {
            Some(d) if longitudinal_reason.is_none() || axle_reason.is_none() => d,
            _ => {
                return Err(ExtendedError::NoModel {
                    file,
                    longitudinal: longitudinal_reason.unwrap_or_default(),
                    axle: axle_reason.unwrap_or_default(),
                })
            }
        };
        // `slope_quantization`'s nominal value: the resolution the vehicle file says the bus
        // sends the slope with; the recording's own lattice step is what the effect's fit
        // compares with it (`fit_spec::applicable`)
        let nominal_slope_resolution = vehicle.sensors.road_slope_resolution();
        let slope = column(log, "road_slope", Interpolation::Hold).unwrap_or_else(|| vec![0.0; n]);
        let slope_resolution = estimate_quantization(&slope)
            .map(|q| q.step)
            .filter(|q| *q > 0.0 && *q < 0.1)
            .unwrap_or(nominal_slope_resolution);
        let nominal_truth = ExtendedVehicle::nominal(d, vehicle.axles.as_ref());
        let nominal = Theta::nominal(&nominal_truth, nominal_slope_resolution);
        Ok(Setup {
            nominal_truth,
            ratios: vehicle.gearbox.ratios.clone(),
            nominal,
            slope_resolution,
            longitudinal: longitudinal_reason.is_none(),
            longitudinal_reason,
            axle: axle_reason.is_none(),
            axle_reason,
        })
    }

    /// The longitudinal model of `log`, when it applies.
    ///
    /// # Errors
    /// [`ExtendedError`] when the model cannot be bound.
    pub fn longitudinal_model<'a>(
        &'a self,
        log: &'a DriveLog,
    ) -> Result<Option<LongitudinalModel<'a>>, ExtendedError> {
        if !self.longitudinal {
            return Ok(None);
        }
        LongitudinalModel::new(
            log,
            &self.nominal_truth,
            &self.ratios,
            self.nominal,
            LongitudinalConfig::default(),
        )
        .map(Some)
    }

    /// The axle model of `log`, when it applies.
    ///
    /// # Errors
    /// [`ExtendedError`] when the model cannot be bound.
    pub fn axle_model<'a>(
        &'a self,
        log: &'a DriveLog,
    ) -> Result<Option<AxleModel<'a>>, ExtendedError> {
        if !self.axle {
            return Ok(None);
        }
        AxleModel::new(log, &self.nominal_truth, &self.ratios, self.nominal).map(Some)
    }
}
