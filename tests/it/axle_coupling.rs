//! End-to-end: the driveline model's drive-shaft torque and speed drive the axle-load model on the
//! diesel variant of the axle-load thesis truck.

use crate::common::fixture;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::axle::{HalfTruck, Start};
use fleetdyn::sim::axle_coupling::axle_inputs_from_driveline;
use fleetdyn::sim::hybrid::HybridDriveline;
use fleetdyn::sim::scenarios::mixed_gear_drive;

#[test]
fn driveline_torque_reaches_the_axles_and_the_longitudinal_balance_closes() {
    let v = VehicleFile::load(&fixture("fixtures/vehicles/seed002-6x2-diesel.toml")).unwrap();
    let (d, p) = (v.driveline.as_ref().unwrap(), v.axles.as_ref().unwrap());
    let ratios = &v.gearbox.ratios;
    let (sc, y0, mode0) = mixed_gear_drive(d, ratios, 120.0);
    let tr = HybridDriveline::new(d, ratios, &sc)
        .simulate(y0, mode0, 1e-9, 100.0)
        .unwrap();
    let u = axle_inputs_from_driveline(&tr, &sc, d.wheel_radius_m, 0.01).unwrap();
    let m = HalfTruck::new(p);
    let out = m.simulate(&u, &tr.t, Start::Steady);
    let g = p.gravity_m_per_s2;
    let mass = m.static_state().mass_kg;
    // The remainder the axle model closes at the resistance height must be exactly what the
    // driveline resisted the drive torque with: rolling resistance, air drag and the wheels'
    // inertia, R = −(F_r + F_a) − J_w a / r_w² (the wheel equation of Myklebust & Eriksson (2012),
    // §2; the scenario has no service brake). The axle model's acceleration is a centred difference
    // over ±10 ms of the 100 Hz trajectory: exact on smooth stretches (median error measured 0.000
    // N), off by h²/6·|a‴|·m during shuffle (99th percentile measured 68 N) and smeared over one
    // sample at the clutch-lock and gear-change events, where the acceleration jumps (max 2.7 kN).
    let mut errs = Vec::new();
    for k in 1..tr.t.len() - 1 {
        let t = tr.t[k];
        let l = m.longitudinal(&u, t);
        let v_k = d.wheel_radius_m * tr.y[k][7];
        let s = sc.slope.eval(t);
        let road = d.road_force(v_k, s, 0.0, sc.smoothing) - mass * g * s.atan().sin();
        let r = l.resistance_n + road + d.j_w_kg_m2 * l.accel_mps2 / d.wheel_radius_m.powi(2);
        errs.push(r.abs());
    }
    errs.sort_by(f64::total_cmp);
    let q = |f: f64| errs[((errs.len() - 1) as f64 * f) as usize];
    assert!(q(0.5) < 1.0, "median closure error {} N", q(0.5));
    assert!(
        q(0.99) < 100.0,
        "99th percentile closure error {} N",
        q(0.99)
    );
    assert!(q(1.0) < 5000.0, "largest closure error {} N", q(1.0));
    // and the torque is felt: the driven-axle load varies with the drive torque (anti-squat)
    let n_r = &out.normal_n[1];
    let (lo, hi) = n_r
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(hi - lo > 1000.0, "driven-axle load range {} N", hi - lo);
}
