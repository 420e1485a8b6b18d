//! The fast path (exponential integrator, dt = 10 ms) against the accurate integrator.

use crate::common::*;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::fast::FastDriveline;
use fleetdyn::sim::hybrid::{
    steady_state_locked, ClutchMode, EngineInput, HybridDriveline, Scenario, N_STATES,
};
use fleetdyn::sim::inputs::Piecewise;

/// Largest and root-mean-square absolute difference of two equally long traces.
fn max_and_rms_diff(a: &[f64], b: &[f64]) -> (f64, f64) {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| (x - y).abs()).collect();
    let max = d.iter().copied().fold(0.0, f64::max);
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    (max, rms)
}

fn pw(p: &[(f64, f64, f64, f64)]) -> Piecewise {
    Piecewise::new(p.to_vec()).unwrap()
}

fn compare(name: &str, sc: &Scenario, y0: [f64; N_STATES], mode0: ClutchMode, tol_v: f64) {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let acc = HybridDriveline::new(p, r, sc)
        .simulate(y0, mode0, 1e-9, 100.0)
        .unwrap();
    let fast = FastDriveline::new(p, r, 0.01)
        .simulate(sc, y0, mode0)
        .unwrap();
    assert_eq!(acc.t.len(), fast.t.len());
    let va = acc.speed(p.wheel_radius_m);
    let vf = fast.speed(p.wheel_radius_m);
    let dv = va
        .iter()
        .zip(&vf)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let dwe = acc
        .y
        .iter()
        .zip(&fast.y)
        .map(|(a, b)| (a[0] - b[0]).abs())
        .fold(0.0, f64::max);
    let ev = |t: &fleetdyn::sim::hybrid::Trajectory| {
        t.events
            .iter()
            .map(|e| format!("{}@{:.3}", e.kind, e.t))
            .collect::<Vec<_>>()
    };
    println!("{name}: fast vs accurate max |Δv| {dv:.2e} m/s, max |Δω_e| {dwe:.2e} rad/s; events {:?} vs {:?}", ev(&fast), ev(&acc));
    assert_eq!(
        fast.events.iter().map(|e| &e.kind).collect::<Vec<_>>(),
        acc.events.iter().map(|e| &e.kind).collect::<Vec<_>>(),
        "{name}"
    );
    for (a, b) in fast.events.iter().zip(&acc.events) {
        assert!(
            (a.t - b.t).abs() <= 0.0101,
            "{name}: {} at {} vs {}",
            a.kind,
            a.t,
            b.t
        );
    }
    assert!(dv < tol_v, "{name}: {dv}");
}

#[test]
fn fast_path_agrees_with_the_accurate_integrator() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let rpm = std::f64::consts::PI / 30.0;
    // 1: slope step in 1st gear under PI control (shuffle)
    let w = 1220.0 * rpm;
    let v0 = w * p.wheel_radius_m / (r[0] * p.final_drive_ratio);
    let (y0, _) = steady_state_locked(p, r, 1, v0, 0.0, true);
    let sc = Scenario {
        t_end_s: 20.0,
        gear: Piecewise::constant(20.0, 1.0),
        clutch_x: Piecewise::constant(20.0, 0.0),
        slope: pw(&[(0.0, 2.0, 0.0, 0.0), (2.0, 20.0, 0.01, 0.01)]),
        brake_n: Piecewise::constant(20.0, 0.0),
        engine: EngineInput::SpeedReference(Piecewise::constant(20.0, w)),
        smoothing: true,
        standstill_events: false,
    };
    // Locked clutch, step at a sample boundary: the linear part is exact and the held road force
    // is the only approximation. Measured 4.6e-8 m/s; bound 1e-6 m/s.
    compare(
        "slope step, 1st gear, PI",
        &sc,
        y0,
        ClutchMode::Locked,
        1e-6,
    );
    // 2: launch: clutch closes from 1 s to 3 s while the PI holds 900 rpm
    let mut y0 = [0.0; N_STATES];
    y0[0] = 900.0 * rpm;
    let sc = Scenario {
        t_end_s: 10.0,
        gear: Piecewise::constant(10.0, 1.0),
        clutch_x: pw(&[
            (0.0, 1.0, 1.0, 1.0),
            (1.0, 3.0, 1.0, 0.0),
            (3.0, 10.0, 0.0, 0.0),
        ]),
        slope: Piecewise::constant(10.0, 0.0),
        brake_n: Piecewise::constant(10.0, 0.0),
        engine: EngineInput::SpeedReference(Piecewise::constant(10.0, 900.0 * rpm)),
        smoothing: true,
        standstill_events: false,
    };
    // The lock is found at the end of the 10 ms step in which the slip speed crosses zero (6 ms
    // late here). Measured 4.4e-4 m/s; bound 1e-3 m/s.
    compare(
        "launch with clutch engagement",
        &sc,
        y0,
        ClutchMode::Slipping(1.0),
        1e-3,
    );
}

#[test]
fn fast_and_accurate_agree_on_a_mixed_gear_drive() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    // 12 minutes: every gear up and down once (the benchmark runs the same scenario for an hour)
    let (sc, y0, mode0) = fleetdyn::sim::scenarios::mixed_gear_drive(p, r, 720.0);
    let t0 = std::time::Instant::now();
    let acc = HybridDriveline::new(p, r, &sc)
        .simulate(y0, mode0, 1e-8, 100.0)
        .unwrap();
    let t_acc = t0.elapsed();
    let t0 = std::time::Instant::now();
    let fast = FastDriveline::new(p, r, 0.01)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let t_fast = t0.elapsed();
    let va = acc.speed(p.wheel_radius_m);
    let vf = fast.speed(p.wheel_radius_m);
    let (dv, rms) = max_and_rms_diff(&va, &vf);
    println!(
        "mixed-gear 720 s: {} events; fast vs accurate |Δv| max {dv:.2e} rms {rms:.2e} m/s; wall accurate {t_acc:?} ({} steps), fast {t_fast:?} (timings informative only, see benches)",
        acc.events.len(),
        acc.stats.accepted
    );
    assert!(
        va.iter().chain(&vf).all(|v| v.is_finite()),
        "no NaN in the outputs"
    );
    // Same shifts; the fast path may add a slip reversal while the clutch is open (the disc rings
    // on its damper around the engine speed with zero capacity, and the 10 ms steps see a sign
    // change the located events do not) — harmless, as the transmitted torque is zero then.
    let kinds = |t: &fleetdyn::sim::hybrid::Trajectory, k: &str| {
        t.events.iter().filter(|e| e.kind == k).count()
    };
    for k in ["lock", "unlock"] {
        assert_eq!(kinds(&fast, k), kinds(&acc, k), "{k}");
    }
    // Measured on this 720 s drive: max 0.32 m/s, rms 0.017 m/s. The differences come from mode
    // switches and PI-clamp transitions resolved to the 10 ms step instead of located; the PI has
    // no anti-windup (docs/models/driveline.md), and during the saturated stretches of the
    // 12th-gear climb and the engine-braked downshifts its wound-up integrator amplifies them
    // transiently before the two runs re-converge once the controller leaves saturation.
    // Bounds: 0.5 m/s max, 0.03 m/s rms, and agreement again at the end of the drive.
    assert!(dv < 0.5 && rms < 0.03, "max {dv} rms {rms}");
    let end = (va.last().unwrap() - vf.last().unwrap()).abs();
    println!("end of drive: |Δv| = {end:.2e} m/s");
    assert!(end < 1e-3, "{end}");
}

#[test]
fn fast_path_stops_and_breaks_away_like_the_accurate_one() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    // the reference's start-stop case: 1.5 m/s in 1st gear, torque off and 40 kN brake at 1 s,
    // brake ramps out 3-4 s, torque ramps 0 -> 100 N*m over 8-10 s; no smoothing, stop and
    // breakaway as events
    let (y0, me) = steady_state_locked(p, r, 1, 1.5, 0.0, false);
    let sc = Scenario {
        t_end_s: 15.0,
        gear: Piecewise::constant(15.0, 1.0),
        clutch_x: Piecewise::constant(15.0, 0.0),
        slope: Piecewise::constant(15.0, 0.0),
        brake_n: pw(&[
            (0.0, 1.0, 0.0, 0.0),
            (1.0, 3.0, 40000.0, 40000.0),
            (3.0, 4.0, 40000.0, 0.0),
            (4.0, 15.0, 0.0, 0.0),
        ]),
        engine: EngineInput::Torque(pw(&[
            (0.0, 1.0, me, me),
            (1.0, 8.0, 0.0, 0.0),
            (8.0, 10.0, 0.0, 100.0),
            (10.0, 15.0, 100.0, 100.0),
        ])),
        smoothing: false,
        standstill_events: true,
    };
    // The stop is found at the end of its 10 ms step and the hold is a projection. Measured:
    // max |Δv| 1.1e-5 m/s, events 7 and 6 ms late. Bounds: 1e-4 m/s, one step (0.011 s).
    let veh_acc = HybridDriveline::new(p, r, &sc)
        .simulate(y0, ClutchMode::Locked, 1e-9, 100.0)
        .unwrap();
    let fast = FastDriveline::new(p, r, 0.01)
        .simulate(&sc, y0, ClutchMode::Locked)
        .unwrap();
    let (va, vf) = (
        veh_acc.speed(p.wheel_radius_m),
        fast.speed(p.wheel_radius_m),
    );
    let dv = va
        .iter()
        .zip(&vf)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let ev = |t: &fleetdyn::sim::hybrid::Trajectory| {
        t.events
            .iter()
            .map(|e| (e.kind.clone(), e.t))
            .collect::<Vec<_>>()
    };
    println!(
        "start-stop: fast vs accurate max |Δv| {dv:.2e} m/s; events {:?} vs {:?}",
        ev(&fast),
        ev(&veh_acc)
    );
    let kinds = |t: &fleetdyn::sim::hybrid::Trajectory| {
        t.events.iter().map(|e| e.kind.clone()).collect::<Vec<_>>()
    };
    assert_eq!(kinds(&fast), kinds(&veh_acc));
    assert_eq!(kinds(&veh_acc), ["stop", "breakaway"]);
    for (a, b) in fast.events.iter().zip(&veh_acc.events) {
        assert!((a.t - b.t).abs() < 0.011, "{} {} vs {}", a.kind, a.t, b.t);
    }
    assert!(dv < 1e-4, "{dv}");
    // held means held: no creeping while stopped
    let stop = fast.events[0].t;
    let go = fast.events[1].t;
    assert!(fast
        .t
        .iter()
        .zip(&vf)
        .filter(|(t, _)| **t > stop + 0.01 && **t < go)
        .all(|(_, v)| *v == 0.0));
}

#[test]
fn fast_and_accurate_on_the_same_drive_with_100_hz_sampled_inputs() {
    // The benchmark's form of the inputs: every signal sampled at 100 Hz as a recording gives it.
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let (scripted, y0, mode0) = fleetdyn::sim::scenarios::mixed_gear_drive(p, r, 720.0);
    let sc = fleetdyn::sim::scenarios::sampled_inputs(&scripted, 100.0);
    let acc = HybridDriveline::new(p, r, &sc)
        .simulate(y0, mode0, 1e-8, 100.0)
        .unwrap();
    let fast = FastDriveline::new(p, r, 0.01)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let (va, vf) = (acc.speed(p.wheel_radius_m), fast.speed(p.wheel_radius_m));
    let (dv, rms) = max_and_rms_diff(&va, &vf);
    println!("mixed-gear 720 s, 100 Hz sampled inputs: fast vs accurate |Δv| max {dv:.2e} rms {rms:.2e} m/s");
    assert!(va.iter().chain(&vf).all(|v| v.is_finite()));
    // Measured: max 1.50 m/s, rms 0.20 m/s — worse than with the scripted inputs. The fast path
    // finds each clutch lock up to one 10 ms step late: the 1-2 upshift's lock is 9.1 ms late
    // here (6.4 ms with the scripted inputs) and the engine speed after it differs by 0.8 rad/s;
    // the PI without anti-windup carries such differences through the later saturated shifts.
    // Regression bounds: max 2 m/s, rms 0.3 m/s; locating the lock inside the step is a known
    // limit of the fast path.
    assert!(dv < 2.0 && rms < 0.3, "max {dv} rms {rms}");
}

#[test]
fn drive_shaft_lash_is_a_dead_zone_that_converges_with_the_step() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let (sc, y0, mode0) = fleetdyn::sim::scenarios::mixed_gear_drive(p, r, 120.0);
    // no play: the nominal path, bit for bit
    let plain = FastDriveline::new(p, r, 0.01)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let zero = FastDriveline::new(p, r, 0.01)
        .with_lash(0.0)
        .simulate(&sc, y0, mode0)
        .unwrap();
    assert!(plain.y == zero.y && plain.torques == zero.torques);
    // 0.04 rad of play at steps 1 ms and 0.1 ms (every 10th sample kept)
    let b = 0.04;
    let coarse = FastDriveline::new(p, r, 1e-3)
        .with_lash(b)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let fine = FastDriveline::new(p, r, 1e-4)
        .with_lash(b)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let fine_y: Vec<_> = fine.y.iter().step_by(10).collect();
    assert_eq!(fine_y.len(), coarse.y.len());
    // dead zone: no shaft torque inside the play, and the play is crossed during the drive
    let mut in_gap = 0;
    for (y, m) in coarse.y.iter().zip(&coarse.torques) {
        if y[6].abs() < 0.5 * b {
            assert_eq!(m[3], 0.0, "torque {} N·m in the gap at φ_d {}", m[3], y[6]);
            in_gap += 1;
        }
    }
    let v = |y: &[f64; N_STATES]| y[7] * p.wheel_radius_m;
    let (mut dv, mut dwe) = (0.0f64, 0.0f64);
    for (a, b) in coarse.y.iter().zip(&fine_y) {
        dv = dv.max((v(a) - v(b)).abs());
        dwe = dwe.max((a[0] - b[0]).abs());
    }
    let crossings = coarse
        .y
        .windows(2)
        .filter(|w| (w[0][6].abs() < 0.5 * b) != (w[1][6].abs() < 0.5 * b))
        .count();
    let plain_v: Vec<f64> = plain.speed(p.wheel_radius_m);
    let lash_v: Vec<f64> = coarse.y.iter().step_by(10).map(v).collect();
    let (effect, _) = max_and_rms_diff(&plain_v, &lash_v);
    println!(
        "lash {b} rad: {in_gap} samples in the gap, {crossings} gap entries/exits; 1 ms vs 0.1 ms max |Δv| {dv:.2e} m/s, |Δω_e| {dwe:.2e} rad/s; lash vs none max |Δv| {effect:.2e} m/s"
    );
    assert!(in_gap > 100 && crossings >= 4);
    // Impacts are found at step ends: the 1 ms run overshoots the contact by up to
    // |ω_d − ω_w|·1 ms and so differs from the 0.1 ms one; the difference must be a small part
    // of what the lash itself changes. Measured: 4.5e-4 m/s against 7.5e-2 m/s, 0.066 rad/s of
    // engine speed. Bounds: 2 % of the effect, 0.5 rad/s (5 rpm).
    assert!(dv < 0.02 * effect, "Δv {dv} vs lash effect {effect}");
    assert!(dwe < 0.5, "Δω_e {dwe} rad/s");
}

#[test]
fn lash_tip_out_is_the_same_in_the_generators_spans_and_in_one_run() {
    // The proof's truth (synth/drive.rs: one `simulate_span` per 0.1 s control step at
    // sample_dt/10 = 1 ms, the state carried over) and the diagnosis' model
    // (diagnose/extended.rs: one span per window at 1 ms when the lash is non-zero) are the same
    // integrator; this pins that splitting the run into spans does not disturb the lash's
    // contact state, on the transient where the lash shows: a tip-out from +800 to −250 N·m
    // at 10 m/s in 10th gear with 0.03 rad of play.
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let (b, t_step, t_end) = (0.03, 3.0, 4.0);
    let scenario = |t_end: f64, engine: Piecewise| Scenario {
        t_end_s: t_end,
        gear: Piecewise::constant(t_end, 10.0),
        clutch_x: Piecewise::constant(t_end, 0.0),
        slope: Piecewise::constant(t_end, 0.0),
        brake_n: Piecewise::constant(t_end, 0.0),
        engine: EngineInput::Torque(engine),
        smoothing: false,
        standstill_events: true,
    };
    let torque = |t: f64| if t < t_step { 800.0 } else { -250.0 };
    let (mut y0, _) = steady_state_locked(p, r, 10, 10.0, 0.0, false);
    y0[8] = 0.0;
    let mut y0_lash = y0;
    y0_lash[6] += 0.5 * b; // in contact on the drive side, as the diagnosis' windows start
    let step = pw(&[(0.0, t_step, 800.0, 800.0), (t_step, t_end, -250.0, -250.0)]);
    // engine speed every 10 ms
    let one_run = |dt: f64, lash: f64, y: [f64; N_STATES]| -> Vec<f64> {
        let tr = FastDriveline::new(p, r, dt)
            .with_lash(lash)
            .simulate_span(
                &scenario(t_end, step.clone()),
                0.0,
                t_end,
                y,
                ClutchMode::Locked,
            )
            .unwrap();
        let k = (0.01 / dt).round() as usize;
        tr.y.iter().step_by(k).map(|y| y[0]).collect()
    };
    let mut spans = Vec::new();
    let mut fast = FastDriveline::new(p, r, 1e-3).with_lash(b);
    let (mut y, mut mode) = (y0_lash, ClutchMode::Locked);
    for k in 0..40 {
        let (t, t1) = (k as f64 * 0.1, (k + 1) as f64 * 0.1);
        let sc = scenario(t1, Piecewise::constant(t1, torque(t + 1e-9)));
        let tr = fast.simulate_span(&sc, t, t1, y, mode).unwrap();
        spans.extend(tr.y.iter().step_by(10).take(10).map(|y| y[0]));
        (y, mode) = (tr.y[100], tr.mode[100]);
    }
    spans.push(y[0]);
    let single = one_run(1e-3, b, y0_lash);
    let reference = one_run(1e-5, b, y0_lash);
    let no_lash = one_run(1e-3, 0.0, y0);
    assert_eq!(spans.len(), single.len());
    let i_step = (t_step / 0.01).round() as usize;
    let after = |a: &[f64], c: &[f64]| max_and_rms_diff(&a[i_step..], &c[i_step..]).0;
    let dip = (i_step..no_lash.len())
        .map(|i| no_lash[i] - single[i])
        .fold(0.0f64, f64::max);
    let (d_spans, d_ref) = (after(&spans, &single), after(&single, &reference));
    println!(
        "tip-out, lash {b} rad: engine-speed dip against no lash {:.1} rpm; spans vs one run {d_spans:.2e} rad/s; 1 ms vs 10 µs {:.2} rpm",
        dip * 30.0 / std::f64::consts::PI,
        d_ref * 30.0 / std::f64::consts::PI
    );
    // Measured: dip 58 rpm (the proof's backlash drives: 37–53 rpm truth − nominal).
    assert!(dip > 20.0 * std::f64::consts::PI / 30.0, "dip {dip} rad/s");
    // Same arithmetic, only the span boundaries differ: equal to round-off (measured 0).
    assert!(d_spans < 1e-9, "spans vs one run {d_spans} rad/s");
    // The 1 ms step finds the impacts at step ends (module doc of sim::fast); measured 1.7 rpm
    // against the 10 µs run. Bound: 5 % of the dip, below the ~10 rpm the study leaves between
    // the recording and the model at the true lash (docs/diagnosis/events.md).
    assert!(
        d_ref < 0.05 * dip,
        "1 ms vs 10 µs {d_ref} rad/s, dip {dip} rad/s"
    );
}

#[test]
fn the_states_only_path_gives_the_trajectorys_states_bit_for_bit() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let (sc, y0, mode0) = fleetdyn::sim::scenarios::mixed_gear_drive(p, r, 120.0);
    for (lash, dt) in [(0.0, 0.005), (0.04, 1e-3)] {
        // the whole drive in two spans, the second from where the first ended
        let mid = 60.0;
        let mut full = FastDriveline::new(p, r, dt).with_lash(lash);
        let a = full.simulate_span(&sc, 0.0, mid, y0, mode0).unwrap();
        let (ya, ma) = (*a.y.last().unwrap(), *a.mode.last().unwrap());
        let b = full.simulate_span(&sc, mid, 120.0, ya, ma).unwrap();
        let mut states = FastDriveline::new(p, r, dt).with_lash(lash);
        let mut got: Vec<(f64, [f64; N_STATES])> = Vec::new();
        let end_a = states
            .simulate_span_states(&sc, (0.0, mid), y0, mode0, false, &mut |t, y| {
                got.push((t, *y))
            })
            .unwrap();
        assert!(
            end_a.y == ya && end_a.mode == ma,
            "lash {lash}: first span's end"
        );
        let end_b = states
            .simulate_span_states(&sc, (mid, 120.0), end_a.y, end_a.mode, true, &mut |t, y| {
                got.push((t, *y))
            })
            .unwrap();
        // the first span's last sample is the second's first: handed over once
        let want: Vec<(f64, [f64; N_STATES])> = a.t[..a.t.len() - 1]
            .iter()
            .zip(&a.y)
            .chain(b.t.iter().zip(&b.y))
            .map(|(&t, &y)| (t, y))
            .collect();
        assert_eq!(got.len(), want.len(), "lash {lash}");
        assert!(got == want, "lash {lash}: states differ");
        assert!(end_b.y == *b.y.last().unwrap() && end_b.mode == *b.mode.last().unwrap());
        // "locked throughout" is the trajectory's modes, every sample of the span
        let all_locked = |m: &[ClutchMode]| m.iter().all(|&m| m == ClutchMode::Locked);
        assert_eq!(end_a.locked_throughout, all_locked(&a.mode), "lash {lash}");
        assert_eq!(end_b.locked_throughout, all_locked(&b.mode), "lash {lash}");
        // the drive switches clutch mode or gear, so the mode logic is exercised
        assert!(!a.events.is_empty() || !b.events.is_empty());
    }
}

/// Samples of `tr` on the grid of `dt` from 0 (one per grid time, in order): `(k, state)`.
fn on_grid(tr: &fleetdyn::sim::hybrid::Trajectory, dt: f64) -> Vec<(usize, [f64; N_STATES])> {
    let mut out: Vec<(usize, [f64; N_STATES])> = Vec::new();
    for (t, y) in tr.t.iter().zip(&tr.y) {
        let k = (t / dt).round();
        if (t - k * dt).abs() < 1e-9 && out.last().is_none_or(|l| l.0 != k as usize) {
            out.push((k as usize, *y));
        }
    }
    out
}

#[test]
fn lash_substeps_cut_the_steps_near_the_gap_and_keep_the_whole_steps_elsewhere() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let (sc, y0, mode0) = fleetdyn::sim::scenarios::mixed_gear_drive(p, r, 120.0);
    let (b, dt, m) = (0.04, 5e-3, 5);
    // without a lash, or with one substep, the substeps change nothing, bit for bit
    let plain = FastDriveline::new(p, r, dt)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let plain_m = FastDriveline::new(p, r, dt)
        .with_gap_substeps(m)
        .simulate(&sc, y0, mode0)
        .unwrap();
    assert!(plain.t == plain_m.t && plain.y == plain_m.y && plain.torques == plain_m.torques);
    let whole = FastDriveline::new(p, r, dt)
        .with_lash(b)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let whole_1 = FastDriveline::new(p, r, dt)
        .with_lash(b)
        .with_gap_substeps(1)
        .simulate(&sc, y0, mode0)
        .unwrap();
    assert!(whole.y == whole_1.y && whole.events == whole_1.events);
    let sub = FastDriveline::new(p, r, dt)
        .with_lash(b)
        .with_gap_substeps(m)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let fine = FastDriveline::new(p, r, dt / m as f64)
        .with_lash(b)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let reference = FastDriveline::new(p, r, 1e-4)
        .with_lash(b)
        .simulate(&sc, y0, mode0)
        .unwrap();
    // every sample in the gap, and the one before it, is a substep apart from its neighbours:
    // the play is crossed at the fine step
    let h = dt / m as f64;
    let mut in_gap = 0;
    for i in 1..sub.t.len() - 1 {
        if sub.y[i][6].abs() < 0.5 * b {
            in_gap += 1;
            for j in [i - 1, i] {
                let gap = sub.t[j + 1] - sub.t[j];
                assert!(
                    (gap - h).abs() < 1e-9,
                    "step {gap} s at t {} in the gap",
                    sub.t[j]
                );
            }
        }
    }
    // how much of the drive ran in whole steps
    let n_whole = sub.t.windows(2).filter(|w| w[1] - w[0] > 2.0 * h).count();
    let n_steps = (120.0 / dt) as usize;
    // the samples on the 5 ms grid against the 0.1 ms reference, beside the whole 1 ms run's
    let (g_sub, g_fine, g_ref, g_plain) = (
        on_grid(&sub, dt),
        on_grid(&fine, dt),
        on_grid(&reference, dt),
        on_grid(&plain, dt),
    );
    assert!(g_sub.len() == n_steps + 1 && g_fine.len() == n_steps + 1);
    assert!(g_ref.len() == n_steps + 1 && g_plain.len() == n_steps + 1);
    let v = |y: &[f64; N_STATES]| y[7] * p.wheel_radius_m;
    let diff = |a: &[(usize, [f64; N_STATES])], c: &[(usize, [f64; N_STATES])]| {
        let (mut dv, mut dwe) = (0.0f64, 0.0f64);
        for ((_, x), (_, y)) in a.iter().zip(c) {
            dv = dv.max((v(x) - v(y)).abs());
            dwe = dwe.max((x[0] - y[0]).abs());
        }
        (dv, dwe)
    };
    let (dv_sub, dwe_sub) = diff(&g_sub, &g_ref);
    let (dv_fine, dwe_fine) = diff(&g_fine, &g_ref);
    let (effect, _) = diff(&g_plain, &g_ref);
    // the nominal model's own 5 ms step error, without a lash
    let plain_ref = FastDriveline::new(p, r, 1e-4)
        .simulate(&sc, y0, mode0)
        .unwrap();
    let (dv_nom, dwe_nom) = diff(&g_plain, &on_grid(&plain_ref, dt));
    println!(
        "lash {b} rad, {dt} s steps with {m} substeps near the gap: {n_whole} of {n_steps} steps whole, {in_gap} samples in the gap; against 0.1 ms max |Δv| {dv_sub:.2e} m/s, |Δω_e| {dwe_sub:.2e} rad/s (1 ms throughout: {dv_fine:.2e} m/s, {dwe_fine:.2e} rad/s; no lash at 5 ms against 0.1 ms: {dv_nom:.2e} m/s, {dwe_nom:.2e} rad/s); lash vs none {effect:.2e} m/s"
    );
    assert!(in_gap > 100, "{in_gap} samples in the gap");
    // most of the drive is away from the gap: the point of the substeps
    assert!(n_whole > n_steps / 2, "{n_whole} whole steps of {n_steps}");
    // The whole steps are the nominal model's 5 ms steps in contact, where the step error is
    // that of the linear driveline with held inputs (the nominal model's, see the tests
    // above); the impacts are found at 1 ms as with 1 ms throughout. Bounds as for the 1 ms
    // run in `drive_shaft_lash_is_a_dead_zone_that_converges_with_the_step`: 2 % of what
    // the lash changes, 0.5 rad/s (5 rpm) of engine speed. Measured: 1.15e-3 m/s (1.5 % of
    // 7.5e-2) and 0.19 rad/s, against 4.5e-4 m/s and 0.066 rad/s at 1 ms throughout and
    // 3.1e-4 m/s and 0.065 rad/s for the model without a lash at 5 ms; the largest errors
    // follow the shaft bouncing through its play after a torque step (from 90.2 s on: the
    // twist's phase against the reference grows by 1 mrad over four crossings).
    assert!(
        dv_sub < 0.02 * effect,
        "Δv {dv_sub} vs lash effect {effect}"
    );
    assert!(dwe_sub < 0.5, "Δω_e {dwe_sub} rad/s");
}

#[test]
fn a_span_taken_up_at_its_first_unlock_with_a_larger_capacity_is_the_whole_simulation() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p0 = veh.driveline.as_ref().unwrap();
    let r = &veh.gearbox.ratios;
    let (sc, y0, mode0) = fleetdyn::sim::scenarios::mixed_gear_drive(p0, r, 120.0);
    assert_eq!(mode0, ClutchMode::Locked);
    let at = |f: f64| {
        let mut p = p0.clone();
        p.clutch_max_torque_nm *= f;
        p
    };
    // a worn clutch (40 % capacity) unlocks; the whole span at 60 %, and taken up from the
    // 40 % run's first unlock
    let states = |p: &fleetdyn::model::driveline::DrivelineParams, lash: f64, from: Option<_>| {
        let mut fast = FastDriveline::new(p, r, 5e-3)
            .with_lash(lash)
            .with_gap_substeps(5)
            .tracking_first_unlock(true);
        let mut got: Vec<(f64, [f64; N_STATES])> = Vec::new();
        let end = match from {
            Some(from) => fast.resume_span_states(&sc, (0.0, 120.0), &from, true, &mut |t, y| {
                got.push((t, *y))
            }),
            None => fast.simulate_span_states(&sc, (0.0, 120.0), y0, mode0, true, &mut |t, y| {
                got.push((t, *y))
            }),
        }
        .unwrap();
        (got, end)
    };
    for lash in [0.0, 0.02] {
        let (p_low, p_high) = (at(0.4), at(0.6));
        let (low, end_low) = states(&p_low, lash, None);
        let from = end_low.first_unlock.expect("the worn clutch unlocks");
        assert!(!end_low.locked_throughout);
        let (whole, end_whole) = states(&p_high, lash, None);
        let (taken_up, end_taken_up) = states(&p_high, lash, Some(from));
        // the samples up to the step's start are the worn clutch's
        let k0 = whole
            .iter()
            .position(|(t, _)| *t == from.step() as f64 * 5e-3)
            .expect("the step's start is a sample");
        assert!(k0 > 0 && low[..=k0] == whole[..=k0], "lash {lash}");
        // from it on, the whole simulation's samples, bit for bit, and its end
        assert_eq!(taken_up.as_slice(), &whole[k0..], "lash {lash}");
        assert_eq!(end_taken_up, end_whole, "lash {lash}");
        // the larger capacity unlocks later (or not at all)
        assert!(end_whole
            .first_unlock
            .is_none_or(|r| r.step() >= from.step()));
    }
}
