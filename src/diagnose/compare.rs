//! Step 1 of the diagnosis, compare (diagnosis.md): the recording's outputs next to the nominal
//! model's, on the recording's rows, with what the later steps need to locate a mismatch —
//! time, distance, which rows count, and the operating condition of every row.
//!
//! Comparison method (say which, diagnosis.md): the longitudinal model runs in windows
//! re-initialised from the measured state ([`super::extended::LongitudinalModel`], 20 s), so
//! open-loop drift never spans more than one window; the axle model runs open loop (it is
//! stable). Both see the recording's own inputs.

use super::extended::{AxleModel, ExtendedError, LongitudinalModel, Theta};

/// One compared signal on the recording's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Compared {
    /// Canonical column (`vehicle_speed`, `engine_speed`, `bellow_pressure_rear`, …).
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Measured values (gaps filled linearly; see `valid`).
    pub measured: Vec<f64>,
    /// Simulated values.
    pub simulated: Vec<f64>,
    /// Rows that count: finite, a real sample (not a filled gap), and for longitudinal signals
    /// the vehicle moving.
    pub valid: Vec<bool>,
}

impl Compared {
    /// Residual `measured − simulated` (NaN where not valid).
    pub fn residual(&self) -> Vec<f64> {
        self.measured
            .iter()
            .zip(&self.simulated)
            .zip(&self.valid)
            .map(|((m, s), v)| if *v { m - s } else { f64::NAN })
            .collect()
    }
}

/// The operating condition of every row, for locating by condition.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Conditions {
    /// Times, s from the first row.
    pub t_s: Vec<f64>,
    /// Travelled distance, m (∫ v dt of the measured speed).
    pub distance_m: Vec<f64>,
    /// Engaged gear (0 = neutral).
    pub gear: Vec<f64>,
    /// Engine torque as recorded, N·m (its sign: drive or engine brake).
    pub engine_torque_nm: Vec<f64>,
    /// Measured vehicle speed, m/s.
    pub speed_mps: Vec<f64>,
    /// Recorded slope, tan α.
    pub slope: Vec<f64>,
    /// Longitudinal acceleration from the measured speed, m/s².
    pub accel_mps2: Vec<f64>,
    /// Service brake or retarder active.
    pub braking: Vec<bool>,
    /// Clutch not fully engaged (position above 5 %).
    pub clutch_actuated: Vec<bool>,
}

/// What the nominal models say about one recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Compared signals (longitudinal and/or axle, as the recording allows).
    pub signals: Vec<Compared>,
    /// Operating conditions.
    pub conditions: Conditions,
}

/// Simulated outputs of the extended models at `theta`, as [`Compared`] signals with the
/// measured ones (`None` for a model the recording cannot drive).
///
/// # Errors
/// [`ExtendedError`] from the simulations.
pub fn compare_at(
    long: Option<&LongitudinalModel<'_>>,
    axle: Option<&AxleModel<'_>>,
    theta: &Theta,
    long_valid: &[bool],
    axle_measured: Option<&[Vec<f64>; 3]>,
    axle_valid: Option<&[Vec<bool>; 3]>,
) -> Result<Vec<Compared>, ExtendedError> {
    let mut out = Vec::new();
    if let Some(m) = long {
        let o = m.simulate(theta)?;
        out.push(Compared {
            name: "vehicle_speed".into(),
            unit: "m/s".into(),
            measured: m.measured_speed().to_vec(),
            simulated: o.vehicle_speed,
            valid: long_valid.to_vec(),
        });
        out.push(Compared {
            name: "engine_speed".into(),
            unit: "rad/s".into(),
            measured: m.measured_engine_speed().to_vec(),
            simulated: o.engine_speed,
            valid: long_valid.to_vec(),
        });
    }
    if let (Some(m), Some(meas), Some(valid)) = (axle, axle_measured, axle_valid) {
        let p = m.simulate(theta)?;
        for (i, axle_name) in ["front", "rear", "tag"].iter().enumerate() {
            out.push(Compared {
                name: format!("bellow_pressure_{axle_name}"),
                unit: "Pa".into(),
                measured: meas[i].clone(),
                simulated: p[i].clone(),
                valid: valid[i].clone(),
            });
        }
    }
    Ok(out)
}
