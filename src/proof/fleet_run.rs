//! Running a fleet proof ([`run_fleet_proof`]): every planned drive simulated and diagnosed in
//! parallel, each truck scored ([`super::fleet`]), the summary against the targets and the
//! fleet evidence written.

use super::fleet::{
    fleet_plan, run_drive, score_truck, FleetDriveResult, FleetProofConfig, FleetTruck, TruckScore,
};
use super::run::ProveError;
use crate::fleet::evidence::VehicleEvidence;
use crate::io::AtomicFile;
use crate::model::vehicle::VehicleFile;
use crate::report::fleet_files::{write_fleet_outputs, FleetMeta};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The targets a fleet proof is held to.
pub const TARGET_DELAY_DRIVES: usize = 5;
/// Most false alarms per 20 vehicle-months.
pub const TARGET_FALSE_ALARMS_PER_20_VEHICLE_MONTHS: f64 = 1.0;
/// Largest pooled estimate error of drag area, rolling resistance and clutch capacity.
pub const TARGET_ESTIMATE_ERROR: f64 = 0.05;

/// A fleet proof's result.
#[derive(Debug, Clone, Serialize)]
pub struct FleetProofRun {
    /// The configuration.
    pub config: FleetProofConfig,
    /// The nominal vehicle file.
    pub vehicle: String,
    /// Per truck.
    pub trucks: Vec<TruckScore>,
    /// Faulty trucks whose fault was flagged within [`TARGET_DELAY_DRIVES`] drives.
    pub detected_in_time: usize,
    /// Faulty trucks flagged at all.
    pub detected: usize,
    /// Faulty trucks.
    pub faulty: usize,
    /// False alarms.
    pub false_alarms: usize,
    /// Vehicle-months observed (drives / drives a month).
    pub vehicle_months: f64,
    /// Drives that failed.
    pub failed_drives: usize,
    /// Drives.
    pub drives: usize,
    /// Simulated drive hours.
    pub drive_hours: f64,
    /// Diagnosis time per drive-hour, s (all threads).
    pub seconds_per_drive_hour: f64,
    /// Wall time, s.
    pub elapsed_s: f64,
}

impl FleetProofRun {
    /// False alarms per 20 vehicle-months.
    pub fn false_alarm_rate(&self) -> f64 {
        20.0 * self.false_alarms as f64 / self.vehicle_months.max(1e-12)
    }

    /// The summary in Markdown.
    pub fn to_markdown(&self) -> String {
        let c = &self.config;
        let mut s = format!(
            "# Fleet proof (independent truth)\n\n\
             Seed {}, {} trucks × {} drives of {}–{} km ({} faulty), {} drives a month.\n\n\
             | measure | result | target |\n|---|---|---|\n\
             | faults flagged within {} drives of onset | {} of {} ({} flagged at all) | all |\n\
             | false alarms per 20 vehicle-months | {:.2} ({} in {:.1} vehicle-months) | ≤ {} |\n",
            c.seed,
            c.trucks,
            c.drives_per_truck,
            c.length_km.0,
            c.length_km.1,
            c.faulty,
            c.drives_per_month,
            TARGET_DELAY_DRIVES,
            self.detected_in_time,
            self.faulty,
            self.detected,
            self.false_alarm_rate(),
            self.false_alarms,
            self.vehicle_months,
            TARGET_FALSE_ALARMS_PER_20_VEHICLE_MONTHS,
        );
        for id in ["aero_drag", "rolling_resistance", "clutch_slip"] {
            let errs: Vec<f64> = self
                .trucks
                .iter()
                .flat_map(|t| &t.estimates)
                .filter(|e| e.0 == id && e.3.is_finite())
                .map(|e| e.3.abs())
                .collect();
            let within = errs.iter().filter(|e| **e <= TARGET_ESTIMATE_ERROR).count();
            let mut sorted = errs.clone();
            let med = crate::signal::stats::median(&mut sorted);
            s.push_str(&format!(
                "| {id} pooled estimate within 5 % of the truth | {within} of {} trucks (median error {:.1} %) | all |\n",
                errs.len(),
                100.0 * med
            ));
        }
        let mut mass: Vec<f64> = self
            .trucks
            .iter()
            .flat_map(|t| &t.trip_mass)
            .filter(|m| m.2.is_finite())
            .map(|m| m.2.abs())
            .collect();
        let within = mass.iter().filter(|e| **e <= TARGET_ESTIMATE_ERROR).count();
        let n_mass = mass.len();
        let med = crate::signal::stats::median(&mut mass);
        s.push_str(&format!(
            "| mass per trip within 5 % of the trip's truth | {within} of {n_mass} trips (median error {:.1} %) | no target |\n",
            100.0 * med
        ));
        s.push_str(&format!(
            "\n{} drives ({} failed), {:.1} drive-hours, diagnosis {:.1} s per drive-hour, {:.0} s wall.\n\n\
             | truck | fault (onset day) | flagged after | false alarms | other flags after onset | drag area est./truth | c_r1 est./truth | clutch est./truth |\n|---|---|---|---|---|---|---|---|\n",
            self.drives,
            self.failed_drives,
            self.drive_hours,
            self.seconds_per_drive_hour,
            self.elapsed_s
        ));
        for t in &self.trucks {
            let fault = t
                .fault
                .map_or("—".to_string(), |(f, d)| format!("{} ({d})", f.effect()));
            let delay = match (t.fault, t.delay) {
                (None, _) => "—".to_string(),
                (Some(_), Some(d)) => format!("{d} drives"),
                (Some(_), None) => "not flagged".to_string(),
            };
            let list = |v: &[(String, usize)]| {
                if v.is_empty() {
                    "—".to_string()
                } else {
                    v.iter()
                        .map(|(p, d)| format!("{p} (day {d})"))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            };
            let est = |id: &str| {
                t.estimates
                    .iter()
                    .find(|e| e.0 == id)
                    .map_or("—".to_string(), |e| {
                        format!("{:.4} / {:.4} ({:+.1} %)", e.1, e.2, 100.0 * e.3)
                    })
            };
            s.push_str(&format!(
                "| {} | {fault} | {delay} | {} | {} | {} | {} | {} |\n",
                t.vehicle_id,
                list(&t.false_alarms),
                list(&t.side_flags),
                est("aero_drag"),
                est("rolling_resistance"),
                est("clutch_slip"),
            ));
        }
        s
    }
}

/// Runs the fleet proof of `cfg` on the vehicle file `vehicle` into `out` with `jobs` threads;
/// `progress(done, total)` after each drive. `out` receives `fleet_proof.md`,
/// `fleet_proof.json` (the run and every drive's result with its estimates, from which
/// [`rescore_fleet_proof`] scores it again) and the fleet evidence under `fleet/`.
///
/// # Errors
/// [`ProveError`] for the vehicle file, the thread pool or the outputs; a failing drive only
/// fails that drive.
pub fn run_fleet_proof(
    cfg: &FleetProofConfig,
    vehicle: &Path,
    out: &Path,
    jobs: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<FleetProofRun, ProveError> {
    let t0 = std::time::Instant::now();
    let vf = VehicleFile::load(vehicle)?;
    let (trucks, drives) = fleet_plan(cfg);
    let scratch = out.join("scratch");
    std::fs::create_dir_all(&scratch).map_err(io(&scratch))?;
    let results: Vec<FleetDriveResult> = super::workers::on_workers(
        jobs,
        &drives,
        |d| {
            let dir = scratch.join(format!("t{:03}-d{:03}", d.truck, d.day));
            run_drive(d, &trucks[d.truck], vehicle, &vf, &dir)
        },
        &|k| progress(k, drives.len()),
    )
    .map_err(ProveError::Pool)?;
    let _ = std::fs::remove_dir_all(&scratch);
    let elapsed_s = t0.elapsed().as_secs_f64();
    let vehicle = vehicle.display().to_string();
    score_and_write(cfg, &trucks, &vehicle, results, elapsed_s, out)
}

/// What [`rescore_fleet_proof`] reads back of a fleet proof's run.
#[derive(Deserialize)]
struct SavedRun {
    config: FleetProofConfig,
    #[serde(default)]
    vehicle: String,
    elapsed_s: f64,
}

/// Scores the fleet proof saved in `saved` (its `fleet_proof.json`) again, without simulating
/// or diagnosing a drive: the drives' estimates as they were, the fleet evidence and the scores
/// as the current code computes them, written into `out` as [`run_fleet_proof`] writes them
/// (the wall time kept from the saved run).
///
/// # Errors
/// [`ProveError::Saved`] when the file cannot be read or is not a fleet proof's, [`ProveError`]
/// for the outputs.
pub fn rescore_fleet_proof(saved: &Path, out: &Path) -> Result<FleetProofRun, ProveError> {
    let path = saved.join("fleet_proof.json");
    let bad = |message: String| ProveError::Saved {
        path: path.clone(),
        message,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    let (run, results): (SavedRun, Vec<FleetDriveResult>) =
        serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    run.config.validate().map_err(|e| bad(e.to_string()))?;
    let (trucks, planned) = fleet_plan(&run.config);
    if planned.len() != results.len()
        || planned
            .iter()
            .zip(&results)
            .any(|(p, r)| (p.truck, p.day, p.seed) != (r.drive.truck, r.drive.day, r.drive.seed))
    {
        return Err(bad(
            "its drives are not the plan of its configuration".to_string()
        ));
    }
    score_and_write(
        &run.config,
        &trucks,
        &run.vehicle,
        results,
        run.elapsed_s,
        out,
    )
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ProveError {
    let path = path.to_path_buf();
    move |source| ProveError::Io {
        path: path.clone(),
        source,
    }
}

/// Scores every truck of the plan (`trucks`, of `cfg`) from the drives' `results` and writes the
/// summary, the JSON and the fleet evidence into `out`.
fn score_and_write(
    cfg: &FleetProofConfig,
    trucks: &[FleetTruck],
    vehicle: &str,
    results: Vec<FleetDriveResult>,
    elapsed_s: f64,
    out: &Path,
) -> Result<FleetProofRun, ProveError> {
    let mut scores = Vec::new();
    let mut evidence: Vec<VehicleEvidence> = Vec::new();
    for (t, truck) in trucks.iter().enumerate() {
        let mine: Vec<&FleetDriveResult> = results.iter().filter(|r| r.drive.truck == t).collect();
        let (s, v) = score_truck(truck, &mine);
        scores.push(s);
        if !v.drives.is_empty() {
            evidence.push(v);
        }
    }
    let ok: Vec<&FleetDriveResult> = results.iter().filter(|r| r.error.is_none()).collect();
    let drive_hours = ok.iter().map(|r| r.duration_s).sum::<f64>() / 3600.0;
    let faulty = scores.iter().filter(|s| s.fault.is_some()).count();
    let run = FleetProofRun {
        config: cfg.clone(),
        vehicle: vehicle.to_string(),
        detected_in_time: scores
            .iter()
            .filter(|s| s.delay.is_some_and(|d| d <= TARGET_DELAY_DRIVES))
            .count(),
        detected: scores.iter().filter(|s| s.delay.is_some()).count(),
        faulty,
        false_alarms: scores.iter().map(|s| s.false_alarms.len()).sum(),
        vehicle_months: ok.len() as f64 / cfg.drives_per_month,
        failed_drives: results.len() - ok.len(),
        drives: results.len(),
        drive_hours,
        seconds_per_drive_hour: ok.iter().map(|r| r.seconds).sum::<f64>() / drive_hours.max(1e-12),
        elapsed_s,
        trucks: scores,
    };
    std::fs::create_dir_all(out).map_err(io(out))?;
    let md = out.join("fleet_proof.md");
    AtomicFile::write_all(&md, run.to_markdown().as_bytes()).map_err(io(&md))?;
    let json = out.join("fleet_proof.json");
    let mut text = serde_json::to_string_pretty(&(&run, &results)).unwrap_or_default();
    text.push('\n');
    AtomicFile::write_all(&json, text.as_bytes()).map_err(io(&json))?;
    let files: BTreeMap<String, String> = trucks
        .iter()
        .map(|t| (t.vehicle_id.clone(), vehicle.to_string()))
        .collect();
    write_fleet_outputs(
        &out.join("fleet"),
        &evidence,
        &files,
        &FleetMeta {
            pipeline: "prove --fleet",
            model_version: "proof",
            source_file: vehicle,
            config_hash: "",
        },
        &|_, _| "#".to_string(),
    )
    .map_err(|e| ProveError::Io {
        path: out.join("fleet"),
        source: std::io::Error::other(e.to_string()),
    })?;
    Ok(run)
}
