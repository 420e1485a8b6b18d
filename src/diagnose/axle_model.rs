//! The axle-load model of one recording extended by the catalogue's axle effects, and by the
//! longitudinal ones that change its inputs or masses (docs/diagnosis/method.md, step 3;
//! [`super::extended`]). [`AxleModel::simulate`]: the three bellow pressures on the log's rows,
//! open loop from the steady state (the suspension is stable, nothing drifts).
//!
//! Pressures in Pa.

use super::effect_parameters::Theta;
use super::extended_error::ExtendedError;
use super::model_inputs::{corrected_log, filled};
use super::slope_grid::{cured_slope, SlopeGrid};
use crate::model::axle::AxleParams;
use crate::model::catalogue::Effect;
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::sim::axle::{HalfTruck, Start};
use crate::sim::axle_recorded::{axle_inputs_from_log, AxleRecordConfig};
use crate::table::DriveLog;
use std::sync::OnceLock;

/// The axle-load model of one recording, extended by the catalogue's axle effects (and by the
/// longitudinal ones that change its inputs or masses).
#[derive(Debug, Clone)]
pub struct AxleModel<'a> {
    log: &'a DriveLog,
    nominal_truth: &'a ExtendedVehicle,
    ratios: &'a [f64],
    nominal: Theta,
    /// The recorded slope's grid, built when a cure first asks for it ([`cured_slope`]).
    slope_grid: OnceLock<Option<SlopeGrid>>,
    cfg: AxleRecordConfig,
}

impl<'a> AxleModel<'a> {
    /// Binds a recording with bellow pressures and the nominal vehicle (with axles).
    ///
    /// # Errors
    /// [`ExtendedError::Missing`] for missing pressures or axles.
    pub fn new(
        log: &'a DriveLog,
        nominal_truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
    ) -> Result<Self, ExtendedError> {
        if nominal_truth.axles.is_none() {
            return Err(ExtendedError::Missing {
                file: log.meta.source_file.clone(),
                column: "[axles] of the vehicle file".into(),
            });
        }
        for c in [
            "bellow_pressure_front",
            "bellow_pressure_rear",
            "bellow_pressure_tag",
        ] {
            filled(log, c)?;
        }
        Ok(Self {
            log,
            nominal_truth,
            ratios,
            nominal,
            slope_grid: OnceLock::new(),
            cfg: AxleRecordConfig::default(),
        })
    }

    /// Simulated bellow pressures front, rear, tag on the log's rows, Pa.
    ///
    /// # Errors
    /// [`ExtendedError`] for parameters outside their domain or inputs that cannot be built.
    pub fn simulate(&self, theta: &Theta) -> Result<[Vec<f64>; 3], ExtendedError> {
        let mut tm = self.nominal_truth.clone();
        for e in theta.changed(&self.nominal) {
            if matches!(
                e,
                Effect::GradeOffset
                    | Effect::SlopeQuantization
                    | Effect::SignalDelay
                    | Effect::EngineTorqueOffset
            ) {
                continue;
            }
            tm.set(e, theta.get(e))?;
        }
        let a: &AxleParams = tm.axles.as_ref().expect("checked in new");
        let d = &tm.driveline;
        let cured = cured_slope(self.log, &self.slope_grid, theta, &self.nominal);
        let log = corrected_log(self.log, theta, cured.as_deref());
        let rec = axle_inputs_from_log(
            &log,
            a.mass_kg(),
            a.wheel_radius_m,
            a.gravity_m_per_s2,
            self.ratios,
            Some(d.final_drive_ratio),
            Some(d),
            None,
            &self.cfg,
        )?;
        let traj = HalfTruck::new(a).with_extensions(tm.axle_ext).simulate(
            &rec.inputs,
            &rec.t_s,
            Start::Steady,
        );
        Ok(traj.pressure_pa)
    }
}
