//! `fleetdyn completions` and `fleetdyn man`: shell completions and man pages from the command
//! line's own definition.

use super::failure::{io, Failure};
use std::path::PathBuf;

/// A resolved `completions`.
pub struct Job {
    /// Shell.
    pub shell: clap_complete::Shell,
    /// The command line's definition.
    pub command: clap::Command,
}

/// A resolved `man`.
pub struct ManJob {
    /// Output folder.
    pub output: PathBuf,
    /// The command line's definition.
    pub command: clap::Command,
}

/// Prints the completion script to stdout.
pub fn run(mut job: Job) -> Result<(), Failure> {
    let name = job.command.get_name().to_string();
    clap_complete::generate(job.shell, &mut job.command, name, &mut std::io::stdout());
    Ok(())
}

/// Writes `fleetdyn.1` and one page per subcommand.
pub fn man(job: ManJob) -> Result<(), Failure> {
    let fail = |e: std::io::Error| io(anyhow::anyhow!("{}: {e}", job.output.display()));
    std::fs::create_dir_all(&job.output).map_err(fail)?;
    clap_mangen::generate_to(job.command, &job.output).map_err(fail)?;
    say!("wrote the man pages into {}", job.output.display());
    Ok(())
}
