//! Study: the engine speed while the clutch is actuated (the rows `diagnose::compare` leaves
//! out within ±0.5 s of a clutch transition, with a gear engaged, the clutch not fully open
//! and the truck moving) as a view of the longitudinal model, weighted by its own null
//! variance from the noise floor's copies (which jitter the 10 Hz clutch's sampling phase).
//! Per case of a proof folder: rows per part of the diagnosis' split, and the weighted mean
//! square of each part at the nominal parameters and with the hidden effect at its truth
//! (what `Problem::with_actuation` scores; docs/diagnosis/events.md). `ACTUATION_MIN_SPEED_MPS=x` takes
//! the rows from `x` m/s instead of 1 m/s (the launches from standstill).
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin actuation_view -- DIR case-0009 case-0016 …
//! ```
use fleetdyn::diagnose::compare::Compared;
use fleetdyn::diagnose::extended::Theta;
use fleetdyn::diagnose::noise::{noise_floors_with, NoiseConfig, NoiseError};
use fleetdyn::diagnose::rows;
use fleetdyn::diagnose::setup::Setup;
use fleetdyn::table::DriveLog;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)]
mod proof_dir;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (dir, cases) = a.split_first().ok_or("usage: actuation_view DIR CASE…")?;
    let dir = PathBuf::from(dir);
    // ACTUATION_MIN_SPEED_MPS=x: rows from x m/s (launches), instead of the view's 1 m/s
    let min_speed: f64 = std::env::var("ACTUATION_MIN_SPEED_MPS")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(1.0);
    println!("case | label | rows train / held-out | MS nominal train, held-out | MS truth train, held-out");
    for case in cases {
        let (vf, log) = proof_dir::load(&dir, case)?;
        let ans = proof_dir::answer(&dir, case);
        let setup = Setup::new(&log, &vf)?;
        let sim = |l: &DriveLog, th: &Theta| -> Result<Vec<f64>, NoiseError> {
            match setup.longitudinal_model(l)? {
                Some(m) => Ok(m.simulate(th)?.engine_speed),
                None => Ok(vec![f64::NAN; l.len()]),
            }
        };
        let act = rows::actuation_channel_rows(&log, min_speed);
        let floors = noise_floors_with(&log, &NoiseConfig::default(), None, |l| {
            Ok(vec![Compared {
                name: "engine_speed".into(),
                unit: "rad/s".into(),
                measured: l.signal("engine_speed").unwrap_or(&[]).to_vec().into(),
                simulated: sim(l, &setup.nominal)?.into(),
                valid: act.clone(),
            }])
        })?;
        let var = &floors.floors[0].null_variance;
        let mut th = setup.nominal;
        if let Some((e, v)) = ans.effect {
            th.set(e, v);
        }
        let meas = log
            .signal("engine_speed")
            .ok_or("no engine speed")?
            .to_vec();
        let nom = sim(&log, &setup.nominal)?;
        let tru = sim(&log, &th)?;
        // the diagnosis' own split
        let heldout = setup.problem(&log, None)?.split().heldout.clone();
        let ms = |y: &[f64], part: bool| -> (usize, f64) {
            let idx: Vec<usize> = (0..log.len())
                .filter(|&i| act[i] && heldout[i] == part && y[i].is_finite())
                .filter(|&i| var[i].is_finite() && var[i] > 0.0)
                .collect();
            let s: f64 = idx.iter().map(|&i| (meas[i] - y[i]).powi(2) / var[i]).sum();
            (idx.len(), s / idx.len().max(1) as f64)
        };
        let (ntr, ntr_ms) = ms(&nom, false);
        let (nho, nho_ms) = ms(&nom, true);
        let (_, ttr_ms) = ms(&tru, false);
        let (_, tho_ms) = ms(&tru, true);
        println!(
            "{case} | {} | {ntr} / {nho} | {ntr_ms:.2}, {nho_ms:.2} | {ttr_ms:.2}, {tho_ms:.2}",
            ans.label
        );
    }
    Ok(())
}
