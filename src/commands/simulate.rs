//! `fleetdyn simulate shuffle|axle`: a recorded drive through the driveline or axle-load model,
//! validated against the recording.

use super::failure::{input, io, model, Failure};
use super::progress::Progress;
use fleetdyn::ingest::IngestOptions;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::axle_stage::{self, AxleStageConfig, AxleStageError, LongitudinalSource};
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::slope_stage::{add_filtered_slope, FilteredSlopeError};
use fleetdyn::report::axle_scenario::{run_scenario, RunScenarioError};
use fleetdyn::report::axle_validation::axle_summary;
use fleetdyn::report::validation;
use fleetdyn::sim::axle_validate::AxleValidationConfig;
use fleetdyn::sim::validate::{validate_shuffle, ValidationConfig, ValidationError};
use fleetdyn::table::DriveLog;
use std::path::PathBuf;

/// A resolved `simulate`.
pub enum Job {
    /// The driveline model on a recording.
    Shuffle(ShuffleJob),
    /// The axle-load model on a recording.
    Axle(AxleJob),
    /// A scripted axle-load scenario.
    AxleScenario {
        /// Scenario name.
        name: &'static str,
        /// Vehicle file (has `[axles]`).
        vehicle: VehicleFile,
        /// Its path.
        vehicle_file: String,
        /// Output folder.
        output: PathBuf,
    },
}

/// A resolved `simulate shuffle`.
pub struct ShuffleJob {
    /// Recording.
    pub drive: PathBuf,
    /// Vehicle file (has `[driveline]`).
    pub vehicle: VehicleFile,
    /// Its path.
    pub vehicle_file: String,
    /// Output folder.
    pub output: PathBuf,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
    /// Simulation windows and step.
    pub validation: ValidationConfig,
    /// Simulate on the zero-phase filtered slope (else the raw sensor).
    pub filtered_slope: bool,
}

/// A resolved `simulate axle` on a recording.
pub struct AxleJob {
    /// Recording.
    pub drive: PathBuf,
    /// Vehicle file (has `[axles]`).
    pub vehicle: VehicleFile,
    /// Its path.
    pub vehicle_file: String,
    /// Output folder.
    pub output: PathBuf,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
    /// Validation settings.
    pub validation: AxleValidationConfig,
    /// Where the longitudinal inputs come from.
    pub longitudinal: LongitudinalSource,
    /// Simulate on the zero-phase filtered slope (else the raw sensor).
    pub filtered_slope: bool,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    match job {
        Job::Shuffle(j) => shuffle(j),
        Job::Axle(j) => axle(j),
        Job::AxleScenario {
            name,
            vehicle,
            vehicle_file,
            output,
        } => {
            let p = vehicle.axles(&vehicle_file).map_err(input)?;
            let rep = run_scenario(name, p, &vehicle.vehicle_id, &output).map_err(|e| match e {
                RunScenarioError::Output(_) | RunScenarioError::Plot(_) => io(e),
                _ => model(e),
            })?;
            say_raw!("{rep}");
            Ok(())
        }
    }
}

/// The slope column the simulation reads: the filtered slope added to the log, or `None` for
/// the raw sensor (or a log without one).
fn slope_column(log: &mut DriveLog, filtered: bool) -> Result<Option<&'static str>, Failure> {
    if !filtered {
        return Ok(None);
    }
    add_filtered_slope(log).map_err(|e: FilteredSlopeError| input(e))
}

fn validation_failure(e: ValidationError) -> Failure {
    match e {
        ValidationError::Sim { .. } => model(e),
        _ => input(e),
    }
}

fn shuffle(j: ShuffleJob) -> Result<(), Failure> {
    let v = &j.vehicle;
    let p = v.driveline(&j.vehicle_file).map_err(input)?;
    let mut ing = ingest_stage::run(&j.drive, &j.opts).map_err(input)?;
    let slope = slope_column(&mut ing.log, j.filtered_slope)?;
    let spinner = Progress::spinner("simulating the driveline");
    let val = validate_shuffle(&ing.log, p, &v.gearbox.ratios, slope, &j.validation)
        .map_err(validation_failure)?;
    drop(spinner);
    let fp = format!(
        "{}\n{}",
        j.cfg.fingerprint(&j.opts),
        j.validation.fingerprint(p, &v.gearbox.ratios, slope)
    );
    validation::write(&j.output, &ing.log, &val, &fp).map_err(io)?;
    say!(
        "{}: driveline simulation vs recording (windows of {} s re-initialised from the measured state; slope from {})",
        ing.log.meta.drive_id,
        j.validation.window_s,
        val.slope_column.as_deref().unwrap_or("none: flat road")
    );
    say_raw!("{}", validation::summary(&val));
    say!(
        "wrote {} and {}",
        j.output.join("shuffle_sim.parquet").display(),
        j.output.join("validation.parquet").display()
    );
    Ok(())
}

fn axle(j: AxleJob) -> Result<(), Failure> {
    let v = &j.vehicle;
    let p = v.axles(&j.vehicle_file).map_err(input)?;
    let mut ing = ingest_stage::run(&j.drive, &j.opts).map_err(input)?;
    let slope = slope_column(&mut ing.log, j.filtered_slope)?;
    let scfg = AxleStageConfig {
        validation: j.validation,
        longitudinal: j.longitudinal,
        slope_column: slope.map(String::from),
    };
    let spinner = Progress::spinner("simulating the axle loads");
    let val = axle_stage::run(&ing.log, v, &j.vehicle_file, &scfg).map_err(|e| match e {
        // a vehicle file without the section the mode needs is a configuration error
        AxleStageError::Vehicle(_) => super::failure::usage(e),
        AxleStageError::Driveline(e) => validation_failure(e),
        AxleStageError::Coupling { .. } => model(e),
        AxleStageError::Validation(_) => input(e),
    })?;
    drop(spinner);
    let fp = format!("{}\n{}", j.cfg.fingerprint(&j.opts), scfg.fingerprint(p));
    axle_stage::write(&j.output, &ing.log, &val, p.gravity_m_per_s2, &fp).map_err(io)?;
    say!(
        "{}: axle-load model vs recording (acceleration from {}; slope from {}; {})",
        ing.log.meta.drive_id,
        val.recorded.accel_source,
        val.recorded
            .slope_column
            .as_deref()
            .unwrap_or("none: flat road"),
        if val.recorded.torque_inputs {
            "torque inputs"
        } else {
            "acceleration only"
        }
    );
    say_raw!("{}", axle_summary(&val));
    say!(
        "wrote {} and {}",
        j.output.join("axle_sim.parquet").display(),
        j.output.join("axle_validation.parquet").display()
    );
    Ok(())
}
