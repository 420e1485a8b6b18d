//! The fleet evidence's output folder (docs/fleet.md): `fleet_vehicles.parquet`,
//! `fleet_parameters.parquet`, `fleet_changes.parquet`, `fleet_trips.parquet`,
//! `suggested/<vehicle_id>.toml` and
//! `fleet.html` ([`write_fleet_outputs`]). Each file is written atomically; the suggestions
//! folder holds exactly this evidence's suggestions (those of vehicles now consistent are
//! removed).

use super::fleet_html::{fleet_html, PageInfo};
use crate::fleet::suggest::suggestion;
use crate::fleet::tables::{change_columns, parameter_columns, trip_columns, vehicle_columns};
use crate::fleet::{FleetError, VehicleEvidence};
use crate::io::{escape, remove_stale_temps, write_table, AtomicFile, TableMeta};
use std::collections::BTreeMap;
use std::path::Path;

/// What the outputs record of where they came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FleetMeta<'a> {
    /// Pipeline (or harness) name.
    pub pipeline: &'a str,
    /// Model version.
    pub model_version: &'a str,
    /// The configuration file.
    pub source_file: &'a str,
    /// Configuration hash.
    pub config_hash: &'a str,
}

/// Writes the evidence of `vehicles` into `dir` (module documentation); `files` names each
/// vehicle's vehicle file in its suggestion, `drive_link` links a drive from the page.
///
/// # Errors
/// [`FleetError::Output`] or [`FleetError::Io`] when a file cannot be written.
pub fn write_fleet_outputs(
    dir: &Path,
    vehicles: &[VehicleEvidence],
    files: &BTreeMap<String, String>,
    meta: &FleetMeta<'_>,
    drive_link: &dyn Fn(&str, &str) -> String,
) -> Result<(), FleetError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| FleetError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    // leftovers of an interrupted write of this folder (it belongs to the one step writing it)
    remove_stale_temps(dir).map_err(io(dir))?;
    let table_meta = |table: &str| TableMeta {
        table: table.into(),
        drive_id: String::new(),
        vehicle_id: None,
        source_file: meta.source_file.to_string(),
        config_hash: meta.config_hash.to_string(),
        extra: vec![
            ("pipeline".into(), meta.pipeline.to_string()),
            ("model_version".into(), meta.model_version.to_string()),
        ],
    };
    write_table(
        &dir.join("fleet_vehicles.parquet"),
        &table_meta("fleet_vehicles"),
        &vehicle_columns(vehicles),
    )?;
    write_table(
        &dir.join("fleet_parameters.parquet"),
        &table_meta("fleet_parameters"),
        &parameter_columns(vehicles),
    )?;
    write_table(
        &dir.join("fleet_changes.parquet"),
        &table_meta("fleet_changes"),
        &change_columns(vehicles),
    )?;
    write_table(
        &dir.join("fleet_trips.parquet"),
        &table_meta("fleet_trips"),
        &trip_columns(vehicles),
    )?;
    let sdir = dir.join("suggested");
    if sdir.is_dir() {
        std::fs::remove_dir_all(&sdir).map_err(io(&sdir))?;
    }
    for v in vehicles {
        let file = files
            .get(&v.vehicle_id)
            .map_or("its vehicle file", String::as_str);
        if let Some(text) = suggestion(v, file) {
            std::fs::create_dir_all(&sdir).map_err(io(&sdir))?;
            let p = sdir.join(format!("{}.toml", escape(&v.vehicle_id)));
            AtomicFile::write_all(&p, text.as_bytes()).map_err(io(&p))?;
        }
    }
    let page = fleet_html(
        &PageInfo {
            pipeline: meta.pipeline,
            model_version: meta.model_version,
        },
        vehicles,
        drive_link,
    );
    let html = dir.join("fleet.html");
    AtomicFile::write_all(&html, page.as_bytes()).map_err(io(&html))?;
    Ok(())
}
