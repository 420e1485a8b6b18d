//! `fleetdyn diagnose` and `fleetdyn prove`.

use super::common::{jobs, load_vehicle, IngestArgs};
use crate::commands::failure::{setting, Failure};
use crate::commands::{diagnose, prove};
use clap::{Args, ValueEnum};
use fleetdyn::diagnose::run::DiagnoseConfig;
use fleetdyn::proof::{Driving, FleetProofConfig, ProofConfig};
use std::path::PathBuf;

/// Diagnose where a recording and the nominal model disagree (docs/diagnosis/method.md):
/// compare, locate against the noise floor, explain with the effect catalogue (fit, held-out
/// test, fixed acceptance rule), show. Writes diagnosis.json, mismatch.parquet,
/// findings.parquet, report.md with residual plots, and detail.json into the output folder.
#[derive(Args, Debug)]
pub struct DiagnoseCmd {
    /// Drive file (MCAP or Parquet).
    #[arg(long)]
    drive: PathBuf,
    /// Vehicle file: the nominal model the recording is compared with.
    #[arg(long)]
    vehicle: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
    /// Most findings accepted (greedy rounds).
    #[arg(long, default_value_t = 3)]
    max_findings: usize,
    #[command(flatten)]
    ingest: IngestArgs,
}

impl DiagnoseCmd {
    /// The job: drive, vehicle file, ingest and diagnosis settings.
    pub fn resolve(self) -> Result<diagnose::Job, Failure> {
        let vehicle = load_vehicle(&self.vehicle)?;
        let (cfg, opts) = self.ingest.resolve(&[], Some(&vehicle))?;
        Ok(diagnose::Job {
            drive: self.drive,
            vehicle,
            vehicle_file: self.vehicle,
            output: self.output,
            cfg,
            opts,
            diagnose: DiagnoseConfig {
                max_findings: self.max_findings,
                ..DiagnoseConfig::default()
            },
        })
    }
}

/// The diagnosis proof: synthetic drives each hiding one catalogue effect, nothing, or an
/// effect outside the catalogue; diagnosed blind and scored. Writes proof.md, proof.json,
/// proof_cases.parquet and every case's drive, answer and diagnosis.
#[derive(Args, Debug)]
pub struct ProveCmd {
    /// Where the drives come from: `independent`, the independent truth plant (the proof);
    /// `model`, the diagnosis's own extended model (an inversion check).
    #[arg(long, value_enum, default_value = "independent")]
    truth: TruthArg,
    /// Number of drives (a cycle covers every effect once, four clean drives and the
    /// out-of-catalogue ones: 17 on the independent truth, 22 on the model).
    #[arg(long, default_value_t = 66)]
    drives: usize,
    /// Seed of the plan; drive i uses seed + i.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Shortest drive, km.
    #[arg(long, default_value_t = 3.0)]
    min_km: f64,
    /// Longest drive, km.
    #[arg(long, default_value_t = 6.0)]
    max_km: f64,
    /// Nominal vehicle file (default: fixtures/vehicles/truck-40t.toml on the independent
    /// truth, fixtures/vehicles/seed002-6x2-diesel.toml, which has [axles], on the model).
    #[arg(long)]
    vehicle: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long, default_value = "out/proof")]
    output: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    jobs: Option<usize>,
    /// Run only these plan indices (comma separated, e.g. 49,60), each drive exactly as in the
    /// whole plan of --drives and --seed.
    #[arg(long, value_delimiter = ',')]
    cases: Vec<usize>,
    /// The drives' driving on the model truth: `drawn`, a driver drawn per drive
    /// (acceleration, braking, speed holding, torque tips, lift-offs, stop time); `fixed`, the
    /// generator's one default driver for every drive. The independent truth has its own
    /// driver and ignores it.
    #[arg(long, value_enum, default_value = "drawn")]
    driving: DrivingArg,
    /// Independent truth only: drives without wind (no mean wind, no gusts). A study of what
    /// the wind costs the diagnosis (docs/validation/proof.md), not the proof.
    #[arg(long, conflicts_with = "fleet")]
    calm: bool,
    /// Independent truth only: tyres that start warm, at the rolling resistance the file
    /// states, instead of cold. A study of what their warm-up costs the diagnosis
    /// (docs/validation/proof.md), not the proof.
    #[arg(long, conflicts_with = "fleet")]
    warm_tyres: bool,
    /// The fleet-level proof instead (docs/fleet.md): trucks drawn once from the independent
    /// truth, payload per trip, some developing a fault part-way; every drive diagnosed, the
    /// fleet evidence scored (detection delay, false alarms per vehicle-month, estimate errors).
    #[arg(long)]
    fleet: bool,
    /// Fleet proof: trucks.
    #[arg(long, default_value_t = 20, requires = "fleet")]
    trucks: usize,
    /// Fleet proof: drives per truck (one a day).
    #[arg(long, default_value_t = 30, requires = "fleet")]
    drives_per_truck: usize,
    /// Fleet proof: trucks that develop a fault.
    #[arg(long, default_value_t = 6, requires = "fleet")]
    faulty: usize,
    /// Fleet proof: score the fleet proof saved in this folder (its fleet_proof.json) again,
    /// without simulating or diagnosing; the plan is the saved one, so the plan's flags are
    /// not allowed beside it.
    #[arg(long, requires = "fleet", conflicts_with_all = ["seed", "trucks", "drives_per_truck", "faulty", "min_km", "max_km", "vehicle"])]
    rescore: Option<PathBuf>,
}

/// Where the proof's drives come from.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum TruthArg {
    /// The independent truth plant.
    Independent,
    /// The diagnosis's own extended model (an inversion check).
    Model,
}

/// How the model truth's drives are driven.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum DrivingArg {
    /// A driver drawn per drive.
    Drawn,
    /// One default driver.
    Fixed,
}

impl ProveCmd {
    /// The job: the plan, the nominal vehicle file, output and threads.
    pub fn resolve(self) -> Result<prove::Job, Failure> {
        if let Some(saved) = self.rescore {
            return Ok(prove::Job::Rescore {
                saved,
                output: self.output,
            });
        }
        if self.fleet {
            let cfg = FleetProofConfig {
                seed: self.seed,
                trucks: self.trucks,
                drives_per_truck: self.drives_per_truck,
                faulty: self.faulty,
                length_km: (self.min_km, self.max_km),
                ..FleetProofConfig::default()
            };
            cfg.validate().map_err(setting)?;
            return Ok(prove::Job::Fleet {
                cfg,
                vehicle: self
                    .vehicle
                    .unwrap_or_else(|| PathBuf::from("fixtures/vehicles/truck-40t.toml")),
                output: self.output,
                jobs: jobs(self.jobs)?,
            });
        }
        let base = match self.truth {
            TruthArg::Independent => ProofConfig::independent(),
            TruthArg::Model => ProofConfig::model(),
        };
        let vehicle = self.vehicle.unwrap_or_else(|| {
            PathBuf::from(match self.truth {
                TruthArg::Independent => "fixtures/vehicles/truck-40t.toml",
                TruthArg::Model => "fixtures/vehicles/seed002-6x2-diesel.toml",
            })
        });
        let cfg = ProofConfig {
            drives: self.drives,
            seed: self.seed,
            length_km: (self.min_km, self.max_km),
            only: self.cases,
            driving: match self.driving {
                DrivingArg::Drawn => Driving::Drawn,
                DrivingArg::Fixed => Driving::Fixed,
            },
            wind: !self.calm,
            warm_tyres: self.warm_tyres,
            ..base
        };
        cfg.validate().map_err(setting)?;
        Ok(prove::Job::Cases {
            cfg,
            vehicle,
            output: self.output,
            jobs: jobs(self.jobs)?,
        })
    }
}
