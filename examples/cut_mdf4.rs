//! Cuts an excerpt of a raw CAN logging session into small MDF4 files (the committed fixtures
//! under `fixtures/real/*/` are made with it; their PROVENANCE.md gives the exact command).
//!
//! ```text
//! cargo run --release --example cut_mdf4 -- --from-s 400 --to-s 700 [--drop-ids 9,…] \
//!     --out DIR FILE.MF4…
//! ```
//!
//! Each input file is read with fleetdyn's MDF4 reader; its frames with a time in
//! [session start + from, session start + to) — the session start being the HD start time of
//! the first file — and an identifier not in `--drop-ids` are written, unchanged (time, id, IDE,
//! bus, payload), to `DIR/<same file name>` in the layout CANedge loggers write (sorted records,
//! payloads in signal data), deflated with transposed records. A file with no frame in the
//! window is not written. Nothing else of the source (other bus groups, metadata) is kept.

use fleetdyn::ingest::can::mdf4::read_mdf4;
use fleetdyn::ingest::can::mdf4_write::{write_mdf4, Layout, Storage};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (mut from_s, mut to_s, mut drop, mut out, mut files) =
        (0.0f64, f64::INFINITY, Vec::<u32>::new(), None, Vec::new());
    while let Some(a) = args.next() {
        match a.as_str() {
            "--from-s" => from_s = args.next().ok_or("--from-s needs a value")?.parse()?,
            "--to-s" => to_s = args.next().ok_or("--to-s needs a value")?.parse()?,
            "--drop-ids" => {
                for id in args.next().ok_or("--drop-ids needs a list")?.split(',') {
                    let id = id.trim();
                    drop.push(match id.strip_prefix("0x") {
                        Some(h) => u32::from_str_radix(h, 16)?,
                        None => id.parse()?,
                    });
                }
            }
            "--out" => out = Some(PathBuf::from(args.next().ok_or("--out needs a folder")?)),
            _ => files.push(PathBuf::from(a)),
        }
    }
    let out = out.ok_or("--out DIR is required")?;
    std::fs::create_dir_all(&out)?;
    let mut session_start = None;
    for f in &files {
        let log = read_mdf4(f)?;
        let start = *session_start.get_or_insert(log.start_ns);
        let lo = start + (from_s * 1e9) as i64;
        let hi = if to_s.is_finite() {
            start + (to_s * 1e9) as i64
        } else {
            i64::MAX
        };
        let kept: Vec<_> = log
            .frames
            .iter()
            .filter(|fr| fr.t_ns >= lo && fr.t_ns < hi && !drop.contains(&fr.id))
            .copied()
            .collect();
        if kept.is_empty() {
            continue;
        }
        let bytes = write_mdf4(
            &kept,
            log.start_ns,
            Layout::SignalData,
            Storage::Zipped {
                chunk_bytes: 1 << 16,
                transpose: true,
            },
        );
        let name = f.file_name().ok_or("input without a file name")?;
        let dest = out.join(name);
        std::fs::write(&dest, &bytes)?;
        println!(
            "{} -> {}: {} of {} frames, {} bytes",
            f.display(),
            dest.display(),
            kept.len(),
            log.frames.len(),
            bytes.len()
        );
    }
    Ok(())
}
