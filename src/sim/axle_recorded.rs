//! Recorded drives as inputs of the axle-load model (docs/models/axle.md): the canonical drive
//! log's speed or IMU acceleration, slope, engine (or motor) torque, gear, clutch, retarder and
//! service-brake columns turned into [`AxleInputs`].
//!
//! Rules (state, not guess):
//! - time from the first row, s; short gaps filled as the column's interpolation kind allows;
//! - acceleration: the `longitudinal_acceleration` column taken as the acceleration along the
//!   road (an IMU's specific force would add g·sin α; map such a signal elsewhere) when chosen
//!   or when present with [`AccelSource::Auto`]; otherwise the derivative of `vehicle_speed`,
//!   a centred difference over ±`speed_derivative_half_window_s`;
//! - drive torque at the driven wheels: with the vehicle's driveline parameters, the drive-shaft
//!   torque `M_d` of docs/models/driveline.md by inverse dynamics (see below), from the torque
//!   the engine produces (the recorded ECU figure through the driveline's
//!   `engine_torque_lag_s`, [`crate::signal::first_order_lag`]); without them
//!   `T = M_e · i_t(gear) · i_f` while a gear is engaged and the clutch closed (`clutch_position` <
//!   0.5, or absent), else 0, driveline inertia and losses not modelled (they act as a resistance
//!   the model closes at `resistance_height_m`);
//! - auxiliary brake torque at the wheels `retarder_torque · i_f` (the column is on the
//!   propeller shaft, ≥ 0 brakes);
//! - without `engine_torque` the model takes the whole longitudinal force at the driven axle
//!   (docs/models/axle.md), and this is reported;
//! - slope: the named column (e.g. the filtered slope), else `road_slope`, else a flat road;
//! - `brake_force` is the force at the ground. At standstill (`vehicle_speed` below
//!   `standstill_speed_mps`) brakes only hold: a recorded brake force there (a pressure-derived
//!   signal reports the brakes' capacity; a synthetic drive logs the holding force's magnitude,
//!   the CAN signal being ≥ 0) is replaced by the holding force the drive torque and the grade
//!   ask for, `F_d/r_w·… − m g sin α`, limited to ± the recorded force. In it `sin α` is the
//!   mean over the standstill (the truck stands on one spot of road) and the drive force its
//!   mean over ±`speed_derivative_half_window_s`: the limit is a non-linearity, and per-sample
//!   noise in the force asked for, clipped against a recorded force that carries the holding
//!   force's own magnitude, biases the held force. Measured on a clean proof drive (seed 20,
//!   18.7 t parked on 4 % for 6 s, clutch open): the 0.2 % slope noise (370 N per 10 Hz sample)
//!   and the wheels' rate noise clipped this way left −1.0 kPa of mean rear-bellow residual,
//!   −0.39 kPa with the means and the held wheels; the noise floor's copies carry the same bias
//!   and cannot see it.
//!
//! # Drive torque by inverse dynamics (docs/models/driveline.md)
//! The engine torque is not the torque at the wheels: the engine, clutch disc and gearbox must be
//! accelerated too, and an open or slipping clutch passes only part of it. With
//! `G = i_t(gear)·i_f`, the wheel speed `ω_w = v/r_w` and its rate `ω̇_w = a/r_w` (`a` the
//! acceleration input), the shaft equations of docs/models/driveline.md with the shafts' torsion
//! rates neglected (`ω_c = i_t ω_p`, `ω_p = i_f ω_d`, `ω_d = ω_w`: quasi-static shafts) give
//! - torque into the gearbox `M_c = M_e − J_e ω̇_e − J_c G ω̇_w` — from the engine's own balance,
//!   so it holds locked (`M_c`), slipping (`M_trans = M_e − J_e ω̇_e`) and open (governed engine:
//!   `M_c ≈ 0`) alike; `ω̇_e` from the recorded `engine_speed` (without it, the locked clutch's
//!   `ω̇_e = G ω̇_w`). Where the recorded clutch is fully open (normalised `clutch_position ≥ L_u`,
//!   no capacity) the friction faces pass nothing, but the clutch disc turns with the gearbox
//!   input, so `M_c = −J_c G ω̇_w`. In 1st gear of the diesel variant of the axle-load thesis truck
//!   (`fixtures/vehicles/seed002-6x2-diesel.toml`) `J_c G²` is 211 kg·m² at the wheels, half the
//!   gearbox's 426: on a clean proof drive rolling away downhill with the clutch open, leaving this
//!   term out leaves +2 … +3.5 kPa of bellow residual on every axle for 12 s, and with it the
//!   residual stays within ±1.2 kPa. No gear engaged disconnects the gearbox input side altogether.
//!   At a standstill the wheels are held: `ω_w = ω̇_w = 0` there (the 10 Hz speed's difference over
//!   the torque's window is noise of σ ≈ 0.2 m/s², times up to 650 kg·m² in 1st gear);
//! - drive-shaft torque
//!   `M_d = G M_c − ((J_t(gear) + J_p) i_f² + J_f + J_d) ω̇_w − (b_t i_f² + b_f) ω_w`
//!   (gear 0 or below — neutral, or a reverse gear the model lacks — disconnects the gearbox
//!   input side: `M_c`, `J_t` and `b_t` drop out).
//!
//! `M_e` is averaged and `ω_e`, `v` differentiated over one centred window
//! (`torque_half_window_s`): a centred difference is exactly the window mean of the derivative,
//! so every term is the same window mean and the balance holds for the means. The neglected
//! torsion rates are the shaft oscillation (shuffle); the engine-side part of it is in `ω̇_e`.
//!
//! The window is ±0.05 s by default, shorter than the acceleration input's ±0.25 s: the engine
//! signals come at 50 Hz (J1939 EEC1), so ±0.05 s still averages five frames — at the wheels
//! `σ ≈ G·10 N·m` from the 1 % torque resolution with 0.5 % noise and 1 rpm speed noise — while
//! a ±0.25 s boxcar would smear a gear shift's 0.1–0.2 s torque ramps and, with its first zero
//! at 2 Hz, the chassis pitch and bounce band. The wheels' rate over this window comes from the
//! 10 Hz speed and is noisy (σ ≈ 0.2 m/s²), but it only multiplies the small inertias behind
//! the clutch (`J_out + J_c G²` ≤ 650 kg·m² in 1st gear, ≈ 9 kg·m² in top gear, at the fixture
//! truck's values).

use super::axle::AxleInputs;
use super::inputs::Piecewise;
use super::recorded::{pieces, relative_times, slope_input, RecordedError};
use crate::model::driveline::DrivelineParams;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::signal::first_order_lag;
use crate::table::LogView;

/// Where the acceleration input comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum AccelSource {
    /// The IMU column when present, else the speed derivative.
    Auto,
    /// The `longitudinal_acceleration` column (an error when absent).
    Imu,
    /// The derivative of `vehicle_speed`.
    Speed,
}

/// How a recording becomes axle-model inputs.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AxleRecordConfig {
    /// Acceleration source.
    pub accel: AccelSource,
    /// Half window of the centred speed difference, s (0.25 s averages the 1/256 km/h
    /// quantisation of a 10 Hz wheel speed to ~0.002 m/s²).
    pub speed_derivative_half_window_s: f64,
    /// Below this speed the vehicle stands and brakes only hold, m/s (0.1 m/s: a wheel-speed
    /// sensor's lowest reading is ~0.3 km/h).
    pub standstill_speed_mps: f64,
    /// Half window of the drive torque's inverse dynamics, s (module doc).
    pub torque_half_window_s: f64,
}

impl Default for AxleRecordConfig {
    fn default() -> Self {
        Self {
            accel: AccelSource::Auto,
            speed_derivative_half_window_s: 0.25,
            standstill_speed_mps: 0.1,
            torque_half_window_s: 0.05,
        }
    }
}

/// A recording as axle-model inputs, with the time axis they were built on.
#[derive(Debug, Clone)]
pub struct RecordedAxleInputs {
    /// The inputs.
    pub inputs: AxleInputs,
    /// Sample times relative to the first row, s (shared with the inputs' pieces).
    pub t_s: std::sync::Arc<[f64]>,
    /// Acceleration used, m/s², per row.
    pub accel_mps2: Vec<f64>,
    /// Where it came from (`longitudinal_acceleration` or `d(vehicle_speed)/dt`).
    pub accel_source: &'static str,
    /// Slope column used (`None`: flat road).
    pub slope_column: Option<String>,
    /// Whether torque signals drive the model (else acceleration only).
    pub torque_inputs: bool,
}

/// The runs `[a, e)` of consecutive `true` values of `flags`.
fn runs_of(flags: &[bool]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (k, &f) in flags.iter().enumerate() {
        match (f, start) {
            (true, None) => start = Some(k),
            (false, Some(a)) => {
                out.push((a, k));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(a) = start {
        out.push((a, flags.len()));
    }
    out
}

/// Per sample `k`, the first and last sample index inside `[t_k − half, t_k + half]`; where
/// that holds one sample only, its neighbours.
fn centred_windows(t: &[f64], half: f64) -> Vec<(usize, usize)> {
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
            if hi > lo {
                (lo, hi)
            } else {
                (k.saturating_sub(1), (k + 1).min(n - 1))
            }
        })
        .collect()
}

/// Centred difference `(v_b − v_a)/(t_b − t_a)` over the samples inside `t_k ± half` (the mean
/// of the derivative over that span), per sample; 0 where the span is empty.
pub(crate) fn centred_derivative(t: &[f64], v: &[f64], half: f64) -> Vec<f64> {
    centred_windows(t, half)
        .into_iter()
        .map(|(a, b)| {
            if t[b] > t[a] {
                (v[b] - v[a]) / (t[b] - t[a])
            } else {
                0.0
            }
        })
        .collect()
}

/// Mean of the piecewise-linear `v` over the same span as [`centred_derivative`] (trapezoidal
/// integral over the span divided by its length), per sample; the sample itself where the span
/// is empty.
pub(crate) fn centred_mean(t: &[f64], v: &[f64], half: f64) -> Vec<f64> {
    // cumulative trapezoidal integral
    let mut cum = Vec::with_capacity(t.len());
    let mut acc = 0.0;
    cum.push(0.0);
    for i in 1..t.len() {
        acc += 0.5 * (v[i] + v[i - 1]) * (t[i] - t[i - 1]);
        cum.push(acc);
    }
    centred_windows(t, half)
        .into_iter()
        .enumerate()
        .map(|(k, (a, b))| {
            if t[b] > t[a] {
                (cum[b] - cum[a]) / (t[b] - t[a])
            } else {
                v[k]
            }
        })
        .collect()
}

/// The driveline parameters the axle inputs are built from (module doc): the inertias, losses,
/// final drive and wheel radius of the inverse dynamics, the clutch's open position and the
/// engine's torque lag. [`axle_inputs_from_log`] reads nothing else of a [`DrivelineParams`], so
/// two drivelines with equal `InverseDynamicsParams` build equal inputs from one recording (a
/// clutch capacity, a shaft stiffness or a drag area does not change them).
#[derive(Debug, Clone, PartialEq)]
pub struct InverseDynamicsParams {
    /// Wheel radius `r_w`, m.
    pub wheel_radius_m: f64,
    /// Final drive ratio `i_f`.
    pub final_drive_ratio: f64,
    /// Engine inertia `J_e`, kg·m².
    pub j_e_kg_m2: f64,
    /// Clutch-disc inertia `J_c`, kg·m².
    pub j_c_kg_m2: f64,
    /// Gearbox inertia `J_t` per gear, kg·m².
    pub j_t_kg_m2: Vec<f64>,
    /// Gearbox viscous loss `b_t`, N·m·s/rad.
    pub b_t_nm_s_per_rad: f64,
    /// Propeller-shaft inertia `J_p`, kg·m².
    pub j_p_kg_m2: f64,
    /// Final-drive inertia `J_f`, kg·m².
    pub j_f_kg_m2: f64,
    /// Final-drive viscous loss `b_f`, N·m·s/rad.
    pub b_f_nm_s_per_rad: f64,
    /// Drive-shaft inertia `J_d`, kg·m².
    pub j_d_kg_m2: f64,
    /// Normalised clutch position `L_u` from which the clutch passes no torque.
    pub clutch_l_upper: f64,
    /// Lag of the produced engine torque behind the reported one, s.
    pub engine_torque_lag_s: f64,
}

impl From<&DrivelineParams> for InverseDynamicsParams {
    fn from(d: &DrivelineParams) -> Self {
        Self {
            wheel_radius_m: d.wheel_radius_m,
            final_drive_ratio: d.final_drive_ratio,
            j_e_kg_m2: d.j_e_kg_m2,
            j_c_kg_m2: d.j_c_kg_m2,
            j_t_kg_m2: d.j_t_kg_m2.clone(),
            b_t_nm_s_per_rad: d.b_t_nm_s_per_rad,
            j_p_kg_m2: d.j_p_kg_m2,
            j_f_kg_m2: d.j_f_kg_m2,
            b_f_nm_s_per_rad: d.b_f_nm_s_per_rad,
            j_d_kg_m2: d.j_d_kg_m2,
            clutch_l_upper: d.clutch_l_upper,
            engine_torque_lag_s: d.engine_torque_lag_s,
        }
    }
}

/// Drive-shaft torque `M_d` at the driven wheels by inverse dynamics of the driveline (module doc,
/// docs/models/driveline.md), N·m (+ driving), per row. `m_e` engine torque (N·m), `w_e` engine
/// speed (rad/s; `None`: locked clutch assumed), `gear` (rounded; below 1 = no gear engaged;
/// engaged gears already checked against `ratios`), `clutch` normalised clutch position (`None`:
/// engaged), `v` vehicle speed (m/s) and `a` its centred difference over `half` (m/s²), all on
/// times `t` (s).
#[allow(clippy::too_many_arguments)]
fn drive_torque_inverse_dynamics(
    p: &InverseDynamicsParams,
    ratios: &[f64],
    t: &[f64],
    m_e: &[f64],
    w_e: Option<&[f64]>,
    gear: &[f64],
    clutch: Option<&[f64]>,
    v: &[f64],
    a: &[f64],
    half: f64,
) -> Vec<f64> {
    let m_mean = centred_mean(t, m_e, half);
    let dw_e = w_e.map(|w| centred_derivative(t, w, half));
    let i_f = p.final_drive_ratio;
    let r = p.wheel_radius_m;
    (0..t.len())
        .map(|k| {
            let (w_w, dw_w) = (v[k] / r, a[k] / r);
            if gear[k] < 1.0 {
                // neutral: only the propeller side turns with the wheels
                return -((p.j_p_kg_m2 * i_f * i_f + p.j_f_kg_m2 + p.j_d_kg_m2) * dw_w
                    + p.b_f_nm_s_per_rad * w_w);
            }
            let g = gear[k].round() as usize;
            let big_g = ratios[g - 1] * i_f;
            // the column is normalised by x_max, as L_u is
            let open = clutch.is_some_and(|c| c[k] >= p.clutch_l_upper);
            let m_c = if open {
                // no torque through the friction faces; the disc turns with the gearbox input
                -p.j_c_kg_m2 * big_g * dw_w
            } else {
                let dw_e_k = dw_e.as_ref().map_or(big_g * dw_w, |d| d[k]);
                m_mean[k] - p.j_e_kg_m2 * dw_e_k - p.j_c_kg_m2 * big_g * dw_w
            };
            let j_out = (p.j_t_kg_m2[g - 1] + p.j_p_kg_m2) * i_f * i_f + p.j_f_kg_m2 + p.j_d_kg_m2;
            big_g * m_c - j_out * dw_w - (p.b_t_nm_s_per_rad * i_f * i_f + p.b_f_nm_s_per_rad) * w_w
        })
        .collect()
}

/// Builds the axle-model inputs of a recorded drive (see the module rules).
///
/// `driveline`: the vehicle's `[driveline]` parameters, when it has them — the drive torque is
/// then the drive-shaft torque by inverse dynamics (module doc), with the driveline's final
/// drive; without them, engine torque × gear ratio × `final_drive_ratio`.
///
/// # Errors
/// [`RecordedError`] for logs shorter than 2 rows, no usable acceleration source, a gear with
/// no ratio, or a torque signal without gear ratios or final drive. `mass_kg` and
/// `wheel_radius_m` are the axle model's (for the holding force at standstill).
#[allow(clippy::too_many_arguments)]
pub fn axle_inputs_from_log(
    log: LogView<'_>,
    mass_kg: f64,
    wheel_radius_m: f64,
    gravity_m_per_s2: f64,
    gear_ratios: &[f64],
    final_drive_ratio: Option<f64>,
    driveline: Option<&DrivelineParams>,
    slope_column: Option<&str>,
    cfg: &AxleRecordConfig,
) -> Result<RecordedAxleInputs, RecordedError> {
    // the driveline's parameters the inputs are built from, and no others
    let driveline = driveline.map(InverseDynamicsParams::from);
    let driveline = driveline.as_ref();
    let file = log.log.meta.source_file.clone();
    let t = relative_times(log.log)?;
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
    // the torque the engine produces: the ECU's reported figure through the engine's lag
    let torque = column("engine_torque", Interpolation::Linear).map(|m| match driveline {
        Some(d) if d.engine_torque_lag_s > 0.0 => first_order_lag(&t, &m, d.engine_torque_lag_s),
        _ => m,
    });
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
            for (row, &g) in gear.iter().enumerate() {
                let g = g.round();
                if g >= 1.0 && gear_ratios.get(g as usize - 1).is_none() {
                    return Err(RecordedError::Gear {
                        file: file.clone(),
                        gear: g,
                        row,
                        max: gear_ratios.len(),
                    });
                }
            }
            let gear: Vec<f64> = gear.iter().map(|g| g.round()).collect();
            match (driveline, column("vehicle_speed", Interpolation::Linear)) {
                (Some(p), Some(v)) => {
                    // the wheels' rate over the torque's window (module doc); at a
                    // standstill the wheels are held
                    let mut a_drive = centred_derivative(&t, &v, cfg.torque_half_window_s);
                    let mut v_held = v.clone();
                    for (a, x) in a_drive.iter_mut().zip(v_held.iter_mut()) {
                        if x.abs() < cfg.standstill_speed_mps {
                            (*a, *x) = (0.0, 0.0);
                        }
                    }
                    let w_e = column("engine_speed", Interpolation::Linear);
                    Some(drive_torque_inverse_dynamics(
                        p,
                        gear_ratios,
                        &t,
                        &m_e,
                        w_e.as_deref(),
                        &gear,
                        clutch.as_deref(),
                        &v_held,
                        &a_drive,
                        cfg.torque_half_window_s,
                    ))
                }
                _ => Some(
                    m_e.iter()
                        .zip(&gear)
                        .enumerate()
                        .map(|(row, (&m, &g))| {
                            let open = clutch.as_ref().is_some_and(|c| c[row] >= 0.5);
                            if g < 1.0 || open {
                                0.0
                            } else {
                                m * gear_ratios[g as usize - 1] * i_f
                            }
                        })
                        .collect(),
                ),
            }
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
        // the holding force (module doc): the drive force's mean over the acceleration's
        // window, the grade's mean over the standstill
        let f_raw: Vec<f64> = (0..b.len())
            .map(|k| {
                (drive.as_ref().map_or(0.0, |d| d[k]) - aux.as_ref().map_or(0.0, |x| x[k]))
                    / wheel_radius_m
            })
            .collect();
        let f_drive = centred_mean(&t, &f_raw, cfg.speed_derivative_half_window_s);
        let still: Vec<bool> = v
            .iter()
            .map(|x| x.abs() < cfg.standstill_speed_mps)
            .collect();
        for (a, e) in runs_of(&still) {
            let sin_grade =
                slope[a..e].iter().map(|s| s.atan().sin()).sum::<f64>() / (e - a) as f64;
            for k in a..e {
                let need = f_drive[k] - mass_kg * gravity_m_per_s2 * sin_grade;
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
    use crate::table::{DriveLog, DriveMeta, Signal};

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
            LogView::of(&log),
            18_700.0,
            0.5,
            9.81,
            &[2.0, 1.0],
            Some(3.0),
            None,
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
    fn a_parked_truck_is_held_by_the_mean_grade_whatever_the_slope_and_speed_noise() {
        // 10 s parked on 4 % with the clutch open: the slope sensor's noise (±0.4 %, 370 N at
        // 18.7 t) and a rectified speed noise below the standstill speed; the recorded brake is
        // the holding force's magnitude (as the synthetic CAN logs it). Taken per sample, the
        // force asked for is clipped at that magnitude on every steeper sample, and the held
        // force comes out 761 N short on average (with the per-sample grade and the speed's own
        // rate); with the grade's mean over the standstill and the wheels held it is the holding
        // force on every sample.
        let n = 500;
        let (m, g) = (18_700.0, 9.81);
        let slope: Vec<f64> = (0..n)
            .map(|k| 0.04 + if k % 2 == 0 { 0.004 } else { -0.004 })
            .collect();
        let speed: Vec<f64> = (0..n).map(|k| 0.02 * ((k * 7) % 5) as f64).collect();
        let hold = -m * g * 0.04f64.atan().sin();
        let sig = |name: &str, unit: &str, values: Vec<f64>| Signal {
            name: name.into(),
            unit: unit.into(),
            values,
        };
        let log = DriveLog {
            meta: DriveMeta::default(),
            timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
            signals: vec![
                sig("vehicle_speed", "m/s", speed),
                sig("road_slope", "1", slope),
                sig("engine_torque", "N*m", vec![0.0; n]),
                sig("engine_speed", "rad/s", vec![62.8; n]),
                sig("gear", "1", vec![1.0; n]),
                sig("clutch_position", "1", vec![1.0; n]),
                sig("brake_force", "N", vec![-hold; n]),
            ],
        };
        let (p, ratios) = diesel();
        let r = axle_inputs_from_log(
            LogView::of(&log),
            m,
            p.wheel_radius_m,
            g,
            &ratios,
            Some(p.final_drive_ratio),
            Some(&p),
            None,
            &AxleRecordConfig::default(),
        )
        .unwrap();
        let mean_sin = (0.044f64.atan().sin() + 0.036f64.atan().sin()) / 2.0;
        let want = -m * g * mean_sin;
        let b = r.inputs.service_brake_n.as_ref().unwrap();
        let d = r.inputs.drive_torque_wheel_nm.as_ref().unwrap();
        for k in 0..n {
            let x = k as f64 * 0.02;
            // the drive torque of an open clutch with the wheels held is 0
            assert!(d.eval(x).abs() < 1e-9, "{x}: drive torque {}", d.eval(x));
            assert!(
                (b.eval(x) - want).abs() < 1e-6,
                "{x}: {} vs {want}",
                b.eval(x)
            );
        }
    }

    fn diesel() -> (DrivelineParams, Vec<f64>) {
        let v = crate::model::vehicle::VehicleFile::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/seed002-6x2-diesel.toml"
        )))
        .unwrap();
        (v.driveline.clone().unwrap(), v.gearbox.ratios.clone())
    }

    #[test]
    fn inverse_dynamics_in_steady_acceleration_is_the_shaft_balance() {
        // locked clutch, 2nd gear, a = 0.5 m/s² from 3 m/s, M_e = 900 N·m: the shaft equations of
        // docs/models/driveline.md with every shaft speed rigidly tied to the wheels give M_d
        // directly
        let (p, ratios) = diesel();
        let (gear, a, m_e) = (2usize, 0.5, 900.0);
        let big_g = ratios[gear - 1] * p.final_drive_ratio;
        let r = p.wheel_radius_m;
        let t: Vec<f64> = (0..200).map(|k| k as f64 * 0.02).collect();
        let v: Vec<f64> = t.iter().map(|x| 3.0 + a * x).collect();
        let w_e: Vec<f64> = v.iter().map(|x| big_g * x / r).collect();
        let acc = centred_derivative(&t, &v, 0.05);
        let md = drive_torque_inverse_dynamics(
            &(&p).into(),
            &ratios,
            &t,
            &vec![m_e; t.len()],
            Some(&w_e),
            &vec![gear as f64; t.len()],
            Some(&vec![0.0; t.len()]),
            &v,
            &acc,
            0.05,
        );
        let dw = a / r;
        let j1 = p.j_e_kg_m2 + p.j_c_kg_m2;
        let j2 = p.j_t_kg_m2[gear - 1] + p.j_p_kg_m2;
        let j3 = p.j_f_kg_m2 + p.j_d_kg_m2;
        let i_f = p.final_drive_ratio;
        for k in 5..195 {
            let w_w = v[k] / r;
            // engine side, gearbox output, final drive: M_c, M_p, M_d in turn
            let m_c = m_e - j1 * big_g * dw;
            let m_p = ratios[gear - 1] * m_c - p.b_t_nm_s_per_rad * i_f * w_w - j2 * i_f * dw;
            let want = i_f * m_p - p.b_f_nm_s_per_rad * w_w - j3 * dw;
            assert!(
                (md[k] - want).abs() < 1e-6 * want.abs(),
                "{k}: {} vs {want}",
                md[k]
            );
        }
        // the product G·M_e, without the rotating inertias and losses, is 18 % high here
        let crude = big_g * m_e / md[100];
        assert!((crude - 1.18).abs() < 0.005, "{crude}");
    }

    #[test]
    fn an_open_clutch_passes_no_engine_torque_but_its_disc_turns_with_the_gearbox() {
        // coasting at 10 m/s with the clutch open while the engine is governed up at 200 rad/s²:
        // its torque J_e·ω̇_e goes into its own inertia, none reaches the wheels
        let (p, ratios) = diesel();
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.02).collect();
        let v = vec![10.0; t.len()];
        let w_e: Vec<f64> = t.iter().map(|x| 70.0 + 200.0 * x).collect();
        let m_e = vec![p.j_e_kg_m2 * 200.0; t.len()];
        let gear = vec![6.0; t.len()];
        let acc = vec![0.0; t.len()];
        let losses = (p.b_t_nm_s_per_rad * p.final_drive_ratio.powi(2) + p.b_f_nm_s_per_rad) * 10.0
            / p.wheel_radius_m;
        for clutch in [Some(vec![1.0; t.len()]), None] {
            let md = drive_torque_inverse_dynamics(
                &(&p).into(),
                &ratios,
                &t,
                &m_e,
                Some(&w_e),
                &gear,
                clutch.as_deref(),
                &v,
                &acc,
                0.05,
            );
            for x in &md[3..97] {
                assert!((x + losses).abs() < 1e-6, "{x} vs {}", -losses);
            }
        }
        // rolling away at +0.7 m/s² in 1st gear, clutch open, engine idling: the gearbox input
        // side — its shafts and the clutch disc, which turns with it — is spun up by the wheels
        let gear = vec![1.0; t.len()];
        let v: Vec<f64> = t.iter().map(|x| 2.0 + 0.7 * x).collect();
        let acc = centred_derivative(&t, &v, 0.05);
        let md = drive_torque_inverse_dynamics(
            &(&p).into(),
            &ratios,
            &t,
            &vec![0.0; t.len()],
            Some(&vec![62.8; t.len()]),
            &gear,
            Some(&vec![1.0; t.len()]),
            &v,
            &acc,
            0.05,
        );
        let (i_f, r) = (p.final_drive_ratio, p.wheel_radius_m);
        let big_g = ratios[0] * i_f;
        let dw = 0.7 / r;
        let j_wheels = p.j_c_kg_m2 * big_g * big_g
            + (p.j_t_kg_m2[0] + p.j_p_kg_m2) * i_f * i_f
            + p.j_f_kg_m2
            + p.j_d_kg_m2;
        for k in 3..97 {
            let losses = (p.b_t_nm_s_per_rad * i_f * i_f + p.b_f_nm_s_per_rad) * v[k] / r;
            let want = -j_wheels * dw - losses;
            assert!(
                (md[k] - want).abs() < 1e-6 * want.abs(),
                "{k}: {} vs {want}",
                md[k]
            );
        }
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
