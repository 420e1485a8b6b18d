//! Row masks of the diagnosis: which rows of a recording each compared signal counts on. The
//! models describe a truck in gear with the clutch engaged and known inputs; rows around clutch
//! transitions, gear changes, input gaps and input steps (brake pulses, torque steps) are left
//! out, each for the reasons stated at its constant (docs/diagnosis/method.md, step 1).

use crate::table::DriveLog;

/// A recorded service-brake force below this is a released brake, N: 5× the 0.2 kN noise of a
/// J1939 brake-force channel, which a brake at rest never reaches. The models read it as 0
/// ([`super::extended::corrected_log`]): a force channel clamped at 0 turns its noise into a
/// positive mean (σ/√(2π) ≈ 80 N at σ = 0.2 kN), a phantom drag that, on synthetic drives,
/// makes the fit call aerodynamic drag 4–20 % lower than the truth on drives whose hidden
/// effect is elsewhere.
///
/// Only outside braking episodes: within ±[`BRAKE_EPISODE_HALFWIDTH_S`] of a sample at or above
/// the threshold every value counts — a driver holding 0.4–1 kN on a descent is braking
/// (measured: zeroing such a stretch left −0.1 m/s of speed residual on a clean drive).
pub const BRAKE_RELEASED_BELOW_N: f64 = 1000.0;
/// Half-width of a braking episode around a sample at or above [`BRAKE_RELEASED_BELOW_N`], s.
pub const BRAKE_EPISODE_HALFWIDTH_S: f64 = 3.0;

/// Half-width of the rows left out around a clutch transition for the longitudinal signals, s.
pub const CLUTCH_TRANSITION_HALFWIDTH_S: f64 = 0.5;
/// Half-width of the rows left out around a gear change or clutch transition for the bellow
/// pressures, s.
pub const SHIFT_HALFWIDTH_AXLE_S: f64 = 1.0;

/// Marks the rows of `t` within ±`half_s` of `center` as not counting.
fn clear_around(ok: &mut [bool], t: &[f64], center: f64, half_s: f64) {
    let lo = t.partition_point(|&x| x < center - half_s);
    let hi = t.partition_point(|&x| x <= center + half_s);
    for o in &mut ok[lo..hi] {
        *o = false;
    }
}

/// Rows of `log` that are not within `halfwidth_s` of an event: a real sample of `column`
/// that differs from the previous real one by more than `tolerance`, or (for
/// `clutch_position`) lies strictly inside (`tolerance`, 1 − `tolerance`). A log without the
/// column has no events.
fn away_from_events(log: &DriveLog, column: &str, tolerance: f64, halfwidth_s: f64) -> Vec<bool> {
    let n = log.len();
    let Some(v) = log.signal(column) else {
        return vec![true; n];
    };
    let t: Vec<f64> = log.seconds_from_start();
    let clutch = column == "clutch_position";
    let mut events = Vec::new();
    let mut prev: Option<f64> = None;
    for (i, &x) in v.iter().enumerate() {
        if !x.is_finite() {
            continue;
        }
        let moving = prev.is_some_and(|p| (x - p).abs() > tolerance);
        let between = clutch && x > tolerance && x < 1.0 - tolerance;
        if moving || between {
            events.push(t[i]);
        }
        prev = Some(x);
    }
    let mut ok = vec![true; n];
    for e in events {
        clear_around(&mut ok, &t, e, halfwidth_s);
    }
    ok
}

/// Input columns of the models: a gap in any of them makes the rows it covers unknown.
pub const MODEL_INPUTS: [&str; 7] = [
    "engine_torque",
    "gear",
    "clutch_position",
    "brake_force",
    "retarder_torque",
    "road_slope",
    "vehicle_speed",
];

/// Rows of `log` with every input of [`MODEL_INPUTS`] the log has recorded (not a gap the
/// ingest left missing) for the last `after_s`. Why: the noise floor perturbs the recorded
/// samples, but inside a CAN dropout the input is the gap fill, whose error is not noise —
/// measured on a clean synthetic drive, a 0.9 s EEC1 dropout during a torque ramp left 6.8 kPa
/// of pressure residual (6.6× the floor). The `after_s` tail covers the models' response.
fn away_from_input_gaps(log: &DriveLog, after_s: f64) -> Vec<bool> {
    let n = log.len();
    let t: Vec<f64> = log.seconds_from_start();
    let mut ok = vec![true; n];
    for c in MODEL_INPUTS {
        let Some(v) = log.signal(c) else { continue };
        let mut last_gap: Option<f64> = None;
        for i in 0..n {
            if !v[i].is_finite() {
                last_gap = Some(t[i]);
                ok[i] = false;
            } else if last_gap.is_some_and(|g| t[i] - g <= after_s) {
                ok[i] = false;
            }
        }
    }
    ok
}

/// Rows where the longitudinal model's clutch mode is known from the recording: not within
/// ±[`CLUTCH_TRANSITION_HALFWIDTH_S`] of a clutch transition (a `clutch_position` sample
/// between 2 % and 98 % or 2 % away from the previous one). Why: the clutch actuator is
/// reported at 10 Hz while the engine speed comes at 50 Hz, so the moment the clutch
/// closes — where the model switches from slipping to locked and the engine speed jumps onto
/// the gearbox's — is known only to one 0.1 s sample; measured on clean synthetic drives,
/// that sample alone gives engine-speed residual spikes of ~10 rad/s (12× the noise floor)
/// at every shift, and the torque ramp after it a further 8 rad/s spike 0.4 s later. Rows with the clutch fully open or fully closed still count, so a clutch
/// that slips when closed (`clutch_slip`) stays visible.
///
/// Also left out: ±[`CLUTCH_TRANSITION_HALFWIDTH_S`] around a service-brake step
/// ([`BRAKE_STEP_N`]), and input gaps with [`INPUT_GAP_TAIL_S`] after them.
pub fn longitudinal_rows(log: &DriveLog) -> Vec<bool> {
    let (clutch, known) = clutch_and_known_rows(log);
    (0..clutch.len()).map(|i| clutch[i] && known[i]).collect()
}

/// Rows away from a clutch transition, and rows away from a service-brake step and an input
/// gap, each ±[`CLUTCH_TRANSITION_HALFWIDTH_S`] ([`longitudinal_rows`], [`actuation_rows`]).
fn clutch_and_known_rows(log: &DriveLog) -> (Vec<bool>, Vec<bool>) {
    let clutch = away_from_events(log, "clutch_position", 0.02, CLUTCH_TRANSITION_HALFWIDTH_S);
    let brake = away_from_steps(
        log,
        "brake_force",
        BRAKE_STEP_N,
        STEP_WINDOW_S,
        CLUTCH_TRANSITION_HALFWIDTH_S,
    );
    let gaps = away_from_input_gaps(log, INPUT_GAP_TAIL_S);
    let known = brake.iter().zip(&gaps).map(|(b, g)| *b && *g).collect();
    (clutch, known)
}

/// Name of the engine speed compared on [`actuation_channel_rows`] (the noise floor's copies
/// and the explain step's clutch-actuation view; not a located signal).
pub const ACTUATION_CHANNEL: &str = "engine_speed_actuated";

/// Rows where the clutch is actuated — the rows [`longitudinal_rows`] leaves out within
/// ±[`CLUTCH_TRANSITION_HALFWIDTH_S`] of a clutch transition — with the engine coupled (a gear
/// engaged, the clutch not fully open, as [`engine_speed_rows`]), away from service-brake steps and
/// input gaps as the longitudinal rows are. `clutch_slip`'s fingerprint is here
/// (docs/diagnosis/catalogue.md: "engine speed mismatch while clutch actuated"): a worn clutch lets
/// the engine run up while it closes. The speed condition (the model's minimum) is the caller's.
pub fn actuation_rows(log: &DriveLog) -> Vec<bool> {
    let (clutch, known) = clutch_and_known_rows(log);
    let coupled = coupled_rows(log);
    (0..clutch.len())
        .map(|i| !clutch[i] && known[i] && coupled[i])
        .collect()
}

/// The rows of the clutch-actuation channel: [`actuation_rows`] with a recorded vehicle speed
/// of at least `min_speed_mps` (the longitudinal model's minimum) and a recorded engine speed
/// — the rows the noise floor compares it on ([`super::noise::ModelSet::compared`]) and the
/// explain step's view scores ([`super::problem::Problem::with_actuation`]).
pub fn actuation_channel_rows(log: &DriveLog, min_speed_mps: f64) -> Vec<bool> {
    let act = actuation_rows(log);
    let (Some(v), Some(w)) = (log.signal("vehicle_speed"), log.signal("engine_speed")) else {
        return vec![false; log.len()];
    };
    (0..log.len())
        .map(|i| act[i] && v[i].is_finite() && v[i] >= min_speed_mps && w[i].is_finite())
        .collect()
}

/// Rows with a gear engaged and the clutch not fully open (below 98 %), gaps held/filled.
fn coupled_rows(log: &DriveLog) -> Vec<bool> {
    use crate::schema::Interpolation;
    use crate::signal::distance::fill_gaps;
    let clutch = log
        .signal("clutch_position")
        .and_then(|c| fill_gaps(c, Interpolation::Linear));
    let gear = log
        .signal("gear")
        .and_then(|g| fill_gaps(g, Interpolation::Hold));
    (0..log.len())
        .map(|i| {
            let open = clutch.as_ref().is_some_and(|c| c[i] >= 0.98);
            let neutral = gear.as_ref().is_some_and(|g| g[i].round() < 1.0);
            !open && !neutral
        })
        .collect()
}

/// Rows after an input gap that still do not count, s ([`longitudinal_rows`], [`axle_rows`]).
pub const INPUT_GAP_TAIL_S: f64 = 1.0;

/// Rows where the axle model's torque input is known from the recording: not within
/// ±[`SHIFT_HALFWIDTH_AXLE_S`] of a gear change or a clutch transition. Why: within a shift
/// the drive torque at the wheels comes from the inverse dynamics of an engine synchronising
/// behind a clutch that is reported at 10 Hz; measured on clean synthetic drives, the
/// pressures' residual there reaches 15–30 kPa (15–30× the floor) for a few tenths of a
/// second at each shift, an artefact of the input, not of the axle physics.
///
/// Also left out: ±[`SHIFT_HALFWIDTH_AXLE_S`] around an engine-torque step of more than
/// [`TORQUE_STEP_NM`] within [`STEP_WINDOW_S`] (a tip-in or tip-out). The axle model's
/// drive torque is the quasi-static inverse dynamics of the recorded engine torque, which
/// neglects the shafts' torsion (the shuffle a step excites for about a second); measured on
/// clean synthetic drives, a tip-out from 1 300 N·m to engine braking leaves 6–9 kPa of
/// residual (6–9× the floor) for ~1 s. And input gaps with [`INPUT_GAP_TAIL_S`] after them.
///
/// Last, a stretch of counting rows shorter than [`MIN_AXLE_RUN_S`] between two left-out ones
/// is left out too: it lies within the half-width of an event on each side, so in the ringing
/// of both.
pub fn axle_rows(log: &DriveLog) -> Vec<bool> {
    let a = away_from_events(log, "clutch_position", 0.02, SHIFT_HALFWIDTH_AXLE_S);
    let b = away_from_events(log, "gear", 0.5, SHIFT_HALFWIDTH_AXLE_S);
    let mut ok: Vec<bool> = a.iter().zip(&b).map(|(x, y)| *x && *y).collect();
    let c = away_from_steps(
        log,
        "engine_torque",
        TORQUE_STEP_NM,
        STEP_WINDOW_S,
        SHIFT_HALFWIDTH_AXLE_S,
    );
    let d = away_from_steps(
        log,
        "brake_force",
        BRAKE_STEP_N,
        STEP_WINDOW_S,
        SHIFT_HALFWIDTH_AXLE_S,
    );
    let e = away_from_input_gaps(log, INPUT_GAP_TAIL_S);
    for (i, o) in ok.iter_mut().enumerate() {
        *o = *o && c[i] && d[i] && e[i];
    }
    drop_short_runs(&mut ok, &log.seconds_from_start(), MIN_AXLE_RUN_S);
    ok
}

/// Shortest stretch of counting rows [`axle_rows`] keeps, s (the event half-width
/// [`SHIFT_HALFWIDTH_AXLE_S`]). Why: a launch from standstill locks the clutch in 1st gear
/// at full launch torque and the truck pitches hardest there (the bellow pressures swing by
/// 100–150 kPa within half a second), and the 1→2 upshift follows within about 2 s; the
/// rows between the lock's and the upshift's left-out half-widths form an island of 0.3–0.6
/// s in which the pitch still rings. The axle model reproduces the swing from the recorded
/// inputs only to 5–12 kPa there, and no better fed every input at its truth (about 12 kPa RMS
/// over the second after a launch's lock; 0.5–1.5 kPa before the launch; the noise floor's
/// copies, whose clutch and brake samples are jittered in phase, put 1.5 kPa of null there).
/// On the proof's clean drives (`research/studies/axle_residual.rs` with
/// `AXLE_RESIDUAL_BIN_S=0.1`) such an island after a launch is what makes a no-effect drive
/// `unexplained` through a bellow pressure, at 3–6 km and at 10–20 km alike; without the
/// island those drives are `no_significant_mismatch` (unless a speed window remains), and so
/// is a lash drive invisible at its truth. The cost: an air-spring drive whose progressive
/// bellow shows mostly in those swings (its largest travels are there) can lose its name or
/// its halving (docs/validation/proof.md).
pub const MIN_AXLE_RUN_S: f64 = SHIFT_HALFWIDTH_AXLE_S;

/// Clears every run of `true` in `ok` that starts after the first row and ends before the
/// last one (a stretch between two left-out rows) and lasts less than `min_s`: from its first
/// row's time to the time of the left-out row after it. Runs touching either end of the log
/// are kept (nothing is known to ring there).
fn drop_short_runs(ok: &mut [bool], t: &[f64], min_s: f64) {
    let n = ok.len().min(t.len());
    for (a, b) in crate::signal::stats::runs(&ok[..n]) {
        if a > 0 && b < n && t[b] - t[a] < min_s {
            ok[a..b].iter_mut().for_each(|o| *o = false);
        }
    }
}

/// Rows of `log` not within `halfwidth_s` of a step of `column` (gaps filled linearly): a row
/// whose value differs by more than `step` from the value `window_s` earlier. A log without
/// the column has no steps.
pub(crate) fn away_from_steps(
    log: &DriveLog,
    column: &str,
    step: f64,
    window_s: f64,
    halfwidth_s: f64,
) -> Vec<bool> {
    use crate::schema::Interpolation;
    use crate::signal::distance::fill_gaps;
    let n = log.len();
    let Some(m) = log
        .signal(column)
        .and_then(|m| fill_gaps(m, Interpolation::Linear))
    else {
        return vec![true; n];
    };
    let t: Vec<f64> = log.seconds_from_start();
    let mut ok = vec![true; n];
    // the first row within the window before row i; on time stamps that never decrease it
    // only moves forward, so one walk finds it for every row (`partition_point` otherwise)
    let sorted = t.windows(2).all(|w| w[0] <= w[1]);
    let mut j = 0;
    for i in 0..n {
        let from = t[i] - window_s;
        if sorted {
            while j < n && t[j] < from {
                j += 1;
            }
        } else {
            j = t.partition_point(|&x| x < from);
        }
        if (m[i] - m[j]).abs() > step {
            clear_around(&mut ok, &t, t[i], halfwidth_s);
        }
    }
    ok
}

/// A service-brake force change larger than this within [`STEP_WINDOW_S`] is a step
/// for [`axle_rows`] and [`longitudinal_rows`], N: the 10 Hz brake channel samples a brake
/// pulse once or twice, so its shape between samples — which the pitch and the speed follow —
/// is unknown (measured on clean synthetic drives: a single 6.7 kN sample left 12.7 kPa of
/// pressure residual).
pub const BRAKE_STEP_N: f64 = 2000.0;

/// An engine-torque change larger than this within [`STEP_WINDOW_S`] is a step for
/// [`axle_rows`], N·m (about a quarter of a heavy-truck engine's reference torque).
pub const TORQUE_STEP_NM: f64 = 600.0;
/// Window of the step tests ([`TORQUE_STEP_NM`], [`BRAKE_STEP_N`]), s.
pub const STEP_WINDOW_S: f64 = 0.3;

/// Rows where the engine speed is a driveline output: the longitudinal rows
/// ([`longitudinal_rows`]) with a gear engaged and the clutch not fully open
/// (`clutch_position` below 98 %). With the clutch open or in neutral the engine is decoupled
/// and its speed is set by the idle governor, which the driveline model does not contain
/// (measured on clean synthetic drives: a steady 5–7 rad/s offset through every coasting
/// phase). The vehicle speed still counts there.
pub fn engine_speed_rows(log: &DriveLog) -> Vec<bool> {
    let coupled = coupled_rows(log);
    longitudinal_rows(log)
        .iter()
        .zip(&coupled)
        .map(|(a, b)| *a && *b)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` rows at 50 Hz of a clutch (10 Hz, held on the grid as the ingest holds it) open
    /// until 2 s, closing linearly over the next `closing_s`, closed after.
    fn closing_clutch(n: usize, closing_s: f64) -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = (k - k % 5) as f64 * 0.02;
                (1.0 - (t - 2.0) / closing_s).clamp(0.0, 1.0)
            })
            .collect()
    }

    /// 10 s at 50 Hz, gear 7: the clutch (10 Hz, held on the grid as the ingest holds it)
    /// open until 2 s, closing over 2.0–2.6 s, closed after; neutral from 8 s.
    fn shift_log() -> DriveLog {
        let n = 500;
        let clutch = closing_clutch(n, 0.6);
        let gear: Vec<f64> = (0..n).map(|k| if k < 400 { 7.0 } else { 0.0 }).collect();
        DriveLog::from_columns(
            20_000_000,
            vec![
                ("clutch_position", "1", clutch),
                ("gear", "1", gear),
                ("engine_speed", "rad/s", vec![150.0; n]),
                ("vehicle_speed", "m/s", vec![10.0; n]),
            ],
        )
    }

    #[test]
    fn short_runs_between_left_out_rows_are_dropped_and_the_ends_kept() {
        // 50 Hz: rows 0.00 … 1.98 s
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.02).collect();
        let mut ok = vec![true; 100];
        // left out: 0.20–0.38 s and 0.90–1.08 s; runs: 0–0.18 (at the start), 0.40–0.88
        // (0.5 s to the next left-out row), 1.10–1.98 (to the end)
        for k in (10..20).chain(45..55) {
            ok[k] = false;
        }
        drop_short_runs(&mut ok, &t, 0.5);
        assert!(ok[..10].iter().all(|&o| o), "a run at the start is kept");
        assert!(
            ok[20..45].iter().all(|&o| o),
            "0.40 → 0.90 s lasts 0.5 s: kept"
        );
        assert!(ok[55..].iter().all(|&o| o), "a run at the end is kept");
        let mut shorter = ok.clone();
        shorter[44] = false; // 0.40 → 0.88 s: 0.48 s
        drop_short_runs(&mut shorter, &t, 0.5);
        assert!(
            shorter[20..45].iter().all(|&o| !o),
            "a 0.48 s island is dropped"
        );
        assert_eq!(shorter[..10], ok[..10]);
        assert_eq!(shorter[55..], ok[55..]);
    }

    #[test]
    fn axle_rows_leave_out_an_island_between_a_launch_and_the_upshift() {
        // 10 s at 50 Hz: the clutch (10 Hz) closes over the samples 2.1 … 2.4 s, gear 1 → 2 at
        // 4.8 s: the rows within 1 s of either are left out (1.1 … 3.4 s and 3.8 … 5.8 s),
        // which leaves the island 3.42 … 3.78 s, and that goes too
        let n = 500;
        let clutch = closing_clutch(n, 0.4);
        let gear: Vec<f64> = (0..n).map(|k| if k < 240 { 1.0 } else { 2.0 }).collect();
        let log = DriveLog::from_columns(
            20_000_000,
            vec![("clutch_position", "1", clutch), ("gear", "1", gear)],
        );
        let t = log.seconds_from_start();
        let h = SHIFT_HALFWIDTH_AXLE_S;
        let events = away_from_events(&log, "clutch_position", 0.02, h);
        let shifts = away_from_events(&log, "gear", 0.5, h);
        let rows = axle_rows(&log);
        let (lo, hi) = (2.1 - h, 4.8 + h);
        let mut island = 0;
        for (i, &r) in rows.iter().enumerate() {
            if (t[i] - lo).abs() < 0.03 || (t[i] - hi).abs() < 0.03 {
                continue; // the half-widths' edge rows
            }
            assert_eq!(r, t[i] < lo || t[i] > hi, "row {i} at {} s", t[i]);
            if t[i] > 3.42 && t[i] < 3.78 {
                assert!(
                    events[i] && shifts[i],
                    "row {i}: counted but for the island rule"
                );
                island += 1;
            }
        }
        assert!(island >= 15, "{island}");
    }

    #[test]
    fn actuation_rows_are_the_coupled_rows_the_longitudinal_rows_leave_out_at_the_clutch() {
        let log = shift_log();
        let t = log.seconds_from_start();
        let act = actuation_rows(&log);
        let steady = longitudinal_rows(&log);
        let engine = engine_speed_rows(&log);
        let h = CLUTCH_TRANSITION_HALFWIDTH_S;
        // boundaries: the transition samples 2.1 … 2.6 s ± h; the clutch leaves fully open at
        // 2.1 s; neutral from 8 s
        let edges = [2.1 - h, 2.6 + h, 2.1, 8.0];
        let mut counted = 0;
        for i in 0..log.len() {
            assert!(!(act[i] && engine[i]), "row {i}: the speeds compare it too");
            if edges.iter().any(|e| (t[i] - e).abs() < 0.015) {
                continue;
            }
            let near = t[i] > 2.1 - h && t[i] < 2.6 + h;
            assert_eq!(steady[i], !near, "row {i} at {} s", t[i]);
            let coupled = t[i] > 2.1 && t[i] < 8.0;
            assert_eq!(act[i], near && coupled, "row {i} at {} s", t[i]);
            counted += usize::from(act[i]);
        }
        // 2.1 … 3.1 s but for the rows next to the edges
        assert!(counted >= 45, "{counted}");
    }
}
