//! Benchmarks of the issue-2 kernels on the sizes fleet jobs see, with the same scenarios the
//! tests use. Peer numbers (scipy on the same inputs) come from `fixtures/gen/peer_bench.py`.
//!
//! Run: `cargo bench --bench kernels`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fleetdyn::ingest::{ingest_file, IngestOptions};
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

fn filters(c: &mut Criterion) {
    let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).unwrap();
    let mut g = c.benchmark_group("sosfiltfilt_slope_filter");
    for n in [10_000usize, 100_000, 1_000_000] {
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
    for n in [100_000usize, 1_000_000] {
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

criterion_group!(benches, filters, spectra, ingest);
criterion_main!(benches);
