//! Drag area from the force balance's segment means with and without a steady wind in the
//! regression: per case of each proof folder given, the truth's drag area and mean headwind
//! (from its answer), and the estimates `A_file + 2 β_v² / ρ` of the regression of the segment
//! means ([`resistance_stretch::segments`], slope reconstructed between the sensor's steps) on
//! a constant, the mean `g sin α + v̇`, time and the mean squared speed, with and without the
//! mean speed (which carries the wind's `ρ A w v`), tab-separated; last, the median relative
//! error of each estimate against the truck's drag area over the cases whose hidden effect
//! leaves the driving resistances and the recorded channels alone (no effect, drag area,
//! driveline, clutch and delay effects).
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin drag_wind -- DIR...
//! ```
use fleetdyn::diagnose::compare::Conditions;
use fleetdyn::diagnose::extended::SlopeGrid;
use fleetdyn::diagnose::resistance_stretch::{segments, Segment, StretchConfig};
use fleetdyn::diagnose::setup::Setup;
use fleetdyn::signal::stats::median;
use nalgebra::{DMatrix, DVector};
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)]
mod proof_dir;

/// OLS of y on the columns; (coefficient of column `k`, its standard error).
fn ols(segs: &[Segment], cols: &[fn(&Segment) -> f64], k: usize) -> Option<(f64, f64)> {
    let n = segs.len();
    let p = cols.len();
    if n <= p + 2 {
        return None;
    }
    let x = DMatrix::from_fn(n, p, |i, j| cols[j](&segs[i]));
    let y = DVector::from_fn(n, |i, _| segs[i].force_n);
    // scale columns for conditioning
    let scale: Vec<f64> = (0..p).map(|j| x.column(j).amax().max(1e-12)).collect();
    let xs = DMatrix::from_fn(n, p, |i, j| x[(i, j)] / scale[j]);
    let xtx = xs.transpose() * &xs;
    let inv = xtx.try_inverse()?;
    let b = &inv * xs.transpose() * &y;
    let r = &y - &xs * &b;
    let s2 = r.norm_squared() / (n - p) as f64;
    Some((b[k] / scale[k], (s2 * inv[(k, k)]).sqrt() / scale[k]))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dirs: Vec<String> = std::env::args().skip(1).collect();
    let cfg = StretchConfig::default();
    // hidden effects that change a resistance, the force balance's inputs or the slope
    const AWAY: [&str; 8] = [
        "stuck_speed_sensor",
        "hidden_retarder",
        "wet_surface",
        "rolling_resistance",
        "engine_torque_offset",
        "vehicle_mass",
        "grade_offset",
        "slope_quantization",
    ];
    let (mut err_nowind, mut err_wind) = (Vec::new(), Vec::new());
    println!("case\thidden\troad\tlen_km\twind\tA_true\tA_file\tA_nowind\tse_nowind\tA_wind\tse_wind\tsegs\tv_sd");
    for dir in dirs {
        let dir = PathBuf::from(dir);
        for case in proof_dir::cases(&dir, vec![])? {
            let Ok(s) = std::fs::read_to_string(dir.join("answers").join(format!("{case}.json")))
            else {
                continue;
            };
            let ans: serde_json::Value = serde_json::from_str(&s)?;
            let hidden = ans["concealed"]["id"]
                .as_str()
                .or(ans["concealed"]["kind"].as_str())
                .unwrap_or("?")
                .to_string();
            let Ok((vf, log)) = proof_dir::load(&dir, &case) else {
                continue;
            };
            let setup = Setup::new(&log, &vf)?;
            let c = Conditions::from_log(&log);
            let d = &setup.nominal_truth.driveline;
            let grade = SlopeGrid::new(&log).and_then(|g| g.cured(setup.slope_resolution));
            let Some(segs) = segments(
                &log,
                &c.t_s,
                &c.distance_m,
                d,
                &setup.ratios,
                grade.as_deref(),
                &cfg,
            ) else {
                continue;
            };
            let rho = d.rho_air_kg_per_m3;
            let a0 = d.c_w_a_f_m2;
            let nowind: [fn(&Segment) -> f64; 4] = [
                |_| 1.0,
                |s| s.speed2_m2ps2,
                |s| s.grade_accel_mps2,
                |s| s.t_s,
            ];
            let wind: [fn(&Segment) -> f64; 5] = [
                |_| 1.0,
                |s| s.speed2_m2ps2,
                |s| s.grade_accel_mps2,
                |s| s.t_s,
                |s| s.speed_mps,
            ];
            let f = |r: Option<(f64, f64)>| {
                r.map_or((f64::NAN, f64::NAN), |(b, se)| {
                    (a0 + 2.0 * b / rho, 2.0 * se / rho)
                })
            };
            let (an, sn) = f(ols(&segs, &nowind, 1));
            let (aw, sw) = f(ols(&segs, &wind, 1));
            let a_true = ans["params"]["c_w_a_f_m2"].as_f64().unwrap_or(f64::NAN);
            if !AWAY.contains(&hidden.as_str()) && an.is_finite() && aw.is_finite() {
                err_nowind.push((an / a_true - 1.0).abs());
                err_wind.push((aw / a_true - 1.0).abs());
            }
            let vm = segs.iter().map(|s| s.speed_mps).sum::<f64>() / segs.len() as f64;
            let vsd = (segs.iter().map(|s| (s.speed_mps - vm).powi(2)).sum::<f64>()
                / segs.len() as f64)
                .sqrt();
            println!(
                "{case}\t{hidden}\t{}\t{:.1}\t{:.2}\t{:.2}\t{a0:.2}\t{an:.2}\t{sn:.2}\t{aw:.2}\t{sw:.2}\t{}\t{vsd:.2}",
                ans["road"].as_str().unwrap_or("?"),
                ans["length_m"].as_f64().unwrap_or(f64::NAN) / 1000.0,
                ans["wind"]["mean_mps"].as_f64().unwrap_or(f64::NAN),
                a_true,
                segs.len(),
            );
        }
    }
    println!(
        "# {} cases: median |A / A_truck - 1| without the speed term {:.2}, with it {:.2}",
        err_wind.len(),
        median(&mut err_nowind),
        median(&mut err_wind)
    );
    Ok(())
}
