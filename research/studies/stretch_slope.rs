//! The resistance-stretch scan on the recorded slope steps and on their reconstruction: per case of
//! each proof folder given, what was hidden (the catalogue or out-of-catalogue effect's id, or
//! `none`) and the scan's F of the best step with the recorded readings (generalised least squares
//! with the run covariance, `SlopeReading::grade` `None`) and with the slope reconstructed between
//! the steps (`SlopeGrid::cured` at the drive's resolution, the diagnosis's reading),
//! tab-separated. The largest of each column over the calibration seeds' no-effect drives is that
//! reading's threshold (docs/diagnosis/method.md, rule 6).
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin stretch_slope -- DIR...
//! ```
use fleetdyn::diagnose::compare::Conditions;
use fleetdyn::diagnose::extended::SlopeGrid;
use fleetdyn::diagnose::resistance_stretch::{resistance_stretch, SlopeReading, StretchConfig};
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one uses a part
mod proof_dir;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dirs: Vec<String> = std::env::args().skip(1).collect();
    if dirs.is_empty() {
        return Err("usage: stretch_slope DIR...".into());
    }
    let cfg = StretchConfig::default();
    println!("folder\tcase\thidden\tf_recorded_steps\tf_reconstructed");
    for dir in dirs {
        let dir = PathBuf::from(dir);
        for case in proof_dir::cases(&dir, vec![])? {
            // the concealed effect's id (catalogue or not), else its kind (`none`)
            let concealed =
                std::fs::read_to_string(dir.join("answers").join(format!("{case}.json")))
                    .ok()
                    .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
                    .map(|v| v["concealed"].clone())
                    .unwrap_or_default();
            let hidden = concealed["id"]
                .as_str()
                .or(concealed["kind"].as_str())
                .unwrap_or("?")
                .to_string();
            let (vf, log) = proof_dir::load(&dir, &case)?;
            let setup = Setup::new(&log, &vf)?;
            let c = Conditions::from_log(&log);
            let d = &setup.nominal_truth.driveline;
            let f = |grade: Option<&[f64]>| {
                let slope = SlopeReading {
                    resolution: setup.slope_resolution,
                    grade,
                };
                resistance_stretch(&log, &c.t_s, &c.distance_m, d, &setup.ratios, slope, &cfg)
                    .map_or(f64::NAN, |s| s.f)
            };
            let grade = SlopeGrid::new(&log).and_then(|g| g.cured(setup.slope_resolution));
            println!(
                "{}\t{case}\t{hidden}\t{:.2}\t{:.2}",
                dir.display(),
                f(None),
                grade.as_deref().map_or(f64::NAN, |g| f(Some(g)))
            );
        }
    }
    Ok(())
}
