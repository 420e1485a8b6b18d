//! Study: the oracle check's rule-1 figure (the relative fall of the own model's weighted RMSE
//! with the hidden effect at its truth, nothing fitted) on the held-out part, on the training
//! part and on both together, for proof cases: whether an effect invisible on the held-out
//! blocks shows on the training blocks. Per view it prints the change at the truth
//! (`chg`, [`Evaluator::change_ms`], which decides whether rules 1 and 2 score the view) and
//! the weighted mean squares before → after on each part. The three figures are over every
//! changed view of the own model, as the rule scored before the views it scores were chosen
//! by their change. With `ORACLE_FOLDS_WINDOWS=1` it lists first, per
//! channel of the speeds view, the 20 s stretches whose nominal residual has a mean square
//! above 4 in units of the channel's noise floor (`t` train, `h` held-out).
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin oracle_folds -- DIR [CASE …]
//! ```
use fleetdyn::diagnose::fit::Evaluator;
use fleetdyn::diagnose::problem::ViewKind;
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one uses a part
mod proof_dir;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut a = std::env::args().skip(1);
    let dir = PathBuf::from(a.next().ok_or("usage: oracle_folds DIR [CASE …]")?);
    for case in proof_dir::cases(&dir, a.collect())? {
        let ans = proof_dir::answer(&dir, &case);
        let Some((e, truth)) = ans.effect else {
            continue;
        };
        let (vf, log) = proof_dir::load(&dir, &case)?;
        let floor = proof_dir::noise_floor(&dir, &case)?;
        let setup = Setup::new(&log, &vf)?;
        let actuation = proof_dir::actuation_variance(&log, &setup)?;
        let problem = setup.problem(&log, actuation.as_deref())?;
        let (ev, base) = Evaluator::at_nominal(&problem, Some(&floor));
        let own: Vec<bool> = ev
            .models
            .iter()
            .map(|v| v.domain == e.domain() && v.serves(e))
            .collect();
        let at = ev.eval(&base, &own, e, truth)?;
        let (mut bt, mut at_, mut bh, mut ah) = (0.0, 0.0, 0.0, 0.0);
        let mut per = Vec::new();
        for (m, &o) in own.iter().enumerate() {
            if o && ev.changed(m, &at, &base) {
                bt += base.train[m];
                at_ += at.train[m];
                bh += base.heldout[m];
                ah += at.heldout[m];
                per.push(format!(
                    "{:?} chg {:.2e} tr {:.3}->{:.3} ho {:.3}->{:.3}",
                    problem.views()[m].kind,
                    ev.change_ms(m, &at, &base),
                    base.train[m],
                    at.train[m],
                    base.heldout[m],
                    at.heldout[m]
                ));
            }
        }
        if std::env::var_os("ORACLE_FOLDS_WINDOWS").is_some() {
            // the speeds view's residual per 20 s, in units of each channel's floor
            let Some(sv) = problem
                .views()
                .iter()
                .position(|v| v.kind == ViewKind::Speeds)
            else {
                continue;
            };
            let v = &problem.views()[sv];
            let t = problem.times();
            let nw = (t.last().copied().unwrap_or(0.0) / 20.0).ceil() as usize;
            for (k, &c) in v.chans.iter().enumerate() {
                let ch = &problem.channels()[c];
                let sig = floor.get(&ch.name).copied().unwrap_or(1.0);
                let mut acc = vec![(0.0, 0usize, false); nw.max(1)];
                for i in ch.train_idx.iter().chain(ch.held_idx.iter()) {
                    let w = ((t[*i] / 20.0) as usize).min(nw.max(1) - 1);
                    let r = (ch.measured[*i] - base.outputs[sv][k][*i]) / sig;
                    acc[w].0 += r * r;
                    acc[w].1 += 1;
                    acc[w].2 = problem.split().heldout[*i];
                }
                let cells: Vec<String> = acc
                    .iter()
                    .enumerate()
                    .filter(|(_, a)| a.1 > 0 && a.0 / a.1 as f64 > 4.0)
                    .map(|(w, a)| {
                        format!(
                            "{}s{} {:.1}",
                            w * 20,
                            if a.2 { "h" } else { "t" },
                            a.0 / a.1 as f64
                        )
                    })
                    .collect();
                println!("  {} windows with MS > 4: {}", ch.name, cells.join(", "));
            }
        }
        let g = |a: f64, b: f64| if b > 0.0 { 1.0 - (a / b).sqrt() } else { 0.0 };
        println!(
            "{case} {:<32} held {:+.3} train {:+.3} pooled {:+.3} | {}",
            ans.label,
            g(ah, bh),
            g(at_, bt),
            g(ah + at_, bh + bt),
            per.join("; ")
        );
    }
    Ok(())
}
