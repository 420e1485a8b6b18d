//! `fleetdyn bode`: the per-gear resonances of the linear driveline model.

use super::failure::{io, usage, Failure};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::report::bode::{fingerprint, plot_svg, BodeTable};
use std::path::PathBuf;

/// A resolved `bode`.
pub struct Job {
    /// Vehicle file (has a `[driveline]`).
    pub vehicle: VehicleFile,
    /// Its path, for messages.
    pub vehicle_file: String,
    /// Output folder.
    pub output: PathBuf,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let v = &job.vehicle;
    let p = v.driveline(&job.vehicle_file).map_err(usage)?;
    let table = BodeTable::new(&v.vehicle_id, p, &v.gearbox.ratios);
    say_raw!("{table}");
    match table.open_loop_peak_gone_from() {
        Some(g) => say!("open-loop F_dr -> v resonance: no peak from gear {g} on"),
        None => say!("open-loop F_dr -> v resonance: a peak in every gear"),
    }
    let fp = fingerprint(p, &v.gearbox.ratios);
    let (pq, svg) = (job.output.join("bode.parquet"), job.output.join("bode.svg"));
    table.write(&pq, &fp).map_err(io)?;
    plot_svg(&svg, p, &v.gearbox.ratios, &table).map_err(|e| io(anyhow::anyhow!(e)))?;
    say!("wrote {} and {}", pq.display(), svg.display());
    Ok(())
}
