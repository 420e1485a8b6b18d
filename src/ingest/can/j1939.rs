//! SAE J1939 identifiers and parameter ranges: which parameter group a frame carries, and which
//! raw values mean "not available" or "error".
//!
//! A 29-bit J1939 identifier is, from the most significant bit: priority (3 bits), extended data
//! page (1), data page (1), PDU format PF (8), PDU specific PS (8), source address SA (8)
//! (SAE J1939-21 §5.2). The parameter group number is EDP·DP·PF·PS (18 bits). For PDU1 formats
//! (PF < 240) PS is the destination address, not part of the group, so it is masked to 0; for
//! PDU2 (PF ≥ 240) PS is the group extension and belongs to the PGN. A DBC file's J1939 message
//! id is a full identifier with some priority and source address; frames match it when their
//! PGNs are equal, whatever the priority, source and (PDU1) destination.
//!
//! Raw value ranges (SAE J1939-71 §5.1.4, "Parameter ranges"): for a parameter of one or more
//! whole bytes, the most significant byte 0xFE marks an error indicator and 0xFF "not available"
//! (so 0xFE/0xFF for one byte, 0xFE00–0xFEFF / 0xFF00–0xFFFF for two, …); for a discrete
//! parameter of fewer than 8 bits, all ones means not available and all ones minus one error
//! (2-bit states: `10` error, `11` not available). Both become missing values, never numbers.
//! One-bit parameters have no indicator values.
//!
//! Multi-packet groups (SAE J1939-21 §5.10, transport protocol): a connection-management frame
//! (TP.CM, PGN 0xEC00) announces a group of up to 1785 bytes, broadcast (BAM, control byte 32)
//! or to one destination (RTS, control byte 16); data-transfer frames (TP.DT, PGN 0xEB00) carry
//! it 7 bytes at a time after a sequence number 1, 2, …. [`reassemble`] turns each complete
//! transfer into one frame of the announced PGN (priority 6, the sender's source address, at the
//! time of its last packet), so groups like EC1 (engine configuration, 40 bytes, with the
//! reference torque) decode like single frames. A transfer with a missing or out-of-order packet
//! is dropped; groups longer than 64 bytes are dropped (no signal fleetdyn maps is in one).

/// The parameter group number of a 29-bit identifier (PDU1 destination masked).
pub fn pgn(id: u32) -> u32 {
    let pgn = (id >> 8) & 0x3_FFFF;
    let pf = (pgn >> 8) & 0xFF;
    if pf < 240 {
        pgn & 0x3_FF00
    } else {
        pgn
    }
}

/// The source address of a 29-bit identifier.
pub fn source_address(id: u32) -> u8 {
    (id & 0xFF) as u8
}

/// Why a raw J1939 value is not a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Indicator {
    /// The sender does not have the parameter ("not available").
    NotAvailable,
    /// The sender has the parameter but it is in error.
    Error,
}

/// Classifies the raw (unscaled, unsigned) value of a `bits`-long parameter.
pub fn indicator(raw: u64, bits: u32) -> Option<Indicator> {
    if bits == 0 || bits > 64 {
        return None;
    }
    if bits >= 8 && bits.is_multiple_of(8) {
        let top = (raw >> (bits - 8)) & 0xFF;
        return match top {
            0xFF => Some(Indicator::NotAvailable),
            0xFE => Some(Indicator::Error),
            _ => None,
        };
    }
    if bits < 2 {
        // a one-bit parameter has no room for the indicators
        return None;
    }
    let ones = if bits == 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    if raw == ones {
        Some(Indicator::NotAvailable)
    } else if raw == ones - 1 {
        Some(Indicator::Error)
    } else {
        None
    }
}

use super::frames::{CanFrame, MAX_DATA_BYTES};

const TP_CM: u32 = 0xEC00;
const TP_DT: u32 = 0xEB00;

struct Transfer {
    pgn: u32,
    size: usize,
    packets: u8,
    next_seq: u8,
    data: Vec<u8>,
}

/// The multi-packet groups of `frames` (time-sorted), each as one frame; see the module doc.
pub fn reassemble(frames: &[CanFrame]) -> Vec<CanFrame> {
    // open transfers by (bus, source address, destination address)
    let mut open: std::collections::HashMap<(u8, u8, u8), Transfer> =
        std::collections::HashMap::new();
    let mut out = Vec::new();
    for f in frames.iter().filter(|f| f.extended) {
        let pf_group = (f.id >> 8) & 0x3_FF00;
        let key = (f.bus, source_address(f.id), ((f.id >> 8) & 0xFF) as u8);
        let d = f.data();
        if pf_group == TP_CM && d.len() >= 8 && matches!(d[0], 16 | 32) {
            let size = usize::from(u16::from_le_bytes([d[1], d[2]]));
            let pgn = u32::from(d[5]) | u32::from(d[6]) << 8 | u32::from(d[7]) << 16;
            if (9..=MAX_DATA_BYTES).contains(&size) && d[3] > 0 {
                open.insert(
                    key,
                    Transfer {
                        pgn,
                        size,
                        packets: d[3],
                        next_seq: 1,
                        data: Vec::with_capacity(size + 7),
                    },
                );
            } else {
                open.remove(&key);
            }
        } else if pf_group == TP_DT && !d.is_empty() {
            let Some(t) = open.get_mut(&key) else {
                continue;
            };
            if d[0] != t.next_seq {
                open.remove(&key);
                continue;
            }
            t.data.extend_from_slice(&d[1..]);
            t.next_seq = t.next_seq.wrapping_add(1);
            if t.next_seq > t.packets || t.data.len() >= t.size {
                let t = open.remove(&key).expect("present");
                if t.data.len() >= t.size {
                    let id = (6 << 26) | (t.pgn << 8) | u32::from(key.1);
                    out.push(CanFrame::new(f.t_ns, id, true, f.bus, &t.data[..t.size]));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pdu2_keeps_the_group_extension() {
        // EEC1 from the engine (SA 0x00), priority 3: 0x0CF00400 -> PGN 0xF004 = 61444.
        assert_eq!(pgn(0x0CF0_0400), 61444);
        // the same PGN from another source and priority matches
        assert_eq!(pgn(0x18F0_04FE), 61444);
        // CCVS1 PGN 65265 = 0xFEF1
        assert_eq!(pgn(0x18FE_F100), 65265);
        assert_eq!(source_address(0x18FE_F117), 0x17);
    }

    #[test]
    fn pdu1_masks_the_destination() {
        // TSC1 (PGN 0 / 0x0000) to the engine (DA 0x00) and to the retarder (DA 0x0F).
        assert_eq!(pgn(0x0C00_000B), 0);
        assert_eq!(pgn(0x0C00_0F0B), 0);
        // EBC1-like PDU1 group 0xEF00 (PF 239 < 240) to DA 0x21
        assert_eq!(pgn(0x18EF_2100), 0xEF00);
        // data page bit belongs to the PGN
        assert_eq!(pgn(0x1DEF_2100), 0x1_EF00);
    }

    #[test]
    fn bam_transfer_becomes_one_frame() {
        // EC1 (PGN 65251 = 0xFEE3), 40 bytes from SA 0x00 in 6 packets; reference torque
        // (SPN 544, bytes 20-21, 1 N·m/bit) = 2600 N·m = 0x0A28
        let mut ec1 = [0u8; 40];
        ec1[19] = 0x28;
        ec1[20] = 0x0A;
        let bam = CanFrame::new(
            0,
            0x1CEC_FF00,
            true,
            1,
            &[32, 40, 0, 6, 0xFF, 0xE3, 0xFE, 0x00],
        );
        let mut frames = vec![bam];
        for k in 0..6u8 {
            let mut d = [0xFFu8; 8];
            d[0] = k + 1;
            for j in 0..7 {
                if let Some(&b) = ec1.get(usize::from(k) * 7 + j) {
                    d[1 + j] = b;
                }
            }
            frames.push(CanFrame::new(i64::from(k) + 1, 0x1CEB_FF00, true, 1, &d));
        }
        let out = reassemble(&frames);
        assert_eq!(out.len(), 1);
        assert_eq!(pgn(out[0].id), 65251);
        assert_eq!(source_address(out[0].id), 0);
        assert_eq!(out[0].t_ns, 6);
        assert_eq!(out[0].data(), &ec1[..]);
        // a lost packet drops the transfer
        frames.remove(3);
        assert!(reassemble(&frames).is_empty());
    }

    #[test]
    fn not_available_and_error_ranges() {
        assert_eq!(indicator(0xFF, 8), Some(Indicator::NotAvailable));
        assert_eq!(indicator(0xFE, 8), Some(Indicator::Error));
        assert_eq!(indicator(0xFA, 8), None);
        assert_eq!(indicator(0xFF12, 16), Some(Indicator::NotAvailable));
        assert_eq!(indicator(0xFE00, 16), Some(Indicator::Error));
        assert_eq!(indicator(0xFAFF, 16), None);
        assert_eq!(indicator(0xFFFF_FFFF, 32), Some(Indicator::NotAvailable));
        assert_eq!(indicator(0b11, 2), Some(Indicator::NotAvailable));
        assert_eq!(indicator(0b10, 2), Some(Indicator::Error));
        assert_eq!(indicator(0b01, 2), None);
        assert_eq!(indicator(0xF, 4), Some(Indicator::NotAvailable));
        assert_eq!(indicator(0xE, 4), Some(Indicator::Error));
        assert_eq!(indicator(1, 1), None);
        assert_eq!(indicator(0, 1), None);
    }
}
