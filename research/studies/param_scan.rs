//! Study: the weighted mean square of each view of a proof drive's own model, on the training
//! and held-out parts, as the hidden effect's parameter runs over a grid (nothing fitted; the
//! diagnosis' noise floor as the weights, the clutch-actuation view's per-row floor computed
//! again as the diagnosis computes it): whether the fit's optimum and the truth share a basin.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin param_scan -- DIR case-0005 0.0 0.5 11
//! ```
use fleetdyn::diagnose::fit::Evaluator;
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one lists no cases
mod proof_dir;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let [dir, case, lo, hi, n] = a.as_slice() else {
        return Err("usage: param_scan DIR CASE FROM TO POINTS".into());
    };
    let (lo, hi, n): (f64, f64, usize) = (lo.parse()?, hi.parse()?, n.parse()?);
    let dir = PathBuf::from(dir);
    let (vf, log) = proof_dir::load(&dir, case)?;
    let ans = proof_dir::answer(&dir, case);
    let (e, truth) = ans.effect.ok_or("not a catalogue case")?;
    let floor = proof_dir::noise_floor(&dir, case)?;
    let setup = Setup::new(&log, &vf)?;
    let actuation = proof_dir::actuation_variance(&log, &setup)?;
    let problem = setup.problem(&log, actuation.as_deref())?;
    let (ev, base) = Evaluator::at_nominal(&problem, Some(&floor));
    let own: Vec<bool> = ev.models.iter().map(|v| v.domain == e.domain()).collect();
    println!("{case} [{}], truth {truth}", ans.label);
    let kinds: Vec<String> = problem
        .views()
        .iter()
        .filter(|v| v.domain == e.domain())
        .map(|v| format!("{:?}", v.kind))
        .collect();
    println!(
        "value | per view train MS, held-out MS: {}",
        kinds.join(", ")
    );
    for k in 0..n {
        let x = lo + (hi - lo) * k as f64 / (n.max(2) - 1) as f64;
        let at = ev.eval(&base, &own, e, x)?;
        let cells: Vec<String> = (0..ev.models.len())
            .filter(|&m| own[m])
            .map(|m| format!("{:.3} {:.3}", at.train[m], at.heldout[m]))
            .collect();
        println!("{x:.4} | {}", cells.join(" | "));
    }
    Ok(())
}
