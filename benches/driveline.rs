//! One drive-hour of the mixed-gear scenario (`sim::scenarios::mixed_gear_drive`, the same one the
//! tests use for 720 s) with its inputs sampled at 100 Hz, as a recording provides them
//! (360 000 input samples per signal): the fast exponential integrator (dt 10 ms) and the
//! accurate Dormand–Prince integrator (rtol 1e-8, restarting at every input sample).
//! Real-time factor = 3600 s / wall time.
//!
//! Run: `cargo bench --bench driveline`.

use criterion::{criterion_group, criterion_main, Criterion};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::fast::FastDriveline;
use fleetdyn::sim::hybrid::HybridDriveline;
use fleetdyn::sim::scenarios::{mixed_gear_drive, sampled_inputs};
use std::hint::black_box;
use std::path::Path;

fn drive_hour(c: &mut Criterion) {
    let v = VehicleFile::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/vehicles/truck-40t.toml"),
    )
    .unwrap();
    let p = v.driveline.as_ref().unwrap();
    let r = &v.gearbox.ratios;
    let (scripted, y0, mode0) = mixed_gear_drive(p, r, 3600.0);
    let sc = sampled_inputs(&scripted, 100.0);
    let mut g = c.benchmark_group("driveline_drive_hour");
    g.sample_size(10);
    g.bench_function("fast_exponential_dt10ms", |b| {
        b.iter(|| {
            FastDriveline::new(p, r, 0.01)
                .simulate(black_box(&sc), y0, mode0)
                .unwrap()
        })
    });
    g.bench_function("accurate_dopri5_rtol1e-8", |b| {
        b.iter(|| {
            HybridDriveline::new(p, r, black_box(&sc))
                .simulate(y0, mode0, 1e-8, 100.0)
                .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, drive_hour);
criterion_main!(benches);
