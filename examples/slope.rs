//! Ingest a recorded drive, resample it to travelled distance and filter its road slope without
//! phase lag: the library calls behind `fleetdyn slope`.
//!
//! ```text
//! cargo run --release --example slope                       # fixtures/drives/truck-0001.mcap
//! cargo run --release --example slope -- DRIVE.mcap|DRIVE.parquet
//! ```
//!
//! Run it from the repository top. It prints the drive, the distance grid and the filter's
//! figures, and writes `distance_log.parquet`, `slope_distance.parquet` and
//! `slope_time.parquet` into `out/examples/slope/`.

use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::{resample_stage, slope_stage};
use fleetdyn::road::slope_filter::{filter_slope, SlopeFilterConfig};
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use std::error::Error;
use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn Error>> {
    let input = std::env::args_os().nth(1).map_or_else(
        || PathBuf::from("fixtures/drives/truck-0001.mcap"),
        PathBuf::from,
    );
    let out = Path::new("out/examples/slope");
    std::fs::create_dir_all(out)?;

    // 1. Ingest: the format (MCAP, Parquet) is detected from the file's magic bytes and a
    //    mapping is chosen automatically. Naming the stages we will run makes ingest check
    //    that their required columns (speed for the distance, road_slope for the filter) exist.
    let ingest = IngestConfig::default();
    let opts = ingest.options(&[Stage::Resample, Stage::Slope], None)?;
    let ing = ingest_stage::run(&input, &opts)?;
    let log = &ing.log;
    println!(
        "{}: {} rows, {:.0} s ({} via mapping {})",
        log.meta.drive_id,
        log.len(),
        log.duration_s(),
        ing.report.format,
        ing.report.mapping
    );

    // 2. Resample from time to a uniform 1 m distance grid. Samples at standstill add no
    //    distance and collapse onto one grid point.
    let resample = ResampleConfig::default();
    let d = resample_to_distance(log, &resample)?;
    println!(
        "  {:.3} km on a {} m grid: {} points, distance from {}, {} samples collapsed",
        d.map.total_m() / 1000.0,
        d.step_m,
        d.distance_m.len(),
        d.map.source.name(),
        d.collapsed_samples
    );

    // 3. Filter the slope on the distance grid: a zero-phase (forward-backward) Butterworth
    //    low-pass for off-line use and a causal one for on-line use, both mapped back to time.
    let slope = SlopeFilterConfig::default();
    let f = filter_slope(&d, &slope)?;
    match f.quantization {
        Some(q) => println!(
            "  slope sensor quantised in steps of {:.3} %",
            q.step * 100.0
        ),
        None => println!("  slope sensor not quantised"),
    }
    println!(
        "  gain at {} 1/m: zero-phase {:.1} dB, causal (order {}) {:.1} dB; required <= -{} dB",
        slope.stop_per_m,
        f.zero_phase_gain_at_stop_db,
        f.causal_order,
        f.causal_gain_at_stop_db,
        slope.required_attenuation_db
    );
    // Zero phase means no lag: filtering forward then backward cancels the phase. The causal
    // filter cannot look ahead, so its slope trails the zero-phase one.
    println!(
        "  causal slope trails the zero-phase one by {} m",
        lag_m(&f.zero_phase, &f.causal, d.step_m)
    );
    let rms = |a: &[f64], b: &[f64]| {
        let s: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
        (s / a.len() as f64).sqrt()
    };
    println!(
        "  RMS removed from the sensor slope: {:.3} % grade",
        100.0 * rms(&f.raw, &f.zero_phase)
    );

    // 4. Write the tables. The fingerprint is the canonical text of every setting; its hash goes
    //    into each file's metadata, so an output records the configuration that made it.
    let ingest_fp = ingest.fingerprint(&opts);
    let resample_fp = format!("{ingest_fp}\n{}", resample_stage::fingerprint(&resample));
    let slope_fp = format!("{resample_fp}\n{}", slope_stage::fingerprint(&slope));
    let (dist, time) = (
        out.join("slope_distance.parquet"),
        out.join("slope_time.parquet"),
    );
    resample_stage::write(&out.join("distance_log.parquet"), &d, &resample_fp)?;
    slope_stage::write(&dist, &time, log, &d, &f, &slope, &slope_fp)?;
    println!(
        "wrote {}/{{distance_log,slope_distance,slope_time}}.parquet",
        out.display()
    );
    Ok(())
}

/// Shift of `y` behind `x` in metres (within ±500 m) that maximises the cross-correlation of
/// their changes from one grid point to the next; positive when `y` trails `x`.
fn lag_m(x: &[f64], y: &[f64], step_m: f64) -> f64 {
    let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let dy: Vec<f64> = y.windows(2).map(|w| w[1] - w[0]).collect();
    let n = dx.len() as isize;
    let corr = |k: isize| -> f64 {
        let i = 0.max(-k)..n.min(n - k);
        i.map(|i| dx[i as usize] * dy[(i + k) as usize]).sum()
    };
    let max_lag = ((500.0 / step_m) as isize).min(n / 2);
    let best = (-max_lag..=max_lag).max_by(|&a, &b| corr(a).total_cmp(&corr(b)));
    best.unwrap_or(0) as f64 * step_m
}
