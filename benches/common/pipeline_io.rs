//! The nightly pipeline and its I/O floor, shared by `benches/pipeline.rs` and the peer
//! benchmark (`benches/peers/peer_side.rs`):
//!
//! - [`nightly`]: `pipelines/nightly.toml` over the five bundled fixture drives on ONE worker
//!   thread, recomputing every drive (`force`): ingest → resample → slope → shuffle → axle →
//!   validate → write;
//! - [`read_write`]: read every input file (as the pipeline hashes it), read every Parquet table
//!   the nightly run wrote with the Arrow reader, and write it again with fleetdyn's writer
//!   settings (zstd level 3, atomic rename after fsync). No physics: the floor.

use arrow::record_batch::RecordBatchReader as _;
use fleetdyn::io::AtomicFile;
use fleetdyn::pipeline::run::{run_plan, RunOptions};
use fleetdyn::pipeline::spec::{PipelineSpec, Plan};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;
use std::path::{Path, PathBuf};

/// The repository top.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The nightly plan's physics stages over the bundled fixture drives (changes into the
/// repository top): `diagnose` and `fleet` and their tables left out, the diagnosis's own cost
/// being `benches/diagnose.rs`.
pub fn plan() -> Plan {
    std::env::set_current_dir(root()).unwrap();
    let mut spec = PipelineSpec::load(Path::new("pipelines/nightly.toml")).unwrap();
    spec.stages.retain(|s| s != "diagnose" && s != "fleet");
    spec.diagnose = None;
    if let Some(t) = spec.write.tables.as_mut() {
        t.retain(|t| t.stage() != fleetdyn::pipeline::spec::PipelineStage::Diagnose);
    }
    spec.plan("pipelines/nightly.toml", None).unwrap()
}

/// Runs the plan into `out` on one worker; returns the drive-hours processed.
pub fn nightly(plan: &Plan, out: &Path) -> f64 {
    let r = run_plan(
        plan,
        &RunOptions {
            out_root: out.to_path_buf(),
            jobs: 1,
            shard: None,
            force: true,
        },
        &|_| {},
    )
    .unwrap();
    assert_eq!(r.failed, 0);
    r.drives
        .iter()
        .filter_map(|d| d.record.as_ref())
        .map(|r| r.metrics.duration_s)
        .sum::<f64>()
        / 3600.0
}

/// Every `.parquet` file under `dir`, recursively.
pub fn parquet_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            parquet_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "parquet") {
            out.push(p);
        }
    }
}

/// The I/O floor of the nightly run (module doc): reads the inputs, re-writes `tables` into `dst`.
pub fn read_write(plan: &Plan, tables: &[PathBuf], dst: &Path) {
    for it in &plan.inputs {
        std::hint::black_box(std::fs::read(&it.path).unwrap());
    }
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::try_new(3).unwrap()))
        .build();
    for (k, f) in tables.iter().enumerate() {
        let reader = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(f).unwrap())
            .unwrap()
            .build()
            .unwrap();
        let schema = reader.schema();
        let tmp = AtomicFile::create(&dst.join(format!("{k}.parquet"))).unwrap();
        let mut w =
            ArrowWriter::try_new(tmp.try_clone_file().unwrap(), schema, Some(props.clone()))
                .unwrap();
        for b in reader {
            w.write(&b.unwrap()).unwrap();
        }
        w.close().unwrap();
        tmp.commit().unwrap();
    }
}
