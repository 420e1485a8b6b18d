//! MCAP sources: JSON-encoded messages, one topic per CAN message group at its own rate.
//!
//! Messages are streamed with `mcap::io::MessageReader` (memory scales with the largest chunk,
//! not the file); every chunk's CRC is checked before its messages are used, as are the data and
//! summary section CRCs, so a corrupt file fails the drive instead of yielding wrong samples.
//! Only mapped topics are decoded. A sample's time is the message's `log_time` (ns, epoch).
//! A mapped field that is absent or `null` in a message becomes NaN (counted downstream); a
//! field of another JSON type (string, object) is an error naming the topic and message.

use super::channel::Channel;
use super::mapping::Mapping;
use super::IngestError;
use mcap::sans_io::LinearReaderOptions;
use serde_json::Value;
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// Largest record we accept (bounds memory on corrupt length fields), bytes.
const RECORD_LIMIT_BYTES: usize = 512 << 20;

/// What an MCAP file yielded.
#[derive(Debug)]
pub struct McapRead {
    /// One channel per mapped signal.
    pub channels: Vec<Channel>,
    /// Messages read (all topics).
    pub messages: u64,
    /// Topics present but not mapped.
    pub ignored: Vec<String>,
    /// Entries of the file's metadata records (e.g. `drive_id`, `vehicle_id`), later records
    /// overriding earlier ones.
    pub metadata: HashMap<String, String>,
}

/// Streaming options that check every chunk CRC before its messages are used, the data and
/// summary section CRCs, and bound a record's length (also used for MCAP CAN frames).
pub(crate) fn validated_options() -> LinearReaderOptions {
    LinearReaderOptions::default()
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_record_length_limit(RECORD_LIMIT_BYTES)
}

fn lookup<'a>(v: &'a Value, path: &[String]) -> Option<&'a Value> {
    path.iter().try_fold(v, |v, k| v.get(k))
}

/// Reads the mapped signals of an MCAP file.
///
/// # Errors
/// [`IngestError::Mcap`] for bad magic, truncated records/chunks and CRC mismatches;
/// [`IngestError::Json`] and [`IngestError::WrongDtype`] for undecodable messages.
pub fn read_mcap(path: &Path, mapping: &Mapping) -> Result<McapRead, IngestError> {
    let file = File::open(path).map_err(|e| IngestError::Io {
        file: path.into(),
        source: e,
    })?;
    let resolved = mapping.resolve()?;
    let mut channels = Channel::for_signals(&resolved);
    // topic -> indices of the signals it carries
    let mut by_topic: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, r) in resolved.iter().enumerate() {
        by_topic.entry(r.source.as_str()).or_default().push(i);
    }
    let reader =
        mcap::io::MessageReader::new_with_options(BufReader::new(file), validated_options());
    let mut messages = 0u64;
    let mut per_topic: HashMap<String, u64> = HashMap::new();
    let mut ignored: Vec<String> = Vec::new();
    for msg in reader {
        let msg = msg.map_err(|e| IngestError::Mcap {
            file: path.into(),
            messages,
            source: e,
        })?;
        messages += 1;
        let topic = msg.channel.topic.as_str();
        let index = {
            let n = per_topic.entry(topic.to_string()).or_insert(0);
            *n += 1;
            *n - 1
        };
        let Some(targets) = by_topic.get(topic) else {
            if !ignored.iter().any(|t| t == topic) {
                ignored.push(topic.to_string());
            }
            continue;
        };
        let time_ns = i64::try_from(msg.log_time).unwrap_or(i64::MAX);
        if msg.channel.message_encoding != "json" {
            return Err(IngestError::WrongDtype {
                file: path.into(),
                column: topic.into(),
                found: format!("message encoding `{}`", msg.channel.message_encoding),
                expected: "json".into(),
            });
        }
        let value: Value = serde_json::from_slice(&msg.data).map_err(|e| IngestError::Json {
            file: path.into(),
            topic: topic.into(),
            index,
            time_ns,
            source: e,
        })?;
        for &k in targets {
            let r = &resolved[k];
            let x = match lookup(&value, &r.field_path) {
                None | Some(Value::Null) => f64::NAN,
                Some(Value::Number(n)) => n.as_f64().unwrap_or(f64::NAN),
                Some(Value::Bool(b)) => f64::from(u8::from(*b)),
                Some(other) => {
                    return Err(IngestError::WrongDtype {
                        file: path.into(),
                        column: format!("{topic}:{}", r.field_path.join(".")),
                        found: format!("JSON {} in message {index}", json_kind(other)),
                        expected: "a JSON number".into(),
                    })
                }
            };
            channels[k].push(time_ns, r.conversion.apply(x), index);
        }
    }
    Ok(McapRead {
        channels,
        messages,
        ignored,
        metadata: metadata_entries(path),
    })
}

/// Key–value entries of every Metadata record listed in the summary section. Metadata is
/// optional provenance: a file without a summary, or one whose summary cannot be read, yields
/// none (its messages were already validated by the streaming pass).
fn metadata_entries(path: &Path) -> HashMap<String, String> {
    use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader};
    use std::io::{Read, Seek, SeekFrom};
    let mut out = HashMap::new();
    let Ok(mut file) = File::open(path) else {
        return out;
    };
    let mut reader = SummaryReader::new();
    while let Some(event) = reader.next_event() {
        let step = match event {
            Ok(SummaryReadEvent::ReadRequest(need)) => file
                .read(reader.insert(need))
                .map(|n| reader.notify_read(n)),
            Ok(SummaryReadEvent::SeekRequest(to)) => file.seek(to).map(|p| reader.notify_seeked(p)),
            Err(_) => return out,
        };
        if step.is_err() {
            return out;
        }
    }
    let Some(summary) = reader.finish() else {
        return out;
    };
    let mut indexes = summary.metadata_indexes;
    indexes.sort_by_key(|m| m.offset);
    for idx in indexes {
        // the index spans the whole record: opcode (1) + length (8) + body
        let Ok(len) = usize::try_from(idx.length) else {
            continue;
        };
        if !(9..=RECORD_LIMIT_BYTES).contains(&len)
            || file.seek(SeekFrom::Start(idx.offset)).is_err()
        {
            continue;
        }
        let mut buf = vec![0u8; len];
        if file.read_exact(&mut buf).is_err() {
            continue;
        }
        if let Ok(mcap::records::Record::Metadata(m)) = mcap::parse_record(buf[0], &buf[9..]) {
            out.extend(m.metadata);
        }
    }
    out
}

fn json_kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "bool",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
}
