//! One logging session of raw CAN files → the canonical drive log.
//!
//! A logger splits a session into files (CANedge: `00000001-60FE3F04.MF4`, `00000002-…`, each
//! with the session's start time in its header and frame times relative to it). The files are
//! read in the order given, their frames merged and sorted by time (stable), J1939
//! multi-packet groups reassembled, the mapped signals decoded, and the channels checked and
//! aligned as every multi-rate source is ([`crate::ingest::align`]).
//!
//! Identification: the drive id is the first file's stem unless the options name one; the
//! source file recorded is the list of files.

use super::dbc::Database;
use super::mapping::decode_channels;
use super::{j1939, mcap_frames, mdf4, CanError, CanFrame};
use crate::ingest::mapping::{Mapping, SourceFormat};
use crate::ingest::{
    align_channels, drives, required_columns, single, IngestError, IngestOptions, IngestReport,
    Ingested, Marks, Recording,
};
use crate::table::DriveMeta;
use std::path::{Path, PathBuf};

/// Frames of a session, time-sorted, with J1939 multi-packet groups reassembled.
#[derive(Debug, Clone)]
pub struct Session {
    /// Files read, in order.
    pub files: Vec<PathBuf>,
    /// Frames of all files, sorted by time.
    pub frames: Vec<CanFrame>,
    /// Frames read from the files (before reassembly).
    pub raw_frames: u64,
    /// Records of other bus-logging groups (MDF4) or other messages (MCAP) skipped.
    pub skipped_records: u64,
    /// Frame records or messages that could not be decoded, skipped.
    pub corrupt_records: u64,
    /// Some file was MCAP.
    pub mcap: bool,
}

/// Reads one file of a session: MDF4 or MCAP, told by its first bytes.
///
/// # Errors
/// [`CanError`] for a file that cannot be read, or is neither format.
pub fn read_bus_log(path: &Path) -> Result<mdf4::BusLog, CanError> {
    let mut head = [0u8; 8];
    let n = std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .map_err(|e| CanError::Io {
            file: path.into(),
            source: e,
        })?;
    match &head[..n] {
        b"MDF     " | b"UnFinMF " => mdf4::read_mdf4(path),
        b"\x89MCAP0\r\n" => mcap_frames::read_mcap_frames(path),
        other => Err(CanError::UnknownFormat {
            file: path.into(),
            head: other
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<Vec<_>>()
                .join(" "),
        }),
    }
}

/// Reads the frames of a session's files (MDF4 or MCAP).
///
/// # Errors
/// [`CanError`] for the first file that cannot be read.
pub fn read_session(files: &[PathBuf]) -> Result<Session, CanError> {
    let mut frames = Vec::new();
    let (mut skipped, mut corrupt) = (0, 0);
    let mut mcap = false;
    for f in files {
        let log = read_bus_log(f)?;
        mcap |= log.format == "mcap";
        skipped += log.skipped_records;
        corrupt += log.corrupt_records;
        frames.extend(log.frames);
    }
    frames.sort_by_key(|f: &CanFrame| f.t_ns);
    let raw_frames = frames.len() as u64;
    let assembled = j1939::reassemble(&frames);
    if !assembled.is_empty() {
        frames.extend(assembled);
        frames.sort_by_key(|f: &CanFrame| f.t_ns);
    }
    Ok(Session {
        files: files.to_vec(),
        frames,
        raw_frames,
        skipped_records: skipped,
        corrupt_records: corrupt,
        mcap,
    })
}

/// Loads DBC files.
///
/// # Errors
/// [`CanError`] for the first that cannot be read or parsed.
pub fn load_dbcs(paths: &[PathBuf]) -> Result<Vec<Database>, CanError> {
    paths.iter().map(|p| Database::load(p)).collect()
}

/// The embedded `can-dbc` mapping with the most of its signals defined in `dbs`.
///
/// # Errors
/// [`IngestError::Mapping`] when no embedded mapping's signal is in the DBC files.
pub fn auto_can_mapping(dbs: &[Database]) -> Result<Mapping, IngestError> {
    let mut best: Option<(usize, Mapping)> = None;
    for m in Mapping::embedded()
        .into_iter()
        .filter(|m| m.format == SourceFormat::CanDbc)
    {
        let found = m
            .signals
            .values()
            .chain(m.passthrough_signals.values())
            .filter(|s| {
                dbs.iter().any(|db| {
                    db.message_index(s.message.as_deref().unwrap_or_default())
                        .is_some_and(|i| {
                            db.messages[i]
                                .signals
                                .iter()
                                .any(|g| Some(g.name.as_str()) == s.signal.as_deref())
                        })
                })
            })
            .count();
        if found > 0 && best.as_ref().is_none_or(|b| found > b.0) {
            best = Some((found, m));
        }
    }
    best.map(|b| b.1).ok_or_else(|| IngestError::Mapping {
        mapping: "<auto>".into(),
        message: format!(
            "no bundled can-dbc mapping names a signal of {}; pass --mapping",
            dbs.iter()
                .map(|d| d.origin.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    })
}

/// Ingests a session of raw CAN files decoded with `dbcs` as one drive (see
/// [`ingest_session_recording`] for sessions split at logger pauses).
///
/// # Errors
/// As [`ingest_session_recording`], and [`IngestError::Segmented`] when the session splits into
/// several drives.
pub fn ingest_session(
    files: &[PathBuf],
    dbcs: &[PathBuf],
    opts: &IngestOptions,
) -> Result<Ingested, IngestError> {
    let rec = ingest_session_recording(files, dbcs, opts)?;
    single(files.first().map_or(Path::new(""), PathBuf::as_path), rec)
}

/// Ingests a session of raw CAN files decoded with `dbcs`, split at logger pauses into drives of
/// their own ([`crate::ingest::segment`]).
///
/// # Errors
/// Any [`IngestError`]: unreadable files ([`IngestError::Can`]), mapping problems, missing
/// required columns, the checks every source gets.
pub fn ingest_session_recording(
    files: &[PathBuf],
    dbcs: &[PathBuf],
    opts: &IngestOptions,
) -> Result<Recording, IngestError> {
    let first: &Path = files.first().ok_or_else(|| IngestError::Setting {
        key: "input".into(),
        value: "(none)".into(),
        rule: "a CAN session needs at least one log file".into(),
    })?;
    if dbcs.is_empty() {
        return Err(IngestError::Setting {
            key: "dbc".into(),
            value: "(none)".into(),
            rule: "raw CAN logs need at least one DBC file".into(),
        });
    }
    let dbs = load_dbcs(dbcs)?;
    let mapping = match &opts.mapping {
        Some(m) => m.clone(),
        None => auto_can_mapping(&dbs)?,
    };
    let required = required_columns(&opts.stages);
    let session = read_session(files)?;
    let names = files
        .iter()
        .map(|f| f.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let decoded = decode_channels(&session.frames, &dbs, &mapping, &names)?;
    for (col, stage) in &required {
        let present = decoded
            .channels
            .iter()
            .any(|c| c.column == *col && c.values.iter().any(|v| !v.is_nan()));
        if !present {
            let source_name = mapping.signals.get(*col).map_or_else(
                || format!("<not in mapping {}>", mapping.name),
                |s| {
                    format!(
                        "{}.{}",
                        s.message.as_deref().unwrap_or("?"),
                        s.signal.as_deref().unwrap_or("?")
                    )
                },
            );
            return Err(IngestError::MissingColumn {
                file: first.into(),
                column: (*col).into(),
                source_name,
                stage: (*stage).into(),
            });
        }
    }
    let mut report = IngestReport {
        format: if session.mcap { "mcap-can" } else { "mdf4-can" }.into(),
        mapping: mapping.name.clone(),
        source_rows: session.raw_frames,
        corrupt_records: session.corrupt_records,
        ignored: decoded.ignored,
        ..Default::default()
    };
    let mut marks = Marks::default();
    let pieces = align_channels(
        first,
        decoded.channels,
        &required,
        opts,
        &mapping,
        &mut report,
        &mut marks,
    )?;
    let meta = DriveMeta {
        drive_id: opts.drive_id.clone().unwrap_or_else(|| {
            first
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        }),
        vehicle_id: opts
            .vehicle_id
            .clone()
            .or_else(|| mapping.vehicle_id.clone()),
        source_file: names,
        segment: None,
    };
    drives(
        first,
        meta,
        report,
        pieces,
        &marks,
        (opts.min_segment_s, opts.min_segment_m),
    )
}
