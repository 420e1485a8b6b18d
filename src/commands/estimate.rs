//! `fleetdyn estimate axle`: axle-model parameters from static measurements, beside the vehicle
//! file's.

use super::failure::{io, usage, Failure};
use fleetdyn::io::AtomicFile;
use fleetdyn::model::axle_estimate::estimate;
use fleetdyn::model::axle_measurement::Measurements;
use fleetdyn::model::vehicle::{VehicleError, VehicleFile};
use std::path::PathBuf;

/// A resolved `estimate axle`.
pub struct Job {
    /// Measurement file.
    pub measurements: PathBuf,
    /// Vehicle file (has `[axles]`).
    pub vehicle: PathBuf,
    /// Where the `[axles]` snippet goes; `None`: printed comparison only.
    pub output: Option<PathBuf>,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let vehicle_file = job.vehicle.display().to_string();
    let vehicle_text = std::fs::read_to_string(&job.vehicle).map_err(|source| {
        usage(VehicleError::Io {
            file: vehicle_file.clone(),
            source,
        })
    })?;
    let v = VehicleFile::parse(&vehicle_text, &vehicle_file).map_err(usage)?;
    let p = v.axles(&vehicle_file).map_err(usage)?;
    let m = Measurements::load(&job.measurements).map_err(usage)?;
    let est = estimate(&m, p, &vehicle_file).map_err(usage)?;
    say!(
        "{}: axle-model parameters from {} beside {}",
        v.vehicle_id,
        m.file,
        vehicle_file
    );
    say_raw!("{}", est.comparison(p));
    if let Some(out) = job.output {
        // never write a snippet that would break the vehicle file
        est.merged_vehicle(&vehicle_text, &vehicle_file)
            .map_err(usage)?;
        let write = || -> std::io::Result<()> {
            use std::io::Write as _;
            let mut f = AtomicFile::create(&out)?;
            f.file().write_all(est.snippet().as_bytes())?;
            f.commit()
        };
        write().map_err(|e| io(anyhow::anyhow!("{}: {e}", out.display())))?;
        say!("wrote {}", out.display());
    }
    Ok(())
}
