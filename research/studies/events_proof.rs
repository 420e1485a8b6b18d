//! Event features ([`fleetdyn::diagnose::events`]) on the drives of a proof run (`fleetdyn
//! prove`), read as the proof reads them (`drive.parquet`, the canonical log, and the nominal
//! `vehicle.toml`). Per case: the launch clutch-torque ratios (1 for the nominal clutch), and
//! per torque reversal the engine-speed residual peak of the diagnosis' windowed model
//! ([`fleetdyn::diagnose::extended::LongitudinalModel`]) at the nominal parameters and — for
//! the cases that hide `clutch_slip` or `driveline_backlash` — at the hidden truth. The answer
//! file is read only to label the case and to set that truth.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin events_proof -- DIR [case-0006 …]
//! ```

use fleetdyn::diagnose::events::{
    launch_clutch_torques, reversal_residual_peaks, torque_reversals, Channels, EventConfig,
};
use fleetdyn::diagnose::setup::Setup;
use fleetdyn::model::catalogue::Effect;
use std::path::PathBuf;

#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one uses a part
mod proof_dir;

const RPM: f64 = 30.0 / std::f64::consts::PI;

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
    let cases = proof_dir::cases(&dir, args.collect())?;
    let cfg = EventConfig::default();
    for case in &cases {
        let answer = proof_dir::answer(&dir, case);
        let label = answer.label;
        // the truth is set only for the two effects the study is about
        let hidden = answer
            .effect
            .filter(|(e, _)| matches!(e, Effect::ClutchSlip | Effect::DrivelineBacklash));
        let (vf, log) = proof_dir::load(&dir, case)?;
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
