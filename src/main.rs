//! `fleetdyn`: the command-line shell over the library. Exit codes: 0 ok, 1 some drive failed,
//! 2 usage or configuration error.

use clap::{Args, Parser, Subcommand};
use fleetdyn::ingest::TimeRepair;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::resample_stage;
use fleetdyn::report::IngestSummary;
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{
    resample_to_distance, DistanceSource, ResampleConfig, ReversePolicy,
};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "fleetdyn",
    version,
    about = "Heavy-truck fleet logs to physics: ingest MCAP/Parquet, resample to distance, filter the road slope without phase lag, write Parquet with units."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Read one MCAP or Parquet file into the canonical drive log and print a summary.
    Ingest {
        /// Input file (MCAP or Parquet; format detected from its magic bytes).
        input: PathBuf,
        /// Output Parquet file (canonical drive log). Without it only the summary is printed.
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        ingest: IngestArgs,
    },
    /// Ingest, then resample the drive to a uniform distance grid.
    Resample {
        /// Input file (MCAP or Parquet).
        input: PathBuf,
        /// Output Parquet file (distance log).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        ingest: IngestArgs,
        #[command(flatten)]
        resample: ResampleArgs,
    },
}

#[derive(Args)]
struct IngestArgs {
    /// Mapping file (schemas/mappings/*.toml); chosen automatically when absent.
    #[arg(long)]
    mapping: Option<PathBuf>,
    /// Stages the drive must be usable for (their required columns are checked), comma separated:
    /// ingest, resample, slope, driveline, axle.
    #[arg(long, value_delimiter = ',', default_value = "ingest")]
    stages: Vec<String>,
    /// Time base for multi-rate sources, Hz (default: the fastest channel's rate).
    #[arg(long)]
    time_base_hz: Option<f64>,
    /// Longest accepted run of missing values in a required column, s.
    #[arg(long, default_value_t = 2.0)]
    max_nan_run_s: f64,
    /// What to do when time goes backwards.
    #[arg(long, value_enum, default_value = "error")]
    time_repair: TimeRepairArg,
    /// Vehicle file (its gearbox bounds the gear column; its id is recorded).
    #[arg(long)]
    vehicle: Option<PathBuf>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TimeRepairArg {
    Error,
    Sort,
}

#[derive(Args)]
struct ResampleArgs {
    /// Distance grid step, m.
    #[arg(long, default_value_t = 1.0)]
    step_m: f64,
    /// Distance source: auto (odometer if fine enough, else the speed integral), odometer, speed.
    #[arg(long, value_enum, default_value = "auto")]
    distance_source: DistanceSourceArg,
    /// Reverse motion: error (fail the drive) or exclude (no distance, collapsed).
    #[arg(long, value_enum, default_value = "error")]
    reverse: ReverseArg,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum DistanceSourceArg {
    Auto,
    Odometer,
    Speed,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ReverseArg {
    Error,
    Exclude,
}

/// A failure and the exit code it maps to.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

fn usage(e: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 2,
        error: e.into(),
    }
}

fn drive(e: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 1,
        error: e.into(),
    }
}

impl IngestArgs {
    fn resolve(
        &self,
        extra_stages: &[Stage],
    ) -> Result<(IngestConfig, fleetdyn::ingest::IngestOptions), Failure> {
        let mut stages = Vec::new();
        for s in &self.stages {
            stages.push(Stage::parse(s).ok_or_else(|| {
                usage(anyhow::anyhow!(
                    "unknown stage {s:?} (ingest, resample, slope, driveline, axle)"
                ))
            })?);
        }
        stages.extend_from_slice(extra_stages);
        let vehicle = match &self.vehicle {
            Some(p) => Some(VehicleFile::load(p).map_err(usage)?),
            None => None,
        };
        let cfg = IngestConfig {
            mapping: self.mapping.clone(),
            time_base_hz: self.time_base_hz,
            max_nan_run_s: self.max_nan_run_s,
            time_repair: match self.time_repair {
                TimeRepairArg::Error => TimeRepair::Error,
                TimeRepairArg::Sort => TimeRepair::Sort,
            },
        };
        let opts = cfg.options(&stages, vehicle.as_ref()).map_err(usage)?;
        Ok((cfg, opts))
    }
}

impl ResampleArgs {
    fn config(&self) -> ResampleConfig {
        ResampleConfig {
            step_m: self.step_m,
            distance_source: match self.distance_source {
                DistanceSourceArg::Auto => DistanceSource::Auto,
                DistanceSourceArg::Odometer => DistanceSource::Odometer,
                DistanceSourceArg::Speed => DistanceSource::Speed,
            },
            reverse: match self.reverse {
                ReverseArg::Error => ReversePolicy::Error,
                ReverseArg::Exclude => ReversePolicy::Exclude,
            },
            ..Default::default()
        }
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Ingest {
            input,
            output,
            ingest,
        } => {
            let (cfg, opts) = ingest.resolve(&[])?;
            let ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            print!("{}", IngestSummary::new(&ing));
            if let Some(out) = output {
                ingest_stage::write(&out, &ing.log, &cfg.fingerprint(&opts)).map_err(drive)?;
                println!("wrote     {}", out.display());
            }
            Ok(())
        }
        Command::Resample {
            input,
            output,
            ingest,
            resample,
        } => {
            let (cfg, opts) = ingest.resolve(&[Stage::Resample])?;
            let rcfg = resample.config();
            let ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            let d = resample_to_distance(&ing.log, &rcfg).map_err(drive)?;
            let fp = format!(
                "{}\n{}",
                cfg.fingerprint(&opts),
                resample_stage::fingerprint(&rcfg)
            );
            resample_stage::write(&output, &d, &fp).map_err(drive)?;
            println!(
                "{}: {:.3} km on a {} m grid ({} points, distance from {:?}, {} samples collapsed) -> {}",
                d.meta.drive_id,
                d.map.total_m() / 1000.0,
                d.step_m,
                d.distance_m.len(),
                d.map.source,
                d.collapsed_samples,
                output.display()
            );
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.error);
            ExitCode::from(f.code)
        }
    }
}
