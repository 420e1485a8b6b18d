//! `fleetdyn`: the command-line shell over the library. The arguments are parsed ([`cli`]),
//! resolved into the library's settings, run ([`commands`]), and the failure's category decides
//! the exit code: 0 success, 1 input, 2 usage, 3 io, 4 model.

mod cli;
mod commands;

use clap::Parser as _;
use std::process::ExitCode;

fn main() -> ExitCode {
    limit_malloc_arenas();
    let cli = cli::Cli::parse();
    match cli.resolve().and_then(commands::execute) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.error);
            ExitCode::from(f.category.exit_code())
        }
    }
}

/// One glibc malloc arena per core instead of glibc's default of up to eight: a long drive's
/// diagnosis frees and allocates full-length columns (14 MB per channel for 10 hours) on its
/// worker threads, and columns freed into arenas that are no longer asked for stay resident.
/// Measured on a 10-hour drive's diagnosis (docs/validation/benchmarks.md): a peak about
/// 0.2 GB lower and 2–4 s less system time than with glibc's default; the nightly job's time is
/// unchanged. Set before any thread starts.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn limit_malloc_arenas() {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let arenas = libc::c_int::try_from(cores).unwrap_or(libc::c_int::MAX);
    // SAFETY: `mallopt` changes an allocator parameter and has no memory-safety
    // preconditions; it runs before the program starts a thread.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, arenas);
    }
}

/// Other platforms keep their allocator's defaults.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn limit_malloc_arenas() {}
