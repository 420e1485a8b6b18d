//! End-to-end simulation (issue 4 point 8): the axle-load model driven by the driveline model's
//! output instead of a recording's longitudinal signals.
//!
//! The driven wheels receive the drive-shaft torque `M_d` (physics.md §1; N·m, + driving,
//! negative in engine braking), which becomes the axle model's drive torque at the wheels; the
//! acceleration is the centred derivative of the simulated vehicle speed; slope and service
//! brake are the driveline scenario's own inputs. Rolling resistance, air drag and the wheels'
//! inertia, which the driveline model resists the torque with, reach the axle model as the
//! remainder it closes at `resistance_height_m` (docs/axle-model.md).

use super::axle::AxleInputs;
use super::axle_recorded::centred_derivative;
use super::hybrid::{Scenario, Trajectory};
use super::inputs::Piecewise;
use super::inputs::PiecewiseError;

/// Axle-model inputs from a driveline trajectory `tr` of scenario `sc` (wheel radius `r_w_m`),
/// on the trajectory's sample times. The acceleration is differentiated over ±`half_window_s`.
///
/// # Errors
/// [`PiecewiseError`] for a trajectory with fewer than 2 samples or non-increasing times.
pub fn axle_inputs_from_driveline(
    tr: &Trajectory,
    sc: &Scenario,
    r_w_m: f64,
    half_window_s: f64,
) -> Result<AxleInputs, PiecewiseError> {
    let v = tr.speed(r_w_m);
    let a = centred_derivative(&tr.t, &v, half_window_s);
    let lin = |y: &[f64]| {
        Piecewise::new(
            tr.t.windows(2)
                .zip(y.windows(2))
                .map(|(t, y)| (t[0], t[1], y[0], y[1]))
                .collect(),
        )
    };
    let m_d: Vec<f64> = tr.torques.iter().map(|q| q[3]).collect();
    Ok(AxleInputs {
        accel_mps2: lin(&a)?,
        slope: sc.slope.clone(),
        drive_torque_wheel_nm: Some(lin(&m_d)?),
        aux_brake_torque_wheel_nm: None,
        service_brake_n: Some(sc.brake_n.clone()),
    })
}
