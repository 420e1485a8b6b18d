//! Throughput of the nightly pipeline (`pipelines/nightly.toml`) on the five bundled fixture
//! drives (0.64 drive-hours: two multi-rate MCAP, a wide and a long Parquet export, a 6x2 drive
//! with bellow pressures), on ONE worker thread, recomputing every drive (`force`), and the I/O
//! floor of the same data:
//!
//! - `nightly_jobs1`: ingest → resample → slope → shuffle (twice: filtered and raw slope) → axle
//!   → validate → write (the dataset's Parquet tables, done-markers, run report);
//! - `read_write_same_parquet`: read every input file (as the pipeline hashes it), read every
//!   Parquet table the nightly run wrote with the Arrow reader, and write it again with
//!   fleetdyn's writer settings (zstd level 3, atomic rename after fsync). No physics.
//!
//! After the criterion groups it prints, from its own repeated timing (median of 7 runs):
//! drive-hours processed per core-hour (= 0.64 h / (wall time on one core in hours)) and the
//! ratio nightly / read-write.
//!
//! Run: `cargo bench --bench pipeline` (from the repository top; not part of `cargo test`).

#[path = "common/pipeline_io.rs"]
mod pipeline_io;

use criterion::{criterion_group, criterion_main, Criterion};
use pipeline_io::{nightly, parquet_files, plan, read_write};
use std::time::Instant;

/// Median wall time of `n` runs of `f`, s.
fn median_s(mut f: impl FnMut(), n: usize) -> f64 {
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[n / 2]
}

fn bench(c: &mut Criterion) {
    let plan = plan();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fleet");
    let drive_h = nightly(&plan, &out);
    let mut tables = Vec::new();
    parquet_files(&out, &mut tables);
    tables.retain(|p| !p.starts_with(out.join("_reports")));
    let dst = dir.path().join("copy");

    let mut g = c.benchmark_group("pipeline");
    g.sample_size(10);
    g.bench_function("nightly_jobs1", |b| b.iter(|| nightly(&plan, &out)));
    g.bench_function("read_write_same_parquet", |b| {
        b.iter(|| read_write(&plan, &tables, &dst))
    });
    g.finish();

    let t_n = median_s(
        || {
            nightly(&plan, &out);
        },
        7,
    );
    let t_rw = median_s(|| read_write(&plan, &tables, &dst), 7);
    let bytes: u64 = tables
        .iter()
        .map(|p| std::fs::metadata(p).unwrap().len())
        .sum();
    println!(
        "nightly on {} drives ({drive_h:.3} drive-hours), one core: {t_n:.3} s = {:.0} drive-hours per core-hour",
        plan.inputs.len(),
        drive_h / (t_n / 3600.0)
    );
    println!(
        "read + write of the same Parquet ({} tables, {:.1} MB): {t_rw:.3} s; nightly / read-write = {:.1}",
        tables.len(),
        bytes as f64 / 1e6,
        t_n / t_rw
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
