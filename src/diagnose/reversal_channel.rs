//! The driveline's relative speed at torque reversals as a compared output of the longitudinal
//! model (docs/diagnosis/method.md, step 3 for `driveline_backlash`): one sample per reversal,
//! scored by the same fixed acceptance rule as the speeds.
//!
//! Why: a lash hides in the time-domain speed residual (the proof's oracle check at the hidden
//! lash: held-out weighted RMSE of the speeds −2.6 … +0.1 %), because a reversal lasts a few tenths
//! of a second, reversals are rare (5.5 per drive), and the driver's tip-outs come with a
//! service-brake step whose ±0.5 s the speeds' comparison leaves out (docs/diagnosis/events.md).
//! Yet at each tip-out the engine side runs free across the gap and dips 37–53 rpm against the
//! wheels — which the model at the true lash reproduces (docs/diagnosis/events.md). As a channel of
//! the longitudinal model, that dip is fitted, held out and tested like any other output.
//!
//! # The channel `reversal_relative_speed`
//! - **Events**: the torque reversals of [`super::events::torque_reversals`] (engine torque
//!   crossing ±60 N·m within 1 s, clutch closed and gear held from [`QUIET_BEFORE_START_S`] before
//!   to 0.6 s after), at a measured speed of at least the model's minimum over the windows, with
//!   the engine and vehicle speed recorded over [`REF_WINDOW_S`]`.0` … [`PEAK_WINDOW_S`]`.1` around
//!   it (no gap between samples longer than [`MAX_SAMPLE_GAP_S`]: a dropout's fill is not a
//!   measurement), and no start of the model's windows ([`super::extended::window_starts`]) within
//!   [`QUIET_BEFORE_START_S`] before it to [`PEAK_WINDOW_S`]`.1` after it (a window started at the
//!   reversal begins on the new flank and cannot cross the lash, docs/diagnosis/events.md; one
//!   started inside the windows would copy the measured dip).
//! - **Feature** of a pair of speed traces (measured or simulated alike): the relative speed
//!   `u = ω_e − G v` of the engine against the wheels (`G = i_t i_f / r_w` of the held gear, the
//!   nominal vehicle's), averaged over ±[`SMOOTHING_HALFWIDTH_S`], its extreme in the direction
//!   of the torque change (the least for a tip-out, the greatest for a tip-in) over
//!   [`PEAK_WINDOW_S`] minus its mean over [`REF_WINDOW_S`], both relative to the reversal, in
//!   rad/s. `u` is the twist rate of the driveline: it is 0 while the shafts hold a steady
//!   torque and swings at the shuffle after a step, so the vehicle's own acceleration, which
//!   the mass, drag, rolling resistance and the grade set, leaves it alone, whereas a lash
//!   (the engine runs free across the gap) and the shafts' stiffness and damping move it.
//! - **Measured** value: the feature of the measured engine and vehicle speeds, on the row of
//!   the reversal; every other row is not valid. **Simulated**: the feature of the model's
//!   engine and vehicle speeds at θ on the same rows.
//! - **Weight** of sample `i`: `1 / (s_noise² + s_floor²)`, `s_noise` the standard deviation
//!   the recording's noise gives the measured feature (engine speed and `G`× vehicle speed, each
//!   with its own rms error from the drive's sensor estimate, [`super::noise`]) and
//!   `s_floor` = [`FLOOR_RAD_S`], the model's own error of the feature on drives without an
//!   effect (module constant's documentation). The channel's `σ_c` is 1, so a residual within
//!   its standard errors scores about 1 like a speed residual at its noise floor.
//!
//! The channel is used when at least [`MIN_REVERSALS_PER_PART`] reversals fall in each part of
//! the split; otherwise the longitudinal model is compared on the speeds (and the shuffle
//! modes) alone.
//!
//! # Conventions
//! Speeds rad/s (engine) and m/s (vehicle); times s from the log's first row; torques N·m,
//! positive driving.

use super::events::{torque_reversals, Channels, EventConfig, TorqueReversal};
use crate::model::driveline::DrivelineParams;
use crate::table::DriveLog;

/// Name of the channel.
pub const NAME: &str = "reversal_relative_speed";
/// Unit of the channel.
pub const UNIT: &str = "rad/s";
/// Window of the extreme, s relative to the reversal (the lash closes within 0.2 s of the
/// reversal at the proof's lashes; the reversal's time is already 0.1 s into the smoothed
/// torque's crossing).
pub const PEAK_WINDOW_S: (f64, f64) = (-0.1, 0.4);
/// Window of the reference level, s relative to the reversal: before the torque leaves its old
/// side (the reversal is detected on a ±0.1 s average).
pub const REF_WINDOW_S: (f64, f64) = (-0.5, -0.25);
/// Half-width of the moving average of `u`, s (±2 samples of the 50 Hz engine speed).
pub const SMOOTHING_HALFWIDTH_S: f64 = 0.04;
/// No window start of the model this long before a reversal, s: the window must have run
/// through the reference window on the old flank (0.5 s) from its measured start state.
pub const QUIET_BEFORE_START_S: f64 = 0.6;
/// The model's own error of the feature, rad/s (1.9 rpm): a standard deviation per reversal.
/// Measured with `research/studies/reversal_floor.rs` on the drawn-driving proof, the model at
/// its 5 ms step and the reversals at 1 ms ([`super::extended::fine_spans`]): on the no-effect
/// drives `measured − nominal` has an rms of 1.86 rpm over 115 reversals, at most 5.3 rpm
/// (`fleetdyn prove --seed 1`), and 1.75 rpm over 113, at most 4.5 rpm (`--seed 1001`), of
/// which the recording's noise accounts for 0.78–0.81 rpm. 0.2 rad/s puts a clean drive's
/// standardised residuals at 0.85–0.9 in rms, the largest at 2.6 σ, while the lash's 6–12 rpm
/// at the proof's lashes stand at 3–6 σ each.
pub const FLOOR_RAD_S: f64 = 0.2;
/// Fewest reversals in each part of the split for the channel to be used.
pub const MIN_REVERSALS_PER_PART: usize = 1;

/// One reversal's sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReversalSample {
    /// Row of the reversal.
    pub row: usize,
    /// Held gear (1-based).
    pub gear: usize,
    /// `+1` for a tip-in (drag to drive), `−1` for a tip-out.
    pub direction: f64,
    /// Overall ratio `G = i_t i_f / r_w` of the gear, rad/m.
    pub ratio_rad_per_m: f64,
    /// Measured feature, rad/s.
    pub value: f64,
    /// Weight `1 / (s_noise² + s_floor²)`.
    pub weight: f64,
}

/// The reversals' settings: [`EventConfig`]'s, with the clutch closed and the gear held
/// from [`QUIET_BEFORE_START_S`] before the reversal (the reference window and the model's
/// run-up on the old flank) to 0.2 s after the extreme's window (a shift the driver starts
/// right after a tip-out does not touch the feature).
fn event_config() -> EventConfig {
    EventConfig {
        reversal_quiet_before_s: -EVENT_SPAN_S.0,
        reversal_quiet_after_s: EVENT_SPAN_S.1,
        ..EventConfig::default()
    }
}

/// Times of the torque reversals the channel samples on `log` (before the speed and window
/// conditions of [`measure`]), s from the first row; empty without the channels.
pub fn reversal_times(log: &DriveLog) -> Vec<f64> {
    Channels::from_log(log).map_or_else(Vec::new, |ch| {
        torque_reversals(&ch, &event_config())
            .into_iter()
            .map(|r| r.t_s)
            .collect()
    })
}

/// Span about a reversal over which [`reversal_times`] requires the clutch closed and the gear
/// held, s relative to it: from [`QUIET_BEFORE_START_S`] before (the reference window starts
/// 0.5 s before) to 0.2 s after the extreme's window ends.
pub const EVENT_SPAN_S: (f64, f64) = (-QUIET_BEFORE_START_S, PEAK_WINDOW_S.1 + 0.2);

/// Rows `[lo, hi)` of `t` within `[a, b]` s of `t0`, edges included to 1 µs (the sums of
/// times are not exact: a sample on an edge counts whichever side the rounding falls).
fn rows(t: &[f64], t0: f64, (a, b): (f64, f64)) -> (usize, usize) {
    const EDGE_S: f64 = 1e-6;
    (
        t.partition_point(|&x| x < t0 + a - EDGE_S),
        t.partition_point(|&x| x <= t0 + b + EDGE_S),
    )
}

/// The feature (module documentation) of the traces `w` (engine, rad/s) and `v` (vehicle, m/s)
/// at a reversal at `t0` with direction `direction` and ratio `g`; NaN when a window is empty.
pub fn feature(t: &[f64], w: &[f64], v: &[f64], t0: f64, direction: f64, g: f64) -> f64 {
    let u = |k: usize| w[k] - g * v[k];
    let smooth = |k: usize| {
        let (lo, hi) = rows(t, t[k], (-SMOOTHING_HALFWIDTH_S, SMOOTHING_HALFWIDTH_S));
        (lo..hi).map(u).sum::<f64>() / (hi - lo).max(1) as f64
    };
    let (ra, rb) = rows(t, t0, REF_WINDOW_S);
    let (pa, pb) = rows(t, t0, PEAK_WINDOW_S);
    if rb <= ra || pb <= pa {
        return f64::NAN;
    }
    let reference = (ra..rb).map(u).sum::<f64>() / (rb - ra) as f64;
    let extreme = (pa..pb)
        .map(|k| direction * smooth(k))
        .fold(f64::NEG_INFINITY, f64::max);
    direction * extreme - reference
}

/// Rms error of the recorded column `name` (noise and quantisation, the sensor estimate of
/// step 2's noise floor: [`crate::signal::sensor_noise_estimate::estimate_sensor_noise`]'s `sigma_raw`); 0 when it
/// cannot be estimated (the floor then carries the weight alone).
fn sensor_rms(log: &DriveLog, name: &str) -> f64 {
    let (Some(s), Ok(dt)) = (
        log.signals.iter().find(|s| s.name == name),
        crate::signal::sensor_noise::grid_step_s(log),
    ) else {
        return 0.0;
    };
    crate::signal::sensor_noise_estimate::estimate_sensor_noise(
        &s.name,
        &s.unit,
        &s.values,
        dt,
        crate::signal::sensor_noise::SampleKind::of_column(name),
    )
    .map_or(0.0, |e| e.sigma_raw)
    .max(0.0)
}

/// Longest time without a recorded sample inside a reversal's windows for it to count, s: more
/// than a 10 Hz channel's period plus its jitter is a dropout, whose gap fill is not a
/// measurement.
pub const MAX_SAMPLE_GAP_S: f64 = 0.15;

/// Recorded samples of `raw` on rows `lo..hi` of `t`, or `None` when two consecutive ones (or
/// a window edge and the nearest one) are more than [`MAX_SAMPLE_GAP_S`] apart.
fn recorded(t: &[f64], raw: &[f64], lo: usize, hi: usize) -> Option<usize> {
    let mut last = t[lo];
    let mut count = 0;
    for k in lo..hi {
        if raw[k].is_finite() {
            if t[k] - last > MAX_SAMPLE_GAP_S {
                return None;
            }
            last = t[k];
            count += 1;
        }
    }
    (t[hi - 1] - last <= MAX_SAMPLE_GAP_S && count > 0).then_some(count)
}

/// The measured samples of `log` (module documentation): `v`, `w` the measured vehicle and
/// engine speeds (gaps filled) on the log's rows, `starts` the model's window starts (s from
/// the first row), `p` and `ratios` the nominal driveline, `min_speed_mps` the model's
/// minimum speed.
///
/// The noise part of a sample's variance: the reference mean averages the engine speed's
/// `n_w,ref` and the vehicle speed's `n_v,ref` recorded samples, the extreme one smoothed
/// value of `n_w,peak` and `n_v,peak` (at least one) of them; so
/// `s_noise² = s_w² (1/n_w,ref + 1/n_w,peak) + G² s_v² (1/n_v,ref + 1/n_v,peak)` — a lower
/// bound, as picking the extreme of noisy values adds to it; the floor dominates.
pub fn measure(
    log: &DriveLog,
    v: &[f64],
    w: &[f64],
    starts: &[f64],
    p: &DrivelineParams,
    ratios: &[f64],
    min_speed_mps: f64,
) -> Vec<ReversalSample> {
    let n = log.len();
    let (Some(ch), Some(v_raw), Some(w_raw)) = (
        Channels::from_log(log),
        log.signal("vehicle_speed"),
        log.signal("engine_speed"),
    ) else {
        return Vec::new();
    };
    if v.len() != n || w.len() != n || v_raw.len() != n || w_raw.len() != n {
        return Vec::new();
    }
    let t = &ch.t_s;
    let (sw, sv) = (
        sensor_rms(log, "engine_speed"),
        sensor_rms(log, "vehicle_speed"),
    );
    let reversals: Vec<TorqueReversal> = torque_reversals(&ch, &event_config());
    reversals
        .into_iter()
        .filter_map(|r| {
            let row = t.partition_point(|&x| x < r.t_s);
            let it = *ratios.get(r.gear.checked_sub(1)?)?;
            let g = it * p.final_drive_ratio / p.wheel_radius_m;
            let (lo, hi) = rows(t, r.t_s, (REF_WINDOW_S.0, PEAK_WINDOW_S.1));
            if hi <= lo || row >= n {
                return None;
            }
            recorded(t, w_raw, lo, hi)?;
            recorded(t, v_raw, lo, hi)?;
            let fast = (lo..hi).all(|k| v[k] >= min_speed_mps);
            let restart = starts
                .iter()
                .any(|&s| s > r.t_s - QUIET_BEFORE_START_S && s <= r.t_s + PEAK_WINDOW_S.1);
            if !fast || restart {
                return None;
            }
            let direction = if r.tip_in { 1.0 } else { -1.0 };
            let value = feature(t, w, v, r.t_s, direction, g);
            let (ra, rb) = rows(t, r.t_s, REF_WINDOW_S);
            let (sa, sb) = rows(t, r.t_s, (-SMOOTHING_HALFWIDTH_S, SMOOTHING_HALFWIDTH_S));
            let count = |raw: &[f64], a: usize, b: usize| {
                (a..b).filter(|&k| raw[k].is_finite()).count().max(1) as f64
            };
            let var_noise = sw * sw * (1.0 / count(w_raw, ra, rb) + 1.0 / count(w_raw, sa, sb))
                + (g * sv).powi(2) * (1.0 / count(v_raw, ra, rb) + 1.0 / count(v_raw, sa, sb));
            let weight = 1.0 / (var_noise + FLOOR_RAD_S * FLOOR_RAD_S);
            value.is_finite().then_some(ReversalSample {
                row,
                gear: r.gear,
                direction,
                ratio_rad_per_m: g,
                value,
                weight,
            })
        })
        .collect()
}

/// The simulated channel's value on every row without a sample ([`simulate`]).
pub const FILL: f64 = 0.0;

/// The simulated channel on the log's rows `t` for the simulated engine and vehicle speeds
/// `w`, `v`: the feature on each sample's row, [`FILL`] (0) on every other row (not valid
/// there).
pub fn simulate(samples: &[ReversalSample], t: &[f64], w: &[f64], v: &[f64]) -> Vec<f64> {
    let mut out = vec![FILL; t.len()];
    for s in samples {
        if let Some(o) = out.get_mut(s.row) {
            let f = feature(t, w, v, t[s.row], s.direction, s.ratio_rad_per_m);
            // a simulation that leaves the window (it cannot: the rows are the log's) or fails
            // there scores far outside any floor rather than poisoning the sums with NaN
            *o = if f.is_finite() { f } else { s.value - 1e3 };
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::linearised_mode::tests::vehicle;
    use crate::table::Signal;

    const DT: f64 = 0.02;

    fn times(n: usize) -> Vec<f64> {
        (0..n).map(|k| k as f64 * DT).collect()
    }

    /// A triangular dip of `depth` rad/s, `half` s wide on each side, centred on `tc`.
    fn dip(t: f64, tc: f64, half: f64, depth: f64) -> f64 {
        depth * (1.0 - ((t - tc) / half).abs()).max(0.0)
    }

    /// The train-only simulation keeps every window within
    /// [`crate::diagnose::problem::REVERSAL_READ_S`] of a train reversal: that reach covers
    /// the rows the feature reads (its reference and peak windows, the peak's smoothing).
    #[test]
    fn the_train_windows_reach_covers_what_the_feature_reads() {
        let before = -REF_WINDOW_S.0.min(PEAK_WINDOW_S.0 - SMOOTHING_HALFWIDTH_S);
        let after = REF_WINDOW_S.1.max(PEAK_WINDOW_S.1 + SMOOTHING_HALFWIDTH_S);
        let reach = crate::diagnose::problem::REVERSAL_READ_S;
        assert!(
            reach >= before && reach >= after,
            "{reach} {before} {after}"
        );
    }

    #[test]
    fn the_feature_ignores_the_vehicles_acceleration_and_measures_the_dip() {
        let t = times(250);
        let g = 7.0;
        // accelerating at 0.5 m/s² with the engine locked to the wheels: u = 0 throughout
        let v: Vec<f64> = t.iter().map(|&x| 10.0 + 0.5 * x).collect();
        let locked: Vec<f64> = v.iter().map(|x| g * x).collect();
        let t0 = 2.0;
        assert!(feature(&t, &locked, &v, t0, -1.0, g).abs() < 1e-9);
        assert!(feature(&t, &locked, &v, t0, 1.0, g).abs() < 1e-9);
        // a 5 rad/s dip 0.16 s after the reversal (on a sample), ±0.2 s wide: the ±40 ms
        // average of the five samples at its apex keeps (0.8 + 0.9 + 1 + 0.9 + 0.8)/5 = 0.88
        // of its depth
        let w: Vec<f64> = t
            .iter()
            .zip(&locked)
            .map(|(&x, l)| l - dip(x, t0 + 0.16, 0.2, 5.0))
            .collect();
        let f = feature(&t, &w, &v, t0, -1.0, g);
        assert!((f + 5.0 * 0.88).abs() < 1e-9, "{f}");
        // a tip-in's feature is the greatest rise: none here
        assert!(feature(&t, &w, &v, t0, 1.0, g).abs() < 1e-9);
        // a dip after the window does not count
        let late: Vec<f64> = t
            .iter()
            .zip(&locked)
            .map(|(&x, l)| l - dip(x, t0 + 0.8, 0.2, 5.0))
            .collect();
        assert!(feature(&t, &late, &v, t0, -1.0, g).abs() < 1e-9);
    }

    /// A 30 s drive in 10th gear at 15 m/s, the clutch closed, 1000 N·m of drive torque
    /// stepping to −250 N·m at 15 s (a tip-out), with the engine locked to the wheels.
    fn tip_out_log() -> (DriveLog, Vec<f64>, Vec<f64>, f64) {
        let (p, ratios) = vehicle();
        let n = 1500;
        let t = times(n);
        let g = ratios[9] * p.final_drive_ratio / p.wheel_radius_m;
        let v = vec![15.0; n];
        let w: Vec<f64> = v.iter().map(|x| g * x).collect();
        let m: Vec<f64> = t
            .iter()
            .map(|&x| if x < 15.0 { 1000.0 } else { -250.0 })
            .collect();
        let sig = |name: &str, unit: &str, values: Vec<f64>| Signal {
            name: name.into(),
            unit: unit.into(),
            values,
        };
        let log = DriveLog {
            timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
            signals: vec![
                sig("vehicle_speed", "m/s", v.clone()),
                sig("engine_speed", "rad/s", w.clone()),
                sig("engine_torque", "N.m", m),
                sig("gear", "1", vec![10.0; n]),
                sig("clutch_position", "1", vec![0.0; n]),
            ],
            ..DriveLog::default()
        };
        (log, v, w, g)
    }

    #[test]
    fn a_tip_out_is_one_sample_unless_a_window_starts_on_it() {
        let (p, ratios) = vehicle();
        let (log, v, w, g) = tip_out_log();
        let s = measure(&log, &v, &w, &[0.0], &p, &ratios, 1.0);
        assert_eq!(s.len(), 1, "{s:?}");
        let t_rev = log.seconds_from_start()[s[0].row];
        assert!((14.9..15.2).contains(&t_rev), "{t_rev}");
        assert_eq!((s[0].gear, s[0].direction), (10, -1.0));
        assert!((s[0].ratio_rad_per_m - g).abs() < 1e-12);
        assert!(
            s[0].value.abs() < 1e-9,
            "locked engine: no dip, {}",
            s[0].value
        );
        // noiseless signals: the weight is the floor's alone
        assert!((s[0].weight - 1.0 / FLOOR_RAD_S.powi(2)).abs() < 1e-9);
        // a window that starts within 0.6 s before, or on, the reversal: no sample
        for start in [14.6, 15.0, 15.3] {
            assert!(measure(&log, &v, &w, &[0.0, start], &p, &ratios, 1.0).is_empty());
        }
        // one that starts earlier does not matter
        assert_eq!(
            measure(&log, &v, &w, &[0.0, 14.0], &p, &ratios, 1.0).len(),
            1
        );
        // below the model's minimum speed: none
        assert!(measure(&log, &v, &w, &[0.0], &p, &ratios, 20.0).is_empty());
    }

    #[test]
    fn a_dropout_of_the_vehicle_speed_at_the_reversal_drops_it() {
        let (p, ratios) = vehicle();
        let (mut log, v, w, _) = tip_out_log();
        let t = log.seconds_from_start();
        let vs = log
            .signals
            .iter_mut()
            .find(|s| s.name == "vehicle_speed")
            .unwrap();
        for (k, x) in vs.values.iter_mut().enumerate() {
            if (14.8..15.1).contains(&t[k]) {
                *x = f64::NAN;
            }
        }
        assert!(measure(&log, &v, &w, &[0.0], &p, &ratios, 1.0).is_empty());
    }

    #[test]
    fn the_simulated_channel_holds_the_feature_on_the_sample_rows_only() {
        let (p, ratios) = vehicle();
        let (log, v, w, _) = tip_out_log();
        let s = measure(&log, &v, &w, &[0.0], &p, &ratios, 1.0);
        let t = log.seconds_from_start();
        // the simulation dips 3 rad/s right after the tip-out
        let w_sim: Vec<f64> = t
            .iter()
            .zip(&w)
            .map(|(&x, y)| y - dip(x, t[s[0].row] + 0.16, 0.2, 3.0))
            .collect();
        let y = simulate(&s, &t, &w_sim, &v);
        let r = s[0].row;
        assert!((y[r] + 3.0 * 0.88).abs() < 1e-9, "{}", y[r]);
        assert!(y.iter().enumerate().all(|(k, x)| k == r || *x == 0.0));
    }
}
