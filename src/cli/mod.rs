//! The command line: clap types, one file per command group, each resolving its arguments into
//! the library's settings (checked by the library) before any work starts.

mod common;
mod diagnose;
mod ingest;
mod road;
mod run;
mod simulate;
mod slope;
mod synth;

use crate::commands::failure::Failure;
use crate::commands::{self, Job};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// Heavy-truck fleet logs to physics.
#[derive(Parser, Debug)]
#[command(
    name = "fleetdyn",
    version,
    about = "Heavy-truck fleet logs to physics: ingest MCAP, Parquet and raw CAN, resample to distance, filter the road slope without phase lag, simulate driveline shuffle and axle loads, diagnose model-vs-recording mismatch, write Parquet with units.",
    after_help = "Exit codes: 0 success; 1 an input could not be used (or a drive of a run failed); 2 bad arguments or configuration; 3 a file could not be read or written; 4 a model could not be evaluated."
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    Ingest(ingest::IngestCmd),
    Resample(ingest::ResampleCmd),
    Slope(slope::SlopeCmd),
    Spectrum(slope::SpectrumCmd),
    Bode(simulate::BodeCmd),
    #[command(subcommand)]
    Simulate(simulate::SimulateCmd),
    #[command(subcommand)]
    Estimate(simulate::EstimateCmd),
    #[command(subcommand)]
    Road(road::RoadCmd),
    #[command(subcommand)]
    Synth(synth::SynthCmd),
    Diagnose(diagnose::DiagnoseCmd),
    Prove(diagnose::ProveCmd),
    Run(run::RunCmd),
    Completions(CompletionsCmd),
    Man(ManCmd),
}

/// Print a shell completion script to stdout (e.g. `fleetdyn completions bash >
/// ~/.local/share/bash-completion/completions/fleetdyn`).
#[derive(Args, Debug)]
struct CompletionsCmd {
    /// Shell.
    shell: clap_complete::Shell,
}

/// Write the man pages (fleetdyn.1 and one per subcommand) into a folder.
#[derive(Args, Debug)]
struct ManCmd {
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
}

impl Cli {
    /// The command with its arguments resolved into library settings.
    pub fn resolve(self) -> Result<Job, Failure> {
        use clap::CommandFactory as _;
        Ok(match self.command {
            Command::Ingest(c) => Job::Ingest(c.resolve()?),
            Command::Resample(c) => Job::Resample(c.resolve()?),
            Command::Slope(c) => Job::Slope(c.resolve()?),
            Command::Spectrum(c) => Job::Spectrum(c.resolve()?),
            Command::Bode(c) => Job::Bode(c.resolve()?),
            Command::Simulate(c) => Job::Simulate(c.resolve()?),
            Command::Estimate(c) => Job::Estimate(c.resolve()?),
            Command::Road(c) => Job::Road(c.resolve()?),
            Command::Synth(c) => Job::Synth(c.resolve()?),
            Command::Diagnose(c) => Job::Diagnose(c.resolve()?),
            Command::Prove(c) => Job::Prove(c.resolve()?),
            Command::Run(c) => Job::Run(c.resolve()?),
            Command::Completions(c) => Job::Completions(commands::completions::Job {
                shell: c.shell,
                command: Cli::command(),
            }),
            Command::Man(c) => Job::Man(commands::completions::ManJob {
                output: c.output,
                command: Cli::command(),
            }),
        })
    }
}
