//! Decoded CAN signals → canonical channels, through a `can-dbc` mapping.
//!
//! A `can-dbc` mapping (`schemas/mappings/can-*.toml`) names, per canonical column, a DBC
//! `message` and `signal` and the signal's `unit` (converted to SI like every mapping);
//! `passthrough_signals` keep extra decoded signals as non-canonical columns in their own unit.
//!
//! Rules:
//! - Every DBC file is searched in the order given; the first holding the message wins.
//! - A mapped signal that no DBC defines is left out (listed as ignored); if its column is
//!   required by a stage, the usual missing-column error follows.
//! - J1939 messages may come from several source addresses (e.g. CCVS1 from the engine and from
//!   the tachograph). Unless the mapping pins `source_address`, the address that sent the
//!   message most often is used (the lowest on a tie), so two senders never interleave.
//! - A sample's time is its frame's time; its row is the frame's index in the session.
//! - With `valid_signal`, a sample whose validity signal (same message) decodes to 0 is NaN.
//! - `%` torque with `reference_torque_from`: the reference is the first valid value of that
//!   signal in the session (EC1 is static configuration); a session without it is a
//!   [`CanError::MissingReference`] naming the message.

use super::dbc::Database;
use super::frames::CanFrame;
use super::j1939;
use super::CanError;
use crate::ingest::channel::Channel;
use crate::ingest::mapping::{Mapping, SourceFormat};
use crate::ingest::IngestError;
use crate::schema::Interpolation;
use std::collections::BTreeMap;

/// What decoding a session yielded.
#[derive(Debug)]
pub struct Decoded {
    /// One channel per mapped signal found in the DBC files (canonical first, then
    /// pass-through), in SI (canonical) or the DBC unit (pass-through).
    pub channels: Vec<Channel>,
    /// Mapped signals that no DBC defines, and J1939 senders left out.
    pub ignored: Vec<String>,
    /// Frames that matched a mapped message.
    pub frames_used: u64,
}

struct Target {
    channel: usize,
    db: usize,
    message: usize,
    signal: usize,
    factor: Option<(String, String)>,
    valid: Option<usize>,
}

fn find(dbs: &[Database], message: &str, signal: &str) -> Option<(usize, usize, usize)> {
    dbs.iter().enumerate().find_map(|(d, db)| {
        let m = db.message_index(message)?;
        let s = db.messages[m]
            .signals
            .iter()
            .position(|s| s.name == signal)?;
        Some((d, m, s))
    })
}

fn valid_index(
    dbs: &[Database],
    db: usize,
    message: usize,
    name: Option<&str>,
    mapping: &Mapping,
) -> Result<Option<usize>, IngestError> {
    let Some(name) = name else {
        return Ok(None);
    };
    let m = &dbs[db].messages[message];
    m.signals
        .iter()
        .position(|s| s.name == name)
        .map(Some)
        .ok_or_else(|| IngestError::Mapping {
            mapping: mapping.origin.clone(),
            message: format!(
                "valid_signal {name} is not a signal of message {} in {}",
                m.name, dbs[db].origin
            ),
        })
}

/// Decodes the mapped signals of time-sorted `frames`; `files` names the session in errors.
///
/// # Errors
/// [`IngestError::Mapping`] for a mapping of another format; [`CanError::MissingReference`]
/// (as [`IngestError::Can`]) for `%` torque without its reference.
pub fn decode_channels(
    frames: &[CanFrame],
    dbs: &[Database],
    mapping: &Mapping,
    files: &str,
) -> Result<Decoded, IngestError> {
    if mapping.format != SourceFormat::CanDbc {
        return Err(IngestError::Mapping {
            mapping: mapping.origin.clone(),
            message: format!(
                "is a {} mapping; raw CAN logs need a can-dbc mapping",
                mapping.format.name()
            ),
        });
    }
    let resolved = mapping.resolve()?;
    let mut channels = Channel::for_signals(&resolved);
    let mut conversions: Vec<_> = resolved.iter().map(|r| r.conversion).collect();
    let mut ignored = Vec::new();
    let mut targets = Vec::new();
    let mut pinned: BTreeMap<(usize, usize), u8> = BTreeMap::new();
    let split = |s: &str| -> Option<(String, String)> {
        s.split_once('.')
            .map(|(m, g)| (m.to_string(), g.to_string()))
    };
    for (k, r) in resolved.iter().enumerate() {
        let src = &mapping.signals[&r.column];
        let (msg, sig) = split(&r.source).expect("can-dbc sources are MESSAGE.SIGNAL");
        match find(dbs, &msg, &sig) {
            Some((db, message, signal)) => {
                if let Some(sa) = src.source_address {
                    pinned.insert((db, message), sa);
                }
                let factor = match &r.reference_torque_from {
                    Some(f) => Some(split(f).ok_or_else(|| IngestError::Mapping {
                        mapping: mapping.origin.clone(),
                        message: format!(
                            "{}: reference_torque_from {f:?} is not MESSAGE.SIGNAL",
                            r.column
                        ),
                    })?),
                    None => None,
                };
                let valid = valid_index(dbs, db, message, src.valid_signal.as_deref(), mapping)?;
                targets.push(Target {
                    channel: k,
                    db,
                    message,
                    signal,
                    factor,
                    valid,
                });
            }
            None => ignored.push(format!(
                "{} <- {} (not in the DBC files)",
                r.column, r.source
            )),
        }
    }
    for (name, src) in &mapping.passthrough_signals {
        let (Some(msg), Some(sig)) = (&src.message, &src.signal) else {
            return Err(IngestError::Mapping {
                mapping: mapping.origin.clone(),
                message: format!("passthrough {name}: `message` and `signal` are required"),
            });
        };
        match find(dbs, msg, sig) {
            Some((db, message, signal)) => {
                let valid = valid_index(dbs, db, message, src.valid_signal.as_deref(), mapping)?;
                targets.push(Target {
                    channel: channels.len(),
                    db,
                    message,
                    signal,
                    factor: None,
                    valid,
                });
                channels.push(Channel::new(name, &src.unit, Interpolation::Linear));
                conversions.push(crate::units::Conversion::IDENTITY);
            }
            None => ignored.push(format!("{name} <- {msg}.{sig} (not in the DBC files)")),
        }
    }

    // Reference torques first: a static signal, its first valid value.
    for t in &targets {
        let Some((msg, sig)) = &t.factor else {
            continue;
        };
        let reference = find(dbs, msg, sig).and_then(|(d, m, s)| {
            let def = &dbs[d].messages[m];
            frames
                .iter()
                .filter(|f| dbs[d].message_for(f) == Some(m))
                .filter_map(|f| def.signal_value(s, f.data()))
                .find(|v| v.is_finite())
        });
        let used = frames
            .iter()
            .any(|f| dbs[t.db].message_for(f) == Some(t.message));
        match reference {
            Some(nm) => {
                if let crate::units::Conversion::Linear { factor, offset } =
                    &mut conversions[t.channel]
                {
                    *factor *= nm / 100.0;
                    *offset *= nm / 100.0;
                }
            }
            None if used => {
                return Err(CanError::MissingReference {
                    column: channels[t.channel].column.clone(),
                    message: msg.clone(),
                    signal: sig.clone(),
                    files: files.into(),
                }
                .into())
            }
            None => {}
        }
    }

    // J1939 sender per message: pinned, else the most frequent.
    let mut senders: BTreeMap<(usize, usize), BTreeMap<u8, u64>> = BTreeMap::new();
    for f in frames {
        for t in &targets {
            let db = &dbs[t.db];
            if db.messages[t.message].j1939 && db.message_for(f) == Some(t.message) {
                *senders
                    .entry((t.db, t.message))
                    .or_default()
                    .entry(j1939::source_address(f.id))
                    .or_default() += 1;
                break;
            }
        }
    }
    let mut chosen: BTreeMap<(usize, usize), u8> = BTreeMap::new();
    for (key, counts) in &senders {
        let sa = pinned.get(key).copied().unwrap_or_else(|| {
            counts
                .iter()
                .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))
                .map(|(sa, _)| *sa)
                .expect("non-empty")
        });
        chosen.insert(*key, sa);
        for (other, n) in counts {
            if *other != sa {
                ignored.push(format!(
                    "{} from source address {other} ({n} frames; using {sa})",
                    dbs[key.0].messages[key.1].name
                ));
            }
        }
    }

    // Targets grouped by (db, message) for one lookup per frame and database.
    let mut by_message: BTreeMap<(usize, usize), Vec<usize>> = BTreeMap::new();
    for (i, t) in targets.iter().enumerate() {
        by_message.entry((t.db, t.message)).or_default().push(i);
    }
    let dbs_used: Vec<usize> = {
        let mut v: Vec<usize> = targets.iter().map(|t| t.db).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let mut frames_used = 0u64;
    for (row, f) in frames.iter().enumerate() {
        let mut used = false;
        for &d in &dbs_used {
            let Some(m) = dbs[d].message_for(f) else {
                continue;
            };
            let Some(list) = by_message.get(&(d, m)) else {
                continue;
            };
            if let Some(&sa) = chosen.get(&(d, m)) {
                if j1939::source_address(f.id) != sa {
                    continue;
                }
            }
            let def = &dbs[d].messages[m];
            for &i in list {
                let t = &targets[i];
                if let Some(mut v) = def.signal_value(t.signal, f.data()) {
                    if let Some(k) = t.valid {
                        if def.signal_value(k, f.data()) != Some(1.0) {
                            v = f64::NAN;
                        }
                    }
                    channels[t.channel].push(f.t_ns, conversions[t.channel].apply(v), row as u64);
                    used = true;
                }
            }
        }
        frames_used += u64::from(used);
    }
    Ok(Decoded {
        channels,
        ignored,
        frames_used,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const DBC: &str = "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_:\n\nBO_ 2566844926 CCVS1: 8 X\n SG_ WheelBasedVehicleSpeed : 8|16@1+ (0.00390625,0) [0|250.996] \"km/h\" X\n\nBO_ 4 gnss_altitude: 4 X\n SG_ AltitudeValid : 0|1@1+ (1,0) [0|1] \"\" X\n SG_ Altitude : 1|18@1+ (0.1,-6000) [-6000|20000] \"m\" X\n\nBA_DEF_ \"ProtocolType\" STRING ;\nBA_ \"ProtocolType\" \"J1939\";\n";

    fn mapping(extra: &str) -> Mapping {
        Mapping::parse(
            &format!(
                "name = \"t\"\nformat = \"can-dbc\"\n[signals.vehicle_speed]\nmessage = \"CCVS1\"\nsignal = \"WheelBasedVehicleSpeed\"\nunit = \"km/h\"\n{extra}\n[signals.altitude]\nmessage = \"gnss_altitude\"\nsignal = \"Altitude\"\nunit = \"m\"\nvalid_signal = \"AltitudeValid\"\n"
            ),
            "t.toml",
        )
        .unwrap()
    }

    fn ccvs1(t: i64, sa: u32, kmh: f64) -> CanFrame {
        let raw = (kmh * 256.0) as u16;
        let [lo, hi] = raw.to_le_bytes();
        CanFrame::new(t, 0x18FE_F100 | sa, true, 1, &[0, lo, hi, 0, 0, 0, 0, 0])
    }

    fn altitude(t: i64, valid: bool, m: f64) -> CanFrame {
        let raw = ((m + 6000.0) / 0.1).round() as u32;
        let word = u32::from(valid) | (raw << 1);
        CanFrame::new(t, 4, false, 1, &word.to_le_bytes())
    }

    #[test]
    fn the_most_frequent_sender_wins_unless_pinned_and_invalid_values_are_missing() {
        let db = Database::parse(DBC, "t.dbc").unwrap();
        // the engine (SA 0x00) sends 36 km/h three times, the tachograph (SA 0xEE) 40 km/h twice
        let frames = vec![
            ccvs1(0, 0x00, 36.0),
            ccvs1(1, 0xEE, 40.0),
            ccvs1(2, 0x00, 36.0),
            ccvs1(3, 0xEE, 40.0),
            ccvs1(4, 0x00, 36.0),
            altitude(5, true, 101.3),
            altitude(6, false, -5400.0),
        ];
        let d = decode_channels(&frames, std::slice::from_ref(&db), &mapping(""), "f").unwrap();
        let v = &d.channels[1];
        assert_eq!(v.column, "vehicle_speed");
        assert_eq!(v.t_ns, [0, 2, 4]);
        assert!(v.values.iter().all(|&x| (x - 10.0).abs() < 1e-12));
        assert!(
            d.ignored.iter().any(|s| s.contains("source address 238")),
            "{:?}",
            d.ignored
        );
        let a = &d.channels[0];
        assert_eq!(a.column, "altitude");
        assert!((a.values[0] - 101.3).abs() < 1e-9);
        assert!(a.values[1].is_nan());

        let pinned = mapping("source_address = 238");
        let d = decode_channels(&frames, &[db], &pinned, "f").unwrap();
        let v = &d.channels[1];
        assert_eq!(v.t_ns, [1, 3]);
        assert!(v.values.iter().all(|&x| (x - 40.0 / 3.6).abs() < 1e-12));
    }
}
