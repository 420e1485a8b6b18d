//! Helpers shared by the integration tests: fixture paths and small input files written on the
//! fly (canonical Parquet, uncompressed MCAP) so each bad-input case is one clear edit.

#![allow(dead_code)]

use arrow::array::{ArrayRef, Float64Array, Int16Array, StringArray, TimestampNanosecondArray};
use arrow::datatypes::{Field, Schema};
use arrow::record_batch::RecordBatch;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

pub fn ts(t_ns: &[i64]) -> ArrayRef {
    Arc::new(TimestampNanosecondArray::from(t_ns.to_vec()).with_timezone("UTC"))
}

pub fn f64s(v: &[f64]) -> ArrayRef {
    Arc::new(Float64Array::from(v.to_vec()))
}

pub fn f64_opt(v: &[Option<f64>]) -> ArrayRef {
    Arc::new(Float64Array::from(v.to_vec()))
}

pub fn i16s(v: &[i16]) -> ArrayRef {
    Arc::new(Int16Array::from(v.to_vec()))
}

pub fn strs(v: &[&str]) -> ArrayRef {
    Arc::new(StringArray::from(v.to_vec()))
}

/// Writes a Parquet file with the given columns (no unit metadata: canonical SI assumed).
pub fn write_parquet(path: &Path, cols: Vec<(&str, ArrayRef)>) {
    let fields: Vec<Field> = cols
        .iter()
        .map(|(n, a)| Field::new(*n, a.data_type().clone(), true))
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let batch =
        RecordBatch::try_new(schema.clone(), cols.into_iter().map(|c| c.1).collect()).unwrap();
    let f = std::fs::File::create(path).unwrap();
    let mut w = parquet::arrow::ArrowWriter::try_new(f, schema, None).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
}

/// A plain moving drive at 10 Hz: n samples, speed 15 m/s, slope 2 %, gear 10.
pub struct Drive {
    pub t_ns: Vec<i64>,
    pub speed: Vec<Option<f64>>,
    pub slope: Vec<Option<f64>>,
    pub gear: Vec<i16>,
}

pub const T0_NS: i64 = 1_772_431_200_000_000_000; // 2026-03-02T06:00:00Z

impl Drive {
    pub fn new(n: usize) -> Self {
        Self {
            t_ns: (0..n as i64).map(|k| T0_NS + k * 100_000_000).collect(),
            speed: vec![Some(15.0); n],
            slope: vec![Some(0.02); n],
            gear: vec![10; n],
        }
    }

    pub fn write(&self, path: &Path) {
        write_parquet(
            path,
            vec![
                ("timestamp", ts(&self.t_ns)),
                ("vehicle_speed", f64_opt(&self.speed)),
                ("road_slope", f64_opt(&self.slope)),
                ("gear", i16s(&self.gear)),
            ],
        );
    }
}

/// Writes an MCAP file with JSON messages `(topic, log_time_ns, json)`.
pub fn write_mcap(
    path: &Path,
    messages: &[(&str, i64, String)],
    compression: Option<mcap::Compression>,
) {
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new()
        .compression(compression)
        .chunk_size(Some(4096))
        .create(f)
        .unwrap();
    let mut ids: BTreeMap<String, u16> = BTreeMap::new();
    let schema = w.add_schema("msg", "jsonschema", b"{}").unwrap();
    for (seq, (topic, t, json)) in messages.iter().enumerate() {
        let id = match ids.get(*topic) {
            Some(id) => *id,
            None => {
                let id = w
                    .add_channel(schema, topic, "json", &BTreeMap::new())
                    .unwrap();
                ids.insert(topic.to_string(), id);
                id
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: seq as u32,
            log_time: *t as u64,
            publish_time: *t as u64,
        };
        w.write_to_known_channel(&header, json.as_bytes()).unwrap();
    }
    w.finish().unwrap();
}

/// A small valid multi-rate MCAP drive: speed and slope at 10 Hz, 60 s at 15 m/s.
pub fn mcap_messages() -> Vec<(&'static str, i64, String)> {
    mcap_messages_at((0..600i64).map(|k| T0_NS + k * 100_000_000))
}

/// The same three J1939 JSON topics (54 km/h, 2 % slope, gear 10) at each time of `times`, ns:
/// speed at the time, slope 1 ms and gear 2 ms after it.
pub fn mcap_messages_at(times: impl Iterator<Item = i64>) -> Vec<(&'static str, i64, String)> {
    let mut m = Vec::new();
    for t in times {
        m.push((
            "/can/ccvs1",
            t,
            format!("{{\"WheelBasedVehicleSpeed\": {}}}", 54.0),
        ));
        m.push((
            "/can/slope",
            t + 1_000_000,
            "{\"RoadSlope\": 2}".to_string(),
        ));
        m.push((
            "/can/etc2",
            t + 2_000_000,
            "{\"TransmissionCurrentGear\": 10}".to_string(),
        ));
    }
    m
}

/// Runs the release binary from the repository top with `args`.
pub fn fleetdyn_at_top<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .current_dir(fixture(""))
        .args(args)
        .output()
        .unwrap()
}

/// Key–value metadata of a Parquet file.
pub fn parquet_kv(path: &Path) -> std::collections::HashMap<String, String> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let r = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    r.metadata()
        .file_metadata()
        .key_value_metadata()
        .unwrap()
        .iter()
        .map(|e| (e.key.clone(), e.value.clone().unwrap_or_default()))
        .collect()
}
