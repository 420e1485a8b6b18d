//! `slope_quantization`'s cure against the truth on the proof's drives: the recorded slope,
//! and its reconstruction (`signal::dequantise`) under several settings, each against the
//! generator's true slope (regenerated, `common/proof_truth.rs`) on the moving rows — RMS per
//! row and RMS of the 20 s means (what a speed residual integrates) — and the nominal
//! longitudinal model's residual on the compared rows fed each of them.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin slope_cure -- DIR case-0004 case-0026 case-0048
//! ```
use fleetdyn::diagnose::rows;
use fleetdyn::diagnose::extended::{LongitudinalConfig, LongitudinalModel, SlopeGrid};
use fleetdyn::diagnose::setup::Setup;
use fleetdyn::signal::dequantise::DequantiseConfig;
use fleetdyn::table::DriveLog;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one uses a part
mod proof_dir;
#[path = "common/proof_truth.rs"]
mod proof_truth;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (dir, given) = a.split_first().ok_or("usage: slope_cure DIR [CASE…]")?;
    let dir = PathBuf::from(dir);
    let base = DequantiseConfig::default();
    // (name, settings, cell margin in σ̂ of the slope sensor's estimated white noise)
    let earlier = DequantiseConfig {
        median_half_width: 3,
        cutoff_per_sample: 0.02,
        iterations: 3,
        ..base
    };
    let variants: Vec<(&str, DequantiseConfig, f64)> = vec![
        ("earlier default (7 m median)", earlier, 0.0),
        ("default, hard cells", base, 0.0),
        ("default, margin σ̂ (the cure)", base, 1.0),
        ("default, margin 2σ̂", base, 2.0),
    ];
    for case in proof_dir::cases(&dir, given.to_vec())? {
        let (vf, log) = proof_dir::load(&dir, &case)?;
        let answer = proof_dir::answer(&dir, &case);
        let ct =
            proof_truth::CaseTruth::regenerate(&dir, &case, &log, &answer.label, answer.effect)?;
        println!("{}", ct.heading);
        let t = log.seconds_from_start();
        let truth = ct.column_on("road_slope", &t, 0.0).ok_or("no true slope")?;
        let recorded = log.signal("road_slope").ok_or("no slope")?.to_vec();
        let setup = Setup::new(&log, &vf)?;
        let step = setup.slope_resolution;
        let grid = SlopeGrid::new(&log).ok_or("no slope grid")?;
        let sigma = grid.noise_sigma();
        println!("  slope sensor's white noise, estimated blind: {sigma:.5}");
        let speed = log.signal("vehicle_speed").ok_or("no speed")?;
        let min = LongitudinalConfig::default().min_speed_mps;
        let moving: Vec<bool> = speed.iter().map(|v| v.is_finite() && *v >= min).collect();
        let masks = [
            rows::longitudinal_rows(&log),
            rows::engine_speed_rows(&log),
        ]
        .map(|m| {
            m.iter()
                .zip(&moving)
                .map(|(a, b)| *a && *b)
                .collect::<Vec<bool>>()
        });
        let slope_err = |s: &[f64]| -> (f64, f64) {
            let e: Vec<(f64, f64)> = (0..t.len())
                .filter(|&i| moving[i] && s[i].is_finite() && truth[i].is_finite())
                .map(|i| (t[i], s[i] - truth[i]))
                .collect();
            let rms = (e.iter().map(|(_, x)| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt();
            let mut means = Vec::new();
            let mut k = 0;
            while k < e.len() {
                let w0 = e[k].0;
                let j = e[k..].partition_point(|(x, _)| *x < w0 + 20.0) + k;
                means.push(e[k..j].iter().map(|(_, x)| x).sum::<f64>() / (j - k) as f64);
                k = j;
            }
            let mrms =
                (means.iter().map(|x| x * x).sum::<f64>() / means.len().max(1) as f64).sqrt();
            (rms, mrms)
        };
        let residual = |s: &[f64]| -> Result<[f64; 2], Box<dyn std::error::Error>> {
            let mut l: DriveLog = log.clone();
            if let Some(c) = l.signals.iter_mut().find(|c| c.name == "road_slope") {
                c.values = s.to_vec();
            }
            let m = LongitudinalModel::new(
                &l,
                &setup.nominal_truth,
                &setup.ratios,
                setup.nominal,
                Default::default(),
            )?;
            let y = m.simulate(&setup.nominal)?;
            let mut out = [0.0; 2];
            for (k, (name, sim)) in [
                ("vehicle_speed", &y.vehicle_speed),
                ("engine_speed", &y.engine_speed),
            ]
            .into_iter()
            .enumerate()
            {
                let meas = log.signal(name).ok_or("no speed")?;
                let ok: Vec<f64> = (0..t.len())
                    .filter(|&i| masks[k][i] && meas[i].is_finite() && sim[i].is_finite())
                    .map(|i| (meas[i] - sim[i]).powi(2))
                    .collect();
                out[k] = (ok.iter().sum::<f64>() / ok.len().max(1) as f64).sqrt();
            }
            Ok(out)
        };
        println!("  step {step:.4}; slope error RMS per row / of 20 s means (tan α); residual RMS vehicle m/s, engine rad/s");
        let show = |name: &str, s: &[f64]| -> Result<(), Box<dyn std::error::Error>> {
            let (r, m) = slope_err(s);
            let [v, w] = residual(s)?;
            println!("  {name:<36} {r:.5} {m:.5} | {v:.4} {w:.3}");
            Ok(())
        };
        show("true", &truth)?;
        show("recorded", &recorded)?;
        for (name, cfg, k) in &variants {
            let cfg = DequantiseConfig {
                cell_margin: k * sigma,
                ..*cfg
            };
            let c = grid.cured_with(step, &cfg).ok_or("cure failed")?;
            if *k == 1.0 {
                // the diagnosis' own cure is this one
                assert_eq!(Some(&c), grid.cured(step).as_ref());
            }
            show(name, &c)?;
        }
    }
    Ok(())
}
