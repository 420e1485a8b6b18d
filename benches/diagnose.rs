//! Speed of the diagnosis (target: one drive-hour in under 60 s on 2 cores): one synthetic drive of
//! about an hour (65 km of Swedish main road, `highway-se`, seed 3, the diesel variant of the
//! axle-load thesis 6x2 truck, multi-rate quantised CAN with dropouts, a stop every 5 km) with a
//! hidden aerodynamic-drag change, diagnosed from its canonical Parquet log as `fleetdyn diagnose`
//! does (ingest → setup → compare → noise floor (12 Monte-Carlo copies) → locate → explain →
//! verdict → contract files, report and plots), on the machine's cores (rayon's global pool; the CI
//! machines have 2).
//!
//! A plain timing harness, not criterion: one run takes tens of seconds, and criterion's
//! minimum of 10 samples would make the bench several minutes for no better figure. It prints
//! each of 3 runs, the median, the drive's duration, the seconds per drive-hour and the
//! verdict with the first finding (so a speed-up that breaks the diagnosis shows).
//!
//! Run: `cargo bench --bench diagnose` (from the repository top; not part of `cargo test`).

#[path = "common/hour_drive.rs"]
mod hour_drive;

use fleetdyn::diagnose::run::{diagnose, DiagnoseConfig};
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::report::diagnosis_files::write_outputs;
use fleetdyn::report::sentences::finding_sentence;
use hour_drive::{hour_drive, HOUR_DRIVE_KM};
use std::time::Instant;

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = Instant::now();
    let d = hour_drive(dir.path());
    let hours = d.log.duration_s() / 3600.0;
    println!(
        "drive: {:.1} km, {:.2} h, {} rows (generated in {:.0} s)",
        HOUR_DRIVE_KM,
        hours,
        d.log.len(),
        t0.elapsed().as_secs_f64()
    );
    let threads = rayon::current_num_threads();
    let mut times = Vec::new();
    for run in 0..3 {
        let t = Instant::now();
        let vf = VehicleFile::load(&d.vehicle).unwrap();
        let log = ingest_file(&d.parquet, &IngestOptions::default())
            .unwrap()
            .log;
        let r = diagnose(&log, &vf, &DiagnoseConfig::default()).unwrap();
        write_outputs(&dir.path().join(format!("diag{run}")), &r, &log, "bench").unwrap();
        let s = t.elapsed().as_secs_f64();
        times.push(s);
        println!(
            "run {run}: {s:.1} s on {threads} threads; verdict {}; first finding: {}",
            r.verdict.as_str(),
            r.explanation
                .findings
                .first()
                .map_or("none".to_string(), finding_sentence)
        );
    }
    times.sort_by(f64::total_cmp);
    let median = times[1];
    println!(
        "diagnosis of one drive: median {median:.1} s = {:.1} s per drive-hour on {threads} threads (target < 60 s)",
        median / hours
    );
}
