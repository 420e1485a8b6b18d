//! One drive of a run, from its input file to its done-marker: reuse of up-to-date outputs,
//! ingest, the analysis stages ([`super::drive_stages`]), the tables written
//! ([`super::drive_tables`]) and the marker that commits them.
//!
//! **Failures.** A drive that fails (bad file, a stage error, even a panic) is recorded with the
//! stage and the error, leaves no output, and the other drives go on. A stage that cannot serve a
//! drive (see [`super::spec`]: `missing = "skip"`) is skipped with its reason; the drive succeeds.
//!
//! **Idempotence.** See [`super::dataset`]: a drive whose done-marker matches its input's
//! content hash and its configuration hash is reused, not recomputed (unless `force`).

use super::dataset::{file_sha256, sweep_temps, utc_date, Dataset};
use super::drive_stages::{compute, fail, Computed, Fail};
use super::drive_tables::{
    base_meta, conformed, metrics_of, spectrum_columns, summary_columns, TableColumns,
};
use super::record::{DriveOutcome, DriveRecord, DriveStatus, StageNote};
use super::spec::Plan;
use super::spec_sections::{DatasetTable, PipelineStage};
use super::vehicles::LoadedVehicle;
use super::{resample_stage, slope_stage};
use crate::diagnose::parameter_table::parameter_columns;
use crate::ingest::{BadSamples, SkippedSegment};
use crate::io::{
    config_hash, write_column_refs_with_constants, AtomicFile, ColumnRef, OutColumn, TableMeta,
};
use crate::report::axle_sim::{axle_sim_columns, AxleSimExtra, TimeAxis};
use crate::report::axle_validation::{axle_meta, axle_validation_columns};
use crate::report::diagnosis_files::write_outputs;
use crate::table::DriveLog;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

/// Vehicle-id partition value of a drive without one.
pub const UNKNOWN_VEHICLE: &str = "__HIVE_DEFAULT_PARTITION__";

/// Configuration hash of a drive: the plan, its vehicle file, the manifest's vehicle id, the
/// fleetdyn version.
fn drive_config_hash(
    plan: &Plan,
    vehicle: Option<&LoadedVehicle>,
    manifest_vehicle: Option<&str>,
) -> String {
    config_hash(&[
        plan.fingerprint.as_bytes(),
        vehicle
            .map_or("no vehicle file", |v| v.sha256.as_str())
            .as_bytes(),
        manifest_vehicle.unwrap_or("").as_bytes(),
        env!("CARGO_PKG_VERSION").as_bytes(),
    ])
}

fn needs_vehicle(plan: &Plan) -> bool {
    plan.has(PipelineStage::Shuffle)
        || plan.has(PipelineStage::Axle)
        || plan.has(PipelineStage::Diagnose)
}

/// Checks the gear column against the vehicle's gearbox (known only once the drive names its
/// vehicle): a gear outside it is masked to missing and counted in `masked` with
/// [`BadSamples::Mask`] (the run of missing values then bounded by `max_nan_run_s`), an error with
/// [`BadSamples::Error`].
fn check_gears(
    log: &mut DriveLog,
    v: &LoadedVehicle,
    opts: &crate::ingest::IngestOptions,
    masked: &mut std::collections::BTreeMap<String, u64>,
) -> Result<(), String> {
    let source = log.meta.source_file.clone();
    let Some(g) = log.signal_mut("gear") else {
        return Ok(());
    };
    let (lo, hi) = v.file.gear_range();
    let mut n = 0;
    for (i, x) in g.iter_mut().enumerate() {
        if x.is_finite() && (*x < f64::from(lo) || *x > f64::from(hi)) {
            if opts.bad_samples == BadSamples::Error {
                return Err(format!(
                    "{source}: column gear row {i}: value {x} outside the gearbox of {} ({lo} … {hi})",
                    v.path
                ));
            }
            *x = f64::NAN;
            n += 1;
        }
    }
    if n > 0 {
        *masked.entry("gear".into()).or_default() += n;
        crate::ingest::check_nan_runs(
            std::path::Path::new(&source),
            &log.timestamp_ns,
            &log.signals,
            &[("gear", "ingest")],
            opts.max_nan_run_s,
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Shared state of a run.
pub(super) struct Ctx<'a> {
    pub(super) plan: &'a Plan,
    pub(super) ds: Dataset,
    pub(super) force: bool,
    pub(super) claims: Mutex<HashMap<String, usize>>,
}

/// What one input gave: its drives' outcomes (one per segment when it was split at pauses) and
/// the segments skipped.
pub(super) struct InputOutcome {
    pub(super) drives: Vec<DriveOutcome>,
    pub(super) skipped: Vec<SkippedSegment>,
}

pub(super) fn process(
    ctx: &Ctx<'_>,
    index: usize,
    item: &super::inputs::InputItem,
) -> InputOutcome {
    let t0 = Instant::now();
    let input = item.path.display().to_string();
    let stem = item
        .path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        process_inner(ctx, index, item, &input)
    }));
    let result = caught.unwrap_or_else(|p| Err((None, panicked(p.as_ref()))));
    let outcome = |r: One, elapsed_s: f64| match r {
        Ok((status, record)) => DriveOutcome {
            input: input.clone(),
            drive_id: record.drive_id.clone(),
            status,
            failed_stage: None,
            error: None,
            elapsed_s,
            record: Some(record),
        },
        Err((id, Fail(stage, e))) => DriveOutcome {
            input: input.clone(),
            drive_id: id.unwrap_or_else(|| stem.clone()),
            status: DriveStatus::Failed,
            failed_stage: Some(stage.name()),
            error: Some(e),
            elapsed_s,
            record: None,
        },
    };
    match result {
        Ok((drives, skipped)) => InputOutcome {
            drives: drives
                .into_iter()
                .map(|(r, elapsed)| outcome(r, elapsed))
                .collect(),
            skipped,
        },
        Err(e) => InputOutcome {
            drives: vec![outcome(Err(e), t0.elapsed().as_secs_f64())],
            skipped: Vec::new(),
        },
    }
}

/// A panic as a drive failure (the stage is not known; it is reported as ingest).
fn panicked(p: &(dyn std::any::Any + Send)) -> Fail {
    let msg = p
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default();
    Fail(
        PipelineStage::Ingest,
        format!("internal error (panic): {msg}"),
    )
}

/// One drive's result.
type One = Result<(DriveStatus, DriveRecord), (Option<String>, Fail)>;
/// An input's drives (each with its wall time, s) and skipped segments, or its failure.
type Processed = Result<(Vec<(One, f64)>, Vec<SkippedSegment>), (Option<String>, Fail)>;

/// Marker key of an input's `j`-th drive (0-based): the input's key for the first, so a
/// recording that is one drive has one marker under its input's key.
fn drive_key(input_key: &str, j: usize) -> String {
    if j == 0 {
        input_key.to_string()
    } else {
        config_hash(&[input_key.as_bytes(), format!("drive {j}").as_bytes()])
    }
}

/// The input's drives from an earlier run, when all are up to date (same configuration, every
/// output present).
fn up_to_date(
    ctx: &Ctx<'_>,
    item: &super::inputs::InputItem,
    key: &str,
    first: &DriveRecord,
) -> Option<Vec<DriveRecord>> {
    let plan = ctx.plan;
    let mut recs = vec![first.clone()];
    for j in 1..first.input_drives {
        recs.push(ctx.ds.read_marker(&drive_key(key, j))?);
    }
    for rec in &recs {
        let vid = (rec.vehicle_id != UNKNOWN_VEHICLE).then_some(rec.vehicle_id.as_str());
        let v = plan.vehicles.resolve(item.vehicle_id.as_deref().or(vid));
        let expected = drive_config_hash(plan, v.map(|v| &**v), item.vehicle_id.as_deref());
        let complete = rec.outputs.iter().all(|o| ctx.ds.root.join(o).is_file());
        if rec.config_hash != expected || !complete {
            return None;
        }
    }
    Some(recs)
}

fn process_inner(
    ctx: &Ctx<'_>,
    index: usize,
    item: &super::inputs::InputItem,
    input: &str,
) -> Processed {
    let t0 = Instant::now();
    let plan = ctx.plan;
    let ing_st = PipelineStage::Ingest;
    let sha = file_sha256(&item.path)
        .map_err(|e| (None, fail(ing_st, format!("{input}: reading: {e}"))))?;
    // one marker per input file and drive: its content and its path as listed (two files with
    // the same bytes are two drives when their ids come from their names)
    let key = config_hash(&[sha.as_bytes(), input.as_bytes()]);
    let prev = ctx.ds.read_marker(&key);
    if let (false, Some(first)) = (ctx.force, &prev) {
        if let Some(recs) = up_to_date(ctx, item, &key, first) {
            let skipped = first.skipped_segments.clone();
            let elapsed = t0.elapsed().as_secs_f64() / recs.len() as f64;
            let drives = recs
                .into_iter()
                .map(|mut rec| {
                    rec.input = input.to_string();
                    (Ok((DriveStatus::Reused, rec)), elapsed)
                })
                .collect();
            return Ok((drives, skipped));
        }
    }

    // ingest: the recording's drives, split at logger pauses
    let manifest_vehicle = item
        .vehicle_id
        .as_deref()
        .and_then(|id| plan.vehicles.resolve(Some(id)));
    let mut opts = plan.ingest.clone();
    opts.vehicle_id = item.vehicle_id.clone();
    opts.gear_range = manifest_vehicle.map(|v| v.file.gear_range());
    let rec = super::ingest_stage::run_recording(&item.path, &opts)
        .map_err(|e| (None, fail(ing_st, e)))?;
    let n = rec.drives.len();
    let ingest_s = t0.elapsed().as_secs_f64() / n as f64;
    let mut drives = Vec::with_capacity(n);
    for (j, ing) in rec.drives.into_iter().enumerate() {
        let t = Instant::now();
        let dkey = drive_key(&key, j);
        let prev_j = if j == 0 {
            prev.clone()
        } else {
            ctx.ds.read_marker(&dkey)
        };
        let skipped = if j == 0 {
            rec.skipped.clone()
        } else {
            Vec::new()
        };
        let input_drive = InputDrive {
            index,
            item,
            input,
            sha: &sha,
            key: &dkey,
            drives: n,
            skipped,
            prev: prev_j.as_ref(),
        };
        let id = ing.log.meta.drive_id.clone();
        // a panic costs this drive, not the input's other drives
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            process_drive(ctx, &input_drive, ing, manifest_vehicle, &opts)
        }))
        .unwrap_or_else(|p| Err((Some(id), panicked(p.as_ref()))));
        drives.push((r, ingest_s + t.elapsed().as_secs_f64()));
    }
    // drives an earlier run made from this input beyond those it gives now
    if let Some(first) = &prev {
        for j in n..first.input_drives {
            let k = drive_key(&key, j);
            if let Some(old) = ctx.ds.read_marker(&k) {
                for o in &old.outputs {
                    let _ = std::fs::remove_file(ctx.ds.root.join(o));
                }
                let _ = std::fs::remove_file(ctx.ds.root.join(ctx.ds.marker_rel(&k)));
            }
        }
    }
    Ok((drives, rec.skipped))
}

/// Which input a drive comes from, and its place among the input's drives.
struct InputDrive<'a> {
    index: usize,
    item: &'a super::inputs::InputItem,
    input: &'a str,
    sha: &'a str,
    /// The drive's marker key.
    key: &'a str,
    /// Drives the input gave.
    drives: usize,
    /// Segments of the input skipped (recorded on its first drive).
    skipped: Vec<SkippedSegment>,
    /// The drive's marker from an earlier run.
    prev: Option<&'a DriveRecord>,
}

fn process_drive(
    ctx: &Ctx<'_>,
    from: &InputDrive<'_>,
    ing: crate::ingest::Ingested,
    manifest_vehicle: Option<&std::sync::Arc<LoadedVehicle>>,
    opts: &crate::ingest::IngestOptions,
) -> One {
    let plan = ctx.plan;
    let ing_st = PipelineStage::Ingest;
    let input = from.input;
    let (mut log, mut ing_report) = (ing.log, ing.report);
    let id = Some(log.meta.drive_id.clone());
    let vehicle = plan
        .vehicles
        .resolve(log.meta.vehicle_id.as_deref())
        .cloned();
    if needs_vehicle(plan) && vehicle.is_none() {
        return Err((
            id,
            fail(
                ing_st,
                match &log.meta.vehicle_id {
                    Some(id) => format!(
                        "{input}: no vehicle file for vehicle_id {id} (pipeline [vehicles], vehicle_dir, vehicle)"
                    ),
                    None => format!(
                        "{input}: the drive names no vehicle_id and the pipeline has no default vehicle file (pipeline vehicle, or a manifest's vehicle_id)"
                    ),
                },
            ),
        ));
    }
    if let (Some(v), None) = (&vehicle, manifest_vehicle) {
        check_gears(&mut log, v, opts, &mut ing_report.masked)
            .map_err(|e| (id.clone(), fail(ing_st, e)))?;
    }
    {
        let mut claims = ctx.claims.lock().unwrap_or_else(|p| p.into_inner());
        match claims.get(&log.meta.drive_id) {
            Some(&other) if other != from.index => {
                return Err((
                    id,
                    fail(
                        ing_st,
                        format!(
                            "drive id {} is not unique in this run (also input #{other})",
                            log.meta.drive_id
                        ),
                    ),
                ))
            }
            _ => {
                claims.insert(log.meta.drive_id.clone(), from.index);
            }
        }
    }
    let hash = drive_config_hash(plan, vehicle.as_deref(), from.item.vehicle_id.as_deref());
    let mut c = compute(plan, log, vehicle.as_deref()).map_err(|f| (id.clone(), f))?;
    c.0.masked = ing_report.masked;
    c.0.conflicts_resolved = ing_report.conflicts_resolved;
    let rec = write_drive(ctx, &c, from, &hash, vehicle.as_deref()).map_err(|f| (id, f))?;
    Ok((DriveStatus::Ok, rec))
}

fn write_drive(
    ctx: &Ctx<'_>,
    computed: &(Computed, Vec<StageNote>),
    from: &InputDrive<'_>,
    hash: &str,
    vehicle: Option<&LoadedVehicle>,
) -> Result<DriveRecord, Fail> {
    let (sha, key, input, prev) = (from.sha, from.key, from.input, from.prev);
    let (c, notes) = computed;
    let plan = ctx.plan;
    let log = &c.log;
    let vehicle_id = log
        .meta
        .vehicle_id
        .clone()
        .unwrap_or_else(|| UNKNOWN_VEHICLE.to_string());
    let mut rec = DriveRecord {
        input: input.to_string(),
        input_sha256: sha.to_string(),
        config_hash: hash.to_string(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: vehicle_id.clone(),
        date: utc_date(log.timestamp_ns[0]),
        vehicle_file: vehicle.map(|v| v.path.clone()),
        stages: notes.clone(),
        outputs: Vec::new(),
        metrics: metrics_of(c),
        segment: log.meta.segment.clone(),
        input_drives: from.drives,
        skipped_segments: from.skipped.clone(),
    };
    let meta = |t: &str| base_meta(t, log, hash, &vehicle_id);
    // Each table is built just before it is written and dropped after: one table's columns
    // in memory at a time, not every table of the drive; the long tables borrow their columns
    // from the drive's results instead of copying them (docs/validation/benchmarks.md).
    let build = |t: DatasetTable| -> Option<(TableMeta, TableColumns<'_>)> {
        use TableColumns::{Borrowed, Built};
        match t {
            DatasetTable::DriveLog => {
                let mut cols = vec![ColumnRef::timestamp(&log.timestamp_ns)];
                cols.extend(conformed(&log.signals, log.len()));
                return Some((meta("drive_log"), Borrowed(cols)));
            }
            DatasetTable::DistanceLog => {
                if let Some(d) = &c.dist {
                    let (mut m, _) = resample_stage::table(d, "");
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    let mut cols = vec![
                        ColumnRef::f64("distance", "m", &d.distance_m),
                        ColumnRef::timestamp(&d.timestamp_ns),
                    ];
                    cols.extend(conformed(&d.signals, d.distance_m.len()));
                    return Some((m, Borrowed(cols)));
                }
            }
            DatasetTable::SlopeDistance | DatasetTable::SlopeTime => {
                if let (Some(d), Some(f)) = (&c.dist, &c.slope) {
                    let (dist, time) = slope_stage::tables(log, d, f);
                    let (name, cols) = if t == DatasetTable::SlopeDistance {
                        ("slope_distance", dist)
                    } else {
                        ("slope_time", time)
                    };
                    let mut m = slope_stage::meta(name, d, f, &plan.spec.slope, "");
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    return Some((m, Borrowed(cols)));
                }
            }
            DatasetTable::ShuffleSim | DatasetTable::ShuffleValidation => {
                if let Some(s) = &c.shuffle {
                    let ((ma, a), (mb, b)) = crate::report::validation::tables(log, &s.val, "");
                    let (mut m, cols) = if t == DatasetTable::ShuffleSim {
                        (ma, Borrowed(a))
                    } else {
                        (mb, Built(b))
                    };
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    return Some((m, cols));
                }
            }
            DatasetTable::AxleSim | DatasetTable::AxleValidation => {
                if let Some(a) = &c.axle {
                    let name = t.name();
                    let mut m = axle_meta(name, log, "", a);
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    let cols = if t == DatasetTable::AxleSim {
                        axle_sim_columns(
                            &a.trajectory,
                            &AxleSimExtra {
                                time: TimeAxis::Recorded {
                                    timestamp_ns: &log.timestamp_ns,
                                },
                                inputs: &a.recorded.inputs,
                                vehicle_speed_mps: log.signal("vehicle_speed"),
                                gravity_m_per_s2: c.gravity,
                            },
                        )
                    } else {
                        axle_validation_columns(a)
                    };
                    return Some((m, Built(cols)));
                }
            }
            DatasetTable::RoadSpectrum => {
                if let Some(sp) = &c.spectrum {
                    let mut m = meta("road_spectrum");
                    m.extra = vec![
                        ("knee_50_per_m".into(), format!("{:e}", sp.knee_50)),
                        ("knee_90_per_m".into(), format!("{:e}", sp.knee_90)),
                        ("knee_99_per_m".into(), format!("{:e}", sp.knee_99)),
                        ("nperseg".into(), sp.psd.nperseg.to_string()),
                        ("step_m".into(), sp.step_m.to_string()),
                    ];
                    return Some((m, Built(spectrum_columns(sp))));
                }
            }
            DatasetTable::Mismatch | DatasetTable::Findings | DatasetTable::ParameterEstimates => {
                if let Some(d) = &c.diagnosis {
                    let diag = &crate::report::contract::assemble(d);
                    let mut m = meta(t.name());
                    m.extra = vec![("verdict".into(), diag.verdict.as_str().into())];
                    let cols = match t {
                        DatasetTable::Mismatch => diag.mismatch_columns(),
                        DatasetTable::Findings => diag.findings_columns(),
                        _ => parameter_columns(&d.parameters),
                    };
                    return Some((m, Built(cols)));
                }
            }
            DatasetTable::DriveSummary => {
                return Some((meta("drive_summary"), Built(summary_columns(&rec))));
            }
        }
        None
    };
    let wst = PipelineStage::Write;
    let root = &ctx.ds.root;
    let mut written: Vec<PathBuf> = Vec::new();
    let undo = |written: &[PathBuf]| {
        for p in written {
            let _ = std::fs::remove_file(root.join(p));
        }
    };
    // the drive's diagnosis report, before the tables (drive_summary stays the last file)
    if let (Some(d), Some(spec)) = (&c.diagnosis, &plan.diagnose) {
        if spec.reports {
            let rel = ctx.ds.diagnosis_rel(&vehicle_id, &rec.drive_id);
            match write_outputs(&root.join(&rel), d, log, hash) {
                Ok(w) => {
                    let mut files = vec![w.mismatch, w.findings, w.parameter_estimates, w.report];
                    files.extend(w.plots);
                    files.extend([w.detail, w.json]);
                    for f in files {
                        if let Ok(p) = f.strip_prefix(root) {
                            written.push(p.to_path_buf());
                        }
                    }
                }
                Err(e) => return Err(fail(wst, e)),
            }
        }
    }
    let segment_kv = log
        .meta
        .segment
        .as_ref()
        .map(|s| s.kv())
        .unwrap_or_default();
    for &t in &plan.tables {
        let Some((mut m, cols)) = build(t) else {
            continue;
        };
        m.extra.extend(segment_kv.iter().cloned());
        let rel = ctx
            .ds
            .table_rel(t.name(), &vehicle_id, &rec.date, &rec.drive_id);
        let path = root.join(&rel);
        sweep_temps(&path);
        let constants = [("drive_id", rec.drive_id.as_str())];
        let written_or = match &cols {
            TableColumns::Borrowed(c) => write_column_refs_with_constants(&path, &m, c, &constants),
            TableColumns::Built(c) => {
                let refs: Vec<ColumnRef<'_>> = c.iter().map(OutColumn::as_column_ref).collect();
                write_column_refs_with_constants(&path, &m, &refs, &constants)
            }
        };
        if let Err(e) = written_or {
            undo(&written);
            return Err(fail(wst, e));
        }
        written.push(rel);
    }
    rec.outputs = written
        .iter()
        .map(|p| p.to_string_lossy().replace('\\', "/"))
        .collect();
    // outputs of an earlier configuration that this one does not write
    if let Some(prev) = prev {
        for o in &prev.outputs {
            if !rec.outputs.contains(o) {
                let _ = std::fs::remove_file(root.join(o));
            }
        }
    }
    let marker = root.join(ctx.ds.marker_rel(key));
    sweep_temps(&marker);
    let json = serde_json::to_vec_pretty(&rec).map_err(|e| fail(wst, e))?;
    if let Err(e) = AtomicFile::write_all(&marker, &json) {
        undo(&written);
        return Err(fail(wst, format!("{}: {e}", marker.display())));
    }
    Ok(rec)
}
