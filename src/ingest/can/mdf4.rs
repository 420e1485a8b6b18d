//! ASAM MDF4 bus logging: the CAN frames of an MDF 4.x file as CAN data loggers write it.
//!
//! A focused reader for the subset bus loggers (CSS Electronics CANedge, Vector, most data
//! loggers) write under the ASAM MDF 4.1 "bus logging" association standard, not a general MDF
//! library: the maintained Rust MDF crates read whole files into dataframe stacks (polars /
//! arrow2), which this project does not build (build time), and none decodes bus-logging groups.
//!
//! The reader comes in layers, one file each: `mdf4_blocks` (the ID block, block headers and
//! links, data blocks with their lists and zipped forms), `mdf4_groups` (channel groups and the
//! fields of CAN data frames in their records) and `mdf4_records` (the records of a data group
//! decoded into frames); this module reads the HD block and walks the data groups.
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
//!
//! ## What is skipped
//! A single frame record whose own fields do not decode (a field outside the record, a payload
//! offset naming no signal data, a time that is not finite or beyond 10¹⁰ s) is a corrupted
//! frame, not a corrupted file: it is skipped and counted in [`BusLog::corrupt_records`], and
//! ingest reports the count.

use super::frames::CanFrame;
use super::mdf4_blocks::Reader;
pub use super::mdf4_records::dlc_bytes;
use super::CanError;
use std::borrow::Cow;
use std::collections::HashSet;
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
    /// Frame records that could not be decoded (a field outside its record, a payload offset
    /// naming no data, a time that is not finite), skipped and counted.
    pub corrupt_records: u64,
    /// The file was unfinalised (`UnFinMF`).
    pub unfinalised: bool,
    /// `mdf4` or `mcap`.
    pub format: &'static str,
}

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

impl<'a> Reader<'a> {
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
        let (mut skipped, mut corrupt) = (0u64, 0u64);
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
            let (s, c) =
                self.records(dg_off, rec_id_size, &groups, &stream, start_ns, &mut frames)?;
            skipped += s;
            corrupt += c;
        }
        frames.sort_by_key(|f: &CanFrame| f.t_ns);
        Ok(BusLog {
            file: self.file.into(),
            start_ns,
            frames,
            skipped_records: skipped,
            corrupt_records: corrupt,
            unfinalised: self.unfinalised,
            format: "mdf4",
        })
    }
}
