//! Vehicle files per vehicle id: a pipeline's `[vehicles]` table (`vehicle_id` → file) first,
//! then `vehicle_dir` (every `*.toml` there, used for the `vehicle_id` it declares), then the
//! default `vehicle`. Every file is parsed once, when the plan is made, and its text hashed: a
//! drive's configuration hash includes its vehicle file, so an edited vehicle file reprocesses
//! exactly the drives of that vehicle.

use crate::io::config_hash;
use crate::model::vehicle::VehicleFile;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

/// A parsed vehicle file with its provenance.
#[derive(Debug, Clone)]
pub struct LoadedVehicle {
    /// Path as given.
    pub path: String,
    /// Parsed parameters.
    pub file: VehicleFile,
    /// Hash of the file's text.
    pub sha256: String,
}

/// Vehicle files by vehicle id.
#[derive(Debug, Clone, Default)]
pub struct VehicleBook {
    by_id: BTreeMap<String, Arc<LoadedVehicle>>,
    default: Option<Arc<LoadedVehicle>>,
}

fn load_one(path: &Path, problems: &mut Vec<String>) -> Option<Arc<LoadedVehicle>> {
    let file = path.display().to_string();
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => {
            problems.push(format!("vehicle file {file}: {e}"));
            return None;
        }
    };
    match VehicleFile::parse(&text, &file) {
        Ok(v) => Some(Arc::new(LoadedVehicle {
            sha256: config_hash(&[text.as_bytes()]),
            path: file,
            file: v,
        })),
        Err(e) => {
            problems.push(format!("vehicle: {e}"));
            None
        }
    }
}

impl VehicleBook {
    /// Loads every vehicle file named by a pipeline, collecting problems.
    pub fn load(
        table: &BTreeMap<String, std::path::PathBuf>,
        dir: Option<&Path>,
        default: Option<&Path>,
        problems: &mut Vec<String>,
    ) -> Self {
        let mut by_id = BTreeMap::new();
        if let Some(d) = dir {
            match std::fs::read_dir(d) {
                Ok(entries) => {
                    let mut paths: Vec<_> = entries
                        .flatten()
                        .map(|e| e.path())
                        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("toml"))
                        .collect();
                    paths.sort();
                    for p in paths {
                        if let Some(v) = load_one(&p, problems) {
                            let id = v.file.vehicle_id.clone();
                            if let Some(prev) = by_id.insert(id.clone(), v) {
                                problems.push(format!(
                                    "vehicle_dir {}: vehicle_id {id} is declared by {} and {}",
                                    d.display(),
                                    prev.path,
                                    p.display()
                                ));
                            }
                        }
                    }
                }
                Err(e) => problems.push(format!("vehicle_dir {}: {e}", d.display())),
            }
        }
        for (id, p) in table {
            if let Some(v) = load_one(p, problems) {
                by_id.insert(id.clone(), v);
            }
        }
        let default = default.and_then(|p| load_one(p, problems));
        Self { by_id, default }
    }

    /// The vehicle file of `vehicle_id` (the default file for unknown or absent ids).
    pub fn resolve(&self, vehicle_id: Option<&str>) -> Option<&Arc<LoadedVehicle>> {
        vehicle_id
            .and_then(|id| self.by_id.get(id))
            .or(self.default.as_ref())
    }

    /// No vehicle file at all.
    pub fn is_empty(&self) -> bool {
        self.by_id.is_empty() && self.default.is_none()
    }

    /// Whether any vehicle file satisfies `f`.
    pub fn any(&self, f: impl Fn(&LoadedVehicle) -> bool) -> bool {
        self.by_id.values().chain(self.default.iter()).any(|v| f(v))
    }
}
