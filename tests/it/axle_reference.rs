//! The half-truck axle-load model against an independent derivation
//! (fixtures/gen/make_axle_reference.py: position vectors and Lagrange's equations with sympy
//! from docs/models/axle.md, integrated with scipy's DOP853 at rtol 1e-12). Parameters: the
//! axle-load thesis truck (fixtures/vehicles/seed002-6x2.toml).
//!
//! Scenarios (each ~10–15 s, inputs piecewise linear, 50 Hz samples): full traction from the
//! static state; auxiliary braking on a 2 % downhill from the steady state; release from a
//! disturbed state (both damper branches); acceleration-only with a service-brake pulse and a
//! grade change.

use crate::common::fixture;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::axle::{AxleInputs, AxleTrajectory, HalfTruck, Start};
use fleetdyn::sim::inputs::Piecewise;
use serde_json::Value;

// Static state and matrices: both sides compute the same closed-form expressions in f64
// (~1e-16 relative rounding, the Rust mass matrix is the inverse of its stored inverse: ~1e-15),
// so 1e-9 relative is tight yet far above rounding.
const REL: f64 = 1e-9;

// Trajectories. The Rust model integrates with classical RK4 at a fixed step h = step_s()
// (2 ms here); the reference is accurate to `radau_check` (DOP853 at rtol 1e-12 vs Radau at
// 1e-10: ≤ 2.6e-4 N, ≤ 5.4e-4 Pa, ≤ 1.5e-10 m, ≤ 1.8e-10 rad/s). The generator also
// integrates its own model with RK4 at the same step and records the deviation, `rk4_check`:
// the error the integrator's order alone explains. It is dominated by the dampers' slope jumps
// (at zero rate and at the table points): a step containing one loses RK4's fourth order (in
// full traction the generator's RK4 error falls only ~3.6× when h halves: ~h²), and its size
// depends on where the step grid falls relative to each crossing, which differs between the
// Rust and the Python step grids. Measured Rust errors / rk4_check over all scenarios and
// signals: 0.20–4.4 (largest: front travel and pressure in full traction). Tolerance:
// 10 × rk4_check, plus 10 × the reference's own uncertainty. For normal forces that is ≤ 0.41 N
// in the three smooth scenarios (of ~7e4 N; measured ≤ 0.04 N) and 13–383 N in the release
// (measured 1.3–40 N: initial rates of 0.1–0.2 m/s cross the damper tables' kinks many times
// in the first 0.3 s).
const RK4_FACTOR: f64 = 10.0;

// With outputs every 0.125 ms the Rust integrator steps at h/16 (it hits every output time):
// pure integration error falls as h² (see above), 256×, while a difference between the two
// derivations would stay as a floor. Tolerance: RK4_FACTOR × rk4_check / 16² + 10 × the
// reference's uncertainty; measured ≤ 1.2e-2 × rk4_check (60–1000× smaller than at h), against
// 3.9e-2 × rk4_check allowed. For scale: the doc's φ row as first written (the arm's
// d'Alembert term with the opposite sign), had it been implemented, would shift the driven-axle
// load by ~400 N at 1.1 m/s², ~5e5 × the tolerance here.
const REFINE: usize = 160;
const STEP_RATIO: f64 = 16.0;

fn doc() -> Value {
    let text = std::fs::read_to_string(fixture("fixtures/reference/axle_reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn truck() -> fleetdyn::model::axle::AxleParams {
    VehicleFile::load(&fixture("fixtures/vehicles/seed002-6x2.toml"))
        .unwrap()
        .axles
        .expect("the thesis truck has an [axles] section")
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn piecewise(v: &Value) -> Option<Piecewise> {
    if v.is_null() {
        return None;
    }
    let pieces = v
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let p = f64s(p);
            (p[0], p[1], p[2], p[3])
        })
        .collect();
    Some(Piecewise::new(pieces).unwrap())
}

fn inputs(v: &Value) -> AxleInputs {
    AxleInputs {
        accel_mps2: piecewise(&v["accel_mps2"]).unwrap(),
        slope: piecewise(&v["slope"]).unwrap(),
        drive_torque_wheel_nm: piecewise(&v["drive_torque_wheel_nm"]),
        aux_brake_torque_wheel_nm: piecewise(&v["aux_brake_torque_wheel_nm"]),
        service_brake_n: piecewise(&v["service_brake_n"]),
    }
}

fn start(v: &Value) -> Start {
    match v.as_str() {
        Some("static") => Start::Static,
        Some("steady") => Start::Steady,
        Some(s) => panic!("unknown start {s}"),
        None => Start::State(f64s(v).try_into().unwrap()),
    }
}

/// The compared signals: (key in the reference, index for per-axle signals, samples).
fn signals(tr: &AxleTrajectory) -> Vec<(&'static str, Option<usize>, &[f64])> {
    let mut out = Vec::new();
    for (name, v) in [
        ("normal_n", &tr.normal_n),
        ("pressure_pa", &tr.pressure_pa),
        ("travel_m", &tr.travel_m),
    ] {
        for (i, s) in v.iter().enumerate() {
            out.push((name, Some(i), s.as_slice()));
        }
    }
    out.push(("pitch_rad", None, tr.pitch_rad.as_slice()));
    out.push((
        "pitch_rate_rad_per_s",
        None,
        tr.pitch_rate_rad_per_s.as_slice(),
    ));
    out.push(("bounce_m", None, tr.bounce_m.as_slice()));
    out
}

fn at(v: &Value, idx: Option<usize>) -> &Value {
    match idx {
        Some(i) => &v[i],
        None => v,
    }
}

/// Largest |a − b| and the time where it occurs.
fn max_diff(t: &[f64], a: &[f64], b: &[f64]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .zip(t)
        .map(|((x, y), t)| ((x - y).abs(), *t))
        .fold((0.0, 0.0), |m, e| if e.0 > m.0 { e } else { m })
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= REL * scale
}

#[test]
fn static_state_and_matrices_match_the_independent_derivation() {
    let p = truck();
    let m = HalfTruck::new(&p);
    let d = doc();
    let st = m.static_state();
    let r = &d["static"];
    assert!(close(
        st.mass_kg,
        r["mass_kg"].as_f64().unwrap(),
        st.mass_kg
    ));
    let x_c = r["chassis_x_cg_m"].as_f64().unwrap();
    assert!(
        close(st.chassis_x_cg_m, x_c, x_c),
        "{} vs {x_c}",
        st.chassis_x_cg_m
    );
    for (key, rust) in [
        ("normal_n", st.normal_n),
        ("bellow_n", st.bellow_n),
        ("pressure_pa", st.pressure_pa),
    ] {
        let want = f64s(&r[key]);
        for i in 0..3 {
            assert!(
                close(rust[i], want[i], want[i].abs()),
                "static {key}[{i}]: {} vs {}",
                rust[i],
                want[i]
            );
        }
    }
    // entries compared on the scale of their row and column: sqrt(|A_ii A_jj|) (units differ
    // between rows; structural zeros must come out as zeros to that precision)
    for (key, a) in [
        ("mass", m.mass_matrix()),
        ("stiffness", m.stiffness_matrix()),
    ] {
        let want: Vec<Vec<f64>> = d["matrices"][key]
            .as_array()
            .unwrap()
            .iter()
            .map(f64s)
            .collect();
        for i in 0..5 {
            for j in 0..5 {
                let scale = (want[i][i] * want[j][j]).abs().sqrt();
                assert!(
                    close(a[i][j], want[i][j], scale),
                    "{key}[{i}][{j}]: {} vs {}",
                    a[i][j],
                    want[i][j]
                );
            }
        }
    }
}

/// Simulates every scenario with outputs `refine` times denser than the reference's 50 Hz and
/// compares at the reference samples; returns the worst (error / tolerance).
fn compare(refine: usize, step_ratio: f64) -> f64 {
    let p = truck();
    let m = HalfTruck::new(&p);
    let h0 = m.step_s();
    assert!(h0 <= 2e-3);
    let d = doc();
    let h_gen = d["rk4_step_s"].as_f64().unwrap();
    assert!(
        close(h0, h_gen, h_gen),
        "step {h0} s, the generator's RK4 check used {h_gen} s"
    );
    let mut worst: f64 = 0.0;
    for case in d["scenarios"].as_array().unwrap() {
        let name = case["name"].as_str().unwrap();
        let t = f64s(&case["t"]);
        let fs = case["fs_hz"].as_f64().unwrap() * refine as f64;
        let t_sim: Vec<f64> = (0..=(t.len() - 1) * refine)
            .map(|k| k as f64 / fs)
            .collect();
        let tr = m.simulate(&inputs(&case["inputs"]), &t_sim, start(&case["start"]));
        for (key, idx, s) in signals(&tr) {
            let s: Vec<f64> = s.iter().step_by(refine).copied().collect();
            let want = f64s(at(&case[key], idx));
            let rk4 = at(&case["rk4_check"][key], idx).as_f64().unwrap();
            let reference_err = at(&case["radau_check"][key], idx).as_f64().unwrap();
            let tol = RK4_FACTOR * (rk4 / (step_ratio * step_ratio) + reference_err);
            let (err, t_at) = max_diff(&t, &s, &want);
            println!(
                "{name:24} {key:>20}{} max err {err:.3e} at t = {t_at:5.2} s, tol {tol:.3e} \
                 ({:.3} × rk4_check)",
                idx.map(|i| format!("[{i}]")).unwrap_or_default(),
                err / rk4
            );
            // the start (static, steady or given state) involves no integration
            let scale = want.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
            assert!(
                (s[0] - want[0]).abs() <= REL * scale,
                "{name} {key}{idx:?} at t = 0: {} vs {}",
                s[0],
                want[0]
            );
            assert!(
                err <= tol,
                "{name} {key}{idx:?}: max error {err:e} at t = {t_at} s exceeds {tol:e}"
            );
            worst = worst.max(err / tol);
        }
    }
    worst
}

#[test]
fn trajectories_match_the_reference_to_rk4_accuracy() {
    let worst = compare(1, 1.0);
    println!("worst error / tolerance {worst:.3}");
}

#[test]
fn trajectories_converge_to_the_reference_as_the_step_shrinks() {
    // 50 Hz × 160 = 8 kHz outputs: steps of 0.125 ms = h/16
    let worst = compare(REFINE, STEP_RATIO);
    println!("worst error / tolerance {worst:.3}");
}
