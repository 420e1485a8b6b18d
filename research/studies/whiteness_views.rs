//! The acceptance rule's held-out figures per view of a proof drive at the hidden truth: for
//! each view of the effect's own model, the held-out weighted mean square and the whiteness
//! (`Q/n`, non-white power) at the nominal parameters and at the truth, weighted as the
//! diagnosis weighted them (its `diagnosis.json` noise floor). Rules 1 and 2 of
//! `diagnose::explain` average these over the views the effect changes.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin whiteness_views -- DIR case-0049
//! ```
use fleetdyn::diagnose::fit::Evaluator;
use fleetdyn::diagnose::setup::Setup;
use std::collections::BTreeMap;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one lists no cases
mod proof_dir;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let [dir, case] = a.as_slice() else {
        return Err("usage: whiteness_views DIR CASE".into());
    };
    let dir = PathBuf::from(dir);
    let (vf, log) = proof_dir::load(&dir, case)?;
    let ans = proof_dir::answer(&dir, case);
    let (e, truth) = ans.effect.ok_or("not a catalogue case")?;
    println!("{case} [{}]", ans.label);
    let d: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(
        dir.join("diagnoses").join(case).join("diagnosis.json"),
    )?)?;
    let floor: BTreeMap<String, f64> = serde_json::from_value(d["noise_floor"].clone())?;
    let setup = Setup::new(&log, &vf)?;
    let problem = setup.problem(&log, None)?; // without the clutch-actuation view (its floor is not computed here)
    let (ev, base) = Evaluator::at_nominal(&problem, Some(&floor));
    let own: Vec<bool> = ev.models.iter().map(|v| v.domain == e.domain()).collect();
    let at = ev.eval(&base, &own, e, truth)?;
    for (m, v) in problem.views().iter().enumerate() {
        let only: Vec<bool> = (0..ev.models.len()).map(|k| k == m).collect();
        let (wb, wa) = (ev.whiteness(&base, &only), ev.whiteness(&at, &only));
        // held-out samples of the view's channels (rows, or events for an events channel)
        let held: Vec<usize> = v
            .chans
            .iter()
            .map(|&c| problem.channels()[c].held_idx.len())
            .collect();
        println!(
            "{:?} {:?} (held-out samples {held:?}): changed {}, held-out MS {:.4} -> {:.4}, Q/n {:.4} -> {:.4}, non-white {:.4} -> {:.4}",
            v.domain,
            v.kind,
            own[m] && ev.changed(m, &at, &base),
            base.heldout[m],
            at.heldout[m],
            wb.q_per_n,
            wa.q_per_n,
            wb.nonwhite_power,
            wa.nonwhite_power
        );
    }
    Ok(())
}
