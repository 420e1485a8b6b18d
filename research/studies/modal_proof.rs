//! Measures the modal comparison ([`fleetdyn::diagnose::modal`]) on the drives of a proof run
//! (`fleetdyn prove`), read as the proof reads them (`drive.parquet`, the canonical log): per
//! case the hidden effect (from `answers/`, read only to label the table), the per-gear
//! measured and simulated shuffle frequencies, `Δf`, `Δσ`, the linearised
//! locked-clutch mode of the gear, and the drive-level test.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin modal_proof -- DIR [--fit-kd] [case-0007 …]
//! ```
//!
//! `--fit-kd`: also fits the drive-shaft stiffness `k_d` (`driveline_compliance`) so that the
//! simulated shuffle frequencies match the measured ones (the mean relative shift of the
//! engagements is brought to zero by a secant search on `ln k_d`, each step one simulation of
//! the extended model) and prints it next to the hidden value.

use fleetdyn::diagnose::extended::Theta;
use fleetdyn::diagnose::modal::{
    compare_modes, summarise, ModalComparison, ModalConfig, Reference,
};
use fleetdyn::diagnose::setup::Setup;
use fleetdyn::diagnose::shaft_stiffness::fit_shaft_stiffness;
use fleetdyn::model::catalogue::Effect;
use fleetdyn::signal::stats::median;
use std::path::PathBuf;

#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one uses a part
mod proof_dir;

fn shift(c: &ModalComparison) -> Option<(f64, usize)> {
    c.test.map(|t| (t.mean_shift, t.n))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(
        args.next()
            .ok_or("usage: modal_proof DIR [--fit-kd] [case…]")?,
    );
    let mut fit_kd = false;
    let mut cases: Vec<String> = Vec::new();
    for a in args {
        if a == "--fit-kd" {
            fit_kd = true;
        } else {
            cases.push(a);
        }
    }
    let cases = proof_dir::cases(&dir, cases)?;
    let cfg = ModalConfig::default();
    let mut table = Vec::new();
    let mut totals = Totals::default();
    for case in &cases {
        let answer = proof_dir::answer(&dir, case);
        let label = answer.label;
        let (vf, log) = proof_dir::load(&dir, case)?;
        let setup = Setup::new(&log, &vf)?;
        let Some(model) = setup.longitudinal_model(&log)? else {
            println!("{case} [{label}]: no longitudinal model");
            continue;
        };
        let sim = model.simulate(&setup.nominal)?;
        let dl = &setup.nominal_truth.driveline;
        let t_modal = std::time::Instant::now();
        let by_sim = compare_modes(
            &log,
            model.measured_engine_speed(),
            &sim.engine_speed,
            Some((dl, &setup.ratios, 0.0)),
            Reference::Simulated,
            &cfg,
        );
        let by_lin = summarise(by_sim.engagements.clone(), Reference::Linearised, &cfg);
        let modal_s = t_modal.elapsed().as_secs_f64();
        let n_eng = by_sim.engagements.len();
        let n_meas = by_sim
            .engagements
            .iter()
            .filter(|e| e.measured.is_ok())
            .count();
        let n_sim = by_sim
            .engagements
            .iter()
            .filter(|e| e.simulated.is_ok())
            .count();
        // engagements whose analysis window holds a re-initialisation of the windowed
        // simulation (the simulated ringing restarts there)
        let starts = fleetdyn::diagnose::extended::window_starts(&log, 20.0);
        let n_restart = by_sim
            .engagements
            .iter()
            .filter(|e| {
                let a = e.engagement.t_close_s + cfg.window_start_s;
                let b = e.engagement.t_close_s + cfg.window_end_s;
                starts.iter().any(|&s| s > a && s < b)
            })
            .count();
        println!(
            "{case} [{label}]: engagements {n_eng}, measured accepted {n_meas}, simulated accepted {n_sim}, simulation restarted inside the window {n_restart}, modal step {modal_s:.3} s over {:.0} s of drive", log.duration_s()
        );
        let fmt_test = |c: &ModalComparison| {
            c.test.map_or("no test".to_string(), |t| {
                format!(
                    "mean r {:+.2}% ± {:.2}% (n {}), t {:+.1}, p {:.1e}, flagged {}",
                    100.0 * t.mean_shift,
                    100.0 * t.shift_se,
                    t.n,
                    t.t,
                    t.p_value,
                    t.flagged
                )
            })
        };
        for c in [&by_sim, &by_lin] {
            println!("  vs {:?}: {}", c.reference, fmt_test(c));
            for g in &c.gears {
                println!(
                    "    gear {:2} n {}: f meas {:.2} ref {:.2} Hz, Δf {:+.3} (sd {:.3}) Hz, Δσ {:+.2} (sd {:.2}) 1/s, p_holm {:.1e}",
                    g.gear,
                    g.n,
                    g.measured_hz,
                    g.reference_hz,
                    g.delta_f_hz,
                    g.delta_f_sd_hz,
                    g.delta_decay_per_s,
                    g.delta_decay_sd_per_s,
                    g.p_holm
                );
            }
        }
        let list: Vec<String> = by_sim
            .engagements
            .iter()
            .map(|e| format!("{:.1} s g{}", e.engagement.t_close_s, e.engagement.gear))
            .collect();
        println!("    engagements: {}", list.join(", "));
        for e in &by_sim.engagements {
            if let Err(m) = &e.measured {
                println!(
                    "    measured rejected: t {:.1} s gear {}: {m:?}",
                    e.engagement.t_close_s, e.engagement.gear
                );
            }
        }
        let k0 = setup.nominal.get(Effect::DrivelineCompliance);
        let hidden = answer
            .effect
            .filter(|(e, _)| *e == Effect::DrivelineCompliance)
            .map(|(_, t)| t);
        let kfit = fit_shaft_stiffness(&by_sim.engagements, dl, &setup.ratios, &cfg);
        if let Some(k) = kfit {
            println!(
                "  k_d (linearised modes): {:.0} N·m/rad ({:+.1} % of nominal {k0:.0}), 95 % CI {:.0}–{:.0}, n {}, rms ln residual {:.3}{}",
                k.k_d_nm_per_rad,
                100.0 * (k.k_d_nm_per_rad / k0 - 1.0),
                k.ci95_nm_per_rad.0,
                k.ci95_nm_per_rad.1,
                k.n,
                k.rms_log_residual,
                hidden.map_or(String::new(), |t| format!(
                    "; hidden {t:.0} ({:+.1} %), error {:+.1} % of the hidden change",
                    100.0 * (t / k0 - 1.0),
                    100.0 * (k.k_d_nm_per_rad - t) / (t - k0)
                ))
            );
        }
        let mut k_sim = None;
        if fit_kd {
            let at = |k: f64| -> Result<Option<(f64, usize)>, Box<dyn std::error::Error>> {
                let mut th: Theta = setup.nominal;
                th.set(Effect::DrivelineCompliance, k);
                let s = model.simulate(&th)?;
                Ok(shift(&compare_modes(
                    &log,
                    model.measured_engine_speed(),
                    &s.engine_speed,
                    None,
                    Reference::Simulated,
                    &cfg,
                )))
            };
            // secant on x = ln(k/k0) for g(x) = mean relative shift = 0
            if let Some((g_nom, _)) = shift(&by_sim) {
                let (mut x0, mut g0) = (0.0, g_nom);
                let mut x1 = 2.0 * g0; // f ∝ √k_d at most: a first step of twice the shift
                let mut g1 = at(k0 * x1.exp())?.map_or(f64::NAN, |s| s.0);
                let mut steps = 1;
                while steps < 8 && g1.is_finite() && g1.abs() > 1e-3 && (g1 - g0).abs() > 1e-12 {
                    let x2 = x1 - g1 * (x1 - x0) / (g1 - g0);
                    x0 = x1;
                    g0 = g1;
                    x1 = x2.clamp(-1.5, 1.5);
                    g1 = at(k0 * x1.exp())?.map_or(f64::NAN, |s| s.0);
                    steps += 1;
                }
                let k = k0 * x1.exp();
                k_sim = Some(k);
                println!(
                    "  k_d (simulated modes): {k:.0} N·m/rad ({:+.1} %), remaining shift {:+.2} %, {steps} simulations{}",
                    100.0 * (k / k0 - 1.0),
                    100.0 * g1,
                    hidden.map_or(String::new(), |t| format!(
                        "; error {:+.1} % of the hidden change",
                        100.0 * (k - t) / (t - k0)
                    ))
                );
            }
        }
        totals.add(
            &label,
            answer.effect.map(|(e, _)| e),
            &by_sim,
            &by_lin,
            modal_s,
            log.duration_s(),
        );
        let cell = |c: &ModalComparison| {
            c.test.map_or("-".to_string(), |t| {
                format!(
                    "{:+.1}% p {:.0e}{}",
                    100.0 * t.mean_shift,
                    t.p_value,
                    if t.flagged { " FLAG" } else { "" }
                )
            })
        };
        table.push(format!(
            "| {case} | {label} | {n_eng}/{n_meas} | {} | {} | {} | {} |",
            cell(&by_sim),
            cell(&by_lin),
            kfit.map_or("-".into(), |k| format!(
                "{:+.1}% [{:+.0}, {:+.0}]",
                100.0 * (k.k_d_nm_per_rad / k0 - 1.0),
                100.0 * (k.ci95_nm_per_rad.0 / k0 - 1.0),
                100.0 * (k.ci95_nm_per_rad.1 / k0 - 1.0)
            )),
            k_sim.map_or("-".into(), |k| format!("{:+.1}%", 100.0 * (k / k0 - 1.0)))
        ));
    }
    println!();
    println!("| case | hidden | engagements/accepted | vs simulated: mean Δf/f, p | vs linearised: mean Δf/f, p | k_d (linearised) [95 % CI] | k_d (simulated) |");
    println!("|---|---|---|---|---|---|---|");
    for r in table {
        println!("{r}");
    }
    totals.print();
    Ok(())
}

/// The figures over all cases (docs/models/driveline.md, "Why the linearised mode is the
/// reference" and "Which engagements count").
#[derive(Default)]
struct Totals {
    modal_s: f64,
    drive_s: f64,
    /// Clean drives: mean relative shift against the linearised modes (fraction).
    clean_mean_shifts: Vec<f64>,
    /// Clean drives, per gear: Δf against the linearised and the simulated modes, Δσ against
    /// the simulated.
    clean_df_lin_hz: Vec<f64>,
    clean_df_sim_hz: Vec<f64>,
    clean_dsigma_sim_per_s: Vec<f64>,
    /// `(R², ln f_measured − ln f_linearised)` of each engagement of a drive whose hidden
    /// effect leaves the driveline's mode alone.
    log_ratio: Vec<(f64, f64)>,
}

/// Hidden effects that move the driveline's locked mode or its engagements: their drives are
/// left out of the per-engagement spread.
const MOVES_MODES: [Effect; 4] = [
    Effect::DrivelineCompliance,
    Effect::DrivelineBacklash,
    Effect::VehicleMass,
    Effect::ClutchSlip,
];

impl Totals {
    fn add(
        &mut self,
        label: &str,
        effect: Option<Effect>,
        by_sim: &ModalComparison,
        by_lin: &ModalComparison,
        modal_s: f64,
        drive_s: f64,
    ) {
        self.modal_s += modal_s;
        self.drive_s += drive_s;
        if label == "none" {
            self.clean_mean_shifts
                .extend(by_lin.test.map(|t| t.mean_shift));
            self.clean_df_lin_hz
                .extend(by_lin.gears.iter().map(|g| g.delta_f_hz));
            self.clean_df_sim_hz
                .extend(by_sim.gears.iter().map(|g| g.delta_f_hz));
            self.clean_dsigma_sim_per_s
                .extend(by_sim.gears.iter().map(|g| g.delta_decay_per_s));
        }
        let leaves_modes = match effect {
            Some(e) => !MOVES_MODES.contains(&e),
            None => label == "none",
        };
        if leaves_modes {
            for e in &by_lin.engagements {
                if let (Ok(m), Some(l)) = (&e.measured, &e.linearised) {
                    self.log_ratio
                        .push((m.r2, (m.frequency_hz / l.frequency_hz).ln()));
                }
            }
        }
    }

    fn print(&self) {
        let finite = |v: &[f64]| {
            v.iter()
                .copied()
                .filter(|x| x.is_finite())
                .collect::<Vec<f64>>()
        };
        let max_abs = |v: &[f64]| finite(v).iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let hours = self.drive_s / 3600.0;
        println!();
        println!(
            "modal step: {:.2} s over {:.1} drive-hours, {:.2} s per drive-hour",
            self.modal_s,
            hours,
            self.modal_s / hours
        );
        let means = finite(&self.clean_mean_shifts);
        let lin = finite(&self.clean_df_lin_hz);
        let mut dsig = finite(&self.clean_dsigma_sim_per_s);
        let dsig_mean = dsig.iter().sum::<f64>() / dsig.len().max(1) as f64;
        let dsig_median = median(&mut dsig);
        println!(
            "clean drives: {} drive means against the linearised modes from {:+.1} % to {:+.1} %; per gear |Δf| ≤ 0.03 Hz on {} of {} (largest {:.3} Hz); against the simulated engine speed largest |Δf| {:.3} Hz, mean Δσ {:+.2} 1/s (median {:+.2})",
            means.len(),
            100.0 * means.iter().copied().fold(f64::INFINITY, f64::min),
            100.0 * means.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            lin.iter().filter(|x| x.abs() <= 0.03).count(),
            lin.len(),
            max_abs(&lin),
            max_abs(&self.clean_df_sim_hz),
            dsig_mean,
            dsig_median,
        );
        println!(
            "engagements of drives whose hidden effect leaves the modes alone (clean and catalogue drives but {:?}): {}",
            MOVES_MODES.map(|e| e.id()),
            self.log_ratio.len()
        );
        for (lo, hi) in [(0.95, 1.01), (0.9, 0.95), (0.6, 0.9)] {
            let v: Vec<f64> = self
                .log_ratio
                .iter()
                .filter(|(r2, x)| *r2 >= lo && *r2 < hi && x.is_finite())
                .map(|(_, x)| *x)
                .collect();
            let rms = (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
            println!(
                "  R² {lo:.2}–{:.2}: {} engagements, rms ln f_measured − ln f_linearised {:.2} %",
                hi.min(1.0),
                v.len(),
                100.0 * rms
            );
        }
    }
}
