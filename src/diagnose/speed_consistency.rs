//! The speed channels against each other: the wheel-based vehicle speed against the engine
//! speed through the engaged gear, with no simulation between them (analytical redundancy).
//!
//! With the clutch closed and a gear held, the engine turns with the driven wheels:
//! `ω_e = G v (1 + κ)`, `G = i_t i_f / r_w`, `κ` the driven tyres' slip. The drive's slip fit
//! ([`super::tyre_slip::estimate`]: `ω_e / (G v) − 1 = a + b F_x`) gives every such row the
//! speed the engine implies,
//!
//! ```text
//! v̂ = ω_e / (G (1 + a + b F_x)),        e = v − v̂   (m/s)
//! ```
//!
//! and `e` stays within the channels' noise, the shuffle's ringing and the slip's transients.
//! A speed channel that freezes, drifts or scales on part of a drive, a clutch that slips with
//! the pedal released, a wheel that spins and a braking force at the wheels the log does not
//! report (the tyres slip under it) all move `e` away from the rest of the drive for as long
//! as they last. [`speed_consistency`] averages `e` over [`ConsistencyConfig::window_s`]
//! windows of usable rows (clutch closed, a gear held and no engine-torque step of more than
//! [`TORQUE_STEP_NM`] within [`STEP_WINDOW_S`] for [`ConsistencyConfig::guard_s`] on either
//! side, at least [`ConsistencyConfig::min_speed_mps`]), takes each window's departure
//! from the median window, and flags the drive when the largest departure exceeds
//! [`ConsistencyConfig::threshold_mps`]. A rolling radius off the file's is taken up by the
//! slip fit's intercept `a` and moves no window.
//!
//! The threshold is calibrated, not derived: the largest departure over the no-effect drives
//! of the twelve calibration seeds of the truth plant (docs/diagnosis/method.md, rule 6),
//! which no proof figure uses. The p-value a flagged stretch carries is nominal: the departure
//! over the robust spread of the window means, two-sided, Bonferroni over the windows; the
//! window means are not independent, so it orders stretches but does not decide.

use std::ops::Range;

use serde::Serialize;

use super::locate::Mismatch;
use super::rows::{away_from_steps, STEP_WINDOW_S, TORQUE_STEP_NM};
use super::tyre_slip::{traction, SlipEstimate, MIN_SPEED_MPS};
use crate::model::driveline::DrivelineParams;
use crate::signal::stats::normal_sf;
use crate::table::DriveLog;

/// Settings of the speed-consistency test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ConsistencyConfig {
    /// Averaging window, s. 1 s: ten samples of a 10 Hz wheel-speed channel, several shuffle
    /// cycles in the high gears; a frozen channel departs by a tenth of a metre per second
    /// within a few seconds of ordinary acceleration.
    pub window_s: f64,
    /// Rows this close to a shift, an open or slipping clutch, a torque step or a slow row are
    /// not used, s. 2 s: the shuffle after an engagement or a tip-in has decayed to the noise
    /// by then (decay rates of 1–6 1/s, docs/models/driveline.md).
    pub guard_s: f64,
    /// Lowest vehicle speed of a usable row, m/s (the slip fit's own bound).
    pub min_speed_mps: f64,
    /// Clutch position at or below which the clutch counts as closed, fraction of travel.
    pub clutch_closed_max: f64,
    /// Largest departure of a window mean from the median window on a healthy truck, m/s
    /// (calibrated: module documentation).
    pub threshold_mps: f64,
    /// Fewest usable windows for a verdict.
    pub min_windows: usize,
}

impl Default for ConsistencyConfig {
    /// 1 s windows, 2 s guards, 3 m/s, 2 % clutch travel, 0.06 m/s, 20 windows.
    fn default() -> Self {
        Self {
            window_s: 1.0,
            guard_s: 2.0,
            min_speed_mps: MIN_SPEED_MPS,
            clutch_closed_max: 0.02,
            threshold_mps: 0.06,
            min_windows: 20,
        }
    }
}

/// The test's result on one drive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpeedConsistency {
    /// Usable windows.
    pub windows: usize,
    /// Median window mean of `v − v̂`, m/s.
    pub centre_mps: f64,
    /// Robust spread of the window means (1.4826 × their median absolute deviation), m/s.
    pub spread_mps: f64,
    /// Largest departure of a window mean from the centre, signed (positive: the wheel-based
    /// speed reads faster than the engine implies), m/s.
    pub departure_mps: f64,
    /// Rows of the stretch: the window of the largest departure and its neighbours beyond the
    /// threshold.
    pub rows: Range<usize>,
    /// Windows in the stretch.
    pub stretch_windows: usize,
    /// Gears held in the stretch.
    pub gears: Vec<usize>,
    /// Nominal p-value of the largest departure (module documentation).
    pub p_value: f64,
    /// Threshold used, m/s.
    pub threshold_mps: f64,
    /// Averaging window used, s.
    pub window_s: f64,
    /// The departure exceeds the threshold.
    pub flagged: bool,
}

/// Runs the test on `log` (module documentation), whose rows are at `t_s` (s from the first),
/// with the driveline `p`, gear `ratios` and the drive's slip fit `slip`. `None` without the engine speed, vehicle speed, gear or clutch
/// column, or with fewer than [`ConsistencyConfig::min_windows`] usable windows.
pub fn speed_consistency(
    log: &DriveLog,
    t_s: &[f64],
    p: &DrivelineParams,
    ratios: &[f64],
    slip: &SlipEstimate,
    cfg: &ConsistencyConfig,
) -> Option<SpeedConsistency> {
    let (w, v, gear, clutch) = (
        log.signal("engine_speed")?,
        log.signal("vehicle_speed")?,
        log.signal("gear")?,
        log.signal("clutch_position")?,
    );
    let n = log.len();
    if n < 3 || t_s.len() != n {
        return None;
    }
    let mut steps: Vec<f64> = t_s.windows(2).map(|d| d[1] - d[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    if dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let guard = (cfg.guard_s / dt).round() as usize;
    let win = ((cfg.window_s / dt).round() as usize).max(2);
    let nan = vec![f64::NAN; n];
    let torque = log.signal("engine_torque").unwrap_or(&nan);
    // a tip-in or tip-out winds the shafts up and moves the tyres' slip: the shuffle it
    // excites is a transient, not an inconsistency (the rows of the step, guarded below)
    let steady = away_from_steps(log, "engine_torque", TORQUE_STEP_NM, STEP_WINDOW_S, 0.0);
    // e = v − v̂ on the rows where the engine follows the wheels, NaN elsewhere
    let e: Vec<f64> = (0..n)
        .map(|i| {
            let g = gear[i].round();
            let held = i > 0 && gear[i - 1].round() == g;
            if !(held
                && steady[i]
                && g >= 1.0
                && clutch[i] <= cfg.clutch_closed_max
                && v[i] >= cfg.min_speed_mps
                && w[i].is_finite())
            {
                return f64::NAN;
            }
            let Some(i_t) = ratios.get(g as usize - 1) else {
                return f64::NAN;
            };
            let big_g = i_t * p.final_drive_ratio / p.wheel_radius_m;
            // the slip needs the row's torque when the drive has any
            let f_x = match traction(torque, gear, i, p, ratios) {
                Some((f, _)) => f,
                None if slip.slip_per_newton == 0.0 => 0.0,
                None => return f64::NAN,
            };
            let kappa = slip.intercept + slip.slip_per_newton * f_x;
            v[i] - w[i] / (big_g * (1.0 + kappa))
        })
        .collect();
    // a row counts when no unusable row lies within the guard on either side
    let mut bad = vec![0usize; n + 1];
    for i in 0..n {
        bad[i + 1] = bad[i] + usize::from(!e[i].is_finite());
    }
    let usable = |i: usize| bad[(i + guard + 1).min(n)] == bad[i.saturating_sub(guard)];
    let step = (win / 2).max(1);
    let windows: Vec<(usize, f64)> = (0..n.saturating_sub(win))
        .step_by(step)
        .filter(|&s| (s..s + win).all(usable))
        .map(|s| (s, e[s..s + win].iter().sum::<f64>() / win as f64))
        .collect();
    if windows.len() < cfg.min_windows.max(1) {
        return None;
    }
    let median = |mut x: Vec<f64>| {
        x.sort_by(f64::total_cmp);
        x[x.len() / 2]
    };
    let centre = median(windows.iter().map(|w| w.1).collect());
    let spread = 1.4826 * median(windows.iter().map(|w| (w.1 - centre).abs()).collect());
    let (k, &(_, m)) = windows
        .iter()
        .enumerate()
        .max_by(|a, b| (a.1 .1 - centre).abs().total_cmp(&(b.1 .1 - centre).abs()))?;
    let departure = m - centre;
    let flagged = departure.abs() > cfg.threshold_mps;
    // the stretch: neighbouring windows (overlapping or adjacent) beyond the threshold
    let beyond = |j: usize| (windows[j].1 - centre).abs() > cfg.threshold_mps;
    let touches = |a: usize, b: usize| windows[b].0 <= windows[a].0 + win;
    let (mut lo, mut hi) = (k, k);
    if flagged {
        while lo > 0 && touches(lo - 1, lo) && beyond(lo - 1) {
            lo -= 1;
        }
        while hi + 1 < windows.len() && touches(hi, hi + 1) && beyond(hi + 1) {
            hi += 1;
        }
    }
    let rows = windows[lo].0..windows[hi].0 + win;
    let mut gears: Vec<usize> = rows.clone().map(|i| gear[i].round() as usize).collect();
    gears.sort_unstable();
    gears.dedup();
    let p_value = if spread > 0.0 {
        (2.0 * windows.len() as f64 * normal_sf(departure.abs() / spread)).min(1.0)
    } else {
        f64::NAN
    };
    Some(SpeedConsistency {
        windows: windows.len(),
        centre_mps: centre,
        spread_mps: spread,
        departure_mps: departure,
        rows,
        stretch_windows: hi - lo + 1,
        gears,
        p_value,
        threshold_mps: cfg.threshold_mps,
        window_s: cfg.window_s,
        flagged,
    })
}

impl SpeedConsistency {
    /// The flagged stretch as a located mismatch of the vehicle speed (`None` unless flagged).
    /// `t_s` and `distance_m` are the rows' times and travelled distances.
    pub fn mismatch(&self, t_s: &[f64], distance_m: &[f64]) -> Option<Mismatch> {
        if !self.flagged {
            return None;
        }
        let (a, b) = (self.rows.start, self.rows.end - 1);
        let at = |x: &[f64], i: usize| x.get(i).copied().unwrap_or(f64::NAN);
        let gears: Vec<String> = self.gears.iter().map(|g| g.to_string()).collect();
        Some(Mismatch {
            signal: "vehicle_speed".into(),
            start_s: at(t_s, a),
            end_s: at(t_s, b),
            start_m: at(distance_m, a),
            end_m: at(distance_m, b),
            // window means resolve periods down to two windows
            band_hz: [0.0, 0.5 / self.window_s],
            condition: format!(
                "clutch closed in gear {}: the wheel-based speed reads {:+.2} m/s against the \
                 engine speed through the gear (a faulty speed channel, a slipping clutch, a \
                 spinning wheel or an unreported brake)",
                gears.join(", "),
                self.departure_mps
            ),
            rms_residual: self.departure_mps.abs(),
            significance: self.p_value,
            floor_rms: self.spread_mps,
            windows: self.stretch_windows,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::tyre_slip::tests::truck;

    /// 300 s at 50 Hz in gear 12, the speed swinging between 18 and 24 m/s, the engine at
    /// `G v` plus a deterministic ±0.3 rad/s ripple; the speed channel frozen from 150 s to
    /// 160 s when `stuck`.
    fn drive(p: &DrivelineParams, ratios: &[f64], stuck: bool) -> (DriveLog, Vec<f64>) {
        let n = 15_000;
        let big_g = ratios[11] * p.final_drive_ratio / p.wheel_radius_m;
        let (mut w, mut v, mut gear, mut clutch, mut t) = (vec![], vec![], vec![], vec![], vec![]);
        let mut held = f64::NAN;
        for i in 0..n {
            let ts = i as f64 * 0.02;
            let speed = 21.0 + 3.0 * (ts / 40.0).sin();
            let ripple = 0.3 * ((i * 7919) % 13) as f64 / 6.0 - 0.3;
            w.push(big_g * speed + ripple);
            let frozen = stuck && (150.0..160.0).contains(&ts);
            if frozen && held.is_nan() {
                held = speed;
            }
            v.push(if frozen { held } else { speed });
            gear.push(12.0);
            clutch.push(0.0);
            t.push(ts);
        }
        (
            DriveLog::from_columns(
                20_000_000,
                vec![
                    ("engine_speed", "rad/s", w),
                    ("vehicle_speed", "m/s", v),
                    ("gear", "1", gear),
                    ("clutch_position", "1", clutch),
                ],
            ),
            t,
        )
    }

    #[test]
    fn a_frozen_speed_channel_is_located_and_a_consistent_one_is_not() {
        let (p, ratios) = truck();
        let cfg = ConsistencyConfig::default();
        let (log, t) = drive(&p, &ratios, false);
        let c = speed_consistency(&log, &t, &p, &ratios, &SlipEstimate::RIGID, &cfg).unwrap();
        assert!(!c.flagged, "{c:?}");
        // the ripple averages to a few mm/s over a window
        assert!(c.departure_mps.abs() < 0.01, "{c:?}");
        assert!(c.mismatch(&t, &t).is_none());
        let (log, t) = drive(&p, &ratios, true);
        let c = speed_consistency(&log, &t, &p, &ratios, &SlipEstimate::RIGID, &cfg).unwrap();
        // frozen at 150 s while the speed falls at 3/40·cos(3.75) ≈ −0.062 m/s²: 0.6 m/s by
        // 160 s, the channel reading high
        assert!(c.flagged, "{c:?}");
        assert!(c.departure_mps > 0.4 && c.departure_mps < 0.65, "{c:?}");
        let (s, e) = (t[c.rows.start], t[c.rows.end - 1]);
        assert!(
            (149.0..158.0).contains(&s) && e > 155.0 && e <= 161.0,
            "{s} … {e}"
        );
        let m = c.mismatch(&t, &t).unwrap();
        assert_eq!(m.signal, "vehicle_speed");
        assert!(m.condition.contains("gear 12"), "{}", m.condition);
    }

    #[test]
    fn a_short_drive_or_one_without_the_channels_gives_no_result() {
        let (p, ratios) = truck();
        let cfg = ConsistencyConfig::default();
        let log =
            DriveLog::from_columns(20_000_000, vec![("vehicle_speed", "m/s", vec![20.0; 100])]);
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.02).collect();
        assert!(speed_consistency(&log, &t, &p, &ratios, &SlipEstimate::RIGID, &cfg).is_none());
        let (log, t) = drive(&p, &ratios, false);
        let short = DriveLog::from_columns(
            20_000_000,
            log.signals
                .iter()
                .map(|s| (s.name.as_str(), s.unit.as_str(), s.values[..500].to_vec()))
                .collect(),
        );
        assert!(
            speed_consistency(&short, &t[..500], &p, &ratios, &SlipEstimate::RIGID, &cfg).is_none()
        );
    }
}
