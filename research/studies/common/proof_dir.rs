//! Reading a proof run's folder (`fleetdyn prove -o DIR`) as the proof reads it, for the
//! studies: the cases under `drives/`, each drive's canonical log and nominal vehicle file,
//! and its answer under `answers/` — read only to label a case and to set its truth.

use fleetdyn::model::catalogue::Effect;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::table::DriveLog;
use std::error::Error;
use std::path::Path;

/// A case's answer.
pub struct Answer {
    /// `none`, `out_of_catalogue`, or the effect's id with its relative change (or its truth
    /// for an absolute one); `?` without an answer file.
    pub label: String,
    /// The hidden catalogue effect and its truth value.
    pub effect: Option<(Effect, f64)>,
}

/// The answer of `case` in the proof folder `dir` (either truth's answer file).
pub fn answer(dir: &Path, case: &str) -> Answer {
    let none = |label: &str| Answer {
        label: label.into(),
        effect: None,
    };
    let Ok(s) = std::fs::read_to_string(dir.join("answers").join(format!("{case}.json"))) else {
        return none("?");
    };
    let v: serde_json::Value = serde_json::from_str(&s).unwrap_or_default();
    // the independent truth's answer: `concealed` with its kind, the effect's id and truth
    let c = &v["concealed"];
    if c.is_object() {
        return match c["kind"].as_str() {
            Some("catalogue") => {
                let id = c["id"].as_str().unwrap_or("?");
                let truth = c["truth"].as_f64().unwrap_or(f64::NAN);
                let nominal = c["nominal"].as_f64().unwrap_or(f64::NAN);
                Answer {
                    label: if nominal != 0.0 && nominal.is_finite() {
                        format!("{id} {:+.0}%", 100.0 * (truth / nominal - 1.0))
                    } else {
                        format!("{id} {truth:.4}")
                    },
                    effect: Effect::from_id(id).ok().map(|e| (e, truth)),
                }
            }
            Some("out_of_catalogue") => none("out_of_catalogue"),
            _ => none("none"),
        };
    }
    let e = &v["effect"];
    if e.is_null() {
        return none(if v["out_of_catalogue"].is_null() {
            "none"
        } else {
            "out_of_catalogue"
        });
    }
    let id = e["id"].as_str().unwrap_or("?");
    let truth = e["truth"].as_f64().unwrap_or(f64::NAN);
    Answer {
        label: match e["relative_change"].as_f64() {
            Some(r) => format!("{id} {:+.0}%", 100.0 * r),
            None => format!("{id} {truth:.4}"),
        },
        effect: Effect::from_id(id).ok().map(|e| (e, truth)),
    }
}

/// `given` when not empty, else every case under `dir/drives`, sorted.
pub fn cases(dir: &Path, given: Vec<String>) -> std::io::Result<Vec<String>> {
    if !given.is_empty() {
        return Ok(given);
    }
    let mut all: Vec<String> = std::fs::read_dir(dir.join("drives"))?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect();
    all.sort();
    Ok(all)
}

/// The nominal vehicle file and the ingested canonical log of `case`.
pub fn load(dir: &Path, case: &str) -> Result<(VehicleFile, DriveLog), Box<dyn Error>> {
    let d = dir.join("drives").join(case);
    let vf = VehicleFile::load(&d.join("vehicle.toml"))?;
    let opts = fleetdyn::pipeline::ingest_stage::IngestConfig::default().options(&[], Some(&vf))?;
    let log = fleetdyn::ingest::ingest_file(&d.join("drive.parquet"), &opts)?.log;
    Ok((vf, log))
}

/// The noise floor (`{"<signal>": floor}`) the proof's diagnosis of `case` wrote in its
/// `diagnosis.json`: the weights the first round of the explain step used.
pub fn noise_floor(
    dir: &Path,
    case: &str,
) -> Result<std::collections::BTreeMap<String, f64>, Box<dyn Error>> {
    let d: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(
        dir.join("diagnoses").join(case).join("diagnosis.json"),
    )?)?;
    Ok(serde_json::from_value(d["noise_floor"].clone())?)
}

/// The clutch-actuation view's per-row null variance of `log`, computed again as the
/// diagnosis computes it (`diagnose::run`), for `Setup::problem`.
pub fn actuation_variance(
    log: &DriveLog,
    setup: &fleetdyn::diagnose::setup::Setup,
) -> Result<Option<Vec<f64>>, Box<dyn Error>> {
    use fleetdyn::diagnose::noise::{noise_floors, ModelSet, NoiseConfig};
    let models = ModelSet {
        actuation: true,
        ..ModelSet::for_log(log, &setup.nominal_truth, &setup.ratios, setup.nominal)
    };
    let floors = noise_floors(log, &models, &setup.nominal, &NoiseConfig::default())?;
    Ok(floors
        .get(fleetdyn::diagnose::rows::ACTUATION_CHANNEL)
        .map(|f| f.null_variance.clone()))
}
