//! CAN sensors as a J1939 logger delivers them, from SI truth signals.
//!
//! A synthetic CAN drive in four parts, each in its own module and re-exported here:
//! - [`super::can_bus`]: the bus — messages (one MCAP topic each, e.g. EEC1 on `/can/eec1`)
//!   carrying channels (one JSON field each, e.g. `EngineSpeed`), the default J1939 truck bus,
//!   the mapping that ingests it;
//! - [`super::can_sample`]: truth signals sampled on the bus (rates, phases, resolution, noise,
//!   delay, dropouts; the conventions of time, wire values and randomness);
//! - [`super::can_mcap`]: the sampled frames written as MCAP;
//! - [`super::can_error`]: what can go wrong.
//!
//! [`write_can_drive`] chains them: sample, write the MCAP, ingest it with the bus's mapping and
//! write the canonical drive log as Parquet.

pub(crate) use super::can_bus::step_value;
pub use super::can_bus::{
    CanBus, CanChannel, CanMessage, Dropouts, TorqueReference, RETARDER_REFERENCE_TORQUE_NM,
};
pub use super::can_error::SynthError;
pub use super::can_mcap::{write_mcap, write_mcap_with, McapCompression, SynthOptions};
pub use super::can_sample::{sample, CanFrame, Truth};
pub(crate) use super::can_sample::{stream, to_wire};
use crate::ingest::{ingest_file, IngestOptions};
use crate::io::{config_hash, drive_log_columns, write_table, TableMeta};
use crate::table::DriveLog;
use std::path::Path;

/// Samples `truth` on `bus`, writes the MCAP at `mcap_path`, ingests it with the bus's mapping
/// ([`CanBus::mapping`]; otherwise ingest's defaults, so e.g. a wheel-speed dropout longer than
/// the 2 s NaN-run limit fails as it would for a real log) and writes the resulting canonical
/// drive log as Parquet at `parquet_path` (table `drive_log`). Returns that drive log.
///
/// Both files appear atomically, and together: if ingest or the Parquet step fails, the MCAP is
/// removed again.
///
/// # Errors
/// As [`sample`] and [`write_mcap`]; [`SynthError::Ingest`] if the MCAP does not ingest;
/// [`SynthError::Output`] if the Parquet cannot be written.
pub fn write_can_drive(
    mcap_path: &Path,
    parquet_path: &Path,
    bus: &CanBus,
    truth: &Truth,
    opts: &SynthOptions,
) -> Result<DriveLog, SynthError> {
    let frames = sample(bus, truth, opts.start_ns, opts.seed)?;
    let mapping = bus.mapping()?;
    write_mcap(mcap_path, bus, &frames, opts)?;
    // the pair appears together or not at all: a failed ingest or Parquet write removes the MCAP
    let rest = || -> Result<DriveLog, SynthError> {
        let ingest = IngestOptions {
            mapping: Some(mapping),
            ..IngestOptions::default()
        };
        let log = ingest_file(mcap_path, &ingest)?.log;
        let meta = TableMeta {
            table: "drive_log".into(),
            drive_id: log.meta.drive_id.clone(),
            vehicle_id: log.meta.vehicle_id.clone(),
            source_file: log.meta.source_file.clone(),
            config_hash: config_hash(&[
                crate::io::canonical("synth-can:v2", &(opts.seed, bus)).as_bytes()
            ]),
            extra: vec![("synth_seed".into(), opts.seed.to_string())],
        };
        write_table(parquet_path, &meta, &drive_log_columns(&log))?;
        Ok(log)
    };
    rest().inspect_err(|_| {
        let _ = std::fs::remove_file(mcap_path);
    })
}
