//! The block layer of the MDF4 reader ([`super::mdf4`]): the ID block (magic `MDF     ` or
//! `UnFinMF `, version 4.x, the unfinalised flags), block headers (`##XX` id, length, links) read
//! with every offset and length bounds-checked, TX/MD text, and the data of DT or SD blocks as
//! one stream, through DL lists (chained with `dl_next`), HL header lists and DZ blocks (deflate,
//! and deflate of transposed records). Integers are little-endian; errors are
//! [`CanError::Mdf`] naming the file, the block offset and what is wrong.

use super::CanError;
use std::borrow::Cow;
use std::collections::HashSet;
use std::io::Read;
use std::path::Path;

/// Largest inflated DZ block accepted, bytes (bounds memory on corrupt length fields).
const DZ_LIMIT_BYTES: u64 = 1 << 30;
/// Deepest nesting of data lists.
pub(super) const LIST_DEPTH_LIMIT: usize = 4;

pub(super) struct Block<'a> {
    pub(super) offset: u64,
    pub(super) id: [u8; 4],
    pub(super) links: Vec<u64>,
    pub(super) data: &'a [u8],
}

impl Block<'_> {
    pub(super) fn link(&self, i: usize) -> u64 {
        self.links.get(i).copied().unwrap_or(0)
    }
}

pub(super) struct Reader<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) file: &'a Path,
    pub(super) unfinalised: bool,
    /// Unfinalised, and the last DT block's length was not updated.
    pub(super) open_last_dt: bool,
    pub(super) trust_cycle_counts: bool,
}

impl<'a> Reader<'a> {
    pub(super) fn new(bytes: &'a [u8], file: &'a Path) -> Result<Self, CanError> {
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
                        "not an MDF file (magic `{}`)",
                        String::from_utf8_lossy(magic).escape_debug()
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

    pub(super) fn err(&self, offset: u64, block: &str, message: String) -> CanError {
        CanError::Mdf {
            file: self.file.into(),
            offset,
            block: block.into(),
            message,
        }
    }

    pub(super) fn block(&self, offset: u64, expect: &[&[u8; 4]]) -> Result<Block<'a>, CanError> {
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
                format!(
                    "found block `{}`",
                    String::from_utf8_lossy(&id).escape_debug()
                ),
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

    pub(super) fn text(&self, offset: u64) -> Result<String, CanError> {
        if offset == 0 {
            return Ok(String::new());
        }
        let b = self.block(offset, &[b"##TX", b"##MD"])?;
        let end = b.data.iter().position(|&c| c == 0).unwrap_or(b.data.len());
        Ok(String::from_utf8_lossy(&b.data[..end]).into_owned())
    }

    /// The data of a DT/SD block, or of a list or zipped form of them, as one stream.
    pub(super) fn stream(
        &self,
        link: u64,
        kind: &[u8; 2],
        depth: usize,
    ) -> Result<Cow<'a, [u8]>, CanError> {
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
                    "holds a `{}` block where a `{}` block is expected",
                    String::from_utf8_lossy(&d[0..2]).escape_debug(),
                    String::from_utf8_lossy(kind).escape_debug()
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
}
