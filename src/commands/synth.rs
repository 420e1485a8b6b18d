//! `fleetdyn synth drive`: a closed-loop synthetic drive written as a real logger would.

use super::failure::{input, io, model, usage, Failure};
use super::progress::Progress;
use fleetdyn::synth::drive::{synth_drive_logged, DriveConfig, DriveError, HiddenEffect};
use fleetdyn::synth::effects::EffectError;
use fleetdyn::synth::export::ExportError;
use fleetdyn::synth::log_writer::LogOptions;
use fleetdyn::synth::road_source::{RoadSource, RoadSourceError};
use fleetdyn::synth::SynthError;
use std::path::PathBuf;

/// A resolved `synth drive`.
pub struct Job {
    /// Vehicle file.
    pub vehicle: PathBuf,
    /// The road.
    pub road: RoadSource,
    /// Seed of the road, the driver's variations, the GNSS track and the CAN noise.
    pub seed: u64,
    /// Output folder.
    pub output: PathBuf,
    /// Driver, AMT and simulation settings.
    pub cfg: DriveConfig,
    /// The catalogue effect hidden in the truth, if any.
    pub hidden: Option<HiddenEffect>,
    /// How the drive is logged.
    pub log: LogOptions,
}

/// Outputs that cannot be written exit 3; a road file that cannot be read exits 1; settings the
/// drive cannot be made with exit 2; a simulation that cannot be completed exits 4.
fn category(e: DriveError) -> Failure {
    match e {
        DriveError::Io { .. } | DriveError::Can(_) | DriveError::Effect(EffectError::Io { .. }) => {
            io(e)
        }
        DriveError::RoadFile(RoadSourceError::Io { .. }) => input(e),
        DriveError::Export(
            ExportError::BadInput { .. }
            | ExportError::Mismatch { .. }
            | ExportError::Mapping { .. }
            | ExportError::Can(SynthError::BadCompressionLevel { .. }),
        ) => usage(e),
        DriveError::Export(_) => io(e),
        DriveError::Sim(_) => model(e),
        _ => usage(e),
    }
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let spinner = Progress::spinner("simulating the drive");
    let r = synth_drive_logged(
        &job.vehicle,
        &job.road,
        job.seed,
        &job.output,
        &job.cfg,
        job.hidden.as_ref(),
        &job.log,
    )
    .map_err(category)?;
    drop(spinner);
    if let Some(h) = &job.hidden {
        say!("answer (hidden effect) -> {}", h.answer_path.display());
    }
    let d = &r.drive;
    let vmax = d.speed_mps.iter().fold(0.0f64, |m, &v| m.max(v));
    let ret_max = d.retarder_torque_nm.iter().fold(0.0f64, |m, &v| m.max(v));
    let me_min = d.engine_torque_nm.iter().fold(0.0f64, |m, &v| m.min(v));
    say!(
        "{:.3} km drive over {}, seed {}: {:.1} s, {} launches, {} shifts, max {:.1} km/h, {:.0} m travelled, engine torque down to {:.0} N·m, retarder up to {:.0} N·m -> {}, {}, {}{}",
        r.road.length_m / 1000.0, r.road.label, job.seed, d.t_s.last().copied().unwrap_or(0.0),
        d.launches.len(), d.shifts.len(), vmax * 3.6,
        d.distance_m.last().copied().unwrap_or(0.0), me_min, ret_max,
        r.log_file.display(), r.parquet.display(), r.vehicle.display(),
        r.truth_file.as_ref().map(|p| format!(", {}", p.display())).unwrap_or_default()
    );
    Ok(())
}
