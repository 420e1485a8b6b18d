//! A nominal model's residual on one drive of a proof run (`fleetdyn prove`) traced to its
//! inputs: the drive is generated again from the proof's plan, so the generator's truth of
//! every recorded column is known (the diagnosis never sees it). Per second of a stretch: the
//! measured and simulated first compared signal and their residual, the second signal's
//! residual (mean and RMS over the second), the mean recorded − true engine torque (N·m), slope (%), service-brake force (N)
//! and retarder torque (N·m), and the gear. The longitudinal model (vehicle speed m/s, engine
//! speed rad/s) by default; with `axle` after the times the axle model (rear bellow, front
//! bellow, tag bellow, Pa). Then, per compared signal, the residual RMS and mean over the
//! stretch's compared rows (`diagnose::compare`: away from clutch transitions and brake
//! steps, moving, …) with the recorded inputs, with each one input replaced by its truth, and
//! with every input and output at its truth ("all": a model that differs from the generator
//! shows here). The per-second table counts every row.
//! `TRUTH_RESIDUAL_TRUTH=1` prints the per-second table for that all-truth log;
//! `TRUTH_RESIDUAL_INPUTS=1` lists the truth's columns every 0.25 s of the stretch first;
//! `TRUTH_RESIDUAL_THETA=1` runs the models at the hidden effect's truth;
//! `TRUTH_RESIDUAL_SHUFFLE=1` adds, per gear, the engine speed's part above ~1 Hz that the
//! recorded slope alone gives the model (against the true slope) beside the residual's
//! (`slope_quantization`'s fingerprint, "spurious shuffle after slope steps");
//! `TRUTH_RESIDUAL_SHIFT_S=x` reads the truth `x` s later against the log's rows (every column
//! alike: the phase of the generator's input steps against the 50 Hz rows).
//! Used to find the clean drives' `unexplained` windows: a slope noise estimate read off its
//! lattice (`diagnose::noise`), a holding force read as a released brake and one biased by
//! clipping (`sim::axle_recorded`, `diagnose::extended::corrected_log`).
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin truth_residual -- DIR case-0060 100 130
//! cargo run --release --manifest-path research/Cargo.toml --bin truth_residual -- DIR case-0018 0 8 axle
//! ```
use fleetdyn::diagnose::rows;
use fleetdyn::diagnose::extended::{AxleModel, LongitudinalConfig, LongitudinalModel};
use fleetdyn::diagnose::setup::Setup;
use fleetdyn::table::DriveLog;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one lists no cases
mod proof_dir;
#[path = "common/proof_truth.rs"]
mod proof_truth;

/// A compared signal's measured and simulated values on the log's rows.
type Pair = (Vec<f64>, Vec<f64>);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (dir, case, from, to, axle) = match a.as_slice() {
        [d, c, f, t] => (d, c, f, t, false),
        [d, c, f, t, m] if m == "axle" => (d, c, f, t, true),
        _ => return Err("usage: truth_residual DIR CASE FROM_S TO_S [axle]".into()),
    };
    let (t0, t1): (f64, f64) = (from.parse()?, to.parse()?);
    let dir = PathBuf::from(dir);
    let (vf, log) = proof_dir::load(&dir, case)?;
    let answer = proof_dir::answer(&dir, case);
    let ct = proof_truth::CaseTruth::regenerate(&dir, case, &log, &answer.label, answer.effect)?;
    println!("{}", ct.heading);
    let truth = &ct.truth;
    if std::env::var_os("TRUTH_RESIDUAL_INPUTS").is_some() {
        // the truth's inputs every 0.25 s of the stretch
        let names: Vec<&str> = truth.columns.iter().map(|(n, _)| n.as_str()).collect();
        println!("truth: t | {}", names.join(" | "));
        let mut x = t0;
        while x < t1 {
            let k = truth
                .t_s
                .partition_point(|&v| v < x)
                .min(truth.t_s.len() - 1);
            let vals: Vec<String> = truth
                .columns
                .iter()
                .map(|(_, y)| format!("{:.4}", y[k]))
                .collect();
            println!("{x:7.2} | {}", vals.join(" | "));
            x += 0.25;
        }
    }
    let t = log.seconds_from_start();
    let shift = std::env::var("TRUTH_RESIDUAL_SHIFT_S")
        .ok()
        .and_then(|x| x.parse::<f64>().ok())
        .unwrap_or(0.0);
    let true_col = |name: &str| ct.column_on(name, &t, shift);
    let with_truth = |names: &[&str]| -> DriveLog {
        let mut l = log.clone();
        for s in l.signals.iter_mut() {
            if names.contains(&s.name.as_str()) {
                if let Some(v) = true_col(&s.name) {
                    s.values = v;
                }
            }
        }
        l
    };
    let setup = Setup::new(&log, &vf)?;
    // TRUTH_RESIDUAL_THETA=1: the models at the hidden effect's truth instead of the nominal
    let mut theta = setup.nominal;
    if std::env::var_os("TRUTH_RESIDUAL_THETA").is_some() {
        if let Some((e, v)) = proof_dir::answer(&dir, case).effect {
            theta.set(e, v);
        }
    }
    // (measured, simulated) of the compared signals: the two speeds, or the three pressures
    let sim = |l: &DriveLog| -> Result<Vec<Pair>, Box<dyn std::error::Error>> {
        let names: &[&str] = if axle {
            &[
                "bellow_pressure_rear",
                "bellow_pressure_front",
                "bellow_pressure_tag",
            ]
        } else {
            &["vehicle_speed", "engine_speed"]
        };
        let y: Vec<Vec<f64>> = if axle {
            let m = AxleModel::new(l, &setup.nominal_truth, &setup.ratios, setup.nominal)?;
            let [f, r, t] = m.simulate(&theta)?;
            vec![r, f, t]
        } else {
            let m = LongitudinalModel::new(
                l,
                &setup.nominal_truth,
                &setup.ratios,
                setup.nominal,
                Default::default(),
            )?;
            let y = m.simulate(&theta)?;
            vec![y.vehicle_speed, y.engine_speed]
        };
        let mut out = Vec::new();
        for (n, y) in names.iter().zip(y) {
            out.push((l.signal(n).ok_or(format!("no {n}"))?.to_vec(), y));
        }
        Ok(out)
    };
    let mut all: Vec<&str> = vec![
        "engine_torque",
        "road_slope",
        "brake_force",
        "retarder_torque",
        "vehicle_speed",
        "engine_speed",
        "clutch_position",
        "gear",
    ];
    if axle {
        all.extend([
            "bellow_pressure_front",
            "bellow_pressure_rear",
            "bellow_pressure_tag",
        ]);
    }
    // TRUTH_RESIDUAL_TRUTH=1: the table for the log with every input and output at its truth
    let shown = if std::env::var_os("TRUTH_RESIDUAL_TRUTH").is_some() {
        with_truth(&all)
    } else {
        log.clone()
    };
    let base = sim(&shown)?;
    let (vm, vs) = (&base[0].0, &base[0].1);
    let (wm, ws) = (&base[1].0, &base[1].1);
    let gear = log.signal("gear").ok_or("no gear")?;
    let inputs = [
        "engine_torque",
        "road_slope",
        "brake_force",
        "retarder_torque",
    ];
    let scale = [1.0, 100.0, 1.0, 1.0];
    let errs: Vec<Option<Vec<f64>>> = inputs
        .iter()
        .map(|n| {
            let rec = log.signal(n)?;
            let tr = true_col(n)?;
            Some(rec.iter().zip(&tr).map(|(a, b)| a - b).collect())
        })
        .collect();
    println!(
        "     t | {} meas, sim, res | res {} (mean, rms) |  dM_e  dslope%  dbrake  dretard | gear",
        if axle { "p_rear" } else { "v" },
        if axle { "p_front" } else { "we" }
    );
    let mut s = t0;
    while s < t1 {
        let idx: Vec<usize> = (0..t.len())
            .filter(|&i| t[i] >= s && t[i] < s + 1.0 && vm[i].is_finite() && wm[i].is_finite())
            .collect();
        let mean = |f: &dyn Fn(usize) -> f64| {
            let v: Vec<f64> = idx
                .iter()
                .map(|&i| f(i))
                .filter(|x| x.is_finite())
                .collect();
            v.iter().sum::<f64>() / v.len().max(1) as f64
        };
        let mut line = format!(
            "{s:6.1} | {:9.3} {:9.3} {:+7.3} | {:+6.2} {:5.2} |",
            mean(&|i| vm[i]),
            mean(&|i| vs[i]),
            mean(&|i| vm[i] - vs[i]),
            mean(&|i| wm[i] - ws[i]),
            mean(&|i| (wm[i] - ws[i]).powi(2)).sqrt(),
        );
        for (e, k) in errs.iter().zip(scale) {
            match e {
                Some(e) => line += &format!(" {:+7.2}", k * mean(&|i| e[i])),
                None => line += "      — ",
            }
        }
        line += &format!(" | {:.0}", mean(&|i| gear[i]));
        println!("{line}");
        s += 1.0;
    }
    // RMS over the stretch of each compared signal (against the log `l`'s own measurement)
    // the rows the diagnosis compares, per compared signal (`diagnose::compare`)
    let masks: Vec<Vec<bool>> = if axle {
        vec![rows::axle_rows(&log); 3]
    } else {
        let min = LongitudinalConfig::default().min_speed_mps;
        let moving: Vec<bool> = vm.iter().map(|v| v.is_finite() && *v >= min).collect();
        let both =
            |r: Vec<bool>| -> Vec<bool> { r.iter().zip(&moving).map(|(a, b)| *a && *b).collect() };
        vec![
            both(rows::longitudinal_rows(&log)),
            both(rows::engine_speed_rows(&log)),
        ]
    };
    let rms = |r: &[Pair]| -> String {
        r.iter()
            .zip(&masks)
            .map(|((m, v), mask)| {
                let ok: Vec<usize> = (0..t.len())
                    .filter(|&i| {
                        t[i] >= t0 && t[i] < t1 && mask[i] && m[i].is_finite() && v[i].is_finite()
                    })
                    .collect();
                let n = ok.len();
                let q: f64 = ok.iter().map(|&i| (m[i] - v[i]).powi(2)).sum();
                let mean: f64 = ok.iter().map(|&i| m[i] - v[i]).sum::<f64>() / n.max(1) as f64;
                format!(" {:10.4} ({:+.4})", (q / n.max(1) as f64).sqrt(), mean)
            })
            .collect()
    };
    // each input's error over the whole drive: its σ per row, and the σ of its 20 s means
    // against what independent 10 Hz samples of that σ would give
    for (n, e) in inputs.iter().zip(&errs) {
        let Some(e) = e else { continue };
        let ok: Vec<usize> = (0..t.len()).filter(|&i| e[i].is_finite()).collect();
        let m = ok.iter().map(|&i| e[i]).sum::<f64>() / ok.len().max(1) as f64;
        let sd =
            (ok.iter().map(|&i| (e[i] - m).powi(2)).sum::<f64>() / ok.len().max(1) as f64).sqrt();
        let mut means = Vec::new();
        let mut a = 0.0;
        while a + 20.0 <= t[t.len() - 1] {
            let w: Vec<f64> = ok
                .iter()
                .filter(|&&i| t[i] >= a && t[i] < a + 20.0)
                .map(|&i| e[i])
                .collect();
            if !w.is_empty() {
                means.push(w.iter().sum::<f64>() / w.len() as f64);
            }
            a += 20.0;
        }
        let msd =
            (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / means.len().max(1) as f64).sqrt();
        println!(
            "{n} error over the drive: mean {m:+.3e}, σ {sd:.3e}, σ of 20 s means {msd:.3e} \
             (independent 10 Hz samples: {:.3e})",
            sd / 200f64.sqrt()
        );
    }
    println!("residual RMS (mean) over the stretch's compared rows per compared signal:");
    println!("  recorded inputs        {}", rms(&sim(&log)?));
    for n in inputs
        .iter()
        .chain(&["vehicle_speed", "engine_speed", "clutch_position"])
    {
        println!("  true {n:<17} {}", rms(&sim(&with_truth(&[n]))?));
    }
    println!("  all (against truth)    {}", rms(&sim(&with_truth(&all))?));
    if !axle && std::env::var_os("TRUTH_RESIDUAL_SHUFFLE").is_some() {
        // the recorded slope's own shuffle: the engine speed's part above ~1 Hz (minus a
        // centred 1 s mean) of the model fed the recorded slope minus the model fed the true
        // one, against the same part of the residual, per gear on the compared rows
        let hp = |y: &[f64]| -> Vec<f64> {
            (0..y.len())
                .map(|i| {
                    let w: Vec<f64> = y[i.saturating_sub(25)..(i + 26).min(y.len())]
                        .iter()
                        .copied()
                        .filter(|x| x.is_finite())
                        .collect();
                    y[i] - w.iter().sum::<f64>() / w.len().max(1) as f64
                })
                .collect()
        };
        let rec = sim(&log)?;
        let tru = sim(&with_truth(&["road_slope"]))?;
        let (wm, wr, wt) = (&rec[1].0, &rec[1].1, &tru[1].1);
        let spurious = hp(&wr.iter().zip(wt).map(|(a, b)| a - b).collect::<Vec<_>>());
        let resid = hp(&wm.iter().zip(wr).map(|(a, b)| a - b).collect::<Vec<_>>());
        println!("gear | rows | engine speed >1 Hz, rad/s RMS: recorded − true slope | residual");
        for g in 1..=16 {
            let idx: Vec<usize> = (0..t.len())
                .filter(|&i| {
                    masks[1][i] && gear[i].round() as usize == g && t[i] >= t0 && t[i] < t1
                })
                .filter(|&i| spurious[i].is_finite() && resid[i].is_finite())
                .collect();
            if idx.is_empty() {
                continue;
            }
            let r = |v: &[f64]| {
                (idx.iter().map(|&i| v[i] * v[i]).sum::<f64>() / idx.len() as f64).sqrt()
            };
            println!(
                "{g:4} | {:5} | {:.3} | {:.3}",
                idx.len(),
                r(&spurious),
                r(&resid)
            );
        }
    }
    Ok(())
}
