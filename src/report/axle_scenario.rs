//! `fleetdyn simulate axle --scenario NAME`: builds a scripted scenario (`sim::axle_scenarios`),
//! simulates the half-truck axle model, and writes `axle_sim.parquet`, `axle_normal_forces.svg`
//! and `axle_pressures.svg` into the output folder — all three or none — returning the peak
//! changes relative to the static state (`sim::axle_summary`).

use super::axle_plot::{plot_normal_forces, plot_pressures, PlotError};
use super::axle_sim::{write_axle_sim, AxleSimExtra, TimeAxis};
use crate::io::{config_hash, OutputError, TableMeta};
use crate::model::axle::AxleParams;
use crate::sim::axle::HalfTruck;
use crate::sim::axle_scenarios::{
    scenario_inputs, AxleScenario, AxleScenarioConfig, ScenarioError,
};
use crate::sim::axle_summary::{summarize, AxleScenarioResult, SummaryError};
use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// File names written into the output folder.
pub const FILES: [&str; 3] = [
    "axle_sim.parquet",
    "axle_normal_forces.svg",
    "axle_pressures.svg",
];

/// Why a scenario run failed.
#[derive(Debug, Error)]
pub enum RunScenarioError {
    /// Unknown scenario or bad configuration.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The trajectory could not be summarised.
    #[error(transparent)]
    Summary(#[from] SummaryError),
    /// The table could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A plot could not be written.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// What a scenario run produced.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioReport {
    /// The scenario.
    pub scenario: AxleScenario,
    /// Vehicle identifier.
    pub vehicle_id: String,
    /// Duration, s.
    pub duration_s: f64,
    /// Output samples.
    pub samples: usize,
    /// Speed at the start and at the end, m/s.
    pub speed_start_mps: f64,
    /// Speed at the end, m/s.
    pub speed_end_mps: f64,
    /// Integration step of the axle model, s.
    pub step_s: f64,
    /// Peak changes relative to the static state.
    pub summary: AxleScenarioResult,
    /// Files written, in [`FILES`] order.
    pub files: Vec<PathBuf>,
}

impl fmt::Display for ScenarioReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: axle loads, scenario {} ({:.1} s, {} samples, speed {:.2} -> {:.2} m/s; RK4 step {:.2} ms)",
            self.vehicle_id,
            self.scenario,
            self.duration_s,
            self.samples,
            self.speed_start_mps,
            self.speed_end_mps,
            self.step_s * 1e3
        )?;
        write!(f, "{}", self.summary)?;
        let names: Vec<String> = self.files.iter().map(|p| p.display().to_string()).collect();
        writeln!(f, "wrote {}", names.join(", "))
    }
}

/// Runs scenario `name` (`full-acceleration` | `aux-braking`) with the default
/// [`AxleScenarioConfig`]; see [`run_scenario_with`].
///
/// # Errors
/// As [`run_scenario_with`].
pub fn run_scenario(
    name: &str,
    p: &AxleParams,
    vehicle_id: &str,
    out_dir: &Path,
) -> Result<ScenarioReport, RunScenarioError> {
    run_scenario_with(name, p, &AxleScenarioConfig::default(), vehicle_id, out_dir)
}

/// Builds scenario `name`, simulates it on the axle model of `p` (checked parameters, e.g. from
/// `VehicleFile::load`) from the steady state of its first inputs, and writes [`FILES`] into
/// `out_dir` (created if needed): all of them, or none on error.
///
/// # Errors
/// [`RunScenarioError::Scenario`] for an unknown name or a bad configuration; output and plot
/// errors.
pub fn run_scenario_with(
    name: &str,
    p: &AxleParams,
    cfg: &AxleScenarioConfig,
    vehicle_id: &str,
    out_dir: &Path,
) -> Result<ScenarioReport, RunScenarioError> {
    let scenario: AxleScenario = name.parse()?;
    let sc = scenario_inputs(scenario, p, cfg)?;
    let model = HalfTruck::new(p);
    let traj = model.simulate(&sc.inputs, &sc.t_s, sc.start);
    let g = p.gravity_m_per_s2;
    let summary = summarize(&traj, model.static_state(), g)?;

    let mut extra: Vec<(String, String)> = vec![("scenario".into(), scenario.name().into())];
    extra.extend(
        cfg.entries()
            .into_iter()
            .map(|(k, v)| (format!("scenario_{k}"), v.to_string())),
    );
    let meta = TableMeta {
        table: "axle_sim".into(),
        drive_id: String::new(),
        vehicle_id: Some(vehicle_id.to_string()),
        source_file: String::new(),
        config_hash: config_hash(&[
            scenario.name().as_bytes(),
            crate::io::canonical("axle-scenario:v2", &(cfg, p)).as_bytes(),
        ]),
        extra,
    };
    let files: Vec<PathBuf> = FILES.iter().map(|f| out_dir.join(f)).collect();
    let remove_first = |k: usize| {
        for f in &files[..k] {
            let _ = std::fs::remove_file(f);
        }
    };
    write_axle_sim(
        &files[0],
        &traj,
        &AxleSimExtra {
            time: TimeAxis::Simulation,
            inputs: &sc.inputs,
            vehicle_speed_mps: Some(&sc.speed_mps),
            gravity_m_per_s2: g,
        },
        &meta,
    )?;
    let title = |what: &str| format!("{vehicle_id}: {what}, scenario {scenario}");
    plot_normal_forces(&files[1], &traj, g, &title("axle normal forces"))
        .inspect_err(|_| remove_first(1))?;
    plot_pressures(&files[2], &traj, &title("air-bellow pressures"))
        .inspect_err(|_| remove_first(2))?;
    Ok(ScenarioReport {
        scenario,
        vehicle_id: vehicle_id.into(),
        duration_s: sc.t_s.last().copied().unwrap_or(0.0),
        samples: sc.t_s.len(),
        speed_start_mps: sc.speed_mps.first().copied().unwrap_or(f64::NAN),
        speed_end_mps: sc.speed_mps.last().copied().unwrap_or(f64::NAN),
        step_s: model.step_s(),
        summary,
        files,
    })
}
