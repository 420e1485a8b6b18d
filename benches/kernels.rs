//! Criterion benches of the kernels and the per-drive stages on the sizes fleet jobs see:
//! Butterworth design, `sosfiltfilt` and Welch up to 10⁷ samples, ingest of the bundled
//! fixtures, distance resampling, and on the bench drive-hour (`benches/common/hour_drive.rs`):
//! MCAP ingest of the 1-hour multi-rate log, Parquet read and write of its canonical table,
//! resampling to distance. The peers on the same inputs: `bash benches/peers/run.sh`.
//!
//! Run: `cargo bench --bench kernels` (from the repository top).

#[path = "common/hour_drive.rs"]
mod hour_drive;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::pipeline::ingest_stage;
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use fleetdyn::signal::{butter, sosfiltfilt, welch, BandType, EdgeMode, WelchConfig};
use std::hint::black_box;
use std::path::Path;

/// A slope-like trace on a 1 m grid: slow hills plus whole-percent quantisation, deterministic.
fn slope_trace(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let x = i as f64;
            let s = 0.03 * (x / 900.0).sin() + 0.015 * (x / 230.0 + 1.0).sin();
            (s * 100.0).round() / 100.0
        })
        .collect()
}

fn design(c: &mut Criterion) {
    let mut g = c.benchmark_group("butter_design");
    for order in [3usize, 8] {
        g.bench_function(BenchmarkId::new("lowpass", order), |b| {
            b.iter(|| butter(black_box(order), 4e-3, 1.0, BandType::Lowpass).unwrap())
        });
    }
    g.bench_function(BenchmarkId::new("highpass", 4), |b| {
        b.iter(|| butter(black_box(4), 0.5, 100.0, BandType::Highpass).unwrap())
    });
    g.finish();
}

fn filters(c: &mut Criterion) {
    let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).unwrap();
    let mut g = c.benchmark_group("sosfiltfilt_slope_filter");
    g.sample_size(10);
    for n in [10_000usize, 100_000, 1_000_000, 10_000_000] {
        let x = slope_trace(n);
        g.throughput(Throughput::Elements(n as u64));
        for (label, edge) in [
            ("scipy", EdgeMode::Scipy { padlen: None }),
            ("matched", EdgeMode::default()),
        ] {
            g.bench_with_input(BenchmarkId::new(label, n), &x, |b, x| {
                b.iter(|| sosfiltfilt(&sos, black_box(x), &edge).unwrap())
            });
        }
    }
    g.finish();
}

fn spectra(c: &mut Criterion) {
    let mut g = c.benchmark_group("welch");
    g.sample_size(10);
    for n in [100_000usize, 1_000_000, 10_000_000] {
        let x = slope_trace(n);
        g.throughput(Throughput::Elements(n as u64));
        for nperseg in [256usize, 4096] {
            let cfg = WelchConfig {
                nperseg: Some(nperseg),
                ..Default::default()
            };
            g.bench_with_input(
                BenchmarkId::new(format!("nperseg{nperseg}"), n),
                &x,
                |b, x| b.iter(|| welch(black_box(x), &cfg).unwrap()),
            );
        }
    }
    g.finish();
}

fn ingest(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let opts = IngestOptions {
        stages: vec![Stage::Slope],
        ..Default::default()
    };
    let mut g = c.benchmark_group("ingest");
    g.sample_size(20);
    for f in [
        "fixtures/drives/truck-0001.mcap",
        "fixtures/drives/truck-0003-export.parquet",
        "fixtures/drives/truck-0004-long.parquet",
    ] {
        let p = root.join(f);
        let rows = ingest_file(&p, &opts).unwrap().report.source_rows;
        g.throughput(Throughput::Elements(rows));
        g.bench_function(f, |b| b.iter(|| ingest_file(black_box(&p), &opts).unwrap()));
    }
    let log = ingest_file(&root.join("fixtures/drives/truck-0001.mcap"), &opts)
        .unwrap()
        .log;
    g.throughput(Throughput::Elements(log.len() as u64));
    g.bench_function("resample_to_distance truck-0001", |b| {
        b.iter(|| resample_to_distance(black_box(&log), &ResampleConfig::default()).unwrap())
    });
    g.finish();
}

fn drive_hour(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let d = hour_drive::hour_drive(dir.path());
    let opts = IngestOptions::default();
    let mut g = c.benchmark_group("drive_hour");
    g.sample_size(10);
    g.throughput(Throughput::Elements(d.log.len() as u64));
    g.bench_function("mcap_ingest", |b| {
        b.iter(|| ingest_file(black_box(&d.log_file), &opts).unwrap())
    });
    g.bench_function("parquet_read", |b| {
        b.iter(|| ingest_file(black_box(&d.parquet), &opts).unwrap())
    });
    let out = dir.path().join("rewrite.parquet");
    g.bench_function("parquet_write", |b| {
        b.iter(|| ingest_stage::write(&out, black_box(&d.log), "bench").unwrap())
    });
    g.bench_function("resample_to_distance", |b| {
        b.iter(|| resample_to_distance(black_box(&d.log), &ResampleConfig::default()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, design, filters, spectra, ingest, drive_hour);
criterion_main!(benches);
