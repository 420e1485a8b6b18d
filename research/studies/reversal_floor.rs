//! The reversal channel ([`fleetdyn::diagnose::reversal_channel`]) on the drives of a proof run
//! (`fleetdyn prove`): per case and reversal, the measured feature, the diagnosis' windowed
//! model's feature at the nominal parameters and at the hidden truth (any catalogue effect),
//! in rpm. The summary gives the rms of `measured − nominal` on the drives without an effect —
//! the model's own error of the feature, from which [`FLOOR_RAD_S`] is set. The answer file
//! is read only to label the case and to set the truth.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin reversal_floor -- DIR [case-0006 …]
//! ```

use fleetdyn::diagnose::reversal_channel::{measure, simulate, FLOOR_RAD_S};
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;

#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one uses a part
mod proof_dir;

const RPM: f64 = 30.0 / std::f64::consts::PI;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().ok_or("usage: reversal_floor DIR [case…]")?);
    let cases = proof_dir::cases(&dir, args.collect())?;
    let mut clean: Vec<(f64, f64)> = Vec::new(); // (residual, noise-only weight part)
    for case in &cases {
        let proof_dir::Answer {
            label,
            effect: hidden,
        } = proof_dir::answer(&dir, case);
        let (vf, log) = proof_dir::load(&dir, case)?;
        let setup = Setup::new(&log, &vf)?;
        let Some(model) = setup.longitudinal_model(&log)? else {
            continue;
        };
        let samples = measure(
            &log,
            model.measured_speed(),
            model.measured_engine_speed(),
            model.window_starts(),
            &setup.nominal_truth.driveline,
            model.ratios(),
            1.0,
        );
        if samples.is_empty() {
            println!("{case} [{label}]: no reversal samples");
            continue;
        }
        let t = model.times();
        let nominal = model.simulate(&setup.nominal)?;
        let y_nom = simulate(&samples, t, &nominal.engine_speed, &nominal.vehicle_speed);
        let y_truth = match hidden {
            Some((e, v)) => {
                let mut th = setup.nominal;
                th.set(e, v);
                let s = model.simulate(&th)?;
                Some(simulate(&samples, t, &s.engine_speed, &s.vehicle_speed))
            }
            None => None,
        };
        println!("{case} [{label}]: {} reversal samples", samples.len());
        for s in &samples {
            let r_nom = s.value - y_nom[s.row];
            let noise_sd = (1.0 / s.weight - FLOOR_RAD_S * FLOOR_RAD_S).max(0.0).sqrt();
            println!(
                "  {:7.2} s gear {:2} {}: measured {:+6.1} rpm, nominal {:+6.1} (residual {:+6.1}){}, noise sd {:.1} rpm",
                t[s.row],
                s.gear,
                if s.direction > 0.0 { "tip-in " } else { "tip-out" },
                s.value * RPM,
                y_nom[s.row] * RPM,
                r_nom * RPM,
                y_truth.as_ref().map_or(String::new(), |y| format!(
                    ", truth {:+6.1} (residual {:+6.1})",
                    y[s.row] * RPM,
                    (s.value - y[s.row]) * RPM
                )),
                noise_sd * RPM,
            );
            if label == "none" {
                clean.push((r_nom, noise_sd));
            }
        }
    }
    if !clean.is_empty() {
        let n = clean.len() as f64;
        let ms = clean.iter().map(|c| c.0 * c.0).sum::<f64>() / n;
        let noise = clean.iter().map(|c| c.1 * c.1).sum::<f64>() / n;
        let mut abs: Vec<f64> = clean.iter().map(|c| c.0.abs()).collect();
        abs.sort_by(f64::total_cmp);
        println!(
            "no-effect drives: {} reversals, rms(measured − nominal) {:.2} rpm, mean noise variance {:.2} rpm², median |r| {:.2} rpm, max |r| {:.2} rpm",
            clean.len(),
            ms.sqrt() * RPM,
            noise * RPM * RPM,
            abs[abs.len() / 2] * RPM,
            abs[abs.len() - 1] * RPM
        );
    }
    Ok(())
}
