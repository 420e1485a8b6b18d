//! The independent truth plant (`fleetdyn::truth`), verified as a model is verified.

use super::common::fixture;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::truth::*;

fn truck() -> VehicleFile {
    VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap()
}

#[test]
fn truth_plant_smoke() {
    let v = truck();
    let cfg = IndependentDriveConfig::new("highway-se", 3.0, 1);
    let t0 = std::time::Instant::now();
    let d = simulate_independent_drive(&v, &cfg).unwrap();
    eprintln!("elapsed {:?}, sim {} s, events {:?}", t0.elapsed(), d.truth.t_s.last().unwrap(), d.events);
    let cols = &d.truth.columns;
    for k in (0..d.truth.t_s.len()).step_by(200) {
        eprint!("t {:7.2} x {:7.1} ", d.truth.t_s[k], d.distance_m[k]);
        for (n, c) in cols { eprint!("{}={:.2} ", &n[..4], c[k]); }
        eprintln!();
    }
}
