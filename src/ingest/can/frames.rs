//! A raw CAN frame as a bus logger recorded it, before any DBC decoding.

/// Largest payload of a CAN FD frame, bytes (classical CAN carries at most 8).
pub const MAX_DATA_BYTES: usize = 64;

/// One received CAN (or CAN FD) data frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CanFrame {
    /// Reception time, ns since the Unix epoch (UTC).
    pub t_ns: i64,
    /// Arbitration id without flags: 11 bits for standard frames, 29 bits for extended ones.
    pub id: u32,
    /// Extended (29-bit, IDE = 1) identifier.
    pub extended: bool,
    /// Logger bus channel (1-based on CANedge; 0 when the source names none).
    pub bus: u8,
    len: u8,
    data: [u8; MAX_DATA_BYTES],
}

impl CanFrame {
    /// A frame; payloads longer than [`MAX_DATA_BYTES`] are cut to it (no CAN frame is longer).
    pub fn new(t_ns: i64, id: u32, extended: bool, bus: u8, payload: &[u8]) -> Self {
        let n = payload.len().min(MAX_DATA_BYTES);
        let mut data = [0u8; MAX_DATA_BYTES];
        data[..n].copy_from_slice(&payload[..n]);
        Self {
            t_ns,
            id,
            extended,
            bus,
            len: n as u8,
            data,
        }
    }

    /// The payload bytes.
    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_is_kept_and_capped() {
        let f = CanFrame::new(5, 0x7E8, false, 1, &[1, 2, 3]);
        assert_eq!(f.data(), &[1, 2, 3]);
        let long = [7u8; 80];
        assert_eq!(CanFrame::new(0, 1, false, 0, &long).data().len(), 64);
    }
}
