//! Recorded drives as inputs of the axle-load model (physics.md §3): the canonical drive log's
//! speed or IMU acceleration, slope, engine (or motor) torque, gear, clutch, retarder and
//! service-brake columns turned into [`AxleInputs`].
//!
//! Rules (state, not guess):
//! - time from the first row, s; short gaps filled as the column's interpolation kind allows;
//! - acceleration: the `longitudinal_acceleration` column taken as the acceleration along the
//!   road (an IMU's specific force would add g·sin α; map such a signal elsewhere) when chosen
//!   or when present with [`AccelSource::Auto`]; otherwise the derivative of `vehicle_speed`,
//!   a centred difference over ±`speed_derivative_half_window_s`;
//! - drive torque at the driven wheels `T = M_e · i_t(gear) · i_f` while a gear is engaged and
//!   the clutch closed (`clutch_position` < 0.5, or absent), else 0; driveline losses are not
//!   modelled (they act as a resistance the model closes at `resistance_height_m`);
//! - auxiliary brake torque at the wheels `retarder_torque · i_f` (the column is on the
//!   propeller shaft, ≥ 0 brakes);
//! - without `engine_torque` the model takes the whole longitudinal force at the driven axle
//!   (docs/axle-model.md), and this is reported;
//! - slope: the named column (e.g. the filtered slope), else `road_slope`, else a flat road;
//! - `brake_force` is the force at the ground. At standstill (`vehicle_speed` below
//!   `standstill_speed_mps`) brakes only hold: a recorded brake force there (a pressure-derived
//!   signal reports the brakes' capacity) is replaced by the holding force the drive torque and
//!   the grade ask for, `F_d/r_w·… − m g sin α`, limited to ± the recorded force.

use super::axle::AxleInputs;
use super::inputs::Piecewise;
use super::recorded::{pieces, relative_times, slope_input, RecordedError};
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;

/// Where the acceleration input comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccelSource {
    /// The IMU column when present, else the speed derivative.
    Auto,
    /// The `longitudinal_acceleration` column (an error when absent).
    Imu,
    /// The derivative of `vehicle_speed`.
    Speed,
}

/// How a recording becomes axle-model inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct AxleRecordConfig {
    /// Acceleration source.
    pub accel: AccelSource,
    /// Half window of the centred speed difference, s (0.25 s averages the 1/256 km/h
    /// quantisation of a 10 Hz wheel speed to ~0.002 m/s²).
    pub speed_derivative_half_window_s: f64,
    /// Below this speed the vehicle stands and brakes only hold, m/s (0.1 m/s: a wheel-speed
    /// sensor's lowest reading is ~0.3 km/h).
    pub standstill_speed_mps: f64,
}

impl Default for AxleRecordConfig {
    fn default() -> Self {
        Self {
            accel: AccelSource::Auto,
            speed_derivative_half_window_s: 0.25,
            standstill_speed_mps: 0.1,
        }
    }
}

/// A recording as axle-model inputs, with the time axis they were built on.
#[derive(Debug, Clone)]
pub struct RecordedAxleInputs {
    /// The inputs.
    pub inputs: AxleInputs,
    /// Sample times relative to the first row, s.
    pub t_s: Vec<f64>,
    /// Acceleration used, m/s², per row.
    pub accel_mps2: Vec<f64>,
    /// Where it came from (`longitudinal_acceleration` or `d(vehicle_speed)/dt`).
    pub accel_source: &'static str,
    /// Slope column used (`None`: flat road).
    pub slope_column: Option<String>,
    /// Whether torque signals drive the model (else acceleration only).
    pub torque_inputs: bool,
}

pub(crate) fn centred_derivative(t: &[f64], v: &[f64], half: f64) -> Vec<f64> {
    let n = t.len();
    let (mut lo, mut hi) = (0usize, 0usize);
    (0..n)
        .map(|k| {
            while t[lo] < t[k] - half {
                lo += 1;
            }
            while hi + 1 < n && t[hi + 1] <= t[k] + half {
                hi += 1;
            }
            let (a, b) = if hi > lo {
                (lo, hi)
            } else {
                (k.saturating_sub(1), (k + 1).min(n - 1))
            };
            if t[b] > t[a] {
                (v[b] - v[a]) / (t[b] - t[a])
            } else {
                0.0
            }
        })
        .collect()
}

/// Builds the axle-model inputs of a recorded drive (see the module rules).
///
/// # Errors
/// [`RecordedError`] for logs shorter than 2 rows, no usable acceleration source, a gear with
/// no ratio, or a torque signal without gear ratios or final drive. `mass_kg` and
/// `wheel_radius_m` are the axle model's (for the holding force at standstill).
#[allow(clippy::too_many_arguments)]
pub fn axle_inputs_from_log(
    log: &DriveLog,
    mass_kg: f64,
    wheel_radius_m: f64,
    gravity_m_per_s2: f64,
    gear_ratios: &[f64],
    final_drive_ratio: Option<f64>,
    slope_column: Option<&str>,
    cfg: &AxleRecordConfig,
) -> Result<RecordedAxleInputs, RecordedError> {
    let file = log.meta.source_file.clone();
    let t = relative_times(log)?;
    let column =
        |name: &str, interp: Interpolation| log.signal(name).and_then(|v| fill_gaps(v, interp));
    let missing = |c: &str| RecordedError::Missing {
        file: file.clone(),
        column: c.into(),
    };
    let imu = column("longitudinal_acceleration", Interpolation::Linear);
    let (accel, accel_source) = match (cfg.accel, imu) {
        (AccelSource::Imu, None) => return Err(missing("longitudinal_acceleration")),
        (AccelSource::Imu | AccelSource::Auto, Some(a)) => (a, "longitudinal_acceleration"),
        (AccelSource::Speed | AccelSource::Auto, _) => {
            let v = column("vehicle_speed", Interpolation::Linear)
                .ok_or_else(|| missing("vehicle_speed or longitudinal_acceleration"))?;
            (
                centred_derivative(&t, &v, cfg.speed_derivative_half_window_s),
                "d(vehicle_speed)/dt",
            )
        }
    };
    let (slope_name, slope) = slope_input(log, slope_column);
    let mut brake = column("brake_force", Interpolation::Linear);
    let retarder = column("retarder_torque", Interpolation::Linear);
    let torque = column("engine_torque", Interpolation::Linear);
    let torque_inputs = torque.is_some() || retarder.is_some();
    let i_f = if torque_inputs {
        Some(final_drive_ratio.ok_or_else(|| {
            missing("final drive ratio (vehicle file: driveline.final_drive_ratio or gearbox.final_drive_ratio)")
        })?)
    } else {
        None
    };
    let drive = match torque {
        None => None,
        Some(m_e) => {
            let gear = column("gear", Interpolation::Hold).ok_or_else(|| missing("gear"))?;
            let clutch = column("clutch_position", Interpolation::Linear);
            let i_f = i_f.expect("set with torque inputs");
            let mut out = Vec::with_capacity(m_e.len());
            for (row, (&m, &g)) in m_e.iter().zip(&gear).enumerate() {
                let g = g.round();
                let open = clutch.as_ref().is_some_and(|c| c[row] >= 0.5);
                if g < 1.0 || open {
                    out.push(0.0);
                    continue;
                }
                let ratio = gear_ratios.get(g as usize - 1).ok_or(RecordedError::Gear {
                    file: file.clone(),
                    gear: g,
                    row,
                    max: gear_ratios.len(),
                })?;
                out.push(m * ratio * i_f);
            }
            Some(out)
        }
    };
    let aux = retarder.map(|r| {
        let i_f = i_f.expect("set with torque inputs");
        r.iter().map(|x| x * i_f).collect::<Vec<_>>()
    });
    if let (Some(b), Some(v)) = (
        brake.as_mut(),
        column("vehicle_speed", Interpolation::Linear),
    ) {
        for k in 0..b.len() {
            if v[k].abs() < cfg.standstill_speed_mps {
                let f_drive = (drive.as_ref().map_or(0.0, |d| d[k])
                    - aux.as_ref().map_or(0.0, |x| x[k]))
                    / wheel_radius_m;
                let need = f_drive - mass_kg * gravity_m_per_s2 * slope[k].atan().sin();
                b[k] = need.clamp(-b[k].abs(), b[k].abs());
            }
        }
    }
    let lin = |v: &[f64]| pieces(&t, v, Interpolation::Linear);
    let inputs = AxleInputs {
        accel_mps2: lin(&accel),
        slope: pieces(&t, &slope, Interpolation::Hold),
        drive_torque_wheel_nm: drive.as_deref().map(lin).or_else(|| {
            aux.as_ref()
                .map(|_| Piecewise::constant(t[t.len() - 1], 0.0))
        }),
        aux_brake_torque_wheel_nm: aux.as_deref().map(lin),
        service_brake_n: brake.as_deref().map(lin),
    };
    Ok(RecordedAxleInputs {
        inputs,
        t_s: t,
        accel_mps2: accel,
        accel_source,
        slope_column: slope_name,
        torque_inputs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{DriveMeta, Signal};

    #[test]
    fn standing_brakes_hold_with_the_force_the_grade_asks_for() {
        let n = 20;
        let sig = |name: &str, unit: &str, v: f64| Signal {
            name: name.into(),
            unit: unit.into(),
            values: vec![v; n],
        };
        let log = DriveLog {
            meta: DriveMeta::default(),
            timestamp_ns: (0..n as i64).map(|k| k * 100_000_000).collect(),
            signals: vec![
                sig("vehicle_speed", "m/s", 0.0),
                sig("road_slope", "1", 0.02),
                sig("engine_torque", "N*m", 0.0),
                sig("gear", "1", 1.0),
                sig("brake_force", "N", 20_000.0),
            ],
        };
        let r = axle_inputs_from_log(
            &log,
            18_700.0,
            0.5,
            9.81,
            &[2.0, 1.0],
            Some(3.0),
            None,
            &AxleRecordConfig::default(),
        )
        .unwrap();
        // parked on a 2 % climb: the brakes hold back m g sin α, not their 20 kN capacity
        let hold = -18_700.0 * 9.81 * 0.02f64.atan().sin();
        let b = r.inputs.service_brake_n.as_ref().unwrap().eval(1.0);
        assert!((b - hold).abs() < 1e-9, "{b} vs {hold}");
    }

    #[test]
    fn centred_derivative_of_a_parabola_is_exact_at_interior_points() {
        let t: Vec<f64> = (0..101).map(|k| k as f64 * 0.1).collect();
        let v: Vec<f64> = t.iter().map(|x| 0.5 * x * x).collect();
        let d = centred_derivative(&t, &v, 0.25);
        for k in 3..98 {
            assert!((d[k] - t[k]).abs() < 1e-9, "{k}: {} vs {}", d[k], t[k]);
        }
    }
}
