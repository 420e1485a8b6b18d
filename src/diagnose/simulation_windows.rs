//! Where the longitudinal model ([`super::longitudinal_model`], docs/diagnosis/method.md, step 3)
//! starts its windows and where it integrates at the fine step: windows re-initialised at the
//! measured state every `window_s` and after every stretch whose inputs the recording does not
//! determine, kept off engine-torque steps ([`window_starts`]); the spans about the torque
//! reversals integrated at [`FINE_STEP_S`] ([`fine_spans`]); a window cut into pieces of one
//! step each (`stepped_pieces`).
//!
//! Times in s from the log's first row.

use crate::table::DriveLog;

/// Step of the longitudinal model about the torque reversals, and everywhere with a drive-shaft
/// lash, s ([`LongitudinalModel::simulate`]).
///
/// [`LongitudinalModel::simulate`]: super::longitudinal_model::LongitudinalModel::simulate
pub const FINE_STEP_S: f64 = 1e-3;

/// The spans integrated at [`FINE_STEP_S`] whatever the parameters: each torque reversal the
/// reversal channel samples ([`super::reversal_channel::reversal_times`]) with its
/// [`super::reversal_channel::EVENT_SPAN_S`], overlaps merged. Why: the channel compares the
/// engine against the wheels there, a few rpm decide it, and the step moves the feature by
/// up to 3.5 rpm between 5 ms and 1 ms (a drive of `fleetdyn prove --seed 1` with 14
/// reversals; 0.003 rpm with these spans, pinned in the test suite). A lash candidate
/// integrates at the fine step, so with the nominal model coarser there the step alone would be
/// part of what a lash explains; and at 5 ms a clutch a percent weaker reproduces a reversal of
/// an out-of-catalogue drive (`fleetdyn prove --seed 2`: `clutch_slip` at 3422 N·m named), which
/// with these spans no clutch does. A drive has a few reversals, so the spans cost little:
/// 2.4 % of the seven drawn-driving seeds' median diagnosis time per drive-hour (−1 … +6 % per
/// seed).
pub fn fine_spans(log: &DriveLog) -> Vec<(f64, f64)> {
    use super::reversal_channel::{reversal_times, EVENT_SPAN_S};
    let mut out: Vec<(f64, f64)> = Vec::new();
    for t in reversal_times(log) {
        let (a, b) = (t + EVENT_SPAN_S.0, t + EVENT_SPAN_S.1);
        match out.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}

/// The pieces of `[ta, tb]` with their steps: `dt` outside `fine`, [`FINE_STEP_S`] inside
/// (`fine` sorted and disjoint); every piece boundary on `ta`'s grid of `dt`, so each piece
/// is a whole number of its steps.
pub(super) fn stepped_pieces(
    ta: f64,
    tb: f64,
    dt: f64,
    fine: &[(f64, f64)],
) -> Vec<(f64, f64, bool)> {
    let snap = |x: f64| (ta + ((x - ta) / dt).round() * dt).clamp(ta, tb);
    let mut out = Vec::new();
    let mut at = ta;
    for &(a, b) in fine {
        let (a, b) = (snap(a), snap(b));
        if b <= at || a >= tb {
            continue;
        }
        if a > at {
            out.push((at, a, false));
        }
        out.push((a.max(at), b, true));
        at = b;
    }
    if tb - at >= 0.5 * dt {
        out.push((at, tb, false));
    }
    out
}

/// How far a regular window start keeps from an engine-torque step, s ([`window_starts`]): the
/// 0.3 s of the step test plus the [`crate::diagnose::reversal_channel`] reference window's
/// 0.5 s and a margin.
pub const STEP_CLEAR_S: f64 = 1.0;

/// Start times of the longitudinal model's windows on `log`, s from the first row: every
/// `window_s`, and wherever the recording determines the model's mode again after a stretch it
/// did not ([`super::rows::longitudinal_rows`] switching back on: a clutch transition, a
/// brake step or an input gap has ended) unless a regular start follows within 2 s. Why: the
/// rows inside such a stretch do not count, but an error the model makes there (measured on
/// clean synthetic drives: 0.1 m/s after one upshift on a climb, from the clutch closing
/// between two 10 Hz samples) would otherwise be carried as a speed offset to the window's end.
///
/// A regular start that falls on an engine-torque step (more than
/// [`super::rows::TORQUE_STEP_NM`] within [`super::rows::STEP_WINDOW_S`], detected from 0.3 s
/// before the start to [`STEP_CLEAR_S`] after it) with the clutch closed (≤ 2 %) and a gear held
/// from the new start to [`STEP_CLEAR_S`] after the old one (not a shift's torque recovery) moves
/// to [`STEP_CLEAR_S`] before the step's first detection, if the window before keeps at least 2 s.
/// Why: a window started on a step begins with the new torque's shaft twists, so it never crosses a
/// lash or rings as the drive did (at a proof lash drive's tip-out: +80 rpm of engine-speed
/// residual at the nominal and at the true lash alike, docs/diagnosis/events.md). The moved
/// window's first rows then lie in the block before; they are simulated from the measured state
/// like every window's, so no fitted quantity crosses the split.
pub fn window_starts(log: &DriveLog, window_s: f64) -> Vec<f64> {
    let n = log.len();
    if n == 0 {
        return vec![0.0];
    }
    let t: Vec<f64> = log.seconds_from_start();
    let end = t[n - 1];
    let regular = (end / window_s).ceil().max(1.0) as usize;
    let torque = log
        .signal("engine_torque")
        .and_then(|m| crate::signal::distance::fill_gaps(m, crate::schema::Interpolation::Linear));
    // the first time in [a, b] whose torque differs by more than a step from STEP_WINDOW_S
    // earlier (compare::away_from_steps' test)
    let step_at = |a: f64, b: f64| -> Option<f64> {
        let m = torque.as_ref()?;
        let lo = t.partition_point(|&x| x < a);
        let hi = t.partition_point(|&x| x <= b);
        (lo..hi)
            .find(|&i| {
                let j = t.partition_point(|&x| x < t[i] - super::rows::STEP_WINDOW_S);
                (m[i] - m[j]).abs() > super::rows::TORQUE_STEP_NM
            })
            .map(|i| t[i])
    };
    let ok = super::rows::longitudinal_rows(log);
    let held = |c: &str| {
        log.signal(c)
            .and_then(|g| crate::signal::distance::fill_gaps(g, crate::schema::Interpolation::Hold))
    };
    let (gear, clutch) = (held("gear"), held("clutch_position"));
    // the clutch closed and the gear held over [a, b]: not a shift's torque recovery
    let steady = |a: f64, b: f64| {
        let lo = t.partition_point(|&x| x < a);
        let hi = t.partition_point(|&x| x <= b);
        hi > lo
            && gear
                .as_ref()
                .is_none_or(|g| (lo..hi).all(|i| g[i].round() == g[lo].round() && g[i] >= 0.5))
            && clutch
                .as_ref()
                .is_none_or(|c| (lo..hi).all(|i| c[i] <= 0.02))
    };
    let mut starts: Vec<f64> = (0..regular)
        .map(|k| {
            let s = k as f64 * window_s;
            match step_at(s - 0.3, s + STEP_CLEAR_S) {
                Some(ts)
                    if k > 0
                        && ts - STEP_CLEAR_S > (k - 1) as f64 * window_s + 2.0
                        && steady(ts - STEP_CLEAR_S, s + STEP_CLEAR_S) =>
                {
                    ts - STEP_CLEAR_S
                }
                _ => s,
            }
        })
        .collect();
    for i in 1..n {
        if ok[i] && !ok[i - 1] {
            let next_regular = ((t[i] / window_s).floor() + 1.0) * window_s;
            if next_regular - t[i] > 2.0 && end - t[i] > 2.0 {
                starts.push(t[i]);
            }
        }
    }
    starts.sort_by(f64::total_cmp);
    starts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    starts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_is_cut_at_the_fine_spans_on_its_own_step_grid() {
        // a 20 s window from 3.0 s at 5 ms; one span inside, one across its end, one before it
        let fine = [(1.0, 2.0), (7.2023, 8.4023), (22.5, 24.0)];
        let p = stepped_pieces(3.0, 23.0, 0.005, &fine);
        let kinds: Vec<bool> = p.iter().map(|x| x.2).collect();
        assert_eq!(kinds, [false, true, false, true], "{p:?}");
        // contiguous, from the window's start to its end
        assert_eq!(p[0].0, 3.0);
        assert_eq!(p[3].1, 23.0);
        for w in p.windows(2) {
            assert_eq!(w[0].1, w[1].0, "{p:?}");
        }
        // boundaries on the window's 5 ms grid: the span's 7.2023 s snaps to 7.200 s
        for &(a, _, _) in &p {
            let k = (a - 3.0) / 0.005;
            assert!((k - k.round()).abs() < 1e-6, "{a}");
        }
        assert!(
            (p[1].0 - 7.2).abs() < 1e-9 && (p[1].1 - 8.4).abs() < 1e-9,
            "{p:?}"
        );
        assert!((p[3].0 - 22.5).abs() < 1e-9, "{p:?}");
        // no span: one coarse piece
        assert_eq!(stepped_pieces(3.0, 23.0, 0.005, &[]), [(3.0, 23.0, false)]);
    }
}
