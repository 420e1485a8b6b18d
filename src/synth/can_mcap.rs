//! Writing sampled CAN frames as MCAP: one JSON-schema record and one `json` channel per bus
//! message, zstd or LZ4 chunks, a `drive` metadata record with the drive's ids and seed. The
//! bytes depend on the bus, the frames and the options alone (single-threaded compression).

use super::can_bus::{CanBus, CanMessage};
use super::can_error::SynthError;
use super::can_sample::CanFrame;
use crate::io::AtomicFile;
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Provenance and randomness of a synthetic drive.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthOptions {
    /// Epoch time of truth time 0, ns since the Unix epoch.
    pub start_ns: i64,
    /// Seed of noise and dropouts.
    pub seed: u64,
    /// Drive id written into the MCAP metadata (and so into the drive log).
    pub drive_id: String,
    /// Vehicle id written into the MCAP metadata, if any.
    pub vehicle_id: Option<String>,
}

/// The JSON schema record of a message: an object of numeric fields with their units.
fn json_schema(bus: &CanBus, m: &CanMessage) -> Vec<u8> {
    let mut props = Map::new();
    for c in &m.channels {
        let mut p = Map::new();
        p.insert("type".into(), Value::from("number"));
        p.insert(
            "description".into(),
            Value::from(format!(
                "{} in {}{}, resolution {}",
                c.column,
                c.wire_unit,
                bus.reference_nm(c.torque_reference)
                    .map(|r| format!(" of {r} N*m"))
                    .unwrap_or_default(),
                c.resolution
            )),
        );
        props.insert(c.field.clone(), Value::Object(p));
    }
    let mut s = Map::new();
    s.insert("type".into(), Value::from("object"));
    s.insert("title".into(), Value::from(m.name.clone()));
    s.insert("properties".into(), Value::Object(props));
    serde_json::to_vec(&Value::Object(s)).expect("JSON of strings and maps")
}

/// Chunk compression of a written MCAP file (both are what ingest reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum McapCompression {
    /// zstd at the encoder's default level (3), single-threaded.
    #[default]
    Zstd,
    /// LZ4 frames at the encoder's default level, no block checksums (the chunk CRC covers
    /// them).
    Lz4,
}

/// Writes `frames` as MCAP, atomically: zstd chunks (single-threaded, so the bytes do not depend
/// on the machine), one JSON-schema record and one `json` channel per bus message that has
/// frames, a metadata record `drive` with `drive_id`, `vehicle_id` (if any), `seed` and
/// `generator`. Message `sequence` counts per channel from 0; `publish_time = log_time`.
///
/// # Errors
/// [`SynthError::BadName`] for a frame whose topic is not on the bus; I/O and MCAP encoder
/// errors. On any error no file is left at `path`.
pub fn write_mcap(
    path: &Path,
    bus: &CanBus,
    frames: &[CanFrame],
    opts: &SynthOptions,
) -> Result<(), SynthError> {
    write_mcap_with(path, bus, frames, opts, McapCompression::Zstd, 0)
}

/// [`write_mcap`] with the chunk compression and its level chosen (`level` 0: the encoder's
/// default, zstd 3 or LZ4's fast mode; zstd 1…22, LZ4 1…12 with ≥ 3 its high-compression
/// mode). Chunks hold at most 1 MiB of uncompressed records (the encoder's default); every chunk
/// carries its CRC; message indexes and the summary are written.
///
/// # Errors
/// As [`write_mcap`]; [`SynthError::BadCompressionLevel`] for a level above the encoder's.
pub fn write_mcap_with(
    path: &Path,
    bus: &CanBus,
    frames: &[CanFrame],
    opts: &SynthOptions,
    compression: McapCompression,
    level: u32,
) -> Result<(), SynthError> {
    let (name, max) = match compression {
        McapCompression::Zstd => ("zstd", 22),
        McapCompression::Lz4 => ("lz4", 12),
    };
    if level > max {
        return Err(SynthError::BadCompressionLevel {
            compression: name,
            level,
            max,
        });
    }
    let io_err = |source| SynthError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mcap_err = |source| SynthError::Mcap {
        path: path.to_path_buf(),
        source: Box::new(source),
    };
    let tmp = AtomicFile::create(path).map_err(io_err)?;
    let handle = BufWriter::new(tmp.try_clone_file().map_err(io_err)?);
    let mut w = mcap::WriteOptions::new()
        .compression(Some(match compression {
            McapCompression::Zstd => mcap::Compression::Zstd,
            McapCompression::Lz4 => mcap::Compression::Lz4,
        }))
        .compression_threads(0)
        .compression_level(level)
        .library("fleetdyn-synth")
        .create(handle)
        .map_err(mcap_err)?;
    let mut metadata = BTreeMap::new();
    metadata.insert("drive_id".to_string(), opts.drive_id.clone());
    if let Some(v) = &opts.vehicle_id {
        metadata.insert("vehicle_id".to_string(), v.clone());
    }
    metadata.insert("seed".to_string(), opts.seed.to_string());
    metadata.insert(
        "generator".to_string(),
        format!("fleetdyn {} synth::can", env!("CARGO_PKG_VERSION")),
    );
    w.write_metadata(&mcap::records::Metadata {
        name: "drive".into(),
        metadata,
    })
    .map_err(mcap_err)?;
    // topic -> (channel id, next sequence)
    let mut ids: BTreeMap<&str, (u16, u32)> = BTreeMap::new();
    for m in &bus.messages {
        if !frames.iter().any(|f| f.topic == m.topic) {
            continue;
        }
        let schema = w
            .add_schema(&m.name, "jsonschema", &json_schema(bus, m))
            .map_err(mcap_err)?;
        let id = w
            .add_channel(schema, &m.topic, "json", &BTreeMap::new())
            .map_err(mcap_err)?;
        ids.insert(&m.topic, (id, 0));
    }
    for f in frames {
        let (id, seq) = ids
            .get_mut(f.topic.as_str())
            .ok_or_else(|| SynthError::BadName {
                what: "frame topic not on the bus",
                name: f.topic.clone(),
            })?;
        let data = serde_json::to_vec(&Value::Object(f.fields.clone())).expect("JSON of numbers");
        let t = u64::try_from(f.log_time_ns).unwrap_or(0);
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: *id,
                sequence: *seq,
                log_time: t,
                publish_time: t,
            },
            &data,
        )
        .map_err(mcap_err)?;
        *seq += 1;
    }
    w.finish().map_err(mcap_err)?;
    let mut handle = w.into_inner();
    handle.flush().map_err(io_err)?;
    drop(handle);
    tmp.commit().map_err(io_err)
}
