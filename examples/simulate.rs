//! Simulate recorded drives with the physics models and validate them against the recording:
//! the library calls behind `fleetdyn simulate shuffle` and `fleetdyn simulate axle`.
//!
//! ```text
//! cargo run --release --example simulate                    # the two bundled drives below
//! cargo run --release --example simulate -- DRIVE VEHICLE.toml
//! ```
//!
//! Run it from the repository top. Without arguments it simulates the 40 t tractor's drive
//! `fixtures/drives/truck-0001.mcap` with the driveline model of `truck-40t.toml`, and the 6x2
//! test truck's drive `truck-0005-axle.parquet` with the axle-load model of `seed002-6x2.toml`.
//! A model runs when the vehicle file has its section (`[driveline]`, `[axles]`) and the
//! recording has its signals. Tables go to `out/examples/simulate/<drive_id>/`.

use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::axle_stage::{self, AxleStageConfig, LongitudinalSource};
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::validation;
use fleetdyn::road::slope_filter::{filter_slope, SlopeFilterConfig};
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use fleetdyn::sim::axle_validate::{require_pressures, Segment};
use fleetdyn::sim::validate::{validate_shuffle, ValidationConfig};
use fleetdyn::table::{DriveLog, Signal};
use std::error::Error;
use std::path::Path;

/// The bundled drives simulated without arguments: (fixtures/drives/…, fixtures/vehicles/…).
const BUNDLED: [(&str, &str); 2] = [
    ("truck-0001.mcap", "truck-40t.toml"),
    ("truck-0005-axle.parquet", "seed002-6x2.toml"),
];

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fixture = |dir: &str, name: &str| Path::new("fixtures").join(dir).join(name);
    match args.as_slice() {
        [] => (BUNDLED.iter())
            .try_for_each(|(d, v)| simulate(&fixture("drives", d), &fixture("vehicles", v))),
        [drive, vehicle] => simulate(Path::new(drive), Path::new(vehicle)),
        _ => Err("usage: simulate [DRIVE VEHICLE.toml]".into()),
    }
}

fn simulate(drive: &Path, vehicle_path: &Path) -> Result<(), Box<dyn Error>> {
    // The vehicle file: gearbox, and the parameters of each model it has a section for. Given
    // to ingest, its gearbox bounds the recorded gear; naming the driveline stage makes ingest
    // check (and prepare) the columns that model needs.
    let vehicle = VehicleFile::load(vehicle_path)?;
    let stages = match vehicle.driveline {
        Some(_) => vec![Stage::Driveline],
        None => vec![],
    };
    let ingest = IngestConfig::default();
    let opts = ingest.options(&stages, Some(&vehicle))?;
    let mut log = ingest_stage::run(drive, &opts)?.log;
    let slope = add_filtered_slope(&mut log)?;
    let out = Path::new("out/examples/simulate").join(&log.meta.drive_id);
    let fingerprint = format!("{}\nexample slope={slope:?}", ingest.fingerprint(&opts));
    println!(
        "{} ({:.0} s) with {}",
        log.meta.drive_id,
        log.duration_s(),
        vehicle.vehicle_id
    );

    // Driveline shuffle model: simulated from the recorded engine torque, gear, clutch and slope
    // in 30 s windows, each started from the measured state so open-loop drift stays bounded.
    if let Some(p) = &vehicle.driveline {
        let cfg = ValidationConfig::default();
        let val = validate_shuffle(&log, p, &vehicle.gearbox.ratios, slope.as_deref(), &cfg)?;
        // one metric per signal over all gears (gear None), then one per signal and gear
        for m in val.metrics.iter().filter(|m| m.gear.is_none()) {
            let unit = if m.signal == "vehicle_speed" {
                "m/s"
            } else {
                "rad/s"
            };
            println!(
                "  driveline {:<14} RMSE {:.3} {unit}, MAE {:.3} {unit}, fit {:.1} % ({} samples)",
                m.signal, m.rmse, m.mae, m.fit_percent, m.samples
            );
        }
        let fits: Vec<String> = (val.metrics.iter())
            .filter(|m| m.signal == "vehicle_speed")
            .filter_map(|m| Some(format!("{}: {:.0} %", m.gear?, m.fit_percent)))
            .collect();
        println!("  vehicle speed fit per gear: {}", fits.join(", "));
        validation::write(&out, &log, &val, &fingerprint)?; // shuffle_sim, validation.parquet
    }

    // Axle-load model: the half truck's bellow pressures (and suspension travel) from the
    // recorded longitudinal inputs, against the recorded ones per axle.
    if let (Some(p), Ok(())) = (&vehicle.axles, require_pressures(&log)) {
        let cfg = AxleStageConfig {
            validation: Default::default(),
            longitudinal: LongitudinalSource::Recorded,
            slope_column: slope.clone(),
        };
        let val = axle_stage::run(&log, &vehicle, &vehicle_path.display().to_string(), &cfg)?;
        // one metric per signal and segment (acceleration, braking, steady); here all rows
        for m in val.metrics.iter().filter(|m| m.segment == Segment::All) {
            let (mae, unit) = match m.unit {
                "Pa" => (m.mae / 1e3, "kPa"),
                "m" => (m.mae * 1e3, "mm"),
                u => (m.mae, u),
            };
            println!(
                "  axle {:<25} MAE {mae:.2} {unit}, fit {:.1} % ({} samples)",
                m.signal, m.fit_percent, m.samples
            );
        }
        axle_stage::write(&out, &log, &val, p.gravity_m_per_s2, &fingerprint)?;
    }
    println!("  tables in {}", out.display());
    Ok(())
}

/// Adds the zero-phase filtered road slope as column `road_slope_filtered` and returns its name
/// (`None` when the drive has no slope: the models then assume a flat road). The sensor's
/// quantisation steps would otherwise excite spurious shuffle in the simulation.
fn add_filtered_slope(log: &mut DriveLog) -> Result<Option<String>, Box<dyn Error>> {
    if log.signal("road_slope").is_none() {
        return Ok(None);
    }
    let d = resample_to_distance(log, &ResampleConfig::default())?;
    let f = filter_slope(&d, &SlopeFilterConfig::default())?;
    log.signals.push(Signal {
        name: "road_slope_filtered".into(),
        unit: "1".into(),
        values: f.zero_phase_time,
    });
    Ok(Some("road_slope_filtered".into()))
}
