//! The channel-group layer of the MDF4 reader ([`super::mdf4`]): the channel groups of a data
//! group (CG list) and, for each, whether it is a CAN data frame group and where its fields sit
//! in the record. Channels are found by name through CN lists and their compositions
//! (`CAN_DataFrame` with children `CAN_DataFrame.ID`, `.IDE`, `.DLC`, `.DataLength`,
//! `.DataBytes`, `.BusChannel`, or flat channels of the same names); a group is a CAN data frame
//! group when it has `CAN_DataFrame.ID`, `CAN_DataFrame.DataBytes` and a time master channel
//! (`cn_type` 2/3, sync type time), read through its CC conversion (identity or linear).
//! `DataBytes` is a fixed-length byte array in the record or a VLSD channel (`cn_type` 1, a
//! `u64` offset into signal data). Other groups (error, remote and LIN frames) have no frame
//! group and are skipped.

use super::mdf4_blocks::{Block, Reader, LIST_DEPTH_LIMIT};
use super::CanError;
use std::collections::HashSet;

/// One channel's place in the record.
#[derive(Debug, Clone, Copy)]
pub(super) struct Field {
    pub(super) byte_offset: u32,
    pub(super) bit_offset: u8,
    pub(super) bit_count: u32,
    pub(super) data_type: u8,
}

#[derive(Debug, Clone, Copy)]
pub(super) enum Conv {
    Identity,
    Linear { offset: f64, factor: f64 },
}

#[derive(Debug, Clone)]
pub(super) enum Payload {
    /// Bytes inside the record.
    Fixed(Field),
    /// A `u64` offset in the record into signal data at this link.
    Vlsd(Field, u64),
}

#[derive(Debug, Clone)]
pub(super) struct FrameGroup {
    pub(super) time: Field,
    pub(super) time_conv: Conv,
    pub(super) id: Field,
    pub(super) ide: Option<Field>,
    pub(super) bus: Option<Field>,
    pub(super) dlc: Option<Field>,
    pub(super) data_length: Option<Field>,
    pub(super) payload: Payload,
}

#[derive(Debug, Clone)]
pub(super) struct Group {
    pub(super) offset: u64,
    pub(super) record_id: u64,
    pub(super) cycle_count: u64,
    pub(super) record_bytes: u64,
    pub(super) vlsd: bool,
    pub(super) frames: Option<FrameGroup>,
}

impl<'a> Reader<'a> {
    pub(super) fn groups(&self, first: u64) -> Result<Vec<Group>, CanError> {
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
}
