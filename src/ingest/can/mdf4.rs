//! ASAM MDF4 bus logging: the CAN frames of an MDF 4.x file as CAN data loggers write it.
//!
//! A focused reader for the subset bus loggers (CSS Electronics CANedge, Vector, most data
//! loggers) write under the ASAM MDF 4.1 "bus logging" association standard, not a general MDF
//! library: the maintained Rust MDF crates read whole files into dataframe stacks (polars /
//! arrow2), which this project does not build (build time), and none decodes bus-logging groups.
//!
//! ## What is read
//! - **ID** block (file start): `MDF     ` or `UnFinMF ` (an unfinalised file, as a logger leaves
//!   it when the power goes; see below), version 4.x. MDF 3 is rejected.
//! - **HD** block (offset 64): first data group, measurement start time (ns since the epoch, UTC;
//!   a local start time is moved to UTC with the stored offsets).
//! - **DG** → **CG** → **CN** lists, **CC** (identity and linear conversions), **TX** names.
//!   Composed channels (`CAN_DataFrame` with children `CAN_DataFrame.ID`, `.IDE`, `.DLC`,
//!   `.DataLength`, `.DataBytes`, `.BusChannel`) and flat channels of the same names are both
//!   found. A channel group is a CAN data frame group when it has `CAN_DataFrame.ID` and
//!   `CAN_DataFrame.DataBytes` and a time master channel; other groups (error, remote and LIN
//!   frames) are skipped and counted.
//! - Data: **DT** (records), **SD** (variable-length signal data), **DL** lists (chained with
//!   `dl_next`), **HL** header lists, **DZ** (deflate, and deflate of transposed records) of DT
//!   or SD. **Sorted** groups (record id size 0, one channel group) and **unsorted** groups (record
//!   ids of 1, 2, 4 or 8 bytes before each record, several groups interleaved, VLSD channel groups
//!   carrying the frame payloads as `u32` length + bytes).
//! - `DataBytes` as a fixed-length byte array in the record, or as a VLSD channel (`cn_type` 1):
//!   the record holds a `u64` offset into the signal data (an SD block or list linked from the
//!   channel, or the records of a VLSD channel group linked from it). The payload is cut to the
//!   frame's `DataLength` (or the DLC's length).
//! - Times: the master channel (`cn_type` 2/3, sync type time) read as unsigned, signed or IEEE
//!   float of its bit count, through its conversion, in seconds from the HD start time. Frames
//!   are returned sorted by time (stable).
//!
//! ## Unfinalised files
//! `UnFinMF` files have flags saying what the logger could not update. With "length of the last
//! DT block not updated" the last DT block in the file runs to the end of the file; cycle counters
//! are not trusted (record counts come from the data length); a truncated last record ends the
//! data instead of failing. Finalised files get none of this leniency.
//!
//! ## What is rejected
//! Every offset and length is bounds-checked; anything else is a [`CanError::Mdf`] naming the
//! file, the block offset and what is wrong: bad magic or version, a link outside the file, a
//! block of the wrong type or with a length that does not fit, link cycles, unknown record ids,
//! records that do not fit their group, a time channel of another data type or conversion, a
//! DZ block that does not inflate to its stated length. The whole file is read into memory.

use super::frames::CanFrame;
use super::CanError;
use std::borrow::Cow;
use std::collections::HashSet;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The frames of one MDF4 file.
#[derive(Debug, Clone)]
pub struct BusLog {
    /// Source file.
    pub file: PathBuf,
    /// Measurement start (HD block), ns since the epoch (UTC).
    pub start_ns: i64,
    /// CAN data frames, sorted by time.
    pub frames: Vec<CanFrame>,
    /// Records of other groups (error, remote, LIN frames) that were skipped.
    pub skipped_records: u64,
    /// The file was unfinalised (`UnFinMF`).
    pub unfinalised: bool,
    /// `mdf4` or `mcap`.
    pub format: &'static str,
}

/// Largest inflated DZ block accepted, bytes (bounds memory on corrupt length fields).
const DZ_LIMIT_BYTES: u64 = 1 << 30;
/// Deepest nesting of data lists.
const LIST_DEPTH_LIMIT: usize = 4;

/// Reads the CAN frames of an MDF4 file.
///
/// # Errors
/// [`CanError::Io`] when the file cannot be read; [`CanError::Mdf`] as listed in the module doc.
pub fn read_mdf4(path: &Path) -> Result<BusLog, CanError> {
    let bytes = std::fs::read(path).map_err(|e| CanError::Io {
        file: path.into(),
        source: e,
    })?;
    parse_mdf4(&bytes, path)
}

/// Parses MDF4 bytes (`file` names them in errors). Never panics on malformed input.
///
/// # Errors
/// As [`read_mdf4`].
pub fn parse_mdf4(bytes: &[u8], file: &Path) -> Result<BusLog, CanError> {
    let r = Reader::new(bytes, file)?;
    r.read()
}

struct Block<'a> {
    offset: u64,
    id: [u8; 4],
    links: Vec<u64>,
    data: &'a [u8],
}

impl Block<'_> {
    fn link(&self, i: usize) -> u64 {
        self.links.get(i).copied().unwrap_or(0)
    }
}

/// One channel's place in the record.
#[derive(Debug, Clone, Copy)]
struct Field {
    byte_offset: u32,
    bit_offset: u8,
    bit_count: u32,
    data_type: u8,
}

#[derive(Debug, Clone, Copy)]
enum Conv {
    Identity,
    Linear { offset: f64, factor: f64 },
}

#[derive(Debug, Clone)]
enum Payload {
    /// Bytes inside the record.
    Fixed(Field),
    /// A `u64` offset in the record into signal data at this link.
    Vlsd(Field, u64),
}

#[derive(Debug, Clone)]
struct FrameGroup {
    time: Field,
    time_conv: Conv,
    id: Field,
    ide: Option<Field>,
    bus: Option<Field>,
    dlc: Option<Field>,
    data_length: Option<Field>,
    payload: Payload,
}

#[derive(Debug, Clone)]
struct Group {
    offset: u64,
    record_id: u64,
    cycle_count: u64,
    record_bytes: u64,
    vlsd: bool,
    frames: Option<FrameGroup>,
}

struct Reader<'a> {
    bytes: &'a [u8],
    file: &'a Path,
    unfinalised: bool,
    /// Unfinalised, and the last DT block's length was not updated.
    open_last_dt: bool,
    trust_cycle_counts: bool,
}

impl<'a> Reader<'a> {
    fn new(bytes: &'a [u8], file: &'a Path) -> Result<Self, CanError> {
        let mut r = Self {
            bytes,
            file,
            unfinalised: false,
            open_last_dt: false,
            trust_cycle_counts: true,
        };
        if bytes.len() < 64 {
            return Err(r.err(
                0,
                "ID",
                format!("file of {} bytes is too short", bytes.len()),
            ));
        }
        let magic = &bytes[0..8];
        r.unfinalised = match magic {
            b"MDF     " => false,
            b"UnFinMF " => true,
            _ => {
                return Err(r.err(
                    0,
                    "ID",
                    format!(
                        "not an MDF file (magic {:?})",
                        String::from_utf8_lossy(magic)
                    ),
                ))
            }
        };
        let version = u16::from_le_bytes([bytes[28], bytes[29]]);
        if !(400..500).contains(&version) {
            return Err(r.err(0, "ID", format!("MDF version {version} (only 4.x is read)")));
        }
        if r.unfinalised {
            let flags = u16::from_le_bytes([bytes[60], bytes[61]]);
            r.open_last_dt = flags & 0x04 != 0;
            r.trust_cycle_counts = flags & 0x01 == 0;
        }
        Ok(r)
    }

    fn err(&self, offset: u64, block: &str, message: String) -> CanError {
        CanError::Mdf {
            file: self.file.into(),
            offset,
            block: block.into(),
            message,
        }
    }

    fn block(&self, offset: u64, expect: &[&[u8; 4]]) -> Result<Block<'a>, CanError> {
        let name = expect
            .iter()
            .map(|e| String::from_utf8_lossy(&e[2..]).into_owned())
            .collect::<Vec<_>>()
            .join("/");
        let len = self.bytes.len() as u64;
        if offset < 64 || offset.checked_add(24).is_none_or(|end| end > len) {
            return Err(self.err(
                offset,
                &name,
                format!("link outside the file ({len} bytes)"),
            ));
        }
        let o = offset as usize;
        let h = &self.bytes[o..o + 24];
        let id: [u8; 4] = [h[0], h[1], h[2], h[3]];
        if !expect.iter().any(|e| **e == id) {
            return Err(self.err(
                offset,
                &name,
                format!("found block {:?}", String::from_utf8_lossy(&id)),
            ));
        }
        let length = u64::from_le_bytes(h[8..16].try_into().expect("8 bytes"));
        let link_count = u64::from_le_bytes(h[16..24].try_into().expect("8 bytes"));
        let links_end = link_count
            .checked_mul(8)
            .and_then(|l| l.checked_add(24))
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                self.err(
                    offset,
                    &name,
                    format!("{link_count} links do not fit a block of {length} bytes"),
                )
            })?;
        let end = offset.saturating_add(length);
        if end > len {
            return Err(self.err(
                offset,
                &name,
                format!("block of {length} bytes runs past the end of the file ({len} bytes)"),
            ));
        }
        let links = self.bytes[o + 24..o + links_end as usize]
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        Ok(Block {
            offset,
            id,
            links,
            data: &self.bytes[o + links_end as usize..end as usize],
        })
    }

    fn text(&self, offset: u64) -> Result<String, CanError> {
        if offset == 0 {
            return Ok(String::new());
        }
        let b = self.block(offset, &[b"##TX", b"##MD"])?;
        let end = b.data.iter().position(|&c| c == 0).unwrap_or(b.data.len());
        Ok(String::from_utf8_lossy(&b.data[..end]).into_owned())
    }

    fn read(&self) -> Result<BusLog, CanError> {
        let hd = self.block(64, &[b"##HD"])?;
        if hd.data.len() < 16 {
            return Err(self.err(64, "HD", "data section shorter than 16 bytes".into()));
        }
        let start = u64::from_le_bytes(hd.data[0..8].try_into().expect("8 bytes"));
        let tz_min = i16::from_le_bytes([hd.data[8], hd.data[9]]);
        let dst_min = i16::from_le_bytes([hd.data[10], hd.data[11]]);
        let time_flags = hd.data[12];
        let mut start_ns = i64::try_from(start)
            .map_err(|_| self.err(64, "HD", format!("start time {start} ns out of range")))?;
        if time_flags & 1 != 0 {
            if time_flags & 2 == 0 {
                return Err(self.err(
                    64,
                    "HD",
                    "start time is local time without a UTC offset".into(),
                ));
            }
            start_ns -= (i64::from(tz_min) + i64::from(dst_min)) * 60_000_000_000;
        }

        // Data groups, guarding against link cycles.
        let mut dgs = Vec::new();
        let mut seen = HashSet::new();
        let mut dg = hd.link(0);
        while dg != 0 {
            if !seen.insert(dg) {
                return Err(self.err(dg, "DG", "data group list loops".into()));
            }
            let b = self.block(dg, &[b"##DG"])?;
            dgs.push((
                dg,
                b.link(1),
                b.link(2),
                b.data.first().copied().unwrap_or(0),
            ));
            dg = b.link(0);
        }
        // The last DT block of an unfinalised file may run to the end of the file.
        let last_dt = if self.open_last_dt {
            dgs.iter()
                .map(|d| d.2)
                .filter(|&l| l != 0 && self.block(l, &[b"##DT"]).is_ok())
                .max()
        } else {
            None
        };

        let mut frames = Vec::new();
        let mut skipped = 0u64;
        for &(dg_off, cg_first, data_link, rec_id_size) in &dgs {
            let groups = self.groups(cg_first)?;
            if data_link == 0 || groups.is_empty() {
                continue;
            }
            let stream = if Some(data_link) == last_dt {
                let o = data_link as usize + 24;
                Cow::Borrowed(&self.bytes[o.min(self.bytes.len())..])
            } else {
                self.stream(data_link, b"DT", 0)?
            };
            skipped +=
                self.records(dg_off, rec_id_size, &groups, &stream, start_ns, &mut frames)?;
        }
        frames.sort_by_key(|f: &CanFrame| f.t_ns);
        Ok(BusLog {
            file: self.file.into(),
            start_ns,
            frames,
            skipped_records: skipped,
            unfinalised: self.unfinalised,
            format: "mdf4",
        })
    }

    fn groups(&self, first: u64) -> Result<Vec<Group>, CanError> {
        let mut out = Vec::new();
        let mut seen = HashSet::new();
        let mut cg = first;
        while cg != 0 {
            if !seen.insert(cg) {
                return Err(self.err(cg, "CG", "channel group list loops".into()));
            }
            let b = self.block(cg, &[b"##CG"])?;
            if b.data.len() < 32 {
                return Err(self.err(cg, "CG", "data section shorter than 32 bytes".into()));
            }
            let u64_at = |i: usize| u64::from_le_bytes(b.data[i..i + 8].try_into().expect("8"));
            let u32_at = |i: usize| u32::from_le_bytes(b.data[i..i + 4].try_into().expect("4"));
            let flags = u16::from_le_bytes([b.data[16], b.data[17]]);
            let vlsd = flags & 1 != 0;
            let frames = if vlsd { None } else { self.frame_group(&b)? };
            out.push(Group {
                offset: cg,
                record_id: u64_at(0),
                cycle_count: u64_at(8),
                record_bytes: u64::from(u32_at(24)) + u64::from(u32_at(28)),
                vlsd,
                frames,
            });
            cg = b.link(0);
        }
        Ok(out)
    }

    /// Collects every channel of a group (composition children included) by name.
    fn channels(
        &self,
        first: u64,
        depth: usize,
        seen: &mut HashSet<u64>,
        out: &mut Vec<(String, u64)>,
    ) -> Result<(), CanError> {
        let mut cn = first;
        while cn != 0 {
            if !seen.insert(cn) || depth > LIST_DEPTH_LIMIT {
                return Err(self.err(cn, "CN", "channel list loops".into()));
            }
            let b = self.block(cn, &[b"##CN"])?;
            out.push((self.text(b.link(2))?, cn));
            let comp = b.link(1);
            if comp != 0 && self.block(comp, &[b"##CN"]).is_ok() {
                self.channels(comp, depth + 1, seen, out)?;
            }
            cn = b.link(0);
        }
        Ok(())
    }

    fn field(&self, cn: u64) -> Result<(Field, Block<'a>), CanError> {
        let b = self.block(cn, &[b"##CN"])?;
        if b.data.len() < 16 {
            return Err(self.err(cn, "CN", "data section shorter than 16 bytes".into()));
        }
        let f = Field {
            data_type: b.data[2],
            bit_offset: b.data[3],
            byte_offset: u32::from_le_bytes(b.data[4..8].try_into().expect("4")),
            bit_count: u32::from_le_bytes(b.data[8..12].try_into().expect("4")),
        };
        if f.bit_offset > 7 {
            return Err(self.err(cn, "CN", format!("bit offset {} > 7", f.bit_offset)));
        }
        Ok((f, b))
    }

    fn frame_group(&self, cg: &Block<'a>) -> Result<Option<FrameGroup>, CanError> {
        let mut chans = Vec::new();
        self.channels(cg.link(1), 0, &mut HashSet::new(), &mut chans)?;
        let find = |suffix: &str| {
            chans
                .iter()
                .find(|(n, _)| n.strip_prefix("CAN_DataFrame") == Some(suffix))
                .map(|c| c.1)
        };
        let (Some(id_cn), Some(bytes_cn)) = (find(".ID"), find(".DataBytes")) else {
            return Ok(None);
        };
        // the time master
        let mut master = None;
        for &(_, cn) in &chans {
            let b = self.block(cn, &[b"##CN"])?;
            if b.data.len() >= 2 && matches!(b.data[0], 2 | 3) && b.data[1] == 1 {
                master = Some(cn);
                break;
            }
        }
        let Some(master) = master else {
            return Err(self.err(
                cg.offset,
                "CG",
                "CAN_DataFrame group without a time master channel".into(),
            ));
        };
        let (time, tb) = self.field(master)?;
        if !(matches!(time.data_type, 0..=3) && (1..=64).contains(&time.bit_count)
            || matches!(time.data_type, 4 | 5) && matches!(time.bit_count, 32 | 64))
        {
            return Err(self.err(
                master,
                "CN",
                format!(
                    "time channel of data type {} with {} bits",
                    time.data_type, time.bit_count
                ),
            ));
        }
        if tb.data[0] == 3 {
            return Err(self.err(master, "CN", "virtual time master channel".into()));
        }
        let time_conv = self.conversion(tb.link(4))?;
        let simple = |cn: Option<u64>| -> Result<Option<Field>, CanError> {
            cn.map(|c| {
                let (f, _) = self.field(c)?;
                if f.data_type > 1 || !(1..=64).contains(&f.bit_count) {
                    return Err(self.err(
                        c,
                        "CN",
                        format!(
                            "integer channel of data type {} with {} bits",
                            f.data_type, f.bit_count
                        ),
                    ));
                }
                Ok(f)
            })
            .transpose()
        };
        let (pf, pb) = self.field(bytes_cn)?;
        let payload = match pb.data[0] {
            0 if pf.data_type == 10 && pf.bit_count % 8 == 0 => Payload::Fixed(pf),
            1 if pf.bit_count == 64 => Payload::Vlsd(pf, pb.link(5)),
            t => {
                return Err(self.err(
                    bytes_cn,
                    "CN",
                    format!(
                        "DataBytes channel of type {t}, data type {}, {} bits",
                        pf.data_type, pf.bit_count
                    ),
                ))
            }
        };
        Ok(Some(FrameGroup {
            time,
            time_conv,
            id: simple(Some(id_cn))?.expect("some"),
            ide: simple(find(".IDE"))?,
            bus: simple(find(".BusChannel"))?,
            dlc: simple(find(".DLC"))?,
            data_length: simple(find(".DataLength"))?,
            payload,
        }))
    }

    fn conversion(&self, cc: u64) -> Result<Conv, CanError> {
        if cc == 0 {
            return Ok(Conv::Identity);
        }
        let b = self.block(cc, &[b"##CC"])?;
        if b.data.len() < 24 {
            return Err(self.err(cc, "CC", "data section shorter than 24 bytes".into()));
        }
        let n = usize::from(u16::from_le_bytes([b.data[6], b.data[7]]));
        let val = |i: usize| {
            b.data
                .get(24 + 8 * i..32 + 8 * i)
                .map(|s| f64::from_le_bytes(s.try_into().expect("8")))
        };
        match b.data[0] {
            0 => Ok(Conv::Identity),
            1 if n >= 2 => match (val(0), val(1)) {
                (Some(offset), Some(factor)) => Ok(Conv::Linear { offset, factor }),
                _ => Err(self.err(cc, "CC", "linear conversion without its 2 values".into())),
            },
            t => Err(self.err(
                cc,
                "CC",
                format!(
                    "conversion type {t} on the time channel (only identity and linear are read)"
                ),
            )),
        }
    }

    /// The data of a DT/SD block, or of a list or zipped form of them, as one stream.
    fn stream(&self, link: u64, kind: &[u8; 2], depth: usize) -> Result<Cow<'a, [u8]>, CanError> {
        self.stream_once(link, kind, depth, &mut HashSet::new())
    }

    /// [`Self::stream`], refusing a data block listed twice (which would multiply memory).
    fn stream_once(
        &self,
        link: u64,
        kind: &[u8; 2],
        depth: usize,
        listed: &mut HashSet<u64>,
    ) -> Result<Cow<'a, [u8]>, CanError> {
        if !listed.insert(link) {
            return Err(self.err(link, "DL", "data block listed twice".into()));
        }
        if depth > LIST_DEPTH_LIMIT {
            return Err(self.err(link, "DL", "data lists nested too deep".into()));
        }
        let plain: [u8; 4] = [b'#', b'#', kind[0], kind[1]];
        let b = self.block(link, &[&plain, b"##DZ", b"##DL", b"##HL"])?;
        match &b.id {
            b"##DZ" => self.inflate(&b, kind).map(Cow::Owned),
            b"##DL" => {
                let mut out = Vec::new();
                let mut seen = HashSet::new();
                let mut dl = Some(b);
                while let Some(l) = dl {
                    if !seen.insert(l.offset) {
                        return Err(self.err(l.offset, "DL", "data list chain loops".into()));
                    }
                    for &child in l.links.iter().skip(1) {
                        if child != 0 {
                            out.extend_from_slice(&self.stream_once(
                                child,
                                kind,
                                depth + 1,
                                listed,
                            )?);
                        }
                    }
                    dl = match l.link(0) {
                        0 => None,
                        next => Some(self.block(next, &[b"##DL"])?),
                    };
                }
                Ok(Cow::Owned(out))
            }
            b"##HL" => match b.link(0) {
                0 => Ok(Cow::Borrowed(&[])),
                dl => self.stream_once(dl, kind, depth + 1, listed),
            },
            _ => Ok(Cow::Borrowed(b.data)),
        }
    }

    fn inflate(&self, b: &Block<'a>, kind: &[u8; 2]) -> Result<Vec<u8>, CanError> {
        let d = b.data;
        if d.len() < 24 {
            return Err(self.err(b.offset, "DZ", "data section shorter than 24 bytes".into()));
        }
        if &d[0..2] != kind {
            return Err(self.err(
                b.offset,
                "DZ",
                format!(
                    "holds a {:?} block where a {:?} block is expected",
                    String::from_utf8_lossy(&d[0..2]),
                    String::from_utf8_lossy(kind)
                ),
            ));
        }
        let zip_type = d[2];
        let columns = u64::from(u32::from_le_bytes(d[4..8].try_into().expect("4")));
        let org_len = u64::from_le_bytes(d[8..16].try_into().expect("8"));
        let zipped_len = u64::from_le_bytes(d[16..24].try_into().expect("8"));
        let zipped = usize::try_from(zipped_len)
            .ok()
            .and_then(|n| d.get(24..24 + n))
            .ok_or_else(|| {
                self.err(
                    b.offset,
                    "DZ",
                    format!("{zipped_len} zipped bytes do not fit the block"),
                )
            })?;
        if org_len > DZ_LIMIT_BYTES {
            return Err(self.err(
                b.offset,
                "DZ",
                format!("inflated length {org_len} bytes over the limit"),
            ));
        }
        // deflate expands at most ~1032:1; a larger stated length is not trusted for allocation
        let cap = org_len.min(zipped_len.saturating_mul(1032).saturating_add(64));
        let mut out = Vec::with_capacity(cap as usize);
        flate2::read::ZlibDecoder::new(zipped)
            .take(org_len + 1)
            .read_to_end(&mut out)
            .map_err(|e| self.err(b.offset, "DZ", format!("deflate: {e}")))?;
        if out.len() as u64 != org_len {
            return Err(self.err(
                b.offset,
                "DZ",
                format!("inflates to {} bytes, not the stated {org_len}", out.len()),
            ));
        }
        match zip_type {
            0 => Ok(out),
            1 => {
                // Transposition: the first rows·columns bytes were stored column by column.
                if columns == 0 {
                    return Ok(out);
                }
                let cols = columns as usize;
                let rows = out.len() / cols;
                let mut t = out.clone();
                for c in 0..cols {
                    for r in 0..rows {
                        t[r * cols + c] = out[c * rows + r];
                    }
                }
                Ok(t)
            }
            z => Err(self.err(b.offset, "DZ", format!("zip type {z}"))),
        }
    }

    /// Walks the records of one data group; returns how many records were skipped.
    fn records(
        &self,
        dg: u64,
        rec_id_size: u8,
        groups: &[Group],
        stream: &[u8],
        start_ns: i64,
        frames: &mut Vec<CanFrame>,
    ) -> Result<u64, CanError> {
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
        let mut skipped = 0u64;
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
                return Ok(0);
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
                return Ok(n as u64);
            };
            let sd = self.vlsd_source(fg, &sd_cache);
            for k in 0..n {
                let rec = &stream[k * size..(k + 1) * size];
                if let Some(f) = self.frame(fg, g, rec, sd, &[], start_ns)? {
                    frames.push(f);
                }
            }
            return Ok(0);
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
            if let Some(f) = self.frame(fg, g, rec, sd, &per_group[gi], start_ns)? {
                frames.push(f);
            }
        }
        Ok(skipped)
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
