//! What each command does with its resolved settings: one file per command group, each
//! calling the library and printing its summary.

/// Prints a line to stdout; a closed pipe (`fleetdyn ... | head`) ends output quietly instead
/// of panicking.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// Like [`say!`] without the newline.
macro_rules! say_raw {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

pub mod bode;
pub mod completions;
pub mod diagnose;
pub mod estimate;
pub mod failure;
pub mod ingest;
pub mod progress;
pub mod prove;
pub mod resample;
pub mod road;
pub mod run;
pub mod simulate;
pub mod slope;
pub mod spectrum;
pub mod synth;

use failure::Failure;

/// A command with its settings resolved.
// One value per process: the size of its largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
pub enum Job {
    /// `ingest`.
    Ingest(ingest::Job),
    /// `resample`.
    Resample(resample::Job),
    /// `slope`.
    Slope(slope::Job),
    /// `spectrum`.
    Spectrum(spectrum::Job),
    /// `bode`.
    Bode(bode::Job),
    /// `simulate shuffle|axle`.
    Simulate(simulate::Job),
    /// `estimate axle`.
    Estimate(estimate::Job),
    /// `road …`.
    Road(road::Job),
    /// `synth drive`.
    Synth(synth::Job),
    /// `diagnose`.
    Diagnose(diagnose::Job),
    /// `prove`.
    Prove(prove::Job),
    /// `run`.
    Run(run::Job),
    /// `completions`.
    Completions(completions::Job),
    /// `man`.
    Man(completions::ManJob),
}

/// Runs a resolved command.
pub fn execute(job: Job) -> Result<(), Failure> {
    match job {
        Job::Ingest(j) => ingest::run(j),
        Job::Resample(j) => resample::run(j),
        Job::Slope(j) => slope::run(j),
        Job::Spectrum(j) => spectrum::run(j),
        Job::Bode(j) => bode::run(j),
        Job::Simulate(j) => simulate::run(j),
        Job::Estimate(j) => estimate::run(j),
        Job::Road(j) => road::run(j),
        Job::Synth(j) => synth::run(j),
        Job::Diagnose(j) => diagnose::run(j),
        Job::Prove(j) => prove::run(j),
        Job::Run(j) => run::run(j),
        Job::Completions(j) => completions::run(j),
        Job::Man(j) => completions::man(j),
    }
}
