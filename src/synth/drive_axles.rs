//! The axle model on a synthetic drive's samples.
//!
//! The axle model ([`HalfTruck`], static start) runs on the 100 Hz samples with
//! [`axle_inputs_from_samples`] (acceleration differentiated over ±0.05 s), the retarder torque
//! `T_r i_f` as auxiliary brake torque at the driven wheels.
//!
//! The axle model runs only for vehicles with an `[axles]` section; a vehicle with only a
//! driveline (e.g. a tractor-semitrailer, for which the half-truck axle model does not apply)
//! gets no axle trajectory and no bellow-pressure channels.

use super::drive_error::DriveError;
use super::trajectory::DriveTrajectory;
use crate::sim::axle::{AxleExtensions, AxleTrajectory, HalfTruck, Start};
use crate::sim::axle_coupling::axle_inputs_from_samples;
use crate::sim::inputs::{Piecewise, PiecewiseError};

/// Runs the axle model on a drive's 100 Hz samples (static start), with the retarder's
/// [`DriveTrajectory::aux_brake_wheel_nm`] (when not empty) as auxiliary brake torque at the
/// driven wheels.
///
/// # Errors
/// [`DriveError::Piecewise`] for fewer than two samples, or auxiliary brake samples that do
/// not match the times.
pub fn simulate_axles(
    p: &crate::model::axle::AxleParams,
    tr: &DriveTrajectory,
) -> Result<AxleTrajectory, DriveError> {
    simulate_axles_with(p, AxleExtensions::default(), tr)
}

/// [`simulate_axles`] with model extensions (a hidden axle effect).
///
/// # Errors
/// [`DriveError::Piecewise`] for fewer than two samples.
pub fn simulate_axles_with(
    p: &crate::model::axle::AxleParams,
    ext: AxleExtensions,
    tr: &DriveTrajectory,
) -> Result<AxleTrajectory, DriveError> {
    let held = |v: &[f64]| {
        Piecewise::new(
            tr.t_s
                .windows(2)
                .zip(v.iter())
                .map(|(t, &a)| (t[0], t[1], a, a))
                .collect(),
        )
    };
    let (mut u, _) = axle_inputs_from_samples(
        &tr.t_s,
        &tr.speed_mps,
        &tr.drive_torque_nm,
        held(&tr.slope)?,
        held(&tr.brake_n)?,
        0.05,
    )?;
    let aux = &tr.aux_brake_wheel_nm;
    if !aux.is_empty() {
        if aux.len() != tr.t_s.len() {
            return Err(PiecewiseError(format!(
                "{} auxiliary brake samples for {} times",
                aux.len(),
                tr.t_s.len()
            ))
            .into());
        }
        u.aux_brake_torque_wheel_nm = Some(Piecewise::new(
            tr.t_s
                .windows(2)
                .zip(aux.windows(2))
                .map(|(t, a)| (t[0], t[1], a[0], a[1]))
                .collect(),
        )?);
    }
    Ok(HalfTruck::new(p)
        .with_extensions(ext)
        .simulate(&u, &tr.t_s, Start::Steady))
}
