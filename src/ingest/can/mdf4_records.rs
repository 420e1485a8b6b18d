//! The record layer of the MDF4 reader ([`super::mdf4`]): the records of one data group decoded
//! into CAN frames. **Sorted** groups (record id size 0, one channel group) hold fixed-size
//! records; **unsorted** groups have record ids of 1, 2, 4 or 8 bytes before each record,
//! several groups interleaved, VLSD channel groups carrying the frame payloads as `u32` length +
//! bytes. The time (s from the HD start, through the time channel's conversion) becomes ns since
//! the epoch; the payload is cut to the frame's `DataLength` (or the DLC's length). In an
//! unfinalised file cycle counters are not trusted and a truncated last record ends the data.

use super::frames::CanFrame;
use super::mdf4_blocks::Reader;
use super::mdf4_groups::{Conv, Field, FrameGroup, Group, Payload};
use super::CanError;
use std::borrow::Cow;

impl<'a> Reader<'a> {
    /// Walks the records of one data group; returns how many records of other groups were
    /// skipped and how many frame records could not be decoded (a corrupted field: a glitch
    /// that costs that frame, not the file).
    pub(super) fn records(
        &self,
        dg: u64,
        rec_id_size: u8,
        groups: &[Group],
        stream: &[u8],
        start_ns: i64,
        frames: &mut Vec<CanFrame>,
    ) -> Result<(u64, u64), CanError> {
        let id_len = match rec_id_size {
            0 | 1 | 2 | 4 | 8 => usize::from(rec_id_size),
            n => return Err(self.err(dg, "DG", format!("record id size {n}"))),
        };
        // VLSD payloads of each group's VLSD channel: the signal data, fetched once.
        let mut sd_cache: Vec<(u64, Cow<'a, [u8]>)> = Vec::new();
        for g in groups {
            if let Some(FrameGroup {
                payload: Payload::Vlsd(_, link),
                ..
            }) = &g.frames
            {
                let is_cg = *link != 0 && self.block(*link, &[b"##CG"]).is_ok();
                if *link != 0 && !is_cg && !sd_cache.iter().any(|c| c.0 == *link) {
                    sd_cache.push((*link, self.stream(*link, b"SD", 0)?));
                }
            }
        }
        let (mut skipped, mut corrupt) = (0u64, 0u64);
        if id_len == 0 {
            let [g] = groups else {
                return Err(self.err(
                    dg,
                    "DG",
                    format!("{} channel groups in a sorted data group", groups.len()),
                ));
            };
            let size = usize::try_from(g.record_bytes).unwrap_or(usize::MAX);
            if size == 0 || g.vlsd {
                return Ok((0, 0));
            }
            let mut n = stream.len() / size;
            if self.trust_cycle_counts && !self.unfinalised {
                let want = usize::try_from(g.cycle_count).unwrap_or(usize::MAX);
                if want > n {
                    return Err(self.err(
                        dg,
                        "DG",
                        format!(
                            "{want} records of {size} bytes stated, the data holds {} bytes",
                            stream.len()
                        ),
                    ));
                }
                n = want;
            }
            let Some(fg) = &g.frames else {
                return Ok((n as u64, 0));
            };
            let sd = self.vlsd_source(fg, &sd_cache);
            for k in 0..n {
                let rec = &stream[k * size..(k + 1) * size];
                if let Some(f) = self.frame(fg, g, rec, sd, &[], start_ns)? {
                    frames.push(f);
                }
            }
            return Ok((0, 0));
        }
        // Unsorted: record id, then the record (fixed) or u32 length + bytes (VLSD group).
        // VLSD group records: (group offset, virtual offset, payload range in `stream`).
        let mut vlsd_index: Vec<(u64, u64, usize, usize)> = Vec::new();
        let mut vlsd_pos: Vec<(u64, u64)> = groups
            .iter()
            .filter(|g| g.vlsd)
            .map(|g| (g.offset, 0))
            .collect();
        let mut fixed: Vec<(usize, usize)> = Vec::new(); // (group index, record start)
        let mut pos = 0usize;
        while pos < stream.len() {
            let Some(idb) = stream.get(pos..pos + id_len) else {
                break;
            };
            let mut idv = [0u8; 8];
            idv[..id_len].copy_from_slice(idb);
            let rid = u64::from_le_bytes(idv);
            let Some(gi) = groups.iter().position(|g| g.record_id == rid) else {
                return Err(self.err(
                    dg,
                    "DG",
                    format!("unknown record id {rid} at data byte {pos}"),
                ));
            };
            let g = &groups[gi];
            let body = pos + id_len;
            let next = if g.vlsd {
                let Some(lb) = stream.get(body..body + 4) else {
                    break;
                };
                let len = u32::from_le_bytes(lb.try_into().expect("4")) as usize;
                let end = body + 4 + len;
                if end > stream.len() {
                    break;
                }
                let slot = vlsd_pos
                    .iter_mut()
                    .find(|v| v.0 == g.offset)
                    .expect("every VLSD group has a slot");
                vlsd_index.push((g.offset, slot.1, body + 4, end));
                slot.1 += 4 + len as u64;
                end
            } else {
                let size = usize::try_from(g.record_bytes).unwrap_or(usize::MAX);
                let end = body.saturating_add(size);
                if end > stream.len() {
                    break;
                }
                fixed.push((gi, body));
                end
            };
            pos = next;
        }
        if pos < stream.len() && !self.unfinalised {
            return Err(self.err(
                dg,
                "DG",
                format!("truncated record at data byte {pos} of {}", stream.len()),
            ));
        }
        let per_group: Vec<Vec<(u64, &[u8])>> = groups
            .iter()
            .map(|g| {
                g.frames
                    .as_ref()
                    .map(|fg| vlsd_index_for(fg, &vlsd_index, stream))
                    .unwrap_or_default()
            })
            .collect();
        for (gi, body) in fixed {
            let g = &groups[gi];
            let Some(fg) = &g.frames else {
                skipped += 1;
                continue;
            };
            let rec = &stream[body..body + g.record_bytes as usize];
            let sd = self.vlsd_source(fg, &sd_cache);
            match self.frame(fg, g, rec, sd, &per_group[gi], start_ns) {
                Ok(Some(f)) => frames.push(f),
                Ok(None) => {}
                Err(_) => corrupt += 1,
            }
        }
        Ok((skipped, corrupt))
    }

    fn vlsd_source<'c>(&self, fg: &FrameGroup, cache: &'c [(u64, Cow<'a, [u8]>)]) -> &'c [u8] {
        match &fg.payload {
            Payload::Vlsd(_, link) => cache
                .iter()
                .find(|c| c.0 == *link)
                .map_or(&[][..], |c| &c.1[..]),
            Payload::Fixed(_) => &[],
        }
    }

    fn frame(
        &self,
        fg: &FrameGroup,
        g: &Group,
        rec: &[u8],
        sd: &[u8],
        vlsd_records: &[(u64, &[u8])],
        start_ns: i64,
    ) -> Result<Option<CanFrame>, CanError> {
        let bad = |what: &str| self.err(g.offset, "CG", format!("record does not hold its {what}"));
        let t_raw = read_bits(rec, fg.time).ok_or_else(|| bad("time"))?;
        let t_val = match (fg.time.data_type, fg.time.bit_count) {
            (4 | 5, 32) => f64::from(f32::from_bits(t_raw as u32)),
            (4 | 5, _) => f64::from_bits(t_raw),
            (2 | 3, n) if n < 64 => {
                let s = 64 - n;
                (((t_raw << s) as i64) >> s) as f64
            }
            (2 | 3, _) => t_raw as i64 as f64,
            _ => t_raw as f64,
        };
        let seconds = match fg.time_conv {
            Conv::Identity => t_val,
            Conv::Linear { offset, factor } => offset + factor * t_val,
        };
        if !seconds.is_finite() || seconds.abs() > 1e10 {
            return Err(self.err(g.offset, "CG", format!("frame time {seconds} s")));
        }
        let t_ns = start_ns.saturating_add((seconds * 1e9).round() as i64);
        let raw_id = read_bits(rec, fg.id).ok_or_else(|| bad("ID"))?;
        let (mut id, mut extended) = ((raw_id & 0x1FFF_FFFF) as u32, raw_id & (1 << 31) != 0);
        if let Some(f) = fg.ide {
            extended = read_bits(rec, f).ok_or_else(|| bad("IDE"))? != 0;
        }
        if !extended {
            id &= 0x7FF;
        }
        let bus = match fg.bus {
            Some(f) => read_bits(rec, f).ok_or_else(|| bad("BusChannel"))? as u8,
            None => 0,
        };
        let len = match (fg.data_length, fg.dlc) {
            (Some(f), _) => Some(read_bits(rec, f).ok_or_else(|| bad("DataLength"))? as usize),
            (None, Some(f)) => Some(dlc_bytes(read_bits(rec, f).ok_or_else(|| bad("DLC"))?)),
            _ => None,
        };
        let payload: &[u8] = match &fg.payload {
            Payload::Fixed(f) => {
                let start = f.byte_offset as usize;
                let n = (f.bit_count / 8) as usize;
                rec.get(start..start + n).ok_or_else(|| bad("DataBytes"))?
            }
            Payload::Vlsd(f, _) => {
                let off = read_bits(rec, *f).ok_or_else(|| bad("DataBytes offset"))?;
                if sd.is_empty() && !vlsd_records.is_empty() {
                    match vlsd_records.binary_search_by_key(&off, |r| r.0) {
                        Ok(i) => vlsd_records[i].1,
                        Err(_) => {
                            return Err(self.err(
                                g.offset,
                                "CG",
                                format!("DataBytes offset {off} names no VLSD record"),
                            ))
                        }
                    }
                } else {
                    let o = usize::try_from(off).unwrap_or(usize::MAX);
                    let n = sd
                        .get(o..o.saturating_add(4))
                        .map(|b| u32::from_le_bytes(b.try_into().expect("4")) as usize)
                        .ok_or_else(|| {
                            self.err(
                                g.offset,
                                "CG",
                                format!(
                                    "DataBytes offset {off} outside the signal data ({} bytes)",
                                    sd.len()
                                ),
                            )
                        })?;
                    sd.get(o + 4..o + 4 + n).ok_or_else(|| {
                        self.err(
                            g.offset,
                            "CG",
                            format!(
                                "DataBytes of {n} bytes at offset {off} outside the signal data"
                            ),
                        )
                    })?
                }
            }
        };
        let payload = match len {
            Some(l) if l < payload.len() => &payload[..l],
            _ => payload,
        };
        Ok(Some(CanFrame::new(t_ns, id, extended, bus, payload)))
    }
}

/// The VLSD-group records a frame group's DataBytes channel points to, by virtual offset.
fn vlsd_index_for<'s>(
    fg: &FrameGroup,
    index: &[(u64, u64, usize, usize)],
    stream: &'s [u8],
) -> Vec<(u64, &'s [u8])> {
    let Payload::Vlsd(_, link) = &fg.payload else {
        return Vec::new();
    };
    index
        .iter()
        .filter(|r| r.0 == *link)
        .map(|r| (r.1, &stream[r.2..r.3]))
        .collect()
}

/// Payload length of a CAN / CAN FD data length code.
pub fn dlc_bytes(dlc: u64) -> usize {
    match dlc {
        0..=8 => dlc as usize,
        9 => 12,
        10 => 16,
        11 => 20,
        12 => 24,
        13 => 32,
        14 => 48,
        _ => 64,
    }
}

/// Reads an unsigned little-endian (data type 0, 2, 4) or big-endian (1, 3, 5) bit field.
fn read_bits(rec: &[u8], f: Field) -> Option<u64> {
    if f.bit_count == 0 || f.bit_count > 64 {
        return None;
    }
    let start = f.byte_offset as usize;
    let nbytes = (usize::from(f.bit_offset) + f.bit_count as usize).div_ceil(8);
    let bytes = rec.get(start..start.checked_add(nbytes)?)?;
    let big = matches!(f.data_type, 1 | 3 | 5);
    let mut v: u128 = 0;
    if big {
        for &b in bytes {
            v = (v << 8) | u128::from(b);
        }
    } else {
        for &b in bytes.iter().rev() {
            v = (v << 8) | u128::from(b);
        }
    }
    if !big {
        v >>= f.bit_offset;
    }
    let mask = if f.bit_count == 64 {
        u128::from(u64::MAX)
    } else {
        (1u128 << f.bit_count) - 1
    };
    Some((v & mask) as u64)
}
