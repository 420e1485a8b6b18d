//! fleetdyn's side of the peer benchmark (`benches/peers/run.sh`): runs one operation on inputs
//! written by `benches/peers/peers.py`, repeats it, writes the result for the comparison and prints
//! the timings as one JSON line (median and every run, s).
//!
//! ```text
//! peer_side OP REPEATS ARG…
//! ```
//! Raw vectors are little-endian f64 files. Operations (the same parameters as the Python side):
//! - `sosfiltfilt IN OUT`: 3rd-order Butterworth low-pass at 0.004 of the sampling rate (the
//!   road-slope filter of Myklebust & Eriksson (2012), §5, on a 1 m grid), zero-phase with scipy's
//!   edge handling (odd extension, scipy's padlen) — fleetdyn's `EdgeMode::Scipy`;
//! - `welch IN OUT`: Welch PSD, fs = 1, Hann window, nperseg 4096, 50 % overlap, density
//!   scaling, constant detrend; written as the PSD values (fleetdyn also computes the χ²
//!   interval, which scipy does not — included in its time);
//! - `floor_copy IN OUT`: read the input and write it to a new buffer (one pass each way: the
//!   memory traffic a filter that reads and writes every sample once cannot go below);
//! - `floor_sum IN OUT`: read the input once (a reduction: what a PSD that reads every sample
//!   once cannot go below);
//! - `driveline_accurate IN OUT TOL` / `driveline_fast IN OUT`: the locked-clutch driveline of
//!   docs/models/driveline.md (truck-40t, fixed gear, prescribed engine torque — an ideal torque
//!   source — and road slope, both linear between input samples) simulated by the accurate
//!   Dormand–Prince integrator (`HybridDriveline`, rtol = TOL, restarting at every input sample) or
//!   the exponential integrator (`FastDriveline`, dt = one input sample). IN holds
//!   `[fs_hz, gear, v0_mps, n, dM_e[0..=n], slope[0..=n]]`; the engine torque is the steady torque
//!   at `v0` on `slope[0]` plus `dM_e`. OUT holds
//!   `[y0 (9 states), M_e[0..=n], v[0..=n], w_e[0..=n]]` (the state at start, the torque used,
//!   vehicle and engine speed on the input grid) so the peer integrates exactly the same problem;
//! - `hour_drive DIR`: generates the bench drive-hour (`benches/common/hour_drive.rs`) into
//!   DIR and prints its files and duration (not timed);
//! - `ingest IN OUT`: `ingest_file` of an MCAP or Parquet log into the canonical drive log in
//!   memory (decode, unit conversion, multi-rate alignment, checks) — timed; then written once
//!   to OUT as the canonical Parquet (not timed) for the comparison;
//! - `read_file IN`: read the file's bytes into memory (the floor of any ingest);
//! - `parquet_write IN OUT`: the canonical log of IN written to OUT (`ingest_stage::write`:
//!   zstd, unit metadata, atomic rename after fsync) — timed;
//! - `parquet_decode IN`: decode every column of IN into Arrow record batches (arrow-rs, 64 Ki
//!   rows per batch, as ingest reads), nothing else — the decode share of `ingest`;
//! - `memcpy IN`: copy IN's decoded drive-log columns once (the floor of a Parquet decode or
//!   encode: moving the same values through memory);
//! - `nightly`: `pipelines/nightly.toml` over the bundled fixtures on one worker
//!   (`benches/common/pipeline_io.rs`), then the same data's read+write floor; prints both
//!   medians and the drive-hours;
//! - `diagnose IN VEHICLE DIR`: ingest + `diagnose` + contract files, as `fleetdyn diagnose`
//!   (rayon's pool: all cores).
//!
//! Timing: wall clock of the operation only (input already in memory unless the operation is
//! reading), each repeat on a fresh output.

#[path = "../common/hour_drive.rs"]
mod hour_drive;
#[path = "../common/pipeline_io.rs"]
mod pipeline_io;

use arrow::record_batch::RecordBatch;
use fleetdyn::diagnose::run::{diagnose, DiagnoseConfig};
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::ingest_stage;
use fleetdyn::report::diagnosis_files::write_outputs;
use fleetdyn::signal::{butter, sosfiltfilt, welch, BandType, EdgeMode, WelchConfig};
use fleetdyn::sim::fast::FastDriveline;
use fleetdyn::sim::hybrid::{
    steady_state_locked, ClutchMode, EngineInput, HybridDriveline, Scenario,
};
use fleetdyn::sim::inputs::Piecewise;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn read_f64(path: &str) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    assert!(
        bytes.len().is_multiple_of(8),
        "{path}: not a whole number of f64"
    );
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect()
}

fn write_f64(path: &str, v: &[f64]) {
    let mut out = Vec::with_capacity(v.len() * 8);
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
    std::fs::write(path, out).unwrap_or_else(|e| panic!("{path}: {e}"));
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 3 {
        eprintln!("usage: peer_side OP REPEATS ARG…");
        std::process::exit(2);
    }
    let op = a[1].as_str();
    let repeats: usize = a[2].parse::<usize>().expect("REPEATS is a count").max(1);
    let arg = |k: usize| -> &str {
        a.get(3 + k).map(String::as_str).unwrap_or_else(|| {
            eprintln!("{op}: argument {} missing", k + 1);
            std::process::exit(2)
        })
    };
    match op {
        "sosfiltfilt" | "welch" | "floor_copy" | "floor_sum" => {
            kernel(op, &read_f64(arg(0)), arg(1), repeats)
        }
        "driveline_accurate" | "driveline_fast" => {
            let tol: f64 = a
                .get(5)
                .map_or(1e-8, |t| t.parse().expect("TOL is a number"));
            driveline(op, &read_f64(arg(0)), arg(1), repeats, tol);
        }
        "hour_drive" => {
            let t = Instant::now();
            let d = hour_drive::hour_drive(Path::new(arg(0)));
            println!(
                "{{\"op\": \"hour_drive\", \"mcap\": \"{}\", \"parquet\": \"{}\", \"vehicle\": \"{}\", \"duration_s\": {}, \"rows\": {}, \"generated_s\": {:.1}}}",
                d.log_file.display(),
                d.parquet.display(),
                d.vehicle.display(),
                d.log.duration_s(),
                d.log.len(),
                t.elapsed().as_secs_f64()
            );
        }
        "ingest" => {
            let input = Path::new(arg(0));
            let mut log = None;
            let times = timed(repeats, || {
                log = Some(ingest_file(input, &IngestOptions::default()).expect("ingests"));
            });
            let log = log.expect("one run").log;
            ingest_stage::write(Path::new(arg(1)), &log, "peer").expect("writes");
            report(
                op,
                log.len(),
                &times,
                &format!(", \"duration_s\": {}", log.duration_s()),
            );
        }
        "read_file" => {
            let input = arg(0);
            let mut n = 0;
            let times = timed(repeats, || {
                n = black_box(std::fs::read(input).expect("readable")).len();
            });
            report(op, n, &times, "");
        }
        "parquet_write" => {
            let log = ingest_file(Path::new(arg(0)), &IngestOptions::default())
                .expect("ingests")
                .log;
            let out = Path::new(arg(1));
            let times = timed(repeats, || {
                ingest_stage::write(out, black_box(&log), "peer").expect("writes");
            });
            report(op, log.len(), &times, "");
        }
        "parquet_decode" => {
            let input = Path::new(arg(0));
            let mut rows = 0;
            let times = timed(repeats, || {
                let file = std::fs::File::open(input).expect("readable");
                let reader = ParquetRecordBatchReaderBuilder::try_new(file)
                    .expect("Parquet")
                    .with_batch_size(64 * 1024)
                    .build()
                    .expect("reader");
                let batches: Vec<RecordBatch> =
                    reader.map(|b| b.expect("decodes")).collect::<Vec<_>>();
                rows = batches.iter().map(RecordBatch::num_rows).sum();
                black_box(batches);
            });
            report(op, rows, &times, "");
        }
        "memcpy" => {
            let log = ingest_file(Path::new(arg(0)), &IngestOptions::default())
                .expect("ingests")
                .log;
            let times = timed(repeats, || {
                let t = black_box(log.timestamp_ns.clone());
                let cols: Vec<Vec<f64>> = log
                    .signals
                    .iter()
                    .map(|s| black_box(s.values.clone()))
                    .collect();
                black_box((t, cols));
            });
            report(op, log.len(), &times, "");
        }
        "nightly" => {
            let plan = pipeline_io::plan();
            let dir = tempfile::tempdir().expect("temporary folder");
            let out = dir.path().join("fleet");
            let hours = pipeline_io::nightly(&plan, &out);
            let mut tables = Vec::new();
            pipeline_io::parquet_files(&out, &mut tables);
            tables.retain(|p| !p.starts_with(out.join("_reports")));
            let dst = dir.path().join("copy");
            let t_n = timed(repeats, || {
                pipeline_io::nightly(&plan, &out);
            });
            let t_rw = timed(repeats, || pipeline_io::read_write(&plan, &tables, &dst));
            report(
                op,
                plan.inputs.len(),
                &t_n,
                &format!(
                    ", \"drive_hours\": {hours}, \"floor_median_s\": {}",
                    median(&t_rw)
                ),
            );
        }
        "diagnose" => {
            let (input, vehicle, dir) = (Path::new(arg(0)), Path::new(arg(1)), Path::new(arg(2)));
            let mut verdict = String::new();
            let mut hours = 0.0;
            let times = timed(repeats, || {
                let vf = VehicleFile::load(vehicle).expect("vehicle file");
                let log = ingest_file(input, &IngestOptions::default())
                    .expect("ingests")
                    .log;
                let r = diagnose(&log, &vf, &DiagnoseConfig::default()).expect("diagnoses");
                write_outputs(dir, &r, &log, "peer").expect("writes");
                verdict = r.verdict.as_str().to_string();
                hours = log.duration_s() / 3600.0;
            });
            report(
                op,
                0,
                &times,
                &format!(
                    ", \"drive_hours\": {hours}, \"threads\": {}, \"verdict\": \"{verdict}\"",
                    rayon::current_num_threads()
                ),
            );
        }
        other => {
            eprintln!("unknown OP {other}");
            std::process::exit(2);
        }
    }
}

/// Wall times of `repeats` runs of `f`, s.
fn timed(repeats: usize, mut f: impl FnMut()) -> Vec<f64> {
    (0..repeats)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect()
}

fn median(times: &[f64]) -> f64 {
    let mut sorted = times.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

/// The 1-D kernels.
fn kernel(op: &str, x: &[f64], output: &str, repeats: usize) {
    let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).expect("valid design");
    let edge = EdgeMode::Scipy { padlen: None };
    let wcfg = WelchConfig {
        fs_hz: 1.0,
        nperseg: Some(4096),
        noverlap: None,
        confidence: 0.95,
    };
    let run = |x: &[f64]| -> Vec<f64> {
        match op {
            "sosfiltfilt" => sosfiltfilt(&sos, x, &edge).expect("finite input"),
            "welch" => welch(x, &wcfg).expect("finite input").psd,
            "floor_copy" => x.to_vec(),
            _ => vec![x.iter().sum::<f64>()],
        }
    };
    let mut last = Vec::new();
    let times = timed(repeats, || last = black_box(run(black_box(x))));
    write_f64(output, &last);
    report(op, x.len(), &times, "");
}

/// Prints the timing line: median and every run, plus `extra` JSON members.
fn report(op: &str, n: usize, times: &[f64], extra: &str) {
    let runs: Vec<String> = times.iter().map(|t| format!("{t:.6}")).collect();
    println!(
        "{{\"op\": \"{op}\", \"n\": {n}, \"median_s\": {:.6}, \"runs_s\": [{}]{extra}}}",
        median(times),
        runs.join(", ")
    );
}

/// The driveline operations (see the module documentation).
fn driveline(op: &str, x: &[f64], output: &str, repeats: usize, tol: f64) {
    let v = VehicleFile::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/vehicles/truck-40t.toml"),
    )
    .expect("bundled vehicle file");
    let p = v.driveline.as_ref().expect("truck-40t has a driveline");
    let r = &v.gearbox.ratios;
    let (fs, gear, v0) = (x[0], x[1] as usize, x[2]);
    let n = x[3] as usize;
    assert_eq!(x.len(), 4 + 2 * (n + 1), "input: header + dM_e + slope");
    let (dm, slope) = x[4..].split_at(n + 1);
    let (y0, m0) = steady_state_locked(p, r, gear, v0, slope[0], true);
    let m_e: Vec<f64> = dm.iter().map(|d| m0 + d).collect();
    let t_end = n as f64 / fs;
    let pieces = |s: &[f64]| {
        Piecewise::new(
            (0..n)
                .map(|k| (k as f64 / fs, (k + 1) as f64 / fs, s[k], s[k + 1]))
                .collect(),
        )
        .expect("contiguous knots")
    };
    let sc = Scenario {
        t_end_s: t_end,
        gear: Piecewise::constant(t_end, gear as f64),
        clutch_x: Piecewise::constant(t_end, 0.0),
        slope: pieces(slope),
        brake_n: Piecewise::constant(t_end, 0.0),
        engine: EngineInput::Torque(pieces(&m_e)),
        smoothing: true,
        standstill_events: false,
    };
    let mut traj = None;
    let times = timed(repeats, || {
        let out = match op {
            "driveline_accurate" => {
                HybridDriveline::new(p, r, black_box(&sc)).simulate(y0, ClutchMode::Locked, tol, fs)
            }
            "driveline_fast" => {
                FastDriveline::new(p, r, 1.0 / fs).simulate(black_box(&sc), y0, ClutchMode::Locked)
            }
            other => {
                eprintln!("unknown OP {other}");
                std::process::exit(2);
            }
        }
        .expect("the locked scenario simulates");
        traj = Some(black_box(out));
    });
    let traj = traj.expect("at least one run");
    // Floor: move the same bytes once — the input samples in, the trajectory's states out.
    let floor = median(&timed(repeats, || {
        let inputs = black_box((dm.to_vec(), slope.to_vec()));
        let states = black_box(traj.y.clone());
        black_box((inputs, states));
    }));
    assert_eq!(traj.y.len(), n + 1, "one output per input sample");
    let mut out = y0.to_vec();
    out.extend_from_slice(&m_e);
    out.extend(traj.y.iter().map(|y| p.wheel_radius_m * y[7]));
    out.extend(traj.y.iter().map(|y| y[0]));
    write_f64(output, &out);
    let st = traj.stats;
    report(
        op,
        n,
        &times,
        &format!(
            ", \"tol\": {tol:e}, \"simulated_s\": {t_end}, \"rhs_evals\": {}, \"steps\": {}, \"floor_median_s\": {floor:.6}",
            st.rhs_evals, st.accepted
        ),
    );
}
