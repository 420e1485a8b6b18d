//! Diagnose where a recording and its vehicle's nominal model disagree, and read the result:
//! the library calls behind `fleetdyn diagnose`.
//!
//! ```text
//! cargo run --release --example diagnose    # fixtures/drives/truck-0001.mcap, truck-40t.toml
//! cargo run --release --example diagnose -- DRIVE VEHICLE.toml
//! ```
//!
//! Run it from the repository top. It prints the verdict, the noise floors, the located
//! mismatch stretches, the findings and the parameter estimates from the returned structures,
//! writes the diagnosis folder (`diagnosis.json`, `mismatch.parquet`, `findings.parquet`,
//! `report.md`, residual plots, `detail.json`) into `out/examples/diagnose/<drive_id>/`, and
//! reads `diagnosis.json` back as any other program would.

use fleetdyn::diagnose::run::{diagnose, DiagnoseConfig};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::diagnosis_files::write_outputs;
use fleetdyn::schema::{drive_log, Stage};
use std::error::Error;
use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn Error>> {
    let arg = |i: usize, default: &str| {
        std::env::args_os()
            .nth(i)
            .map_or(PathBuf::from(default), PathBuf::from)
    };
    let drive = arg(1, "fixtures/drives/truck-0001.mcap");
    let vehicle_path = arg(2, "fixtures/vehicles/truck-40t.toml");

    // The nominal model the recording is compared with, and the recording itself (the stage
    // `Ingest` requires the columns every drive must have: time and vehicle speed).
    let vehicle = VehicleFile::load(&vehicle_path)?;
    let ingest = IngestConfig::default();
    let opts = ingest.options(&[Stage::Ingest], Some(&vehicle))?;
    let log = ingest_stage::run(&drive, &opts)?.log;

    // The whole diagnosis: compare the models with the recording, estimate the recording's noise
    // floor, locate the stretches above it, explain them with the effect catalogue, decide.
    let t0 = std::time::Instant::now();
    let d = diagnose(&log, &vehicle, &DiagnoseConfig::default())?;
    // the content of diagnosis.json, as Rust values, with its plain sentences
    let dg = &fleetdyn::report::contract::assemble(&d);
    println!(
        "{}: {:.0} s of drive diagnosed in {:.1} s, verdict {}",
        dg.drive_id,
        log.duration_s(),
        t0.elapsed().as_secs_f64(),
        dg.verdict.as_str()
    );
    // Which models the recording could drive (the signals present decide), and the noise floor
    // of each compared signal, estimated from the recording itself.
    if !d.models.longitudinal {
        let why = d.models.longitudinal_reason.as_deref().unwrap_or("");
        println!("  longitudinal model not used: {why}");
    }
    if !d.models.axle {
        let why = d.models.axle_reason.as_deref().unwrap_or("");
        println!("  axle model not used: {why}");
    }
    for (signal, floor) in &dg.noise_floor {
        let unit = drive_log().column(signal).map_or("", |c| c.unit.as_str());
        println!("  noise floor of {signal}: {floor:.3} {unit}");
    }
    // Where the recording departs from the model beyond its own noise (p: the stretch's
    // family-wise corrected p-value).
    for m in &dg.mismatch {
        println!(
            "  mismatch {} from {:.0} to {:.0} s ({:.2} to {:.2} km): RMS {:.3e}, p = {:.1e}, {}",
            m.signal,
            m.start_s,
            m.end_s,
            m.start_m / 1000.0,
            m.end_m / 1000.0,
            m.rms_residual,
            m.significance,
            m.condition
        );
    }
    // What the catalogue names: one sentence per finding, the fitted parameters with their 95 %
    // intervals, and the held-out improvement that accepted it.
    for f in &dg.findings {
        println!("  finding {}: {}", f.effect, f.sentence);
        for (name, p) in &f.parameters {
            let (v, lo, hi) = (p.value, p.ci_low, p.ci_high);
            let unit = if p.unit == "1" {
                String::new()
            } else {
                format!(" {}", p.unit)
            };
            println!("    {name} = {v:.4}{unit} (95 %: {lo:.4} .. {hi:.4})");
        }
        for (signal, e) in &f.fit {
            let (b, a) = (e.heldout_before, e.heldout_after);
            println!("    held-out {} of {signal}: {b:.4} -> {a:.4}", e.metric);
        }
    }
    // Parameters the drive informs whose fit stays inside the vehicle file's tolerance band:
    // estimated, beside the file's value, but not findings.
    for e in &dg.estimates {
        let (lo, hi) = (e.tolerance_low, e.tolerance_high);
        println!(
            "  estimate {} = {:.4} {} (file {:.4}, tolerance {lo:.4} .. {hi:.4})",
            e.parameter, e.value, e.unit, e.nominal
        );
    }

    // Write the folder. The fingerprint identifies the configuration in the Parquet metadata.
    let out = Path::new("out/examples/diagnose").join(&dg.drive_id);
    let fp = format!(
        "{}\nvehicle {}",
        ingest.fingerprint(&opts),
        vehicle_path.display()
    );
    let written = write_outputs(&out, &d, &log, &fp)?;
    println!(
        "wrote {} (and report.md, tables, plots)",
        written.json.display()
    );

    // diagnosis.json is the output contract other tools read: here with plain serde_json.
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&written.json)?)?;
    let count = |key: &str| json[key].as_array().map_or(0, Vec::len);
    println!(
        "diagnosis.json: verdict {}, {} mismatch stretch(es), {} finding(s), {} estimate(s)",
        json["verdict"],
        count("mismatch"),
        count("findings"),
        count("estimates")
    );
    Ok(())
}
