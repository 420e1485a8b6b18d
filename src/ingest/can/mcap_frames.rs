//! Raw CAN frames in MCAP: the convention of ROS 2 CAN bridges and of JSON-publishing loggers.
//!
//! A channel carries frames when
//! - its message encoding is `cdr` and its schema is `can_msgs/msg/Frame` (ROS 2, e.g. the
//!   `ros2_socketcan` bridge): CDR little- or big-endian after the 4-byte encapsulation header;
//!   fields `std_msgs/Header header` (stamp: `int32 sec`, `uint32 nanosec`; `string frame_id`),
//!   `uint32 id`, `bool is_rtr`, `bool is_extended`, `bool is_error`, `uint8 dlc`,
//!   `uint8[8] data`, aligned as CDR aligns primitives (to their size, from the end of the
//!   encapsulation header). Remote and error frames are skipped; the payload is cut to the DLC.
//! - or its message encoding is `json` and its messages are objects with a numeric `id` and a
//!   `data` array of byte values (or a hex string), optional `bus` (number) and `extended`
//!   (bool; without it an id above 0x7FF is extended). Other JSON channels are not frames and
//!   are ignored.
//!
//! A frame's time is its message's `log_time` (ns since the epoch), as for every MCAP source in
//! fleetdyn. The MCAP is streamed with chunk and data CRCs checked (as in the JSON-signal MCAP
//! source). Frames are returned sorted by time (stable).

use super::frames::CanFrame;
use super::mdf4::BusLog;
use super::CanError;
use serde_json::Value;
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// The ROS 2 CAN frame message type.
pub const ROS2_CAN_FRAME: &str = "can_msgs/msg/Frame";

enum Kind {
    Cdr,
    Json,
    Other,
}

/// Reads the CAN frames of an MCAP file.
///
/// # Errors
/// [`CanError::Io`]; [`CanError::Mcap`] for an invalid MCAP file. A frame message that does not
/// decode is skipped and counted ([`BusLog::corrupt_records`]).
pub fn read_mcap_frames(path: &Path) -> Result<BusLog, CanError> {
    let file = File::open(path).map_err(|e| CanError::Io {
        file: path.into(),
        source: e,
    })?;
    let reader = mcap::io::MessageReader::new_with_options(
        BufReader::new(file),
        crate::ingest::mcap_source::validated_options(),
    );
    let mut frames = Vec::new();
    let (mut skipped, mut corrupt) = (0u64, 0u64);
    let mut kinds: HashMap<u16, Kind> = HashMap::new();
    for (messages, msg) in reader.enumerate() {
        let msg = msg.map_err(|e| CanError::Mcap {
            file: path.into(),
            message: format!("after {messages} messages: {e}"),
        })?;
        let ch = &msg.channel;
        let kind = kinds.entry(ch.id).or_insert_with(|| {
            let schema = ch.schema.as_ref().map(|s| s.name.as_str()).unwrap_or("");
            match ch.message_encoding.as_str() {
                "cdr" if schema == ROS2_CAN_FRAME => Kind::Cdr,
                "json" => Kind::Json,
                _ => Kind::Other,
            }
        });
        let t_ns = i64::try_from(msg.log_time).unwrap_or(i64::MAX);
        let frame = match kind {
            Kind::Cdr => match cdr_frame(&msg.data, t_ns) {
                Ok(f) => f,
                Err(_) => {
                    corrupt += 1;
                    continue;
                }
            },
            Kind::Json => match json_frame(&msg.data, t_ns) {
                Ok(f) => f,
                Err(JsonFrame::NotAFrame) => {
                    *kind = Kind::Other;
                    None
                }
                Err(JsonFrame::Bad) => {
                    corrupt += 1;
                    continue;
                }
            },
            Kind::Other => None,
        };
        match frame {
            Some(f) => frames.push(f),
            None => skipped += 1,
        }
    }
    frames.sort_by_key(|f: &CanFrame| f.t_ns);
    Ok(BusLog {
        file: path.into(),
        start_ns: frames.first().map_or(0, |f| f.t_ns),
        frames,
        skipped_records: skipped,
        corrupt_records: corrupt,
        unfinalised: false,
        format: "mcap",
    })
}

/// Decodes a CDR `can_msgs/msg/Frame`; `None` for remote and error frames.
///
/// # Errors
/// What does not fit, as text.
pub fn cdr_frame(data: &[u8], t_ns: i64) -> Result<Option<CanFrame>, String> {
    let head = data.get(..4).ok_or("shorter than the CDR header")?;
    let little = match head[1] {
        0 => false,
        1 => true,
        r => return Err(format!("encapsulation {r} is not plain CDR")),
    };
    let body = &data[4..];
    let mut pos = 0usize;
    let mut take = |n: usize, align: usize| -> Result<&[u8], String> {
        pos = pos.div_ceil(align) * align;
        let s = body
            .get(pos..pos + n)
            .ok_or_else(|| format!("ends at byte {} of a field at {pos}", body.len()))?;
        pos += n;
        Ok(s)
    };
    let u32_of = |b: &[u8]| {
        let a = [b[0], b[1], b[2], b[3]];
        if little {
            u32::from_le_bytes(a)
        } else {
            u32::from_be_bytes(a)
        }
    };
    take(4, 4)?; // stamp.sec
    take(4, 4)?; // stamp.nanosec
    let n = u32_of(take(4, 4)?) as usize; // frame_id length incl. NUL
    take(n, 1)?;
    let id = u32_of(take(4, 4)?);
    let flags = take(4, 1)?; // is_rtr, is_extended, is_error, dlc
    let payload = take(8, 1)?;
    let (rtr, extended, error, dlc) = (flags[0] != 0, flags[1] != 0, flags[2] != 0, flags[3]);
    if rtr || error {
        return Ok(None);
    }
    let len = usize::from(dlc).min(8);
    let id = if extended {
        id & 0x1FFF_FFFF
    } else {
        id & 0x7FF
    };
    Ok(Some(CanFrame::new(t_ns, id, extended, 0, &payload[..len])))
}

/// Why a JSON message is not a frame: not frame-shaped at all (the topic is not a frame topic),
/// or frame-shaped with a field that does not decode (a corrupted frame, skipped and counted).
enum JsonFrame {
    NotAFrame,
    Bad,
}

fn json_frame(data: &[u8], t_ns: i64) -> Result<Option<CanFrame>, JsonFrame> {
    let v: Value = serde_json::from_slice(data).map_err(|_| JsonFrame::NotAFrame)?;
    let (Some(id), Some(d)) = (v.get("id"), v.get("data")) else {
        return Err(JsonFrame::NotAFrame);
    };
    let id = id
        .as_u64()
        .filter(|&i| i <= 0x1FFF_FFFF)
        .ok_or(JsonFrame::Bad)?;
    let bytes: Vec<u8> = match d {
        Value::Array(a) => a
            .iter()
            .map(|b| b.as_u64().filter(|&b| b <= 255).map(|b| b as u8))
            .collect::<Option<_>>()
            .ok_or(JsonFrame::Bad)?,
        Value::String(s) => {
            let s: String = s.chars().filter(|c| !c.is_whitespace()).collect();
            if !s.len().is_multiple_of(2) {
                return Err(JsonFrame::Bad);
            }
            (0..s.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&s[i..i + 2], 16).ok())
                .collect::<Option<_>>()
                .ok_or(JsonFrame::Bad)?
        }
        _ => return Err(JsonFrame::Bad),
    };
    let extended = v
        .get("extended")
        .and_then(Value::as_bool)
        .unwrap_or(id > 0x7FF);
    let bus = v.get("bus").and_then(Value::as_u64).unwrap_or(0).min(255) as u8;
    Ok(Some(CanFrame::new(t_ns, id as u32, extended, bus, &bytes)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CDR `can_msgs/msg/Frame` as a ROS 2 publisher serialises it (little-endian).
    pub fn cdr(id: u32, extended: bool, data: &[u8], frame_id: &str) -> Vec<u8> {
        let mut b = vec![0, 1, 0, 0];
        let mut body = Vec::new();
        body.extend_from_slice(&12i32.to_le_bytes());
        body.extend_from_slice(&34u32.to_le_bytes());
        body.extend_from_slice(&(frame_id.len() as u32 + 1).to_le_bytes());
        body.extend_from_slice(frame_id.as_bytes());
        body.push(0);
        while !body.len().is_multiple_of(4) {
            body.push(0);
        }
        body.extend_from_slice(&id.to_le_bytes());
        body.extend_from_slice(&[0, u8::from(extended), 0, data.len() as u8]);
        let mut p = [0u8; 8];
        p[..data.len()].copy_from_slice(data);
        body.extend_from_slice(&p);
        b.extend_from_slice(&body);
        b
    }

    #[test]
    fn cdr_frames_decode_with_alignment() {
        for frame_id in ["", "can0", "a_longer_name"] {
            let b = cdr(0x0CF0_0400, true, &[1, 2, 3, 4, 5, 6, 7, 8], frame_id);
            let f = cdr_frame(&b, 7).unwrap().unwrap();
            assert_eq!((f.id, f.extended, f.t_ns), (0x0CF0_0400, true, 7));
            assert_eq!(f.data(), &[1, 2, 3, 4, 5, 6, 7, 8]);
        }
        let f = cdr_frame(&cdr(0x7E8, false, &[3, 0x41, 0x0D], "can0"), 0)
            .unwrap()
            .unwrap();
        assert_eq!(f.data(), &[3, 0x41, 0x0D]);
        let b = cdr(0x7E8, false, &[1], "can0");
        assert!(cdr_frame(&b[..b.len() - 3], 0).is_err());
    }

    #[test]
    fn json_frames_and_other_json() {
        let f = json_frame(br#"{"id": 419361024, "data": [1,2,3], "bus": 2}"#, 5)
            .ok()
            .flatten()
            .unwrap();
        assert_eq!((f.id, f.extended, f.bus), (0x18FE_F100, true, 2));
        assert_eq!(f.data(), &[1, 2, 3]);
        let f = json_frame(br#"{"id": 2024, "data": "03 41 0D 57"}"#, 5)
            .ok()
            .flatten()
            .unwrap();
        assert_eq!((f.id, f.extended), (2024, false));
        assert_eq!(f.data(), &[3, 0x41, 0x0D, 0x57]);
        assert!(matches!(
            json_frame(br#"{"speed": 3}"#, 0),
            Err(JsonFrame::NotAFrame)
        ));
        assert!(matches!(
            json_frame(br#"{"id": 1, "data": [300]}"#, 0),
            Err(JsonFrame::Bad)
        ));
    }
}
