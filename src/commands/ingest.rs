//! `fleetdyn ingest`: one recording (or one raw CAN session) into the canonical drive log.

use super::failure::{input, io, usage, Failure};
use fleetdyn::ingest::IngestOptions;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::ingest_summary::split_lines;
use fleetdyn::report::IngestSummary;
use std::path::PathBuf;

/// A resolved `ingest`.
pub struct Job {
    /// One recording, or with `dbc` the MDF4 files of one session.
    pub inputs: Vec<PathBuf>,
    /// DBC files decoding raw CAN frames.
    pub dbc: Vec<PathBuf>,
    /// Output Parquet file; `None`: summary only.
    pub output: Option<PathBuf>,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let mut fingerprint = job.cfg.fingerprint(&job.opts);
    let rec = if job.dbc.is_empty() {
        ingest_stage::run_recording(&job.inputs[0], &job.opts).map_err(input)?
    } else {
        let texts = job
            .dbc
            .iter()
            .map(std::fs::read)
            .collect::<Result<Vec<_>, _>>()
            .map_err(usage)?;
        let parts: Vec<&[u8]> = texts.iter().map(Vec::as_slice).collect();
        fingerprint.push_str(&format!("\ndbc {}", fleetdyn::io::config_hash(&parts)));
        fleetdyn::ingest::can::ingest_session_recording(&job.inputs, &job.dbc, &job.opts)
            .map_err(input)?
    };
    let split = rec.drives.len() > 1;
    for (k, ing) in rec.drives.iter().enumerate() {
        if k > 0 {
            say_raw!("\n");
        }
        say_raw!("{}", IngestSummary::new(ing));
    }
    say_raw!("{}", split_lines(&rec));
    if let Some(out) = job.output {
        // one file per drive: a split recording's drives beside the named file, `<stem>-s<k>`
        let paths: Vec<PathBuf> = rec
            .drives
            .iter()
            .map(|d| match (&d.log.meta.segment, split) {
                (Some(s), true) => segment_path(&out, s.index),
                _ => out.clone(),
            })
            .collect();
        for (ing, path) in rec.drives.iter().zip(&paths) {
            if let Err(e) = ingest_stage::write(path, &ing.log, &fingerprint) {
                // all or nothing: the drives written before this one are removed
                for p in paths.iter().take_while(|p| *p != path) {
                    let _ = std::fs::remove_file(p);
                }
                return Err(io(e));
            }
        }
        for p in &paths {
            say!("wrote     {}", p.display());
        }
    }
    Ok(())
}

/// `<stem>-s<k>.<ext>` beside `out`.
fn segment_path(out: &std::path::Path, k: usize) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match out.extension() {
        Some(e) => format!("{stem}-s{k}.{}", e.to_string_lossy()),
        None => format!("{stem}-s{k}"),
    };
    out.with_file_name(name)
}
