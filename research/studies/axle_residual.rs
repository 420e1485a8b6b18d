//! The axle model's nominal bellow pressures against the recorded ones, second by second over
//! a stretch of one drive of a proof run (`fleetdyn prove`): the 1 s means of measured,
//! simulated and residual pressure (Pa) per bellow, and how many of the second's rows the
//! diagnosis compares (`rows::axle_rows`). Used to find the open-clutch disc inertia the
//! axle input had dropped (`sim::axle_recorded`; case 17 of seed 1 from 200 to 232 s).
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin axle_residual -- DIR case-0017 200 232
//! ```
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one lists no cases
mod proof_dir;
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let [dir, case, from, to] = a.as_slice() else {
        return Err("usage: axle_residual DIR CASE FROM_S TO_S".into());
    };
    let (t0, t1): (f64, f64) = (from.parse()?, to.parse()?);
    let dir = PathBuf::from(dir);
    let (vf, log) = proof_dir::load(&dir, case)?;
    println!("{case} [{}]", proof_dir::answer(&dir, case).label);
    let setup = Setup::new(&log, &vf)?;
    let m = setup.axle_model(&log)?.ok_or("no axle model")?;
    let y = m.simulate(&setup.nominal)?;
    let t = log.seconds_from_start();
    let rows = fleetdyn::diagnose::rows::axle_rows(&log);
    let names = [
        "bellow_pressure_front",
        "bellow_pressure_rear",
        "bellow_pressure_tag",
    ];
    // AXLE_RESIDUAL_BIN_S=x: bins of x s instead of 1 s
    let bin: f64 = std::env::var("AXLE_RESIDUAL_BIN_S")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(1.0);
    let mut s = t0;
    while s < t1 {
        let idx: Vec<usize> = (0..t.len())
            .filter(|&i| t[i] >= s && t[i] < s + bin)
            .collect();
        let mut line = format!("{s:7.2}");
        for (k, n) in names.iter().enumerate() {
            let raw = log.signal(n).ok_or(format!("{case}: no {n}"))?;
            let (mut sm, mut sy, mut c) = (0.0, 0.0, 0);
            for &i in &idx {
                if raw[i].is_finite() {
                    sm += raw[i];
                    sy += y[k][i];
                    c += 1;
                }
            }
            let counted = idx.iter().filter(|&&i| rows[i]).count();
            line += &format!(
                " | {:>5}: meas {:8.0} sim {:8.0} res {:+6.0} ({}/{})",
                &n[16..],
                sm / c.max(1) as f64,
                sy / c.max(1) as f64,
                (sm - sy) / c.max(1) as f64,
                counted,
                idx.len()
            );
        }
        println!("{line}");
        s += bin;
    }
    Ok(())
}
