//! End-to-end simulation: the axle-load model driven by the driveline model's output instead of
//! a recording's longitudinal signals.
//!
//! The driven wheels receive the drive-shaft torque `M_d` (docs/models/driveline.md; N·m, +
//! driving, negative in engine braking), which becomes the axle model's drive torque at the wheels;
//! the acceleration is the centred derivative of the simulated vehicle speed; slope and service
//! brake are the driveline scenario's own inputs. Rolling resistance, air drag and the wheels'
//! inertia, which the driveline model resists the torque with, reach the axle model as the
//! remainder it closes at `resistance_height_m` (docs/models/axle.md).

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
    let m_d: Vec<f64> = tr.torques.iter().map(|q| q[3]).collect();
    axle_inputs_from_samples(
        &tr.t,
        &tr.speed(r_w_m),
        &m_d,
        sc.slope.clone(),
        sc.brake_n.clone(),
        half_window_s,
    )
    .map(|(u, _)| u)
}

/// Axle-model inputs from sampled driveline outputs: times `t_s`, simulated vehicle speed
/// `v_mps` and drive-shaft torque `m_d_nm` (torque at the driven wheels), with the slope and
/// service-brake inputs the driveline was simulated with. Returns the inputs and the
/// acceleration samples.
///
/// # Errors
/// [`PiecewiseError`] for fewer than 2 samples or non-increasing times.
pub fn axle_inputs_from_samples(
    t_s: &[f64],
    v_mps: &[f64],
    m_d_nm: &[f64],
    slope: Piecewise,
    service_brake_n: Piecewise,
    half_window_s: f64,
) -> Result<(AxleInputs, Vec<f64>), PiecewiseError> {
    if t_s.len() < 2 {
        return Err(PiecewiseError(format!("{} samples; need 2", t_s.len())));
    }
    let a = centred_derivative(t_s, v_mps, half_window_s);
    let lin = |y: &[f64]| {
        Piecewise::new(
            t_s.windows(2)
                .zip(y.windows(2))
                .map(|(t, y)| (t[0], t[1], y[0], y[1]))
                .collect(),
        )
    };
    Ok((
        AxleInputs {
            accel_mps2: lin(&a)?,
            slope,
            drive_torque_wheel_nm: Some(lin(m_d_nm)?),
            aux_brake_torque_wheel_nm: None,
            service_brake_n: Some(service_brake_n),
        },
        a,
    ))
}
