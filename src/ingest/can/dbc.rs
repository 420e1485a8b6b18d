//! DBC decoding: which message a frame is, and the physical value of each of its signals.
//!
//! Parsing is done by the `can-dbc` crate (a maintained, complete grammar of Vector's DBC
//! format); the bit-level decoding is ours, because a decoder must get byte order, sign,
//! multiplexing and the J1939 indicator ranges exactly right and `can-dbc` only parses.
//!
//! ## Conventions
//! - **Bit numbering** (Vector DBC): bit `b` is bit `b % 8` (0 = least significant) of byte
//!   `b / 8`.
//! - **Intel / little-endian** (`@1`): the start bit is the signal's least significant bit; the
//!   signal occupies bits `start … start + size − 1` of the payload read as one little-endian
//!   integer.
//! - **Motorola / big-endian** (`@0`): the start bit is the signal's *most* significant bit; the
//!   following bits run downwards within a byte and continue at bit 7 of the next byte (the
//!   "sawtooth": from bit position 8·k the next is 8·(k+1)+7).
//! - **Sign** (`-`): two's complement over `size` bits. `SIG_VALTYPE_` 1 / 2 marks IEEE-754
//!   single / double signals (32 / 64 bits, in the signal's byte order).
//! - **Scaling**: physical = raw · factor + offset, in the DBC's unit string.
//! - **Multiplexing**: a signal marked `mN` is present only when the message's multiplexor
//!   switch (`M`) has raw value N. Extended multiplexing (`SG_MUL_VAL_`, e.g. OBD2 service →
//!   PID) names each signal's switch and the raw ranges that select it; switches may themselves
//!   be multiplexed (`m65M`), and a signal is present only when its whole chain is.
//! - **J1939** messages (database `ProtocolType` "J1939", or a message whose `VFrameFormat` is
//!   `J1939PG`, and always 29-bit) match frames by PGN (see [`super::j1939`]); their unsigned raw
//!   values in the "not available" / "error" ranges decode to NaN.
//! - A signal reaching past the end of a (short) payload decodes to NaN.

use super::frames::CanFrame;
use super::j1939;
use super::CanError;
use can_dbc::{AttributeDefinition, AttributeValue, AttributeValueType, ByteOrder};
use can_dbc::{MessageId, MultiplexIndicator, SignalExtendedValueType, ValueType};
use std::collections::HashMap;
use std::path::Path;

/// How a signal's raw bits are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawKind {
    /// Unsigned integer.
    Unsigned,
    /// Two's complement signed integer.
    Signed,
    /// IEEE-754 single precision (32 bits).
    Float32,
    /// IEEE-754 double precision (64 bits).
    Float64,
}

/// When a multiplexed signal is present: its switch's raw value lies in one of `ranges`.
#[derive(Debug, Clone, PartialEq)]
pub struct MuxCondition {
    /// Index of the switch signal within the message.
    pub switch: usize,
    /// Inclusive raw value ranges.
    pub ranges: Vec<(u64, u64)>,
}

/// One signal of a message.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalDef {
    /// Signal name.
    pub name: String,
    /// DBC start bit (see the module doc for its meaning per byte order).
    pub start_bit: u32,
    /// Length, bits (1–64).
    pub size: u32,
    /// Motorola (big-endian) when true, Intel otherwise.
    pub big_endian: bool,
    /// How the raw bits are read.
    pub kind: RawKind,
    /// Physical = raw · factor + offset.
    pub factor: f64,
    /// See `factor`.
    pub offset: f64,
    /// Unit string of the DBC.
    pub unit: String,
    /// Present only under this condition (multiplexed signals).
    pub mux: Option<MuxCondition>,
}

/// One message of a DBC.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageDef {
    /// Message name.
    pub name: String,
    /// Identifier without flags.
    pub id: u32,
    /// 29-bit identifier.
    pub extended: bool,
    /// Matched by PGN, with J1939 indicator ranges.
    pub j1939: bool,
    /// Signals in DBC order.
    pub signals: Vec<SignalDef>,
}

/// A parsed DBC file, ready to decode frames.
#[derive(Debug, Clone)]
pub struct Database {
    /// Where it came from (file path), for errors.
    pub origin: String,
    /// Messages in file order.
    pub messages: Vec<MessageDef>,
    exact: HashMap<(u32, bool), usize>,
    by_pgn: HashMap<u32, usize>,
}

const MAX_MUX_DEPTH: usize = 8;

impl Database {
    /// Reads and parses a DBC file (UTF-8, or Windows-1252 as DBC editors write it).
    ///
    /// # Errors
    /// [`CanError::Io`], [`CanError::Dbc`] (syntax, or a signal the decoder cannot read).
    pub fn load(path: &Path) -> Result<Self, CanError> {
        let bytes = std::fs::read(path).map_err(|e| CanError::Io {
            file: path.into(),
            source: e,
        })?;
        let text = match String::from_utf8(bytes) {
            Ok(s) => s,
            // Windows-1252 and Latin-1 agree on every character DBC syntax uses.
            Err(e) => e.into_bytes().iter().map(|&b| char::from(b)).collect(),
        };
        Self::parse(&text, &path.display().to_string())
    }

    /// Parses DBC text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`CanError::Dbc`].
    pub fn parse(text: &str, origin: &str) -> Result<Self, CanError> {
        let err = |message: String| CanError::Dbc {
            file: origin.into(),
            message,
        };
        let dbc = can_dbc::Dbc::try_from(text).map_err(|e| err(e.to_string()))?;
        let protocol_j1939 = dbc.attribute_values_database.iter().any(|a| {
            a.name == "ProtocolType"
                && matches!(&a.value, AttributeValue::String(s) if s == "J1939")
        });
        let frame_formats: Vec<String> = dbc
            .attribute_definitions
            .iter()
            .find_map(|d| match d {
                AttributeDefinition::Message(n, AttributeValueType::Enum(v))
                    if n == "VFrameFormat" =>
                {
                    Some(v.clone())
                }
                _ => None,
            })
            .unwrap_or_default();
        let mut messages = Vec::with_capacity(dbc.messages.len());
        for m in &dbc.messages {
            let (id, extended) = match m.id {
                MessageId::Standard(id) => (u32::from(id), false),
                MessageId::Extended(id) => (id, true),
            };
            let frame_format = match dbc.resolved_message_attribute(m.id, "VFrameFormat") {
                Some(AttributeValue::String(s)) => Some(s.clone()),
                Some(AttributeValue::Uint(i)) => frame_formats.get(*i as usize).cloned(),
                Some(AttributeValue::Int(i)) => usize::try_from(*i)
                    .ok()
                    .and_then(|i| frame_formats.get(i).cloned()),
                _ => None,
            };
            let j1939 = extended
                && (frame_format.as_deref() == Some("J1939PG")
                    || (protocol_j1939 && frame_format.is_none()));
            let mut signals = Vec::with_capacity(m.signals.len());
            for s in &m.signals {
                let kind = match dbc.extended_value_type_for_signal(m.id, &s.name) {
                    Some(SignalExtendedValueType::IEEEfloat32Bit) => RawKind::Float32,
                    Some(SignalExtendedValueType::IEEEdouble64bit) => RawKind::Float64,
                    _ if s.value_type == ValueType::Signed => RawKind::Signed,
                    _ => RawKind::Unsigned,
                };
                let size = u32::try_from(s.size).unwrap_or(u32::MAX);
                let start_bit = u32::try_from(s.start_bit).unwrap_or(u32::MAX);
                let bad = |what: &str| {
                    err(format!(
                        "message {} signal {}: {what} (start bit {}, size {})",
                        m.name, s.name, s.start_bit, s.size
                    ))
                };
                if !(1..=64).contains(&size) {
                    return Err(bad("length must be 1 to 64 bits"));
                }
                if start_bit >= 8 * 64 {
                    return Err(bad("start bit beyond a 64-byte frame"));
                }
                let big_endian = s.byte_order == ByteOrder::BigEndian;
                let bytes = last_byte(start_bit, size, big_endian) + 1;
                if u64::from(bytes) > m.size {
                    return Err(bad(&format!(
                        "its bits reach byte {bytes}, the message has {} bytes",
                        m.size
                    )));
                }
                if (kind == RawKind::Float32 && size != 32)
                    || (kind == RawKind::Float64 && size != 64)
                {
                    return Err(bad("IEEE float signals need 32 or 64 bits"));
                }
                signals.push(SignalDef {
                    name: s.name.clone(),
                    start_bit,
                    size,
                    big_endian,
                    kind,
                    factor: s.factor,
                    offset: s.offset,
                    unit: s.unit.clone(),
                    mux: None,
                });
            }
            // Multiplexing: extended (SG_MUL_VAL_) entries win over the plain `mN` marks.
            let switch = m
                .signals
                .iter()
                .position(|s| s.multiplexer_indicator == MultiplexIndicator::Multiplexor);
            let index = |name: &str| signals.iter().position(|s| s.name == name);
            let mut conds: Vec<Option<MuxCondition>> = vec![None; signals.len()];
            for (k, s) in m.signals.iter().enumerate() {
                let selector = match s.multiplexer_indicator {
                    MultiplexIndicator::MultiplexedSignal(v)
                    | MultiplexIndicator::MultiplexorAndMultiplexedSignal(v) => Some(v),
                    _ => None,
                };
                let ext: Vec<_> = dbc
                    .extended_multiplex
                    .iter()
                    .filter(|x| x.message_id == m.id && x.signal_name == s.name)
                    .collect();
                if let Some(x) = ext.first() {
                    let sw = index(&x.multiplexor_signal_name).ok_or_else(|| {
                        err(format!(
                            "message {}: signal {} is multiplexed by unknown signal {}",
                            m.name, s.name, x.multiplexor_signal_name
                        ))
                    })?;
                    let ranges = ext
                        .iter()
                        .flat_map(|x| x.mappings.iter().map(|r| (r.min_value, r.max_value)))
                        .collect();
                    conds[k] = Some(MuxCondition { switch: sw, ranges });
                } else if let Some(v) = selector {
                    let sw = switch.ok_or_else(|| {
                        err(format!(
                            "message {}: signal {} is multiplexed (m{v}) but the message has no multiplexor",
                            m.name, s.name
                        ))
                    })?;
                    conds[k] = Some(MuxCondition {
                        switch: sw,
                        ranges: vec![(v, v)],
                    });
                }
            }
            for (s, c) in signals.iter_mut().zip(conds) {
                s.mux = c;
            }
            // a cycle of switches would never resolve
            for k in 0..signals.len() {
                let mut at = k;
                for depth in 0.. {
                    match &signals[at].mux {
                        None => break,
                        Some(c) if depth < MAX_MUX_DEPTH => at = c.switch,
                        Some(_) => {
                            return Err(err(format!(
                                "message {}: multiplexor chain of {} deeper than {MAX_MUX_DEPTH} (a cycle?)",
                                m.name, signals[k].name
                            )))
                        }
                    }
                }
            }
            messages.push(MessageDef {
                name: m.name.clone(),
                id,
                extended,
                j1939,
                signals,
            });
        }
        let mut exact = HashMap::new();
        let mut by_pgn = HashMap::new();
        for (i, m) in messages.iter().enumerate() {
            if m.j1939 {
                by_pgn.entry(j1939::pgn(m.id)).or_insert(i);
            } else {
                exact.entry((m.id, m.extended)).or_insert(i);
            }
        }
        Ok(Self {
            origin: origin.into(),
            messages,
            exact,
            by_pgn,
        })
    }

    /// The message a frame carries: an exact identifier match first, then (29-bit frames) a
    /// J1939 message of the same PGN.
    pub fn message_for(&self, frame: &CanFrame) -> Option<usize> {
        self.exact
            .get(&(frame.id, frame.extended))
            .or_else(|| {
                frame
                    .extended
                    .then(|| self.by_pgn.get(&j1939::pgn(frame.id)))
                    .flatten()
            })
            .copied()
    }

    /// Index of a message by name.
    pub fn message_index(&self, name: &str) -> Option<usize> {
        self.messages.iter().position(|m| m.name == name)
    }
}

/// Index of the last payload byte a signal touches (0-based): `(start + size − 1) / 8` for
/// Intel (little-endian) order; for Motorola (big-endian) order, where the start bit is the most
/// significant and the bits run down within a byte, then to the next byte's bit 7, the byte of
/// the least significant bit.
fn last_byte(start_bit: u32, size: u32, big_endian: bool) -> u32 {
    if !big_endian {
        return (start_bit + size - 1) / 8;
    }
    let mut pos = start_bit;
    for _ in 1..size {
        pos = if pos.is_multiple_of(8) {
            pos + 15
        } else {
            pos - 1
        };
    }
    pos / 8
}

/// Raw bits of a signal, unsigned; `None` when it reaches past the payload.
pub fn raw_bits(data: &[u8], start_bit: u32, size: u32, big_endian: bool) -> Option<u64> {
    let bit = |pos: u32| -> Option<u64> {
        let byte = *data.get((pos / 8) as usize)?;
        Some(u64::from((byte >> (pos % 8)) & 1))
    };
    let mut raw = 0u64;
    if big_endian {
        let mut pos = start_bit;
        for i in 0..size {
            raw = (raw << 1) | bit(pos)?;
            if i + 1 < size {
                pos = if pos.is_multiple_of(8) {
                    pos + 15
                } else {
                    pos - 1
                };
            }
        }
    } else {
        for i in (0..size).rev() {
            raw = (raw << 1) | bit(start_bit.checked_add(i)?)?;
        }
    }
    Some(raw)
}

impl SignalDef {
    /// Physical value of this signal in `data` (NaN when the payload is too short or, for
    /// J1939, the raw value is an indicator), ignoring multiplexing.
    pub fn decode(&self, data: &[u8], j1939: bool) -> f64 {
        let Some(raw) = raw_bits(data, self.start_bit, self.size, self.big_endian) else {
            return f64::NAN;
        };
        // J1939 parameters are unsigned with an offset; a signal a DBC declares signed or float
        // is taken as it is
        if j1939 && self.kind == RawKind::Unsigned && j1939::indicator(raw, self.size).is_some() {
            return f64::NAN;
        }
        let x = match self.kind {
            RawKind::Unsigned => raw as f64,
            RawKind::Signed => {
                let shift = 64 - self.size;
                (((raw << shift) as i64) >> shift) as f64
            }
            RawKind::Float32 => f64::from(f32::from_bits(raw as u32)),
            RawKind::Float64 => f64::from_bits(raw),
        };
        x * self.factor + self.offset
    }
}

impl MessageDef {
    /// Whether signal `k` is present in `data` (its multiplexor chain selects it).
    pub fn is_present(&self, k: usize, data: &[u8]) -> bool {
        let mut at = k;
        for _ in 0..=MAX_MUX_DEPTH {
            let Some(c) = &self.signals[at].mux else {
                return true;
            };
            let sw = &self.signals[c.switch];
            let Some(raw) = raw_bits(data, sw.start_bit, sw.size, sw.big_endian) else {
                return false;
            };
            if !c.ranges.iter().any(|&(lo, hi)| (lo..=hi).contains(&raw)) {
                return false;
            }
            at = c.switch;
        }
        false
    }

    /// Signal `k` decoded from `data`: `None` when multiplexing leaves it out of this frame.
    pub fn signal_value(&self, k: usize, data: &[u8]) -> Option<f64> {
        self.is_present(k, data)
            .then(|| self.signals[k].decode(data, self.j1939))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_:\n\n";

    fn db(body: &str) -> Database {
        Database::parse(&format!("{HEADER}{body}"), "test.dbc").unwrap()
    }

    #[test]
    fn intel_unsigned_scaled() {
        // 12 bits from bit 4: payload bytes [0x30, 0x12] -> bits 4..15 = 0x123 = 291
        let d = db("BO_ 256 M: 8 X\n SG_ S : 4|12@1+ (0.5,-10) [0|0] \"km/h\" X\n");
        let m = &d.messages[0];
        let v = m.signal_value(0, &[0x30, 0x12, 0, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(v, 291.0 * 0.5 - 10.0);
        assert_eq!(m.signals[0].unit, "km/h");
    }

    #[test]
    fn motorola_sawtooth() {
        // 16-bit big-endian starting at bit 7 (MSB of byte 0): bytes 0x12 0x34 -> 0x1234
        let d = db("BO_ 256 M: 8 X\n SG_ S : 7|16@0+ (1,0) [0|0] \"\" X\n SG_ T : 3|12@0+ (1,0) [0|0] \"\" X\n");
        let m = &d.messages[0];
        let data = [0x12, 0x34, 0x56, 0, 0, 0, 0, 0];
        assert_eq!(m.signal_value(0, &data), Some(f64::from(0x1234)));
        // 12 bits from bit 3: bits 3..0 of byte 0 (0x2), then byte 1 (0x34) -> 0x234
        assert_eq!(m.signal_value(1, &data), Some(f64::from(0x234)));
        // OBD2 rpm as the CSS Electronics DBCs encode it: 31|16@0+ = bytes 3..4 big-endian
        assert_eq!(
            raw_bits(&[4, 0x41, 0x0C, 0x1A, 0xF8, 0, 0, 0], 31, 16, true),
            Some(0x1AF8)
        );
    }

    #[test]
    fn signed_both_orders() {
        let d = db("BO_ 256 M: 8 X\n SG_ A : 0|8@1- (1,0) [0|0] \"\" X\n SG_ B : 15|12@0- (0.1,0) [0|0] \"\" X\n");
        let m = &d.messages[0];
        // A = 0xFE = -2; B = byte1 0xFF, then high nibble of byte 2 (0xF) -> 0xFFF = -1
        let data = [0xFE, 0xFF, 0xF0, 0, 0, 0, 0, 0];
        assert_eq!(m.signal_value(0, &data), Some(-2.0));
        assert!((m.signal_value(1, &data).unwrap() + 0.1).abs() < 1e-12);
        // most negative 12-bit value: 0x800 -> -2048
        let data = [0, 0x80, 0x00, 0, 0, 0, 0, 0];
        assert!((m.signal_value(1, &data).unwrap() + 204.8).abs() < 1e-9);
    }

    #[test]
    fn float_signal() {
        let d =
            db("BO_ 256 M: 8 X\n SG_ F : 0|32@1- (1,0) [0|0] \"\" X\n\nSIG_VALTYPE_ 256 F : 1;\n");
        let m = &d.messages[0];
        let mut data = [0u8; 8];
        data[..4].copy_from_slice(&1.5f32.to_le_bytes());
        assert_eq!(m.signal_value(0, &data), Some(1.5));
    }

    #[test]
    fn simple_multiplexing() {
        let d = db("BO_ 256 M: 8 X\n SG_ Sw M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A m1 : 8|8@1+ (1,0) [0|0] \"\" X\n SG_ B m2 : 8|8@1+ (2,0) [0|0] \"\" X\n");
        let m = &d.messages[0];
        let f1 = [1, 10, 0, 0, 0, 0, 0, 0];
        let f2 = [2, 10, 0, 0, 0, 0, 0, 0];
        assert_eq!(m.signal_value(1, &f1), Some(10.0));
        assert_eq!(m.signal_value(2, &f1), None);
        assert_eq!(m.signal_value(1, &f2), None);
        assert_eq!(m.signal_value(2, &f2), Some(20.0));
    }

    #[test]
    fn extended_multiplexing_obd2() {
        // service 0x41 selects the PID switch; PID 0x0D selects the speed, 0x0C the rpm
        let d = db("BO_ 2024 OBD: 8 X\n SG_ Service M : 8|8@1+ (1,0) [0|0] \"\" X\n SG_ PID m65M : 16|8@1+ (1,0) [0|0] \"\" X\n SG_ Speed m13 : 24|8@1+ (1,0) [0|0] \"km/h\" X\n SG_ Rpm m12 : 31|16@0+ (0.25,0) [0|0] \"rpm\" X\n\nSG_MUL_VAL_ 2024 PID Service 65-65;\nSG_MUL_VAL_ 2024 Speed PID 13-13;\nSG_MUL_VAL_ 2024 Rpm PID 12-12;\n");
        let m = &d.messages[0];
        let speed = [3, 0x41, 0x0D, 87, 0xAA, 0xAA, 0xAA, 0xAA];
        let rpm = [4, 0x41, 0x0C, 0x1A, 0xF8, 0xAA, 0xAA, 0xAA];
        let other_service = [3, 0x42, 0x0D, 87, 0, 0, 0, 0];
        assert_eq!(m.signal_value(2, &speed), Some(87.0));
        assert_eq!(m.signal_value(3, &speed), None);
        assert_eq!(m.signal_value(3, &rpm), Some(f64::from(0x1AF8) * 0.25));
        assert_eq!(m.signal_value(2, &other_service), None);
    }

    #[test]
    fn j1939_pgn_match_and_not_available() {
        let d = db("BO_ 2364540158 EEC1: 8 X\n SG_ EngineSpeed : 24|16@1+ (0.125,0) [0|8031.875] \"rpm\" X\n SG_ Torque : 16|8@1+ (1,-125) [0|0] \"%\" X\n\nBA_DEF_ BO_ \"VFrameFormat\" ENUM \"StandardCAN\",\"ExtendedCAN\",\"reserved\",\"J1939PG\";\nBA_DEF_DEF_ \"VFrameFormat\" \"J1939PG\";\n");
        let m = &d.messages[0];
        assert!(m.j1939 && m.extended);
        // EEC1 (PGN 61444) sent by SA 0x00 at priority 3: a different id, the same PGN
        let data = [0, 0, 0x7D + 10, 0x50, 0x14, 0, 0, 0];
        let f = CanFrame::new(0, 0x0CF0_0400, true, 1, &data);
        assert_eq!(d.message_for(&f), Some(0));
        assert_eq!(m.signal_value(0, f.data()), Some(f64::from(0x1450) * 0.125));
        assert_eq!(m.signal_value(1, f.data()), Some(10.0));
        // not available / error become NaN
        let na = [0, 0, 0xFF, 0xFF, 0xFF, 0, 0, 0];
        assert!(m.signal_value(0, &na).unwrap().is_nan());
        assert!(m.signal_value(1, &na).unwrap().is_nan());
        let err = [0, 0, 0xFE, 0x00, 0xFE, 0, 0, 0];
        assert!(m.signal_value(0, &err).unwrap().is_nan());
        assert!(m.signal_value(1, &err).unwrap().is_nan());
        // an 11-bit frame with the same low bits does not match
        assert_eq!(
            d.message_for(&CanFrame::new(0, 0x400, false, 1, &data)),
            None
        );
        // another PGN does not match
        assert_eq!(
            d.message_for(&CanFrame::new(0, 0x18FE_F100, true, 1, &data)),
            None
        );
    }

    #[test]
    fn non_j1939_messages_keep_their_numbers_and_match_exactly() {
        let d = db("BO_ 2024 OBD: 8 X\n SG_ B : 0|8@1+ (1,0) [0|0] \"\" X\n");
        let m = &d.messages[0];
        assert!(!m.j1939);
        assert_eq!(m.signal_value(0, &[0xFF]), Some(255.0));
        assert_eq!(
            d.message_for(&CanFrame::new(0, 2024, false, 1, &[0])),
            Some(0)
        );
        assert_eq!(d.message_for(&CanFrame::new(0, 2024, true, 1, &[0])), None);
    }

    #[test]
    fn short_payload_is_missing_not_a_panic() {
        // a frame shorter than its message (a DLC below the DBC's size): the value is missing
        let d = db("BO_ 256 M: 8 X\n SG_ S : 56|8@1+ (1,0) [0|0] \"\" X\n");
        let m = &d.messages[0];
        assert!(m.signal_value(0, &[1, 2, 3]).unwrap().is_nan());
    }

    #[test]
    fn a_signal_beyond_its_message_is_refused() {
        // Motorola running off the end of an 8-byte message, Intel bits 60..75 of 8 bytes
        for sg in ["63|16@0+", "60|16@1+"] {
            let text = format!("{HEADER}BO_ 256 M: 8 X\n SG_ T : {sg} (1,0) [0|0] \"\" X\n");
            let Err(e) = Database::parse(&text, "test.dbc") else {
                panic!("{sg} was accepted");
            };
            let e = e.to_string();
            assert!(e.contains("the message has 8 bytes"), "{e}");
        }
    }

    /// Reference for both byte orders from a different formulation: the payload as one bit
    /// stream. Intel: little-endian bit index = start + i. Motorola: renumber bits MSB-first
    /// (sequential index 8·byte + 7 − bit), where the signal is `size` consecutive bits from its
    /// start bit's sequential index.
    fn reference_bits(data: &[u8], start: u32, size: u32, big_endian: bool) -> Option<u64> {
        let bit = |byte: usize, b: u32| data.get(byte).map(|x| u64::from((x >> b) & 1));
        let mut v = 0u64;
        if big_endian {
            let first = (start / 8) * 8 + (7 - start % 8);
            for k in first..first + size {
                v = (v << 1) | bit((k / 8) as usize, 7 - k % 8)?;
            }
        } else {
            for k in (start..start + size).rev() {
                v = (v << 1) | bit((k / 8) as usize, k % 8)?;
            }
        }
        Some(v)
    }

    #[test]
    fn the_last_byte_is_the_shortest_payload_raw_bits_read() {
        for big_endian in [false, true] {
            for start_bit in 0..64u32 {
                for size in 1..=64u32 {
                    let last = last_byte(start_bit, size, big_endian) as usize;
                    // Motorola signals that run past bit 63 walk off the 8 bytes: skip those
                    if last >= 16 {
                        continue;
                    }
                    let fits = |n: usize| raw_bits(&[0u8; 16][..n], start_bit, size, big_endian);
                    assert!(fits(last + 1).is_some(), "{start_bit} {size} {big_endian}");
                    assert!(fits(last).is_none(), "{start_bit} {size} {big_endian}");
                }
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn raw_bits_agree_with_the_bit_stream_reference(
            data in proptest::collection::vec(proptest::num::u8::ANY, 0..=16),
            start in 0u32..128,
            size in 1u32..=64,
            big_endian in proptest::bool::ANY,
        ) {
            proptest::prop_assert_eq!(
                raw_bits(&data, start, size, big_endian),
                reference_bits(&data, start, size, big_endian)
            );
        }
    }

    #[test]
    fn bad_dbc_is_a_typed_error() {
        let e = Database::parse("BO_ x", "broken.dbc").unwrap_err();
        assert!(e.to_string().contains("broken.dbc"), "{e}");
        let e = Database::parse(
            &format!("{HEADER}BO_ 1 M: 8 X\n SG_ S : 0|70@1+ (1,0) [0|0] \"\" X\n"),
            "long.dbc",
        )
        .unwrap_err();
        assert!(e.to_string().contains("1 to 64"), "{e}");
    }
}
