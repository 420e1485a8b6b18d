//! The axle-load model of one recording extended by the catalogue's axle effects, and by the
//! longitudinal ones that change its inputs or masses (docs/diagnosis/method.md, step 3;
//! [`super::extended`]). [`AxleModel::simulate`]: the three bellow pressures on the log's rows,
//! open loop from the steady state (the suspension is stable, nothing drifts).
//!
//! Pressures in Pa.
//!
//! # Step
//! The diagnosis integrates the half-truck with a step of at most [`AXLE_STEP_S`] = 10 ms (and
//! at most 0.5/ρ, [`crate::sim::axle`]) instead of the model's 2 ms: it simulates the whole
//! recording once per trial parameter set and once per noise copy, and the finer step buys
//! nothing it can see. On the bench's hour drive of the diesel 6x2 truck (50 Hz rows, 0.5/ρ =
//! 9.96 ms, so three steps of 6.7 ms per row) the three bellow pressures differ from the 2 ms
//! step's by at most 19.1 Pa (RMS 0.94 Pa): 2 % of the 1 kPa noise of a bellow-pressure sensor
//! and a fifth of its 0.1 kPa CAN resolution (`cargo bench --bench axle_step`). The difference
//! comes from the kinks of the inputs between rows and of the damper tables, so it grows about
//! linearly with the step (2.1 Pa at 1 ms). A test holds it to 50 Pa on the axle fixture drive.
//!
//! Where no damper changes segment over a row shorter than 2/ρ, the row is stepped exactly
//! ([`HalfTruck::with_segment_steps`]: the model is linear on one segment per damper and the
//! inputs are linear or held between rows); on the hour drive that is 72 % of the rows, at
//! most 18.1 Pa (RMS 0.78 Pa) from the 2 ms step, in half RK4's time (docs/models/axle.md).

use super::effect_parameters::Theta;
use super::extended_error::ExtendedError;
use super::kept::Kept;
use super::model_inputs::{corrected_columns, filled, INPUT_EFFECTS};
use super::slope_grid::{cured_slope, SlopeGrid};
use crate::model::axle::{AxleExtensions, AxleParams};
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::sim::axle::{AxleInputs, HalfTruck, Start};
use crate::sim::axle_recorded::{axle_inputs_from_log, AxleRecordConfig, InverseDynamicsParams};
use crate::table::{DriveLog, LogView};
use std::sync::{Arc, OnceLock};

/// Largest integration step of the diagnosis's axle simulations, s (module doc).
pub const AXLE_STEP_S: f64 = 0.01;

/// The axle-load model of one recording, extended by the catalogue's axle effects (and by the
/// longitudinal ones that change its inputs or masses).
#[derive(Debug)]
pub struct AxleModel<'a> {
    log: &'a DriveLog,
    nominal_truth: &'a ExtendedVehicle,
    ratios: &'a [f64],
    nominal: Theta,
    /// The recorded slope's grid, built when a cure first asks for it ([`cured_slope`]).
    slope_grid: OnceLock<Option<SlopeGrid>>,
    cfg: AxleRecordConfig,
    /// The simulation at the nominal parameters with what it was run on, made by the first
    /// simulation ([`Run`]); `None` when it failed.
    nominal_run: OnceLock<Option<Run>>,
    /// Other simulations kept for parameter sets that build the same model and inputs
    /// ([`Kept`]).
    kept: Kept<Run>,
}

/// A simulation of the axle model with everything it depends on: the half-truck's parameters
/// and extensions, its inputs and their time axis. The simulation is a function of these
/// alone, so a parameter set that builds the same ones (most longitudinal effects change
/// neither the axle model's masses nor its inputs) has the same pressures, taken from here
/// instead of simulated again; one that builds the same inputs for another model is simulated
/// on these inputs without building them.
#[derive(Debug, Clone)]
struct Run {
    params: AxleParams,
    ext: AxleExtensions,
    /// What the inputs are built from besides the recording ([`InputsFrom`]).
    from: InputsFrom,
    inputs: Arc<AxleInputs>,
    t_s: Arc<[f64]>,
    pressures: Arc<[Vec<f64>; 3]>,
}

impl Run {
    fn same_model(&self, tm: &ExtendedVehicle) -> bool {
        tm.axles.as_ref() == Some(&self.params) && tm.axle_ext == self.ext
    }
}

/// Everything [`AxleModel`]'s inputs are built from besides the recording, the gear ratios and
/// the record configuration (fixed per model): the parameters of the catalogue's input effects
/// ([`INPUT_EFFECTS`], the corrected columns and the cured slope), the half-truck's mass, wheel
/// radius and gravity, and the driveline's inverse-dynamics parameters. Equal values build
/// equal inputs, so a parameter set with a kept run's takes that run's inputs without building
/// them.
#[derive(Debug, Clone, PartialEq)]
struct InputsFrom {
    input_effects: [f64; INPUT_EFFECTS.len()],
    mass_kg: f64,
    wheel_radius_m: f64,
    gravity_m_per_s2: f64,
    driveline: InverseDynamicsParams,
}

impl<'a> AxleModel<'a> {
    /// Binds a recording with bellow pressures and the nominal vehicle (with axles).
    ///
    /// # Errors
    /// [`ExtendedError::Missing`] for missing pressures or axles.
    pub fn new(
        log: &'a DriveLog,
        nominal_truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
    ) -> Result<Self, ExtendedError> {
        if nominal_truth.axles.is_none() {
            return Err(ExtendedError::Missing {
                file: log.meta.source_file.clone(),
                column: "[axles] of the vehicle file".into(),
            });
        }
        for c in [
            "bellow_pressure_front",
            "bellow_pressure_rear",
            "bellow_pressure_tag",
        ] {
            filled(log, c)?;
        }
        Ok(Self {
            log,
            nominal_truth,
            ratios,
            nominal,
            slope_grid: OnceLock::new(),
            cfg: AxleRecordConfig::default(),
            nominal_run: OnceLock::new(),
            kept: Kept::for_rows(log.len()),
        })
    }

    /// Simulated bellow pressures front, rear, tag on the log's rows, Pa.
    ///
    /// # Errors
    /// [`ExtendedError`] for parameters outside their domain or inputs that cannot be built.
    pub fn simulate(&self, theta: &Theta) -> Result<[Vec<f64>; 3], ExtendedError> {
        let nominal = self
            .nominal_run
            .get_or_init(|| self.nominal_simulation().ok());
        let (tm, from) = self.truth_at(theta)?;
        // a kept run of the same model on the same inputs, or the inputs of one
        let mut inputs_of = None;
        if let Some(n) = nominal.as_ref().filter(|n| n.from == from) {
            if n.same_model(&tm) {
                return Ok((*n.pressures).clone());
            }
            inputs_of = Some((n.inputs.clone(), n.t_s.clone()));
        }
        if let Some(p) = self
            .kept
            .find(|r| (r.from == from && r.same_model(&tm)).then(|| r.pressures.clone()))
        {
            return Ok((*p).clone());
        }
        if inputs_of.is_none() {
            inputs_of = self
                .kept
                .find(|r| (r.from == from).then(|| (r.inputs.clone(), r.t_s.clone())));
        }
        let (inputs, t_s) = match inputs_of {
            Some(it) => it,
            None => {
                let (inputs, t_s) = self.inputs(theta, &tm)?;
                if let Some(n) = nominal
                    .as_ref()
                    .filter(|n| n.same_model(&tm) && *n.inputs == inputs && n.t_s == t_s)
                {
                    return Ok((*n.pressures).clone());
                }
                (Arc::new(inputs), t_s)
            }
        };
        let pressures = self.simulate_on(&tm, &inputs, &t_s);
        if self.kept.keeps() {
            self.kept.keep(Run {
                params: tm.axles.clone().expect("checked in new"),
                ext: tm.axle_ext,
                from,
                inputs,
                t_s,
                pressures: Arc::new(pressures.clone()),
            });
        }
        Ok(pressures)
    }

    /// The simulation at the nominal parameters with what it was run on.
    fn nominal_simulation(&self) -> Result<Run, ExtendedError> {
        let (tm, from) = self.truth_at(&self.nominal)?;
        let (inputs, t_s) = self.inputs(&self.nominal, &tm)?;
        let pressures = self.simulate_on(&tm, &inputs, &t_s);
        Ok(Run {
            params: tm.axles.clone().expect("checked in new"),
            ext: tm.axle_ext,
            from,
            inputs: Arc::new(inputs),
            t_s,
            pressures: Arc::new(pressures),
        })
    }

    /// The vehicle at `theta` (the input effects aside, which correct the recording instead)
    /// and what its inputs are built from.
    fn truth_at(&self, theta: &Theta) -> Result<(ExtendedVehicle, InputsFrom), ExtendedError> {
        let mut tm = self.nominal_truth.clone();
        for e in theta.changed(&self.nominal) {
            if INPUT_EFFECTS.contains(&e) {
                continue;
            }
            tm.set(e, theta.get(e))?;
        }
        let a: &AxleParams = tm.axles.as_ref().expect("checked in new");
        let from = InputsFrom {
            input_effects: INPUT_EFFECTS.map(|e| theta.get(e)),
            mass_kg: a.mass_kg(),
            wheel_radius_m: a.wheel_radius_m,
            gravity_m_per_s2: a.gravity_m_per_s2,
            driveline: InverseDynamicsParams::from(&tm.driveline),
        };
        Ok((tm, from))
    }

    /// The inputs at `theta` for the vehicle `tm`, and their time axis.
    fn inputs(
        &self,
        theta: &Theta,
        tm: &ExtendedVehicle,
    ) -> Result<(AxleInputs, Arc<[f64]>), ExtendedError> {
        let a: &AxleParams = tm.axles.as_ref().expect("checked in new");
        let d = &tm.driveline;
        let cured = cured_slope(self.log, &self.slope_grid, theta, &self.nominal);
        // the corrected columns alone, read over the recording
        let replaced = corrected_columns(self.log, theta, cured.as_deref(), None);
        let rec = axle_inputs_from_log(
            LogView {
                log: self.log,
                replaced: &replaced,
            },
            a.mass_kg(),
            a.wheel_radius_m,
            a.gravity_m_per_s2,
            self.ratios,
            Some(d.final_drive_ratio),
            Some(d),
            None,
            &self.cfg,
        )?;
        Ok((rec.inputs, rec.t_s))
    }

    /// The three bellow pressures of the vehicle `tm` on `inputs`.
    fn simulate_on(&self, tm: &ExtendedVehicle, inputs: &AxleInputs, t_s: &[f64]) -> [Vec<f64>; 3] {
        HalfTruck::new(tm.axles.as_ref().expect("checked in new"))
            .with_max_step(AXLE_STEP_S)
            .with_segment_steps()
            .with_extensions(tm.axle_ext)
            .simulate_pressures(inputs, t_s, Start::Steady)
    }
}
