//! The clutch engagements of a drive whose shuffle the modal comparison analyses
//! (docs/diagnosis/method.md, steps 2 and 3 for the driveline effects; step 1 of
//! [`super::modal`]): every clutch closing after which the clutch stays closed, the gear stays
//! engaged and unchanged, and the engine speed has no gap over the analysis window
//! ([`ModalConfig::window_start_s`]…[`ModalConfig::window_end_s`] after the closing).
//!
//! Times in s from the log's first row, vehicle speed in m/s, engine torque in N·m.

use super::modal_config::ModalConfig;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;
use serde::Serialize;
use std::ops::Range;

/// One clutch closing with a usable analysis window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Engagement {
    /// Time of the first closed clutch sample, s from the first row.
    pub t_close_s: f64,
    /// Gear held through the window (1-based).
    pub gear: usize,
    /// Rows of the analysis window.
    pub rows: Range<usize>,
    /// Measured vehicle speed at the window start, m/s (NaN without a speed column).
    pub speed_mps: f64,
    /// Mean recorded engine torque over the window, N·m (0 without a torque column; the
    /// finite samples only).
    pub engine_torque_nm: f64,
}

/// The clutch closings of `log` whose analysis window is usable (see [`ModalConfig`] for the
/// thresholds): a row whose clutch position is at or below
/// [`ModalConfig::clutch_closed_max`] after a row above it; from that row to the window end the
/// clutch stays closed (no sample above the threshold, no gap — an unknown clutch is not a
/// closed one), the gear is the same engaged gear on every row (no gap either), and the engine
/// speed has a real sample on every row of the window (a filled dropout carries no ringing);
/// and the measured vehicle speed at the window start is at least
/// [`ModalConfig::min_speed_mps`]. A log without clutch, gear or engine speed has none.
pub fn engagements(log: &DriveLog, cfg: &ModalConfig) -> Vec<Engagement> {
    let (Some(clutch), Some(gear), Some(w)) = (
        log.signal("clutch_position"),
        log.signal("gear"),
        log.signal("engine_speed"),
    ) else {
        return Vec::new();
    };
    let t = log.seconds_from_start();
    let speed = log
        .signal("vehicle_speed")
        .and_then(|v| fill_gaps(v, Interpolation::Linear));
    let torque = log.signal("engine_torque");
    let mean_torque = |r: Range<usize>| {
        let Some(m) = torque else { return 0.0 };
        let (sum, k) = m[r]
            .iter()
            .filter(|x| x.is_finite())
            .fold((0.0, 0usize), |(s, k), x| (s + x, k + 1));
        if k > 0 {
            sum / k as f64
        } else {
            0.0
        }
    };
    let n = t.len();
    let mut out = Vec::new();
    let mut prev_open = false;
    for i in 0..n {
        let c = clutch[i];
        if !c.is_finite() {
            prev_open = false;
            continue;
        }
        let closed = c <= cfg.clutch_closed_max;
        if closed && prev_open {
            let a = t.partition_point(|&x| x < t[i] + cfg.window_start_s);
            let b = t.partition_point(|&x| x <= t[i] + cfg.window_end_s);
            // the window must end inside the log
            let complete = b < n;
            let g0 = gear[i];
            let held = complete
                && g0.is_finite()
                && g0.round() >= 1.0
                && (i..b).all(|k| {
                    clutch[k].is_finite() && clutch[k] <= cfg.clutch_closed_max && gear[k] == g0
                });
            let measured = held && (a..b).all(|k| w[k].is_finite());
            let moving = speed
                .as_ref()
                .is_none_or(|v| a < n && v[a] >= cfg.min_speed_mps);
            if measured && moving && b > a {
                out.push(Engagement {
                    t_close_s: t[i],
                    gear: g0.round() as usize,
                    rows: a..b,
                    speed_mps: speed.as_ref().map_or(f64::NAN, |v| v[a]),
                    engine_torque_nm: mean_torque(a..b),
                });
            }
        }
        prev_open = !closed;
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn log_with(clutch: Vec<f64>, gear: Vec<f64>, w: Vec<f64>) -> DriveLog {
        let n = clutch.len();
        DriveLog::from_columns(
            20_000_000,
            vec![
                ("clutch_position", "1", clutch),
                ("gear", "1", gear),
                ("engine_speed", "rad/s", w),
                ("vehicle_speed", "m/s", vec![10.0; n]),
            ],
        )
    }

    /// 10 s at 50 Hz: clutch open until 3 s, then closed; gear 7; ringing engine speed.
    pub(crate) fn engagement_log() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = 500;
        let clutch: Vec<f64> = (0..n).map(|k| if k < 150 { 1.0 } else { 0.0 }).collect();
        let gear = vec![7.0; n];
        let w: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * 0.02;
                let tau = (t - 3.0).max(0.0);
                140.0 + (-5.0 * tau).exp() * (2.0 * std::f64::consts::PI * 4.3 * tau).sin()
            })
            .collect();
        (clutch, gear, w)
    }

    #[test]
    fn a_clutch_opening_inside_the_window_skips_the_engagement() {
        let (mut c, g, w) = engagement_log();
        // opens again 1.5 s after the closing, inside the 2.5 s window
        for x in &mut c[225..260] {
            *x = 0.4;
        }
        let log = log_with(c, g, w);
        let e = engagements(&log, &ModalConfig::default());
        // the re-closing at 5.2 s has its own window (5.4–7.7 s) and counts; the first does not
        assert_eq!(e.len(), 1, "{e:?}");
        assert!((e[0].t_close_s - 5.2).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn a_gear_change_or_an_engine_speed_gap_skips_the_engagement() {
        let (c, mut g, w) = engagement_log();
        for x in &mut g[200..] {
            *x = 8.0;
        }
        assert!(
            engagements(&log_with(c.clone(), g, w.clone()), &ModalConfig::default()).is_empty()
        );
        let (_, g, mut w2) = engagement_log();
        w2[200] = f64::NAN;
        assert!(engagements(&log_with(c, g, w2), &ModalConfig::default()).is_empty());
    }
}
