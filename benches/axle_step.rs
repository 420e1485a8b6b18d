//! The diagnosis's axle-model step against the model's own (`diagnose::axle_model::AXLE_STEP_S`
//! against 2 ms): on the diagnose bench's hour drive (65 km of `highway-se`, the diesel 6x2
//! truck with axle loads, 50 Hz rows), one whole-drive simulation of the three bellow pressures
//! from the recorded inputs at each step, its time (median of 3) and its largest and RMS
//! difference from the 2 ms step's, in Pa, to set against the 1 kPa noise and 0.1 kPa resolution
//! of a bellow-pressure sensor. The last line is the diagnosis's simulation: exact steps over
//! the rows on which no damper changes segment (`HalfTruck::with_segment_steps`), RK4 at the
//! diagnosis's step over the others.
//!
//! Run: `cargo bench --bench axle_step` (from the repository top; not part of `cargo test`).

#[path = "common/hour_drive.rs"]
mod hour_drive;

use fleetdyn::diagnose::axle_model::AXLE_STEP_S;
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::axle::{HalfTruck, Start};
use fleetdyn::sim::axle_recorded::{axle_inputs_from_log, AxleRecordConfig};
use fleetdyn::table::LogView;
use std::time::Instant;

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let d = hour_drive::hour_drive(dir.path());
    let vf = VehicleFile::load(&d.vehicle).unwrap();
    let log = ingest_file(&d.parquet, &IngestOptions::default())
        .unwrap()
        .log;
    let a = vf.axles.as_ref().unwrap();
    let dl = vf.driveline.as_ref().unwrap();
    let rec = axle_inputs_from_log(
        LogView::of(&log),
        a.mass_kg(),
        a.wheel_radius_m,
        a.gravity_m_per_s2,
        &vf.gearbox.ratios,
        Some(dl.final_drive_ratio),
        Some(dl),
        None,
        &AxleRecordConfig::default(),
    )
    .unwrap();
    let run = |model: &HalfTruck| {
        let mut times = Vec::new();
        let mut p = None;
        for _ in 0..3 {
            let t = Instant::now();
            p = Some(
                model
                    .simulate(&rec.inputs, &rec.t_s, Start::Steady)
                    .pressure_pa,
            );
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        (times[1], p.unwrap())
    };
    let (t_fine, fine) = run(&HalfTruck::new(a));
    println!(
        "{} rows; model step {:.2} ms: {t_fine:.3} s",
        rec.t_s.len(),
        1e3 * HalfTruck::new(a).step_s()
    );
    let variants = [1e-3, 5e-3, AXLE_STEP_S]
        .map(|h| (h, false))
        .into_iter()
        .chain([(AXLE_STEP_S, true)]);
    for (h, segments) in variants {
        let mut model = HalfTruck::new(a).with_max_step(h);
        if segments {
            model = model.with_segment_steps();
        }
        let (t, p) = run(&model);
        let (mut worst, mut ss, mut n) = (0.0f64, 0.0, 0.0);
        for i in 0..3 {
            for (x, y) in p[i].iter().zip(&fine[i]) {
                worst = worst.max((x - y).abs());
                ss += (x - y) * (x - y);
                n += 1.0;
            }
        }
        println!(
            "{}step at most {:.2} ms (at most {:.2} ms after the 0.5/rho bound): {t:.3} s ({:.2}x the model step's speed); \
             pressures against the model step: largest {worst:.1} Pa, RMS {:.2} Pa",
            if segments {
                "exact over intervals on one damper segment, elsewhere RK4 "
            } else {
                ""
            },
            1e3 * h,
            1e3 * model.step_s(),
            t_fine / t,
            (ss / n).sqrt()
        );
    }
}
