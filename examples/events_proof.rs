//! Event features ([`fleetdyn::diagnose::events`]) on the drives of a proof run (`fleetdyn
//! prove`), read as the proof reads them (`drive.parquet`, the canonical log, and the nominal
//! `vehicle.toml`). Per case: the launch clutch-torque ratios (1 for the nominal clutch), and
//! per torque reversal the engine-speed residual peak of the diagnosis' windowed model
//! ([`fleetdyn::diagnose::extended::LongitudinalModel`]) at the nominal parameters and — for
//! the cases that hide `clutch_slip` or `driveline_backlash` — at the hidden truth. The answer
//! file is read only to label the case and to set that truth.
//!
//! ```text
//! cargo run --release --example events_proof -- DIR [case-0006 …]
//! ```

use fleetdyn::diagnose::catalogue::Effect;
use fleetdyn::diagnose::events::{
    launch_clutch_torques, reversal_residual_peaks, torque_reversals, Channels, EventConfig,
};
use fleetdyn::diagnose::setup::Setup;
use std::path::{Path, PathBuf};

const RPM: f64 = 30.0 / std::f64::consts::PI;

/// (label, hidden effect and truth value when it is one of the two).
fn answer(dir: &Path, case: &str) -> (String, Option<(Effect, f64)>) {
    let Ok(s) = std::fs::read_to_string(dir.join("answers").join(format!("{case}.json"))) else {
        return ("?".into(), None);
    };
    let v: serde_json::Value = serde_json::from_str(&s).unwrap_or_default();
    let e = &v["effect"];
    if e.is_null() {
        let l = if v["out_of_catalogue"].is_null() {
            "none"
        } else {
            "out_of_catalogue"
        };
        return (l.into(), None);
    }
    let id = e["id"].as_str().unwrap_or("?");
    let truth = e["truth"].as_f64().unwrap_or(f64::NAN);
    let label = match e["relative_change"].as_f64() {
        Some(r) => format!("{id} {:+.0}%", 100.0 * r),
        None => format!("{id} {truth:.4}"),
    };
    let hidden = Effect::from_id(id)
        .ok()
        .filter(|e| matches!(e, Effect::ClutchSlip | Effect::DrivelineBacklash))
        .map(|e| (e, truth));
    (label, hidden)
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().ok_or("usage: events_proof DIR [case…]")?);
    let mut cases: Vec<String> = args.collect();
    if cases.is_empty() {
        let mut all: Vec<String> = std::fs::read_dir(dir.join("drives"))?
            .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
            .collect();
        all.sort();
        cases = all;
    }
    let cfg = EventConfig::default();
    for case in &cases {
        let d = dir.join("drives").join(case);
        let (label, hidden) = answer(&dir, case);
        let vf = fleetdyn::model::vehicle::VehicleFile::load(&d.join("vehicle.toml"))?;
        let opts =
            fleetdyn::pipeline::ingest_stage::IngestConfig::default().options(&[], Some(&vf))?;
        let log = fleetdyn::ingest::ingest_file(&d.join("drive.parquet"), &opts)?.log;
        let (Some(dl), Some(ch)) = (vf.driveline.as_ref(), Channels::from_log(&log)) else {
            println!("{case} [{label}]: no driveline or channels");
            continue;
        };
        let ratios = &vf.gearbox.ratios;
        let launches = launch_clutch_torques(&ch, dl, ratios, &cfg);
        let mut r: Vec<f64> = launches.iter().map(|l| l.ratio).collect();
        let truth_ratio = hidden
            .filter(|h| h.0 == Effect::ClutchSlip)
            .map(|h| h.1 / dl.clutch_max_torque_nm);
        println!(
            "{case} [{label}]: {} launches, clutch-torque ratio median {:.3}{}: {}",
            launches.len(),
            median(&mut r.clone()),
            truth_ratio.map_or(String::new(), |t| format!(" (hidden {t:.3})")),
            launches
                .iter()
                .map(|l| format!(
                    "{:.0} s {:.2} (slope {:.2}, intercept {:+.0} N·m, C ≤ {:.0} N·m)",
                    l.t_start_s, l.ratio, l.slope, l.intercept_nm, l.max_capacity_nm
                ))
                .collect::<Vec<_>>()
                .join("; ")
        );
        r.clear();
        let reversals = torque_reversals(&ch, &cfg);
        if reversals.is_empty() {
            println!("  no torque reversals");
            continue;
        }
        let setup = Setup::new(&log, &vf)?;
        let Some(model) = setup.longitudinal_model(&log)? else {
            continue;
        };
        let nominal = model.simulate(&setup.nominal)?;
        let peaks_nom = reversal_residual_peaks(
            &reversals,
            model.times(),
            model.measured_engine_speed(),
            &nominal.engine_speed,
            &cfg,
        );
        let peaks_truth = match hidden {
            Some((e, v)) => {
                let mut th = setup.nominal;
                th.set(e, v);
                let s = model.simulate(&th)?;
                Some(reversal_residual_peaks(
                    &reversals,
                    model.times(),
                    model.measured_engine_speed(),
                    &s.engine_speed,
                    &cfg,
                ))
            }
            None => None,
        };
        for (k, rv) in reversals.iter().enumerate() {
            println!(
                "  reversal {:7.1} s gear {:2} {}: engine-speed residual peak vs nominal {:+6.1} rpm{}",
                rv.t_s,
                rv.gear,
                if rv.tip_in { "tip-in " } else { "tip-out" },
                peaks_nom[k] * RPM,
                peaks_truth
                    .as_ref()
                    .map_or(String::new(), |p| format!(", vs hidden truth {:+6.1} rpm", p[k] * RPM))
            );
        }
    }
    Ok(())
}
