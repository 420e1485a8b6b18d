//! Writes CAN frames as an ASAM MDF 4.11 bus-logging file, in the layouts [`super::mdf4`] reads.
//!
//! For fixtures (excerpts of real logs, `examples/cut_mdf4.rs`) and for testing the reader on
//! every layout it accepts; not a general MDF writer. The file has one `CAN_DataFrame` channel
//! group with the record CANedge loggers write: `Timestamp` (u64 ns from the HD start time,
//! conversion 1e-9 → s), then a composed `CAN_DataFrame` channel with `.IDE` (bit 0), `.BusChannel`
//! (bits 1–2), `.ID` (bits 3–31) in bytes 8–11, `.Dir` and `.DataLength` in byte 12, `.DLC` in
//! byte 13 (bits 4–7), and `.DataBytes` from byte 14: 8 bytes in the record
//! ([`Layout::Fixed`]) or a `u64` offset into variable-length signal data ([`Layout::SignalData`],
//! [`Layout::Unsorted`]).

use super::frames::CanFrame;
use std::io::Write;

/// Where the payloads go and how the records are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// Sorted records with the 8 payload bytes inside (classical CAN only: longer payloads are
    /// cut to 8 bytes).
    Fixed,
    /// Sorted records, payloads in an SD block (what CANedge loggers write).
    SignalData,
    /// One unsorted data group: 1-byte record ids, the frame group (id 1) and a VLSD channel
    /// group (id 2) whose records carry the payloads.
    Unsorted,
}

/// How data blocks are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// One DT (and SD) block.
    Plain,
    /// Deflated in DZ blocks of at most `chunk_bytes` original bytes each, under an HL → DL list;
    /// `transpose` stores fixed-size records column by column first (DZ zip type 1).
    Zipped {
        /// Original bytes per DZ block.
        chunk_bytes: usize,
        /// Transpose records before deflating.
        transpose: bool,
    },
}

const RECORD_BYTES: usize = 22;

/// A composition child: name, byte offset, bit offset, bit count, (cn_type, sync, data type).
type ChildSpec = (&'static str, u32, u8, u32, (u8, u8, u8));

struct Writer {
    buf: Vec<u8>,
}

impl Writer {
    fn block(&mut self, id: &[u8; 4], links: &[u64], data: &[u8]) -> u64 {
        while !self.buf.len().is_multiple_of(8) {
            self.buf.push(0);
        }
        let at = self.buf.len() as u64;
        let len = 24 + 8 * links.len() + data.len();
        self.buf.extend_from_slice(id);
        self.buf.extend_from_slice(&[0; 4]);
        self.buf.extend_from_slice(&(len as u64).to_le_bytes());
        self.buf
            .extend_from_slice(&(links.len() as u64).to_le_bytes());
        for l in links {
            self.buf.extend_from_slice(&l.to_le_bytes());
        }
        self.buf.extend_from_slice(data);
        at
    }

    fn text(&mut self, s: &str) -> u64 {
        let mut d = s.as_bytes().to_vec();
        d.push(0);
        while !d.len().is_multiple_of(8) {
            d.push(0);
        }
        self.block(b"##TX", &[], &d)
    }

    /// A CN block; returns its offset.
    #[allow(clippy::too_many_arguments)]
    fn channel(
        &mut self,
        next: u64,
        composition: u64,
        name: &str,
        cc: u64,
        data_link: u64,
        kind: (u8, u8, u8),
        byte_offset: u32,
        bit_offset: u8,
        bit_count: u32,
    ) -> u64 {
        let tx = self.text(name);
        let mut d = Vec::with_capacity(72);
        d.extend_from_slice(&[kind.0, kind.1, kind.2, bit_offset]);
        d.extend_from_slice(&byte_offset.to_le_bytes());
        d.extend_from_slice(&bit_count.to_le_bytes());
        d.extend_from_slice(&0u32.to_le_bytes()); // flags
        d.extend_from_slice(&0u32.to_le_bytes()); // invalidation bit position
        d.extend_from_slice(&[0, 0, 0, 0]); // precision, reserved, attachment count
        d.extend_from_slice(&[0; 48]); // value and limit ranges
        self.block(
            b"##CN",
            &[next, composition, tx, 0, cc, data_link, 0, 0],
            &d,
        )
    }

    fn data(&mut self, kind: &[u8; 2], bytes: &[u8], storage: Storage, columns: usize) -> u64 {
        match storage {
            Storage::Plain => {
                let id = [b'#', b'#', kind[0], kind[1]];
                self.block(&id, &[], bytes)
            }
            Storage::Zipped {
                chunk_bytes,
                transpose,
            } => {
                let step = chunk_bytes.max(1);
                let step = if transpose && columns > 0 {
                    (step / columns).max(1) * columns
                } else {
                    step
                };
                let mut dz = Vec::new();
                for chunk in bytes.chunks(step) {
                    let (zip_type, param, src) = if transpose && columns > 0 {
                        let rows = chunk.len() / columns;
                        let mut t = chunk.to_vec();
                        for r in 0..rows {
                            for c in 0..columns {
                                t[c * rows + r] = chunk[r * columns + c];
                            }
                        }
                        (1u8, columns as u32, t)
                    } else {
                        (0u8, 0u32, chunk.to_vec())
                    };
                    let mut z =
                        flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
                    z.write_all(&src).expect("in-memory write");
                    let zipped = z.finish().expect("in-memory write");
                    let mut d = Vec::with_capacity(24 + zipped.len());
                    d.extend_from_slice(kind);
                    d.push(zip_type);
                    d.push(0);
                    d.extend_from_slice(&param.to_le_bytes());
                    d.extend_from_slice(&(chunk.len() as u64).to_le_bytes());
                    d.extend_from_slice(&(zipped.len() as u64).to_le_bytes());
                    d.extend_from_slice(&zipped);
                    dz.push((self.block(b"##DZ", &[], &d), chunk.len() as u64));
                }
                let mut links = vec![0u64];
                links.extend(dz.iter().map(|d| d.0));
                let mut d = vec![0u8; 4]; // flags 0: offsets listed
                d.extend_from_slice(&(dz.len() as u32).to_le_bytes());
                let mut off = 0u64;
                for (_, n) in &dz {
                    d.extend_from_slice(&off.to_le_bytes());
                    off += n;
                }
                let dl = self.block(b"##DL", &links, &d);
                let mut h = Vec::new();
                h.extend_from_slice(&0u16.to_le_bytes());
                h.push(if transpose { 1 } else { 0 });
                h.extend_from_slice(&[0; 5]);
                self.block(b"##HL", &[dl], &h)
            }
        }
    }
}

fn dlc_of(len: usize) -> u8 {
    match len {
        0..=8 => len as u8,
        9..=12 => 9,
        13..=16 => 10,
        17..=20 => 11,
        21..=24 => 12,
        25..=32 => 13,
        33..=48 => 14,
        _ => 15,
    }
}

/// The 22-byte record of one frame; `payload_field` fills bytes 14..22.
fn record(f: &CanFrame, start_ns: i64, payload_field: [u8; 8]) -> [u8; RECORD_BYTES] {
    let mut r = [0u8; RECORD_BYTES];
    let t = u64::try_from(f.t_ns.saturating_sub(start_ns)).unwrap_or(0);
    r[0..8].copy_from_slice(&t.to_le_bytes());
    let word = u32::from(f.extended) | (u32::from(f.bus & 3) << 1) | (f.id << 3);
    r[8..12].copy_from_slice(&word.to_le_bytes());
    let len = f.data().len();
    r[12] = (len.min(127) as u8) << 1;
    r[13] = dlc_of(len) << 4;
    r[14..22].copy_from_slice(&payload_field);
    r
}

/// Serialises `frames` (time-sorted, at or after `start_ns`) as an MDF 4.11 file.
pub fn write_mdf4(frames: &[CanFrame], start_ns: i64, layout: Layout, storage: Storage) -> Vec<u8> {
    let mut w = Writer {
        buf: Vec::with_capacity(1024 + frames.len() * 40),
    };
    // ID block
    w.buf.extend_from_slice(b"MDF     4.11    fleetdyn");
    w.buf.extend_from_slice(&[0; 4]);
    w.buf.extend_from_slice(&411u16.to_le_bytes());
    w.buf.resize(64, 0);
    // HD block placeholder (patched with the first DG at the end)
    let mut hd = Vec::new();
    hd.extend_from_slice(&u64::try_from(start_ns).unwrap_or(0).to_le_bytes());
    hd.extend_from_slice(&[0, 0, 0, 0, 2, 0, 0, 0]); // tz, dst = 0; offsets valid, UTC
    hd.extend_from_slice(&[0; 16]); // start angle, distance
    let hd_at = w.block(b"##HD", &[0, 0, 0, 0, 0, 0], &hd);
    debug_assert_eq!(hd_at, 64);

    // payload data and records
    let mut sd = Vec::new();
    let mut records = Vec::with_capacity(frames.len() * (RECORD_BYTES + 1));
    for f in frames {
        let field = match layout {
            Layout::Fixed => {
                let mut p = [0u8; 8];
                let n = f.data().len().min(8);
                p[..n].copy_from_slice(&f.data()[..n]);
                p
            }
            Layout::SignalData | Layout::Unsorted => (sd.len() as u64).to_le_bytes(),
        };
        if layout == Layout::Unsorted {
            records.push(2u8);
            records.extend_from_slice(&(f.data().len() as u32).to_le_bytes());
            records.extend_from_slice(f.data());
            records.push(1u8);
        }
        if layout != Layout::Fixed {
            sd.extend_from_slice(&(f.data().len() as u32).to_le_bytes());
            sd.extend_from_slice(f.data());
        }
        let mut r = record(f, start_ns, field);
        if layout == Layout::Fixed {
            r[12] = (f.data().len().min(8) as u8) << 1;
        }
        records.extend_from_slice(&r);
    }

    // channels: composition children (last first, so each can link its successor)
    let vlsd_cg_placeholder = u64::MAX;
    let bytes_link = match layout {
        Layout::Fixed => 0,
        Layout::SignalData => w.data(b"SD", &sd, storage, 0),
        Layout::Unsorted => vlsd_cg_placeholder,
    };
    let payload_kind = if layout == Layout::Fixed {
        (0, 0, 10)
    } else {
        (1, 0, 10)
    };
    let children: [ChildSpec; 7] = [
        ("CAN_DataFrame.BusChannel", 8, 1, 2, (0, 0, 0)),
        ("CAN_DataFrame.ID", 8, 3, 29, (0, 0, 0)),
        ("CAN_DataFrame.IDE", 8, 0, 1, (0, 0, 0)),
        ("CAN_DataFrame.DLC", 13, 4, 4, (0, 0, 0)),
        ("CAN_DataFrame.DataLength", 12, 1, 7, (0, 0, 0)),
        ("CAN_DataFrame.DataBytes", 14, 0, 64, payload_kind),
        ("CAN_DataFrame.Dir", 12, 0, 1, (0, 0, 0)),
    ];
    let mut next = 0u64;
    let mut bytes_cn = 0u64;
    for (name, byte, bit, count, kind) in children.iter().rev() {
        let link = if *name == "CAN_DataFrame.DataBytes" {
            bytes_link
        } else {
            0
        };
        next = w.channel(next, 0, name, 0, link, *kind, *byte, *bit, *count);
        if *name == "CAN_DataFrame.DataBytes" {
            bytes_cn = next;
        }
    }
    let frame_cn = w.channel(0, next, "CAN_DataFrame", 0, 0, (0, 0, 10), 8, 0, 112);
    let mut cc = Vec::new();
    cc.extend_from_slice(&[1, 0, 0, 0, 0, 0, 2, 0]); // linear, 2 values
    cc.extend_from_slice(&[0; 16]); // physical range
    cc.extend_from_slice(&0f64.to_le_bytes());
    cc.extend_from_slice(&1e-9f64.to_le_bytes());
    let cc_at = w.block(b"##CC", &[0, 0, 0, 0], &cc);
    let time_cn = w.channel(frame_cn, 0, "Timestamp", cc_at, 0, (2, 1, 0), 0, 0, 64);

    let cg_data = |record_id: u64, cycles: u64, flags: u16, bytes: u32| {
        let mut d = Vec::new();
        d.extend_from_slice(&record_id.to_le_bytes());
        d.extend_from_slice(&cycles.to_le_bytes());
        d.extend_from_slice(&flags.to_le_bytes());
        d.extend_from_slice(&0u16.to_le_bytes());
        d.extend_from_slice(&[0; 4]);
        d.extend_from_slice(&bytes.to_le_bytes());
        d.extend_from_slice(&0u32.to_le_bytes());
        d
    };
    let n = frames.len() as u64;
    let acq = w.text("CAN_DataFrame");
    let (cg, rec_id_size) = if layout == Layout::Unsorted {
        let vlsd_cg = w.block(
            b"##CG",
            &[0, 0, 0, 0, 0, 0],
            &cg_data(2, n, 1, sd.len() as u32),
        );
        // point DataBytes at the VLSD group
        let link_at = bytes_cn as usize + 24 + 5 * 8;
        w.buf[link_at..link_at + 8].copy_from_slice(&vlsd_cg.to_le_bytes());
        let cg = w.block(
            b"##CG",
            &[vlsd_cg, time_cn, acq, 0, 0, 0],
            &cg_data(1, n, 0, RECORD_BYTES as u32),
        );
        (cg, 1u8)
    } else {
        let cg = w.block(
            b"##CG",
            &[0, time_cn, acq, 0, 0, 0],
            &cg_data(0, n, 0, RECORD_BYTES as u32),
        );
        (cg, 0u8)
    };
    let columns = if layout == Layout::Unsorted {
        0
    } else {
        RECORD_BYTES
    };
    let dt = w.data(b"DT", &records, storage, columns);
    let dg = w.block(
        b"##DG",
        &[0, cg, dt, 0],
        &[rec_id_size, 0, 0, 0, 0, 0, 0, 0],
    );
    let first_dg = 64 + 24;
    w.buf[first_dg..first_dg + 8].copy_from_slice(&dg.to_le_bytes());
    w.buf
}

#[cfg(test)]
mod tests {
    use super::super::mdf4::parse_mdf4;
    use super::*;
    use std::path::Path;

    fn frames() -> Vec<CanFrame> {
        let t0 = 1_627_274_454_000_000_000;
        let mut v = Vec::new();
        for k in 0..300i64 {
            let b = (k % 251) as u8;
            v.push(CanFrame::new(
                t0 + 10_000_000 * k,
                0x7E8,
                false,
                1,
                &[4, 0x41, 0x0C, b, b ^ 0x5A, 0xAA, 0xAA, 0xAA],
            ));
            v.push(CanFrame::new(
                t0 + 10_000_000 * k + 1_000,
                0x0CF0_0400,
                true,
                2,
                &[b, 1, 2, 3, 4, 5, 6, 7],
            ));
            if k % 10 == 0 {
                // a short frame (DLC 3)
                v.push(CanFrame::new(
                    t0 + 10_000_000 * k + 2_000,
                    0x003,
                    false,
                    1,
                    &[1, 2, b],
                ));
            }
        }
        v
    }

    #[test]
    fn every_layout_and_storage_round_trips() {
        let fr = frames();
        let t0 = fr[0].t_ns;
        for layout in [Layout::Fixed, Layout::SignalData, Layout::Unsorted] {
            for storage in [
                Storage::Plain,
                Storage::Zipped {
                    chunk_bytes: 1000,
                    transpose: false,
                },
                Storage::Zipped {
                    chunk_bytes: 4096,
                    transpose: true,
                },
            ] {
                let bytes = write_mdf4(&fr, t0, layout, storage);
                let log = parse_mdf4(&bytes, Path::new("mem.mf4"))
                    .unwrap_or_else(|e| panic!("{layout:?} {storage:?}: {e}"));
                assert_eq!(log.start_ns, t0);
                assert_eq!(log.frames, fr, "{layout:?} {storage:?}");
            }
        }
    }

    #[test]
    fn malformed_files_are_errors_not_panics() {
        // Deterministic mutations (xorshift): truncations and byte flips of a small file of each
        // layout. Any result is fine except a panic.
        let fr: Vec<CanFrame> = frames().into_iter().take(40).collect();
        let t0 = fr[0].t_ns;
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut errors = 0;
        for layout in [Layout::SignalData, Layout::Unsorted] {
            let zipped = Storage::Zipped {
                chunk_bytes: 300,
                transpose: true,
            };
            for storage in [Storage::Plain, zipped] {
                let good = write_mdf4(&fr, t0, layout, storage);
                for _ in 0..400 {
                    let mut b = good.clone();
                    match rnd() % 3 {
                        0 => b.truncate((rnd() as usize) % good.len()),
                        1 => {
                            for _ in 0..1 + rnd() % 4 {
                                let i = (rnd() as usize) % b.len();
                                b[i] = rnd() as u8;
                            }
                        }
                        _ => {
                            // a random 8-byte value where a link or length may be
                            let i = ((rnd() as usize) % (b.len() / 8)) * 8;
                            b[i..i + 8].copy_from_slice(&rnd().to_le_bytes());
                        }
                    }
                    if parse_mdf4(&b, Path::new("fuzz.mf4")).is_err() {
                        errors += 1;
                    }
                }
            }
        }
        // the mutations do hit structure: most files must be rejected, not silently accepted
        assert!(errors > 400, "only {errors} of 1600 mutated files rejected");
    }

    #[test]
    fn errors_name_file_block_and_offset() {
        let fr = frames();
        let mut b = write_mdf4(&fr, fr[0].t_ns, Layout::SignalData, Storage::Plain);
        // point the HD's first data group outside the file
        b[88..96].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let e = parse_mdf4(&b, Path::new("x.mf4")).unwrap_err().to_string();
        assert!(
            e.contains("x.mf4") && e.contains("DG") && e.contains("1099511627776"),
            "{e}"
        );
        let e = parse_mdf4(b"MDF     3.30    ", Path::new("old.mdf"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("too short"), "{e}");
        let mut old = write_mdf4(&fr, fr[0].t_ns, Layout::Fixed, Storage::Plain);
        old[28..30].copy_from_slice(&330u16.to_le_bytes());
        let e = parse_mdf4(&old, Path::new("old.mdf"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("version 330"), "{e}");
    }
}
