//! The `fleet` stage (docs/fleet.md): after the drives are written, every diagnosed drive of the
//! dataset (this model version, all runs) is read back from its `parameter_estimates` table,
//! grouped by vehicle, and turned into per-vehicle evidence ([`crate::fleet`]): the tables
//! `fleet_vehicles`, `fleet_parameters`, `fleet_changes` and `fleet_trips`, a suggested vehicle-file update per
//! vehicle with a parameter outside its tolerance, and the page `fleet.html`, all under the run
//! report's `fleet/` folder. Only an unsharded run (the reduce step of a sharded one) runs it.
//!
//! A drive whose table cannot be read is left out with a warning and counted; it does not stop
//! the stage.

use super::dataset::{escape, Dataset};
use super::record::{DriveRecord, FleetSummary};
use super::spec::Plan;
use crate::fleet::series::{read_parameter_estimates, DriveEstimates, FleetError};
use crate::fleet::{vehicle_evidence, VehicleEvidence};
use crate::io::config_hash;
use crate::report::fleet_files::{write_fleet_outputs, FleetMeta};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every marker of the dataset's model version, sorted by key (deterministic).
fn markers(ds: &Dataset) -> Vec<DriveRecord> {
    let root = ds
        .root
        .join("_state")
        .join(format!("model_version={}", escape(&ds.model_version)));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&root)
        .into_iter()
        .flatten()
        .flatten()
        .flat_map(|d| std::fs::read_dir(d.path()).into_iter().flatten().flatten())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    files
        .iter()
        .filter_map(|p| serde_json::from_slice(&std::fs::read(p).ok()?).ok())
        .collect()
}

/// Runs the stage into `report_dir/fleet` (module documentation).
///
/// # Errors
/// [`FleetError`] when an output cannot be written.
pub fn run_fleet(ds: &Dataset, plan: &Plan, report_dir: &Path) -> Result<FleetSummary, FleetError> {
    let mut by_vehicle: BTreeMap<String, Vec<DriveEstimates>> = BTreeMap::new();
    let mut files: BTreeMap<String, String> = BTreeMap::new();
    let mut unreadable = 0;
    for rec in markers(ds) {
        let Some(rel) = rec
            .outputs
            .iter()
            .find(|o| o.starts_with("parameter_estimates/"))
        else {
            continue;
        };
        match read_parameter_estimates(&ds.root.join(rel)) {
            Ok((rows, verdict)) => {
                if let Some(f) = &rec.vehicle_file {
                    files.insert(rec.vehicle_id.clone(), f.clone());
                }
                by_vehicle
                    .entry(rec.vehicle_id.clone())
                    .or_default()
                    .push(DriveEstimates {
                        vehicle_id: rec.vehicle_id.clone(),
                        drive_id: rec.drive_id.clone(),
                        start_ns: rec.metrics.start_ns,
                        verdict,
                        source: rel.clone(),
                        rows,
                    });
            }
            Err(e) => {
                tracing::warn!("fleet: drive {} left out: {e}", rec.drive_id);
                unreadable += 1;
            }
        }
    }
    let vehicles: Vec<VehicleEvidence> = by_vehicle
        .into_iter()
        .map(|(id, drives)| vehicle_evidence(&id, drives))
        .collect();
    let dir = report_dir.join("fleet");
    let mv = escape(&ds.model_version);
    // links from <root>/_reports/<pipeline>/model_version=M/fleet/ to each drive's report
    let link = |vehicle: &str, drive: &str| {
        format!(
            "../../../diagnose/model_version={mv}/vehicle_id={}/{}/report.md",
            escape(vehicle),
            escape(drive)
        )
    };
    write_fleet_outputs(
        &dir,
        &vehicles,
        &files,
        &FleetMeta {
            pipeline: &plan.spec.name,
            model_version: &plan.spec.model_version,
            source_file: &plan.file,
            config_hash: &config_hash(&[plan.fingerprint.as_bytes()]),
        },
        &link,
    )?;
    Ok(FleetSummary {
        dir: dir.display().to_string(),
        vehicles: vehicles.len(),
        drives: vehicles.iter().map(|v| v.drives.len()).sum(),
        unreadable,
        flagged: vehicles
            .iter()
            .filter(|v| v.flagged().next().is_some())
            .count(),
        changes: vehicles
            .iter()
            .flat_map(|v| &v.parameters)
            .map(|p| p.changes.len())
            .sum(),
    })
}
