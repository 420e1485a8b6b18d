//! One drive-hour of the half-truck axle-load model (`sim::axle`): the deterministic stop-and-go
//! drive of `sim::axle_scenarios::stop_and_go` on the axle-load thesis truck — drive torque,
//! auxiliary braking, service braking to stops, grade within ±3 % — with its inputs sampled at 10
//! Hz as a recording provides them (36 000 samples per signal) and the outputs sampled at 10 Hz.
//! The model integrates with fixed-step RK4 (step from `HalfTruck::step_s`, at most 2 ms).
//! Real-time factor = 3600 s / wall time.
//!
//! Run: `cargo bench --bench axle`.

use criterion::{criterion_group, criterion_main, Criterion};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::axle::HalfTruck;
use fleetdyn::sim::axle_scenarios::{stop_and_go, AxleScenarioConfig};
use std::hint::black_box;
use std::path::Path;

fn drive_hour(c: &mut Criterion) {
    let v = VehicleFile::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/vehicles/seed002-6x2.toml"),
    )
    .unwrap();
    let p = v.axles.as_ref().unwrap();
    let sc = stop_and_go(p, &AxleScenarioConfig::default(), 3600.0, 10.0).unwrap();
    let model = HalfTruck::new(p);
    let mut g = c.benchmark_group("axle_drive_hour");
    g.sample_size(10);
    g.bench_function("rk4_inputs_10hz_outputs_10hz", |b| {
        b.iter(|| model.simulate(black_box(&sc.inputs), black_box(&sc.t_s), sc.start))
    });
    g.finish();
}

criterion_group!(benches, drive_hour);
criterion_main!(benches);
