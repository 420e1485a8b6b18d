//! Event features of a recorded drive for the driveline effects the windowed comparison cannot
//! see (`clutch_slip` and `driveline_backlash`; the study is docs/diagnosis/events.md):
//!
//! - [`launch_clutch_torques`]: per launch from standstill, the clutch torque the recording
//!   implies while the clutch slips, as a fraction of the nominal capacity at the recorded
//!   clutch position — the direct measure of a worn clutch (`clutch_slip`);
//! - [`torque_reversals`] and [`reversal_residual_peaks`]: engine-torque sign changes with the
//!   clutch closed and the gear held, and the engine-speed residual of a simulation right after
//!   each — where a lash in the driveline (`driveline_backlash`) shows.
//!
//! # Launch clutch torque
//! While the clutch slips, the engine side obeys `J_e ω̇_e = M_e − M_k` (docs/models/driveline.md:
//! the clutch passes its kinetic capacity `M_k`, signed by the slip, here positive: the engine
//! drives), so the recording gives the transmitted torque `M̂_k = M_e − J_e ω̇_e` from the engine
//! torque and the engine speed alone. The nominal capacity at the recorded position is
//! [`DrivelineParams::clutch_capacity`]. Over the launch's slipping samples:
//! - `ratio = Σ M̂_k C / Σ C²` (least squares through the origin): 1 for a clutch as the vehicle
//!   file says, `M_k,true / M_k,nominal` for a worn one;
//! - `slope`, `intercept_nm`: least squares `M̂_k ≈ slope·C + intercept`, which tells a scaled
//!   capacity (slope ≠ 1) from an additive engine-torque bias (`engine_torque_offset`,
//!   intercept ≠ 0), since the capacity ramps during a launch.
//!
//! A sample counts as slipping when the engine runs at least [`EventConfig::min_slip_rad_s`]
//! faster than the gear's input speed `i_t i_f v / r_w`. Why that margin: right after a launch
//! locks, the 1st-gear shuffle swings the engine speed against the wheels by up to ~100 rpm
//! (overall ratio ~46), and those locked samples carry less than the capacity (on the 66 proof
//! drives a 50 rpm margin puts clean launches' ratios as low as 0.3, while 150 rpm keeps 177 of
//! 181 launches of drives without a clutch or engine-torque effect within 0.84–0.99;
//! docs/diagnosis/events.md). `ω̇_e` is the centred difference over
//! ±[`EventConfig::derivative_halfwidth_s`].
//!
//! # Torque reversals
//! The engine torque, averaged over ±[`EventConfig::reversal_smoothing_s`] (the recorded
//! channel has 0.5 % noise and 1 % steps of the reference torque), leaves one side of the band
//! ±[`EventConfig::reversal_torque_nm`] and reaches the other within
//! [`EventConfig::reversal_max_crossing_s`], with the clutch closed and the gear unchanged from
//! [`EventConfig::reversal_quiet_before_s`] before to [`EventConfig::reversal_quiet_after_s`]
//! after. The reversal's time is the first sample on the new side. In a lash the shaft torque is
//! zero while the gap closes, so the engine side runs free under the new engine torque, then
//! hits the other flank: the engine speed dips (tip-out) or flares (tip-in) against a model
//! without lash, within a few tenths of a second.
//!
//! # Conventions
//! Times in s from the log's first row; speeds rad/s (engine) and m/s (vehicle); torques N·m,
//! positive driving; clutch position 0 = engaged … 1 = open (docs/inputs.md).

use crate::model::driveline::DrivelineParams;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;
use serde::Serialize;

/// Settings of the event features.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EventConfig {
    /// Clutch position at or above which the clutch counts as open, fraction of travel.
    pub clutch_open_min: f64,
    /// Clutch position at or below which the clutch counts as closed (the 2 % of
    /// [`super::rows::longitudinal_rows`]).
    pub clutch_closed_max: f64,
    /// A launch starts below this measured speed, m/s (the AMT's standstill limit, 0.3 m/s).
    pub launch_speed_max_mps: f64,
    /// Longest launch followed, s (a launch that has not closed the clutch by then ends there).
    pub launch_max_s: f64,
    /// Least engine speed above the gear's input speed for a slipping sample, rad/s
    /// (150 rpm, see the module documentation).
    pub min_slip_rad_s: f64,
    /// Least nominal capacity for a sample, N·m (below it the clutch barely touches and the
    /// ratio is dominated by the engine torque's 26 N·m steps).
    pub min_capacity_nm: f64,
    /// Half-width of the engine-speed derivative, s.
    pub derivative_halfwidth_s: f64,
    /// Least slipping samples for a launch's result.
    pub min_samples: usize,
    /// Half-width of the torque band a reversal crosses, N·m (about 5 noise σ of a 2600 N·m
    /// reference channel after the smoothing).
    pub reversal_torque_nm: f64,
    /// Longest crossing of the band, s (a reversal is a tip-in or tip-out, not a slow drift).
    pub reversal_max_crossing_s: f64,
    /// Half-width of the engine-torque average, s.
    pub reversal_smoothing_s: f64,
    /// Clutch closed and gear held from this long before a reversal, s.
    pub reversal_quiet_before_s: f64,
    /// … to this long after it, s.
    pub reversal_quiet_after_s: f64,
    /// Residual window after a reversal, s, from its start `(a, b)` relative to the reversal.
    pub reversal_window_s: (f64, f64),
}

impl Default for EventConfig {
    fn default() -> Self {
        Self {
            clutch_open_min: 0.98,
            clutch_closed_max: 0.02,
            launch_speed_max_mps: 0.3,
            launch_max_s: 15.0,
            min_slip_rad_s: 150.0 * std::f64::consts::PI / 30.0,
            min_capacity_nm: 50.0,
            derivative_halfwidth_s: 0.1,
            min_samples: 10,
            reversal_torque_nm: 60.0,
            reversal_max_crossing_s: 1.0,
            reversal_smoothing_s: 0.1,
            reversal_quiet_before_s: 1.5,
            reversal_quiet_after_s: 2.0,
            reversal_window_s: (-0.1, 0.5),
        }
    }
}

/// The recorded channels the features read, on one time base (gaps filled).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Channels {
    /// Times, s from the first row.
    pub t_s: Vec<f64>,
    /// Vehicle speed, m/s.
    pub vehicle_speed_mps: Vec<f64>,
    /// Engine speed, rad/s.
    pub engine_speed_rad_s: Vec<f64>,
    /// Engine torque, N·m.
    pub engine_torque_nm: Vec<f64>,
    /// Gear (0 = neutral).
    pub gear: Vec<f64>,
    /// Clutch position, 0 = engaged … 1 = open.
    pub clutch_position: Vec<f64>,
}

impl Channels {
    /// The channels of `log` (linear gap filling, the gear held), or `None` when one of
    /// vehicle speed, engine speed, engine torque, gear or clutch position is absent or empty.
    pub fn from_log(log: &DriveLog) -> Option<Channels> {
        let col = |c: &str, k: Interpolation| log.signal(c).and_then(|v| fill_gaps(v, k));
        Some(Channels {
            t_s: log.seconds_from_start(),
            vehicle_speed_mps: col("vehicle_speed", Interpolation::Linear)?,
            engine_speed_rad_s: col("engine_speed", Interpolation::Linear)?,
            engine_torque_nm: col("engine_torque", Interpolation::Linear)?,
            gear: col("gear", Interpolation::Hold)?,
            clutch_position: col("clutch_position", Interpolation::Linear)?,
        })
    }
}

/// The clutch torque of one launch against the nominal capacity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LaunchClutchTorque {
    /// First sample with the clutch leaving the open position, s.
    pub t_start_s: f64,
    /// First sample with the clutch closed (or the launch cut off), s.
    pub t_end_s: f64,
    /// Slipping samples used.
    pub samples: usize,
    /// `Σ M̂_k C / Σ C²`, 1.
    pub ratio: f64,
    /// Slope of `M̂_k ≈ slope·C + intercept`, 1.
    pub slope: f64,
    /// Intercept of that fit, N·m.
    pub intercept_nm: f64,
    /// Largest nominal capacity among the samples, N·m.
    pub max_capacity_nm: f64,
}

/// Centred difference of `y` over ±`h` s at row `i` (one-sided at the ends), per s.
fn derivative(t: &[f64], y: &[f64], i: usize, h: f64) -> f64 {
    let a = t.partition_point(|&x| x < t[i] - h);
    let b = t.partition_point(|&x| x <= t[i] + h).saturating_sub(1);
    if b > a {
        (y[b] - y[a]) / (t[b] - t[a])
    } else {
        0.0
    }
}

/// The clutch torque of every launch from standstill in `ch` (module documentation), with the
/// nominal driveline `p` and gear `ratios`. A launch starts where the clutch leaves
/// [`EventConfig::clutch_open_min`] with the vehicle below
/// [`EventConfig::launch_speed_max_mps`], and ends at the first closed sample or after
/// [`EventConfig::launch_max_s`]; launches with fewer than [`EventConfig::min_samples`]
/// slipping samples are left out.
pub fn launch_clutch_torques(
    ch: &Channels,
    p: &DrivelineParams,
    ratios: &[f64],
    cfg: &EventConfig,
) -> Vec<LaunchClutchTorque> {
    let t = &ch.t_s;
    let n = t.len();
    let x = &ch.clutch_position;
    let mut out = Vec::new();
    let mut i = 1;
    while i < n {
        let starts = x[i - 1] >= cfg.clutch_open_min
            && x[i] < cfg.clutch_open_min
            && ch.vehicle_speed_mps[i].abs() < cfg.launch_speed_max_mps;
        if !starts {
            i += 1;
            continue;
        }
        let t0 = t[i];
        let mut j = i;
        while j < n && x[j] > cfg.clutch_closed_max && t[j] - t0 <= cfg.launch_max_s {
            j += 1;
        }
        let mut smc = Vec::new(); // (nominal capacity, transmitted torque) per slipping sample
        for (k, &xk) in x.iter().enumerate().take(j).skip(i) {
            let g = ch.gear[k].round();
            if g < 1.0 || g as usize > ratios.len() {
                continue;
            }
            let w_in = ratios[g as usize - 1] * p.final_drive_ratio * ch.vehicle_speed_mps[k]
                / p.wheel_radius_m;
            let c = p.clutch_capacity(xk * p.clutch_x_max);
            if ch.engine_speed_rad_s[k] - w_in < cfg.min_slip_rad_s || c < cfg.min_capacity_nm {
                continue;
            }
            let wdot = derivative(t, &ch.engine_speed_rad_s, k, cfg.derivative_halfwidth_s);
            smc.push((c, ch.engine_torque_nm[k] - p.j_e_kg_m2 * wdot));
        }
        if smc.len() >= cfg.min_samples {
            let (mut scc, mut smk) = (0.0, 0.0);
            for (c, m) in &smc {
                scc += c * c;
                smk += c * m;
            }
            let m = smc.len() as f64;
            let (cbar, mbar) = (
                smc.iter().map(|p| p.0).sum::<f64>() / m,
                smc.iter().map(|p| p.1).sum::<f64>() / m,
            );
            let sxx: f64 = smc.iter().map(|p| (p.0 - cbar).powi(2)).sum();
            let sxy: f64 = smc.iter().map(|p| (p.0 - cbar) * (p.1 - mbar)).sum();
            let slope = if sxx > 0.0 { sxy / sxx } else { f64::NAN };
            out.push(LaunchClutchTorque {
                t_start_s: t0,
                t_end_s: t[j.min(n - 1)],
                samples: smc.len(),
                ratio: smk / scc,
                slope,
                intercept_nm: mbar - slope * cbar,
                max_capacity_nm: smc.iter().map(|p| p.0).fold(0.0, f64::max),
            });
        }
        i = j.max(i + 1);
    }
    out
}

/// One engine-torque sign change with the clutch closed and the gear held.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TorqueReversal {
    /// First sample on the new side of the band, s.
    pub t_s: f64,
    /// Engaged gear.
    pub gear: usize,
    /// Drag to drive (tip-in) or drive to drag (tip-out).
    pub tip_in: bool,
}

/// The torque reversals of `ch` (module documentation).
pub fn torque_reversals(ch: &Channels, cfg: &EventConfig) -> Vec<TorqueReversal> {
    let t = &ch.t_s;
    let n = t.len();
    let m = &ch.engine_torque_nm;
    let mut out = Vec::new();
    let (mut a, mut b) = (0usize, 0usize);
    let mut sum = 0.0;
    let mut last: Option<(f64, f64)> = None; // (side, time last seen on it)
    for i in 0..n {
        while b < n && t[b] <= t[i] + cfg.reversal_smoothing_s {
            sum += m[b];
            b += 1;
        }
        while t[a] < t[i] - cfg.reversal_smoothing_s {
            sum -= m[a];
            a += 1;
        }
        let mean = sum / (b - a) as f64;
        let side = if mean > cfg.reversal_torque_nm {
            1.0
        } else if mean < -cfg.reversal_torque_nm {
            -1.0
        } else {
            continue;
        };
        if let Some((s, tl)) = last {
            if s != side && t[i] - tl <= cfg.reversal_max_crossing_s {
                let lo = t.partition_point(|&x| x < t[i] - cfg.reversal_quiet_before_s);
                let hi = t.partition_point(|&x| x <= t[i] + cfg.reversal_quiet_after_s);
                let g = ch.gear[i].round();
                let quiet = t[i] - cfg.reversal_quiet_before_s >= t[0]
                    && t[i] + cfg.reversal_quiet_after_s <= t[n - 1]
                    && g >= 1.0
                    && (lo..hi).all(|k| {
                        ch.clutch_position[k] <= cfg.clutch_closed_max && ch.gear[k].round() == g
                    });
                if quiet {
                    out.push(TorqueReversal {
                        t_s: t[i],
                        gear: g as usize,
                        tip_in: side > 0.0,
                    });
                }
            }
        }
        last = Some((side, t[i]));
    }
    out
}

/// The signed peak of `measured − simulated` (rad/s for engine speeds) within
/// [`EventConfig::reversal_window_s`] of each reversal (the largest magnitude, its sign kept;
/// NaN where the window holds no sample).
pub fn reversal_residual_peaks(
    reversals: &[TorqueReversal],
    t_s: &[f64],
    measured: &[f64],
    simulated: &[f64],
    cfg: &EventConfig,
) -> Vec<f64> {
    reversals
        .iter()
        .map(|r| {
            let lo = t_s.partition_point(|&x| x < r.t_s + cfg.reversal_window_s.0);
            let hi = t_s.partition_point(|&x| x <= r.t_s + cfg.reversal_window_s.1);
            (lo..hi)
                .map(|k| measured[k] - simulated[k])
                .fold(f64::NAN, |acc: f64, d| {
                    if acc.is_nan() || d.abs() > acc.abs() {
                        d
                    } else {
                        acc
                    }
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::vehicle::VehicleFile;
    use crate::sim::fast::FastDriveline;
    use crate::sim::hybrid::{ClutchMode, EngineInput, Scenario, N_STATES};
    use crate::sim::inputs::Piecewise;

    fn truck() -> (DrivelineParams, Vec<f64>) {
        let vf = VehicleFile::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/seed002-6x2-diesel.toml"
        )))
        .unwrap();
        (vf.driveline.unwrap(), vf.gearbox.ratios)
    }

    /// A launch simulated by the driveline model itself, closed loop as the synthetic AMT
    /// does it: from 1 s the nominal capacity rises at 400 N·m/s, the
    /// engine torque is that capacity plus a proportional governor to 900 rpm
    /// (`K = 0.5 J_e / dt`), and once the clutch locks it closes fully. The plant's clutch
    /// capacity is `factor` times the nominal; the vehicle stands on a 5 % grade. One sample
    /// per 0.02 s control step (the engine-speed channel's 50 Hz).
    fn simulated_launch(factor: f64) -> Channels {
        let (p, ratios) = truck();
        let mut plant = p.clone();
        plant.clutch_max_torque_nm *= factor;
        let dt = 0.02;
        let k_gov = 0.5 * p.j_e_kg_m2 / dt;
        let w_target = 900.0 * std::f64::consts::PI / 30.0;
        let mut fast = FastDriveline::new(&plant, &ratios, 0.002);
        let mut y = [0.0; N_STATES];
        y[0] = 600.0 * std::f64::consts::PI / 30.0;
        let mut mode = ClutchMode::Slipping(1.0);
        let mut ch = Channels::default();
        let mut closed = false;
        for k in 0..300 {
            let t = k as f64 * dt;
            let x = if closed {
                0.0
            } else if t < 1.0 {
                1.0
            } else {
                p.clutch_position_for(400.0 * (t - 1.0 + dt)) / p.clutch_x_max
            };
            let m_e = (p.clutch_capacity(x * p.clutch_x_max) + k_gov * (w_target - y[0]))
                .clamp(p.engine_min_torque_nm, p.engine_max_torque(y[0]));
            ch.t_s.push(t);
            ch.vehicle_speed_mps.push(p.wheel_radius_m * y[7]);
            ch.engine_speed_rad_s.push(y[0]);
            ch.engine_torque_nm.push(m_e);
            ch.gear.push(1.0);
            ch.clutch_position.push(x);
            let sc = Scenario {
                t_end_s: t + dt,
                gear: Piecewise::constant(t + dt, 1.0),
                clutch_x: Piecewise::constant(t + dt, x * p.clutch_x_max),
                slope: Piecewise::constant(t + dt, 0.05),
                brake_n: Piecewise::constant(t + dt, if t < 1.0 { 30_000.0 } else { 0.0 }),
                engine: EngineInput::Torque(Piecewise::constant(t + dt, m_e)),
                smoothing: false,
                standstill_events: true,
            };
            let tr = fast.simulate_span(&sc, t, t + dt, y, mode).unwrap();
            y = *tr.y.last().unwrap();
            mode = *tr.mode.last().unwrap();
            closed |= mode == ClutchMode::Locked && t > 1.0;
        }
        ch
    }

    #[test]
    fn launch_ratio_recovers_the_plant_clutch_capacity() {
        // the driveline model's own launch: the ratio is the plant's capacity factor. Measured
        // error below 0.001 (the model is exactly `J_e ω̇_e = M_e − M_k` while slipping; the
        // 0.1 s centred derivative is exact for the piecewise-constant acceleration but at the
        // ends); tolerance 0.005 leaves room for a change of the integrator's step
        let (p, ratios) = truck();
        let cfg = EventConfig::default();
        for factor in [1.0, 0.7] {
            let ch = simulated_launch(factor);
            let l = launch_clutch_torques(&ch, &p, &ratios, &cfg);
            assert_eq!(l.len(), 1, "factor {factor}: {l:?}");
            let l = l[0];
            assert!(l.samples >= 20, "{l:?}");
            assert!((l.ratio - factor).abs() < 0.005, "factor {factor}: {l:?}");
            assert!((l.slope - factor).abs() < 0.005, "factor {factor}: {l:?}");
            assert!(l.intercept_nm.abs() < 2.0, "factor {factor}: {l:?}");
            assert!((l.t_start_s - 1.0).abs() < 1e-9, "{l:?}");
        }
    }

    #[test]
    fn launch_fit_tells_a_torque_bias_from_a_worn_clutch() {
        // a reported torque 100 N·m above the delivered one (engine_torque_offset) moves the
        // intercept, not the slope; the ratio through the origin is biased upwards
        let (p, ratios) = truck();
        let mut ch = simulated_launch(1.0);
        for m in ch.engine_torque_nm.iter_mut() {
            *m += 100.0;
        }
        let l = launch_clutch_torques(&ch, &p, &ratios, &EventConfig::default())[0];
        assert!((l.slope - 1.0).abs() < 0.005, "{l:?}");
        assert!((l.intercept_nm - 100.0).abs() < 2.0, "{l:?}");
        // through the origin the bias reads as a stronger clutch: 100 N·m on ≤ 520 N·m
        assert!(l.ratio > 1.15, "{l:?}");
    }

    #[test]
    fn no_launch_without_slip_or_from_speed() {
        let (p, ratios) = truck();
        let cfg = EventConfig::default();
        // engine at the gear's input speed: never slipping by the margin
        let mut ch = simulated_launch(1.0);
        for k in 0..ch.t_s.len() {
            ch.engine_speed_rad_s[k] =
                ratios[0] * p.final_drive_ratio * ch.vehicle_speed_mps[k] / p.wheel_radius_m;
        }
        assert!(launch_clutch_torques(&ch, &p, &ratios, &cfg).is_empty());
        // clutch closing while rolling at 5 m/s: a re-engagement, not a launch
        let mut ch = simulated_launch(1.0);
        for v in ch.vehicle_speed_mps.iter_mut() {
            *v += 5.0;
        }
        assert!(launch_clutch_torques(&ch, &p, &ratios, &cfg).is_empty());
    }

    fn reversal_log(step_s: f64, clutch_open_at: Option<f64>) -> Channels {
        // 50 Hz, 10 s: +500 N·m, then a linear change to −250 N·m over `step_s` at 5 s
        let mut ch = Channels::default();
        for k in 0..=500 {
            let t = k as f64 * 0.02;
            let f = ((t - 5.0) / step_s).clamp(0.0, 1.0);
            ch.t_s.push(t);
            ch.engine_torque_nm.push(500.0 - 750.0 * f);
            ch.vehicle_speed_mps.push(15.0);
            ch.engine_speed_rad_s.push(130.0);
            ch.gear.push(10.0);
            let open = clutch_open_at.is_some_and(|a| (t - a).abs() < 0.2);
            ch.clutch_position.push(if open { 1.0 } else { 0.0 });
        }
        ch
    }

    #[test]
    fn reversals_are_fast_sign_changes_with_the_clutch_closed() {
        let cfg = EventConfig::default();
        let r = torque_reversals(&reversal_log(0.2, None), &cfg);
        assert_eq!(r.len(), 1, "{r:?}");
        assert!(!r[0].tip_in);
        assert_eq!(r[0].gear, 10);
        // the 0.2 s mean of the ramp falls below −60 N·m where the ramp is at about −60 N·m
        // plus the averaging lag: between the ramp's −60 N·m point (5.149 s) and its end + 0.1 s
        assert!(r[0].t_s > 5.14 && r[0].t_s < 5.31, "{r:?}");
        // a 3 s ramp crosses the ±60 N·m band in 0.48 s: still a reversal; a 10 s one not
        assert_eq!(torque_reversals(&reversal_log(3.0, None), &cfg).len(), 1);
        assert!(torque_reversals(&reversal_log(10.0, None), &cfg).is_empty());
        // the clutch opened within the quiet time: not a driveline reversal
        assert!(torque_reversals(&reversal_log(0.2, Some(6.0)), &cfg).is_empty());
    }

    #[test]
    fn residual_peak_keeps_the_sign_of_the_largest_excursion() {
        let cfg = EventConfig::default();
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.02).collect();
        let meas: Vec<f64> = t
            .iter()
            .map(|&x| if (x - 1.2).abs() < 0.01 { 96.0 } else { 100.0 })
            .collect();
        let sim = vec![100.5; t.len()];
        let r = [TorqueReversal {
            t_s: 1.0,
            gear: 8,
            tip_in: false,
        }];
        let p = reversal_residual_peaks(&r, &t, &meas, &sim, &cfg);
        assert!((p[0] + 4.5).abs() < 1e-12, "{p:?}");
        // outside the window (reversal at 0.0: window −0.1…0.5 s) the dip at 1.2 s is not seen
        let r0 = [TorqueReversal { t_s: 0.0, ..r[0] }];
        let p0 = reversal_residual_peaks(&r0, &t, &meas, &sim, &cfg);
        assert!((p0[0] + 0.5).abs() < 1e-12, "{p0:?}");
    }
}
