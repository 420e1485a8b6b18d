//! The whole diagnosis of one recording (docs/diagnosis/method.md, "The four steps"):
//! set up → compare → noise floor → locate → explain → verdict → show, and the per-drive output
//! folder of the contract.
//!
//! # Steps
//! 1. [`Setup::new`]: which models the recording drives (the signals present decide), the
//!    nominal parameters from the vehicle file, the slope sensor's resolution read from the
//!    recording.
//! 2. Compare ([`ModelSet::compared`]): longitudinal model in 20 s windows re-initialised from the
//!    measured state (open-loop drift never spans more than a window), axle model open loop.
//! 3. Noise floor ([`noise_floors`]): blind sensor-noise estimates from the recording's own
//!    native samples, propagated through the model by Monte-Carlo copies; the same copies
//!    give the engine speed's null variance on the clutch-actuated rows, which weights the
//!    explain step's clutch-actuation view and is not located.
//! 4. Locate ([`super::locate::locate`]): windows in time, stretches in distance, bands,
//!    coherence, lags, operating-condition cells; Holm-corrected at α = 0.01 with a practical
//!    1.5× rule. Then the shuffle modes after clutch engagements ([`super::modal`]): when their
//!    drive-level test flags (its own test at α = 0.01 with a 3 % margin), one more engine-speed
//!    mismatch stretch, and the mismatch counts as significant. Then the two tests on the
//!    recorded channels alone ([`speed_consistency`]; [`resistance_stretch`], on the slope
//!    reconstructed between the sensor's steps): a flagged one adds a located stretch, which
//!    no estimate within the tolerances explains.
//! 5. Explain ([`explain`]) with the noise floors as the signal weights, and with the slope
//!    sensor's offset measured against the altitude where the log records one
//!    ([`altitude_offset`]) and the torque channel's offset measured on the free engine where
//!    the log has one ([`idle_torque_offset`]); the verdict ([`verdict`]) from the findings
//!    and step 4's significance.
//! 6. Show (`report::diagnosis_files::write_outputs`, a layer above this module):
//!    `diagnosis.json`, `mismatch.parquet`, `findings.parquet`,
//!    `report.md` with one residual SVG per compared signal (before: nominal; after: with the
//!    accepted findings), and `detail.json` with everything the steps computed (window tests,
//!    band powers, coherence, lags, condition cells, statements, every greedy round's screen
//!    and fits) for an engineer who wants to check a verdict.

use super::altitude_offset::{altitude_offset, AltitudeOutcome};
use super::explain::{
    explain, verdict, ExplainConfig, Explanation, Measured, ParameterEstimate, Verdict,
};
use super::extended::{window_starts, ExtendedError, LongitudinalConfig, Theta};
use super::fit::fit_spec;
use super::idle_torque::{idle_torque_offset, IdleTorqueOutcome};
use super::locate::{
    locate_inputs, recorded_inputs, shuffle_band_hz, LocateConfig, LocateError, Location,
};
use super::long_drive::{is_long, map_in_order, release_between_steps};
use super::modal::{compare_modes, tolerance_shift, ModalComparison, ModalConfig, Reference};
use super::noise::{noise_floors, ModelSet, NoiseConfig, NoiseError, NoiseFloors};
use super::parameter_table::{EstimateMethod, ParameterRow};
use super::problem::{ExplainError, Problem};
use super::resistance_stretch::{
    resistance_stretch, ResistanceStretch, SlopeReading, StretchConfig,
};
use super::row_column::RowColumn;
use super::setup::Setup;
use super::slope_grid::SlopeGrid;
use super::speed_consistency::{speed_consistency, ConsistencyConfig, SpeedConsistency};
use super::tyre_slip::{self, tyre_slip_variance};
use crate::diagnose::compare::{share_storage, Comparison, Conditions};
use crate::diagnose::rows::ACTUATION_CHANNEL;
use crate::model::catalogue::Effect;
use crate::model::resonance::{vehicle_speed_at, OPERATING_ENGINE_SPEED_RAD_S};
use crate::model::tolerance::Tolerances;
use crate::model::vehicle::VehicleFile;
use crate::table::DriveLog;
use serde::Serialize;
use std::collections::BTreeMap;

use thiserror::Error;

/// Why a recording could not be diagnosed.
#[derive(Debug, Error)]
pub enum DiagnoseError {
    /// Neither model applies, or a model cannot be bound to the recording.
    #[error(transparent)]
    Setup(#[from] ExtendedError),
    /// The noise floor could not be estimated.
    #[error(transparent)]
    Noise(#[from] NoiseError),
    /// The locate step failed.
    #[error(transparent)]
    Locate(#[from] LocateError),
    /// The explain step failed.
    #[error(transparent)]
    Explain(#[from] ExplainError),
}

/// Per compared signal and row, the variance of the model's output that the vehicle file's
/// tolerances allow: every continuous catalogue parameter of a model in use moved alone to the
/// upper edge of its band `θ₀ + w` (the lower edge where the upper one leaves the fit's
/// physical domain), the output change `Δy` read as the sensitivity across the band, and
/// `Σ Δy²/3` — the variance of a parameter spread uniformly over `θ₀ ± w`, to first order,
/// the parameters independent. A residual this size is what a truck whose values all lie in
/// their bands shows against the nominal model; locate tests the residual against the sensor
/// noise floor plus this (docs/diagnosis/method.md, "Model-form residual"). Made for the
/// channels named in `signals` alone (those the location tests; the events and clutch-actuation
/// channels are not located).
///
/// # Errors
/// [`ExtendedError`] when a model fails at the nominal parameters or at a band's edge.
pub fn tolerance_variance(
    problem: &Problem<'_>,
    tolerances: &Tolerances,
    signals: &[&str],
) -> Result<BTreeMap<String, Vec<f64>>, ExtendedError> {
    let nominal = *problem.nominal();
    let mut out: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for domain in problem.domains() {
        let idx = problem.channel_indices(domain);
        let base = problem.nominal_of(domain);
        let edges: Vec<(Effect, f64)> = Effect::ALL
            .into_iter()
            .filter(|e| e.domain() == domain)
            .filter_map(|e| {
                let nom = nominal.get(e);
                let spec = fit_spec(e, nom, None);
                let w = tolerances.of_effect(e).half_width(nom);
                if spec.switch || w.is_nan() || w <= 0.0 {
                    return None;
                }
                if nom + w <= spec.hi {
                    Some((e, nom + w))
                } else if nom - w >= spec.lo {
                    Some((e, nom - w))
                } else {
                    None
                }
            })
            .collect();
        // the edges' simulations a thread's worth at a time (one at a time on a long drive,
        // each parallel inside: super::long_drive), added in edge order: the same sums
        // whatever the thread count, and never every edge's simulation held at once
        let wanted: Vec<bool> = idx
            .iter()
            .map(|&c| signals.contains(&problem.channels()[c].name.as_str()))
            .collect();
        if !wanted.contains(&true) {
            continue;
        }
        let mut vars: Vec<Vec<f64>> = base
            .iter()
            .zip(&wanted)
            .map(|(b, &w)| if w { vec![0.0; b.len()] } else { Vec::new() })
            .collect();
        let long = is_long(problem.times().len());
        let at_once = if long {
            1
        } else {
            rayon::current_num_threads().max(1)
        };
        for chunk in edges.chunks(at_once) {
            let moved = map_in_order(long, chunk, |&(e, v)| {
                let mut theta = nominal;
                theta.set(e, v);
                problem.simulate(domain, &theta)
            });
            for m in moved {
                let m = m?;
                for (k, var) in vars.iter_mut().enumerate() {
                    if !wanted[k] {
                        continue;
                    }
                    let add =
                        |v: &mut f64, d: f64| *v += if d.is_finite() { d * d / 3.0 } else { 0.0 };
                    match (m[k].sparse_parts(), base[k].sparse_parts()) {
                        // an events view: no change off its rows (equal fills) adds nothing
                        (Some((ra, va, fa)), Some((rb, vb, fb))) if ra == rb && fa == fb => {
                            for ((&i, a), b) in ra.iter().zip(va).zip(vb) {
                                add(&mut var[i], a - b);
                            }
                        }
                        _ => {
                            for (i, v) in var.iter_mut().enumerate() {
                                add(v, m[k][i] - base[k][i]);
                            }
                        }
                    }
                }
            }
        }
        for ((&c, var), w) in idx.iter().zip(vars).zip(wanted) {
            if w {
                out.insert(problem.channels()[c].name.clone(), var);
            }
        }
    }
    Ok(out)
}

/// Gears whose shuffle mode sets the modal test's tolerance margin ([`tolerance_shift`]): the
/// low gears, where clutch engagements ring.
pub const MODAL_TOLERANCE_GEARS: usize = 4;

/// Settings of a diagnosis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DiagnoseConfig {
    /// Noise-floor estimation.
    pub noise: NoiseConfig,
    /// Locate settings; the shuffle band and gear ratios are filled in from the vehicle.
    pub locate: LocateConfig,
    /// Most findings.
    pub max_findings: usize,
    /// The speed channels' consistency test.
    pub consistency: ConsistencyConfig,
    /// The force balance's stretch scan.
    pub stretch: StretchConfig,
}

impl Default for DiagnoseConfig {
    /// The steps' own defaults.
    fn default() -> Self {
        Self {
            noise: NoiseConfig::default(),
            locate: LocateConfig::default(),
            max_findings: ExplainConfig::default().max_findings,
            consistency: ConsistencyConfig::default(),
            stretch: StretchConfig::default(),
        }
    }
}

/// One compared signal's residual before and after, on the recording's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Residual {
    /// Canonical column.
    pub signal: String,
    /// Nominal model: measured − simulated (NaN where the row does not count).
    pub before: Vec<f64>,
    /// With the accepted findings.
    pub after: Vec<f64>,
}

/// Everything a diagnosis produced.
#[derive(Debug, Clone)]
pub struct Diagnosed {
    /// The recording's drive id.
    pub drive_id: String,
    /// The verdict of step 5 ([`verdict`]).
    pub verdict: Verdict,
    /// Step 3, without the null copies, the per-row null variances and the sensors' sample
    /// records ([`NoiseFloors::release_samples`]: steps 3 and 4 read them).
    pub floors: NoiseFloors,
    /// Step 4.
    pub location: Location,
    /// Step 5.
    pub explanation: Explanation,
    /// Times of the rows, s from the first.
    pub t_s: Vec<f64>,
    /// Per compared signal.
    pub residuals: Vec<Residual>,
    /// Models used and why others were not.
    pub models: ModelsUsed,
    /// Shuffle modes per clutch engagement (`None` without an engine-speed comparison).
    pub modal: Option<ModalComparison>,
    /// The speed channels against each other (`None` without the channels or enough usable
    /// windows).
    pub speed_consistency: Option<SpeedConsistency>,
    /// The force balance's stretch scan (`None` without the channels or enough road).
    pub resistance_stretch: Option<ResistanceStretch>,
    /// The slope sensor's offset measured against the recorded altitude, or why not
    /// ([`super::altitude_offset`]).
    pub altitude_offset: AltitudeOutcome,
    /// The torque channel's offset measured on the free engine, or why not
    /// ([`super::idle_torque`]).
    pub idle_torque: IdleTorqueOutcome,
    /// Every catalogue parameter the drive informs ([`super::parameter_table`]).
    pub parameters: Vec<ParameterRow>,
    /// Per-row null variance of the engine speed on the clutch-actuated rows (rad²/s², NaN
    /// where a row does not count; `None` without the longitudinal model): the weights of
    /// the explain step's clutch-actuation view ([`super::problem::Problem::with_actuation`]).
    pub actuation_variance: Option<Vec<f64>>,
}

/// Which models the diagnosis used.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelsUsed {
    /// The longitudinal / driveline model ran.
    pub longitudinal: bool,
    /// Why it did not.
    pub longitudinal_reason: Option<String>,
    /// The axle model ran.
    pub axle: bool,
    /// Why it did not.
    pub axle_reason: Option<String>,
    /// Slope-sensor resolution read from the recording, tan α per step.
    pub slope_resolution: f64,
}

/// Columns of the canonical log that neither the diagnosis nor its outputs read: the GNSS
/// position (the altitude is read: [`super::altitude_offset`]). A caller that owns a long
/// drive's log may drop them before diagnosing it (the `diagnose` command does); the diagnosis
/// is the same, bit for bit.
pub const UNREAD_COLUMNS: [&str; 2] = ["latitude", "longitude"];

/// Diagnoses `log` against the nominal `vehicle` (module documentation).
///
/// # Errors
/// [`DiagnoseError`] from the step that failed.
pub fn diagnose(
    log: &DriveLog,
    vehicle: &VehicleFile,
    cfg: &DiagnoseConfig,
) -> Result<Diagnosed, DiagnoseError> {
    // between steps, a long drive's freed columns go back to the operating system
    // (super::long_drive)
    let release = || release_between_steps(log.len());
    let setup = Setup::new(log, vehicle)?;
    let models = ModelSet {
        actuation: true,
        ..ModelSet::for_log(log, &setup.nominal_truth, &setup.ratios, setup.nominal)
    };
    let mut floors = noise_floors(log, &models, &setup.nominal, &cfg.noise)?;
    // the sensors' sample records serve the noise floor's draws alone
    floors.release_sensor_samples();
    release();
    // the clutch-actuated engine speed is not located: its floor only weights the explain
    // step's clutch-actuation view
    let actuation_variance = floors
        .floors
        .iter()
        .position(|f| f.signal == ACTUATION_CHANNEL)
        .map(|k| floors.floors.remove(k).null_variance);
    let lcfg = LocateConfig {
        shuffle_band_hz: shuffle_band_hz(&setup.nominal_truth.driveline, &setup.ratios),
        gear_ratios: setup.ratios.clone(),
        reinit_times_s: window_starts(log, LongitudinalConfig::default().window_s),
        ..cfg.locate.clone()
    };
    let problem = setup.problem(log, actuation_variance.as_deref())?;
    // residual the vehicle file's tolerances allow is not a mismatch: its variance joins the
    // floor's per-row null variance
    let located: Vec<&str> = floors.floors.iter().map(|f| f.signal.as_str()).collect();
    let mut allowed = tolerance_variance(&problem, &vehicle.tolerance, &located)?;
    if let Some(slip) = tyre_slip_variance(log, &setup.nominal_truth.driveline, &setup.ratios) {
        let v = allowed
            .entry("engine_speed".to_string())
            .or_insert_with(|| vec![0.0; slip.len()]);
        for (a, s) in v.iter_mut().zip(&slip) {
            *a += s;
        }
    }
    for f in floors.floors.iter_mut() {
        if let Some(v) = allowed.get(&f.signal) {
            for (n, a) in f.null_variance.iter_mut().zip(v) {
                if n.is_finite() && a.is_finite() {
                    *n += a;
                }
            }
        }
    }
    drop(allowed);
    release();
    // the recording against the nominal models, made where locate first reads it (on a long
    // drive, not held through the tolerance edges' simulations)
    let mut signals = models.compared(log, &setup.nominal)?;
    signals.retain(|c| c.name != ACTUATION_CHANNEL);
    // the problem holds the same speeds and nominal simulation: one storage for both
    let pool: Vec<_> = problem
        .channels()
        .iter()
        .map(|c| &c.measured)
        .chain(problem.nominal_outputs().iter().flatten())
        .filter_map(RowColumn::dense_storage)
        .collect();
    share_storage(&mut signals, &pool);
    release();
    let mut cmp = Comparison {
        signals,
        conditions: Conditions::from_log(log),
    };
    let mut location = locate_inputs(&cmp, &floors, &recorded_inputs(log), &lcfg)?;
    // the null copies and the per-row null variances serve the location's tests alone
    floors.release_samples();
    release();
    // the shuffle modes after clutch engagements against the nominal driveline's linearised ones
    // (docs/models/driveline.md: the simulated ringing is restarted inside the analysis windows); a
    // flagged drive is a located engine-speed mismatch
    let modal = cmp
        .signals
        .iter()
        .find(|c| c.name == "engine_speed")
        .map(|es| {
            // a shift the vehicle file's tolerances allow is not a mismatch
            let d = &setup.nominal_truth.driveline;
            let allowed = (1..=setup.ratios.len().min(MODAL_TOLERANCE_GEARS))
                .map(|g| {
                    let v0 = vehicle_speed_at(d, &setup.ratios, g, OPERATING_ENGINE_SPEED_RAD_S);
                    tolerance_shift(
                        d,
                        &setup.ratios,
                        g,
                        v0,
                        problem.tyre_share(),
                        &vehicle.tolerance,
                    )
                })
                .fold(0.0, f64::max);
            let mut mcfg = ModalConfig::default();
            mcfg.min_relative_shift = mcfg.min_relative_shift.max(allowed);
            let m = compare_modes(
                log,
                &es.measured,
                &es.simulated,
                Some((
                    &setup.nominal_truth.driveline,
                    &setup.ratios,
                    problem.tyre_share(),
                )),
                Reference::Linearised,
                &mcfg,
            );
            let c = &cmp.conditions;
            if let Some(mm) = m.mismatch(&mcfg, &c.t_s, &c.distance_m, &es.measured, &es.simulated)
            {
                location.mismatch.push(mm);
                location.any_significant = true;
            }
            m
        });
    // two tests on the recorded channels alone, with the longitudinal model's vehicle: the
    // wheel-based speed against the engine speed through the gear, and the force balance's
    // stretch scan; a flagged one is a located mismatch
    let cond = &cmp.conditions;
    let driveline = &setup.nominal_truth.driveline;
    // the slope reconstructed between the sensor's steps: what the force balance and the
    // altitude measurement read
    let grade = (setup.slope_resolution > 0.0)
        .then(|| SlopeGrid::new(log).and_then(|g| g.cured(setup.slope_resolution)))
        .flatten();
    let (consistency, stretch) = if setup.longitudinal {
        // the longitudinal model's own fit; estimated here only when the explain step left
        // that model out
        let slip = problem
            .slip()
            .unwrap_or_else(|| tyre_slip::estimate(log, driveline, &setup.ratios));
        (
            speed_consistency(
                log,
                &cond.t_s,
                driveline,
                &setup.ratios,
                &slip,
                &cfg.consistency,
            ),
            resistance_stretch(
                log,
                &cond.t_s,
                &cond.distance_m,
                driveline,
                &setup.ratios,
                SlopeReading {
                    resolution: setup.slope_resolution,
                    grade: grade.as_deref(),
                },
                &cfg.stretch,
            ),
        )
    } else {
        (None, None)
    };
    let located = [
        consistency
            .as_ref()
            .and_then(|s| s.mismatch(&cond.t_s, &cond.distance_m)),
        stretch
            .as_ref()
            .and_then(|s| s.mismatch(&cond.t_s, &cond.distance_m)),
    ];
    let channel_mismatch = located.iter().any(Option::is_some);
    for m in located.into_iter().flatten() {
        location.mismatch.push(m);
        location.any_significant = true;
    }
    // past the location, the comparison is read for the residuals before and the rows' times
    // alone: made now, the rest dropped before the explain step's simulations
    let before: Vec<(String, Vec<f64>)> = std::mem::take(&mut cmp.signals)
        .into_iter()
        .map(|c| {
            let r = c.residual();
            (c.name, r)
        })
        .collect();
    let t_s = std::mem::take(&mut cmp.conditions.t_s);
    drop(cmp);
    release();
    // the slope sensor's offset against the altitude, when the log records one
    let altitude = altitude_offset(log, grade.as_deref());
    drop(grade);
    // the torque channel's offset on the free engine, when the log has one
    let idle = idle_torque_offset(log, setup.nominal_truth.driveline.j_e_kg_m2);
    let measured = altitude
        .measured()
        .map(|a| Measured {
            effect: Effect::GradeOffset,
            estimate: ParameterEstimate {
                value: a.value_rad,
                ci_low: a.ci_low_rad,
                ci_high: a.ci_high_rad,
                unit: Effect::GradeOffset.unit(),
            },
            source: "altitude",
        })
        .into_iter()
        .chain(idle.measured().map(|m| Measured {
            effect: Effect::EngineTorqueOffset,
            estimate: ParameterEstimate {
                value: m.value_nm,
                ci_low: m.ci_low_nm,
                ci_high: m.ci_high_nm,
                unit: Effect::EngineTorqueOffset.unit(),
            },
            source: "free engine",
        }))
        .collect();
    let explanation = explain(
        &problem,
        &ExplainConfig {
            noise_floor: Some(floors.summary()),
            max_findings: cfg.max_findings,
            tolerances: vehicle.tolerance.clone(),
            measured,
        },
    )?;
    let v = verdict(
        &explanation.findings,
        &explanation.consistent,
        location.any_significant,
        channel_mismatch,
    );
    // residuals after: the extended models at the final parameters, per model in use
    let mut after: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for domain in problem.domains() {
        let idx = problem.channel_indices(domain);
        let sims = problem.simulate(domain, &explanation.theta)?;
        for (k, sim) in idx.iter().zip(sims) {
            let ch = &problem.channels()[*k];
            let r = ch
                .measured
                .values()
                .iter()
                .zip(sim.values().iter())
                .zip(&ch.valid)
                .map(|((m, s), ok)| if *ok { m - s } else { f64::NAN })
                .collect();
            after.insert(ch.name.clone(), r);
        }
    }
    let residuals = before
        .into_iter()
        .map(|(signal, before)| Residual {
            after: after
                .remove(&signal)
                .unwrap_or_else(|| vec![f64::NAN; before.len()]),
            signal,
            before,
        })
        .collect();
    let parameters = parameter_rows(&explanation, &setup.nominal, &vehicle.tolerance);
    Ok(Diagnosed {
        drive_id: log.meta.drive_id.clone(),
        verdict: v,
        parameters,
        floors,
        location,
        explanation,
        t_s,
        residuals,
        models: ModelsUsed {
            longitudinal: setup.longitudinal,
            longitudinal_reason: setup.longitudinal_reason.clone(),
            axle: setup.axle,
            axle_reason: setup.axle_reason.clone(),
            slope_resolution: setup.slope_resolution,
        },
        modal,
        speed_consistency: consistency,
        resistance_stretch: stretch,
        altitude_offset: altitude,
        idle_torque: idle,
        actuation_variance,
    })
}

/// The rows of `ex` in catalogue order: a finding's fit, else a fit (or a measurement) within
/// tolerance, else the linearised estimate; effects the drive does not inform have no row. `nominal` holds the
/// vehicle file's parameters, `tolerances` its bands.
pub fn parameter_rows(
    ex: &Explanation,
    nominal: &Theta,
    tolerances: &Tolerances,
) -> Vec<ParameterRow> {
    let mut rows = Vec::new();
    for e in Effect::ALL {
        let id = e.id();
        let nom = nominal.get(e);
        let (tolerance_low, tolerance_high) = tolerances.band(e, nom);
        let row = |method, value: f64, ci_low: f64, ci_high: f64, n_eff: f64| ParameterRow {
            effect: id,
            parameter: e.parameter(),
            unit: e.unit(),
            value,
            ci_low,
            ci_high,
            nominal: nom,
            tolerance_low,
            tolerance_high,
            method,
            n_eff,
        };
        let named = ex
            .findings
            .iter()
            .find(|f| f.effect == id)
            .and_then(|f| f.parameters.values().next());
        if let Some(p) = named {
            rows.push(row(
                EstimateMethod::Named,
                p.value,
                p.ci_low,
                p.ci_high,
                f64::NAN,
            ));
        } else if let Some(c) = ex.consistent.iter().find(|c| c.effect == id) {
            let p = &c.estimate;
            // a measured estimate is judged against the band it was judged by: the file's own
            let row = |method, value, ci_low, ci_high, n_eff| ParameterRow {
                tolerance_low: c.band_low,
                tolerance_high: c.band_high,
                ..row(method, value, ci_low, ci_high, n_eff)
            };
            rows.push(row(
                if c.measured_by.is_some() {
                    EstimateMethod::Measured
                } else {
                    EstimateMethod::Fitted
                },
                p.value,
                p.ci_low,
                p.ci_high,
                f64::NAN,
            ));
        } else if let Some(l) = ex.linearised.iter().find(|l| l.effect == id) {
            rows.push(row(
                EstimateMethod::Linearised,
                l.value,
                l.ci_low,
                l.ci_high,
                l.n_eff,
            ));
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::tyre_slip::{DRIVEN_LOAD_SHARE_MIN, SLIP_STIFFNESS_MIN};

    #[test]
    fn tyre_slip_variance_follows_the_traction_force_bound() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/vehicles/truck-40t.toml");
        let vf = VehicleFile::load(&path).unwrap();
        let p = vf.driveline.clone().unwrap();
        let r = vf.gearbox.ratios.clone();
        let log = DriveLog::from_columns(
            100_000_000,
            vec![
                (
                    "engine_torque",
                    "N.m",
                    vec![2000.0, -200.0, 2000.0, f64::NAN, 500.0],
                ),
                ("gear", "1", vec![12.0, 12.0, 0.0, 12.0, 1.0]),
                (
                    "engine_speed",
                    "rad/s",
                    vec![150.0, 150.0, 150.0, 150.0, 100.0],
                ),
            ],
        );
        let v = tyre_slip_variance(&log, &p, &r).unwrap();
        // κ_max = M_e i_t i_f / r_w / (8 · 0.25 m g); variance (ω_e κ_max)²/3
        let bound = |m_e: f64, i_t: f64, w: f64| {
            let f_x = m_e * i_t * p.final_drive_ratio / p.wheel_radius_m;
            let k = f_x.abs() / (SLIP_STIFFNESS_MIN * DRIVEN_LOAD_SHARE_MIN * p.mass_kg * 9.81);
            (w * k).powi(2) / 3.0
        };
        assert!((v[0] - bound(2000.0, 1.0, 150.0)).abs() < 1e-12 * v[0].max(1.0));
        // full load in top gear on the 40 t truck: a slip bound of about 1.6 %, 2.4 rad/s
        let kappa = (3.0 * v[0]).sqrt() / 150.0;
        assert!(kappa > 0.015 && kappa < 0.017, "{kappa}");
        // engine braking slips the other way, by its own magnitude
        assert!((v[1] - bound(-200.0, 1.0, 150.0)).abs() < 1e-12);
        // neutral and a missing torque allow nothing
        assert_eq!((v[2], v[3]), (0.0, 0.0));
        assert!((v[4] - bound(500.0, r[0], 100.0)).abs() < 1e-9 * v[4]);
    }
}
