//! The noise floor's null copies over one stretch of one signal of a proof drive: the rows the
//! window test would use, their degrees of freedom (`NoiseFloor::effective_dof` from the pooled
//! autocorrelation, `NoiseFloor::window_dof` as the test uses them), then per second the null's
//! RMS and each of the 12 copies' mean null residual — where the null restarts (a
//! re-initialisation of the longitudinal model) the copies' drifts start again from 0.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin floor_window -- DIR case-0019 vehicle_speed 390 400
//! ```
use fleetdyn::diagnose::noise::{noise_floors, ModelSet, NoiseConfig};
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one lists no cases
mod proof_dir;
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let [dir, case, sig, from, to] = a.as_slice() else {
        return Err("usage: floor_window DIR CASE SIGNAL FROM_S TO_S".into());
    };
    let (t0, t1): (f64, f64) = (from.parse()?, to.parse()?);
    let dir = PathBuf::from(dir);
    let (vf, log) = proof_dir::load(&dir, case)?;
    let setup = Setup::new(&log, &vf)?;
    let models = ModelSet::for_log(&log, &setup.nominal_truth, &setup.ratios, setup.nominal);
    let floors = noise_floors(&log, &models, &setup.nominal, &NoiseConfig::default())?;
    let f = floors.get(sig).ok_or("no floor")?;
    let t = log.seconds_from_start();
    let rows: Vec<usize> = (0..t.len())
        .filter(|&i| {
            t[i] >= t0
                && t[i] < t1
                && f.null_variance
                    .get(i)
                    .is_some_and(|v| v.is_finite() && *v > 0.0)
        })
        .collect();
    println!(
        "rows {} acf nu {:.2} window nu {:.2}",
        rows.len(),
        f.effective_dof(&rows),
        f.window_dof(&rows)
    );
    let mut s = t0;
    while s < t1 {
        let r: Vec<usize> = rows
            .iter()
            .copied()
            .filter(|&i| t[i] >= s && t[i] < s + 1.0)
            .collect();
        let line: Vec<String> = f
            .null_copies
            .iter()
            .map(|c| {
                let m = r.iter().map(|&i| c[i] as f64).sum::<f64>() / r.len().max(1) as f64;
                format!("{m:+.3}")
            })
            .collect();
        let sd =
            (r.iter().map(|&i| f.null_variance[i]).sum::<f64>() / r.len().max(1) as f64).sqrt();
        println!("{s:6.1} sd {sd:.3} | {}", line.join(" "));
        s += 1.0;
    }
    Ok(())
}
