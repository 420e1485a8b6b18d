//! Study: a proof drive's recorded and simulated speeds every 0.1 s over a stretch, with the
//! recorded clutch position, torque and gear and the longitudinal model's window starts.
//!
//! ```text
//! cargo run --release --manifest-path research/Cargo.toml --bin launch_trace -- DIR case-0029 12 20
//! ```
use fleetdyn::diagnose::setup::Setup;
use std::path::PathBuf;
#[path = "common/proof_dir.rs"]
#[allow(dead_code)] // the studies share it; this one lists no cases
mod proof_dir;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let [dir, case, from, to] = a.as_slice() else {
        return Err("usage: launch_trace DIR CASE FROM_S TO_S".into());
    };
    let (t0, t1): (f64, f64) = (from.parse()?, to.parse()?);
    let dir = PathBuf::from(dir);
    let (vf, log) = proof_dir::load(&dir, case)?;
    let setup = Setup::new(&log, &vf)?;
    let m = setup
        .longitudinal_model(&log)?
        .ok_or("the longitudinal model does not apply to this drive")?;
    let y = m.simulate(&setup.nominal)?;
    let starts: Vec<String> = m
        .window_starts()
        .iter()
        .filter(|s| **s >= t0 - 20.0 && **s <= t1)
        .map(|s| format!("{s:.2}"))
        .collect();
    println!("window starts: {}", starts.join(" "));
    let t = log.seconds_from_start();
    let col = |n: &str| log.signal(n).map(|v| v.to_vec()).unwrap_or_default();
    let (x, m_e, g) = (col("clutch_position"), col("engine_torque"), col("gear"));
    println!("t | clutch torque gear | v meas sim | we meas sim res");
    for (i, &ti) in t.iter().enumerate() {
        if ti < t0 || ti > t1 || (ti * 10.0).round() != ti * 10.0 {
            continue;
        }
        let f = |v: &[f64]| v.get(i).copied().unwrap_or(f64::NAN);
        println!(
            "{:6.2} | {:.3} {:7.1} {:.0} | {:.3} {:.3} | {:7.2} {:7.2} {:+6.2}",
            ti,
            f(&x),
            f(&m_e),
            f(&g),
            m.measured_speed()[i],
            y.vehicle_speed[i],
            m.measured_engine_speed()[i],
            y.engine_speed[i],
            m.measured_engine_speed()[i] - y.engine_speed[i]
        );
    }
    Ok(())
}
