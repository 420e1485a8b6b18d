//! The vehicle model extended by the effect catalogue's parameters: the vehicle file's
//! driveline and axle parameters plus the physics and sensor effects a nominal model leaves
//! out ([`crate::model::catalogue`]). Each catalogue effect has one parameter; setting it
//! ([`ExtendedVehicle::set`]) changes this model as follows:
//!
//! | id | what changes | parameter (unit) |
//! |---|---|---|
//! | `aero_drag` | drag area | `c_w_a_f_m2` (m²) |
//! | `rolling_resistance` | both rolling-resistance coefficients, same factor | `c_r1` (1) |
//! | `vehicle_mass` | payload on the chassis at its CG (driveline mass, chassis mass, scale weights) | `mass_kg` (kg) |
//! | `grade_offset` | slope sensor reads `tan(α + δ)` | `slope_offset_rad` (rad) |
//! | `slope_quantization` | slope sensor resolution | `slope_resolution` (1, tan α per step) |
//! | `signal_delay` | the engine-torque channel lags the truth | `engine_torque_delay_s` (s) |
//! | `driveline_backlash` | total drive-shaft play | `drive_shaft_lash_rad` (rad) |
//! | `driveline_compliance` | drive-shaft stiffness | `k_d_nm_per_rad` (N·m/rad) |
//! | `engine_torque_offset` | reported torque = delivered + offset | `engine_torque_offset_nm` (N·m) |
//! | `clutch_slip` | clutch capacity | `clutch_max_torque_nm` (N·m) |
//! | `bogie_torque_reaction` | [`AxleExtensions::torque_reaction`] | `torque_reaction_fraction` (1) |
//! | `load_transfer_height` | chassis CG height | `chassis_cg_height_m` (m) |
//! | `air_spring_nonlinearity` | [`AxleExtensions::bellow_progression_per_m`] | `bellow_progression_per_m` (1/m) |
//! | `cg_position` | sprung load moved rearwards by the shift (scale weights) | `chassis_cg_shift_m` (m) |
//! | `tyre_stiffness` | all tyre stiffnesses, same factor | `tyre_stiffness_factor` (1) |
//! | `grade_load_transfer` | [`AxleExtensions::grade_height_offset_m`] | `grade_height_offset_m` (m) |
//!
//! The diagnosis fits these parameters; the model-based generator of synthetic drives
//! ([`crate::synth::effects`]) hides them in its truth.

use crate::model::axle::{Axle, AxleExtensions, AxleParams};
use crate::model::catalogue::Effect;
use crate::model::driveline::DrivelineParams;
use thiserror::Error;

/// Why an effect's parameter could not be set.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ParameterError {
    /// A value outside the parameter's physical domain.
    #[error("effect {effect}: {parameter} = {value} must be {requirement}")]
    BadValue {
        /// Catalogue id.
        effect: &'static str,
        /// Parameter with unit.
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A vehicle without the part the effect changes.
    #[error("effect {effect} needs the vehicle's {part} section")]
    MissingPart {
        /// Catalogue id.
        effect: &'static str,
        /// `driveline` or `axles`.
        part: &'static str,
    },
}

/// Sensor-side effects: what the recorded channels add to the plant's true signals. All zero
/// (and no resolution override) is a faithful sensor set.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SensorFaults {
    /// Slope sensor mounting angle δ, rad: the sensor reads `tan(α + δ)`.
    pub slope_offset_rad: f64,
    /// Slope sensor resolution, tan α per step (`None`: the bus's own).
    pub slope_resolution: Option<f64>,
    /// Reported minus delivered engine torque, N·m.
    pub engine_torque_offset_nm: f64,
    /// Delay of the engine-torque channel, s.
    pub engine_torque_delay_s: f64,
}

/// The vehicle file's parameters extended by the catalogue's effect parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ExtendedVehicle {
    /// Driveline parameters.
    pub driveline: DrivelineParams,
    /// Axle parameters (if the vehicle has axles).
    pub axles: Option<AxleParams>,
    /// Total drive-shaft play, rad.
    pub lash_rad: f64,
    /// Axle-model extensions.
    pub axle_ext: AxleExtensions,
    /// Sensor effects.
    pub sensors: SensorFaults,
}

impl ExtendedVehicle {
    /// The vehicle file's model: the nominal parameters, no extension, no sensor effect.
    pub fn nominal(driveline: &DrivelineParams, axles: Option<&AxleParams>) -> Self {
        Self {
            driveline: driveline.clone(),
            axles: axles.cloned(),
            lash_rad: 0.0,
            axle_ext: AxleExtensions::default(),
            sensors: SensorFaults::default(),
        }
    }

    /// The value of `e`'s parameter in this model (for the vehicle file's model, its nominal
    /// value); `bus_slope_resolution` is the slope channel's resolution in tan α, which a
    /// vehicle file does not hold.
    ///
    /// # Errors
    /// [`ParameterError::MissingPart`] for an axle effect on a vehicle without axles.
    pub fn value_of(&self, e: Effect, bus_slope_resolution: f64) -> Result<f64, ParameterError> {
        use Effect::*;
        let d = &self.driveline;
        Ok(match e {
            AeroDrag => d.c_w_a_f_m2,
            RollingResistance => d.c_r1,
            VehicleMass => d.mass_kg,
            SlopeQuantization => bus_slope_resolution,
            DrivelineCompliance => d.k_d_nm_per_rad,
            ClutchSlip => d.clutch_max_torque_nm,
            LoadTransferHeight => self.axles(e)?.chassis_cg_height_m,
            TyreStiffness => {
                self.axles(e)?;
                1.0
            }
            GradeOffset | SignalDelay | DrivelineBacklash | EngineTorqueOffset => 0.0,
            BogieTorqueReaction | AirSpringNonlinearity | CgPosition | GradeLoadTransfer => {
                self.axles(e)?;
                0.0
            }
        })
    }

    fn axles(&self, e: Effect) -> Result<&AxleParams, ParameterError> {
        self.axles.as_ref().ok_or(ParameterError::MissingPart {
            effect: e.id(),
            part: "axles",
        })
    }

    /// Sets `e`'s parameter to `value` (see the module table).
    ///
    /// # Errors
    /// [`ParameterError::BadValue`] outside the parameter's physical domain;
    /// [`ParameterError::MissingPart`] for an axle effect on a vehicle without axles.
    pub fn set(&mut self, e: Effect, value: f64) -> Result<(), ParameterError> {
        use Effect::*;
        let bad = |requirement: &'static str| ParameterError::BadValue {
            effect: e.id(),
            parameter: e.parameter(),
            value,
            requirement,
        };
        if !value.is_finite() {
            return Err(bad("finite"));
        }
        let positive = |ok: bool| if ok { Ok(()) } else { Err(bad("> 0")) };
        let d = &mut self.driveline;
        match e {
            AeroDrag => {
                positive(value > 0.0)?;
                d.c_w_a_f_m2 = value;
            }
            RollingResistance => {
                positive(value > 0.0)?;
                let f = value / d.c_r1;
                d.c_r1 = value;
                d.c_r2_s_per_m *= f;
            }
            VehicleMass => {
                let dm = value - d.mass_kg;
                if let Some(a) = self.axles.as_mut() {
                    if a.chassis_mass_kg + dm <= 0.0 {
                        return Err(bad("more than the unsprung mass"));
                    }
                    // payload at the chassis CG: sprung scale loads grow in proportion
                    let f = (a.chassis_mass_kg + dm) / a.chassis_mass_kg;
                    a.chassis_mass_kg += dm;
                    for ax in Axle::ALL {
                        let m_a = a.axle_mass(ax);
                        let w = a.scale_weight(ax);
                        set_scale_weight(a, ax, m_a + (w - m_a) * f);
                    }
                }
                positive(value > 0.0)?;
                self.driveline.mass_kg = value;
            }
            GradeOffset => {
                if value.abs() >= 0.2 {
                    return Err(bad("a mounting angle below 0.2 rad"));
                }
                self.sensors.slope_offset_rad = value;
            }
            SlopeQuantization => {
                positive(value > 0.0)?;
                self.sensors.slope_resolution = Some(value);
            }
            SignalDelay => {
                if value < 0.0 {
                    return Err(bad(">= 0"));
                }
                self.sensors.engine_torque_delay_s = value;
            }
            DrivelineBacklash => {
                if value < 0.0 {
                    return Err(bad(">= 0"));
                }
                self.lash_rad = value;
            }
            DrivelineCompliance => {
                positive(value > 0.0)?;
                d.k_d_nm_per_rad = value;
            }
            EngineTorqueOffset => self.sensors.engine_torque_offset_nm = value,
            ClutchSlip => {
                positive(value > 0.0)?;
                d.clutch_max_torque_nm = value;
            }
            BogieTorqueReaction => {
                self.axles(e)?;
                if value.abs() > 1.0 {
                    return Err(bad("a fraction in [-1, 1]"));
                }
                self.axle_ext.torque_reaction = value;
            }
            LoadTransferHeight => {
                let a = self.axles.as_mut().ok_or(ParameterError::MissingPart {
                    effect: e.id(),
                    part: "axles",
                })?;
                if value <= 0.0 {
                    return Err(bad("> 0"));
                }
                a.chassis_cg_height_m = value;
            }
            AirSpringNonlinearity => {
                self.axles(e)?;
                if value < 0.0 {
                    return Err(bad(">= 0"));
                }
                self.axle_ext.bellow_progression_per_m = value;
            }
            CgPosition => {
                let a = self.axles.as_mut().ok_or(ParameterError::MissingPart {
                    effect: e.id(),
                    part: "axles",
                })?;
                shift_cg(a, value).map_err(|_| bad("a shift that leaves every axle loaded"))?;
            }
            TyreStiffness => {
                let a = self.axles.as_mut().ok_or(ParameterError::MissingPart {
                    effect: e.id(),
                    part: "axles",
                })?;
                positive(value > 0.0)?;
                a.tyre_stiffness_front_n_per_m *= value;
                a.tyre_stiffness_rear_n_per_m *= value;
                a.tyre_stiffness_tag_n_per_m *= value;
            }
            GradeLoadTransfer => {
                self.axles(e)?;
                self.axle_ext.grade_height_offset_m = value;
            }
        }
        Ok(())
    }
}

fn set_scale_weight(a: &mut AxleParams, ax: Axle, w: f64) {
    match ax {
        Axle::Front => a.scale_weight_front_kg = w,
        Axle::Rear => a.scale_weight_rear_kg = w,
        Axle::Tag => a.scale_weight_tag_kg = w,
    }
}

/// Moves the sprung load's CG rearwards by `dx` m (forwards for `dx < 0`): the front scale
/// weight falls by `Δ = m_c dx / x_b` and the bogie's rises by `Δ`, shared by rear and tag in
/// proportion to their sprung loads (`x_b` their load-weighted position), so the total and the
/// moment balance `Σ w_i x_i += m_c dx` hold.
fn shift_cg(a: &mut AxleParams, dx: f64) -> Result<(), ()> {
    let sprung = |a: &AxleParams, ax: Axle| a.scale_weight(ax) - a.axle_mass(ax);
    let (sr, st) = (sprung(a, Axle::Rear), sprung(a, Axle::Tag));
    let xb = (sr * a.axle_x(Axle::Rear) + st * a.axle_x(Axle::Tag)) / (sr + st);
    let delta = a.chassis_mass_kg * dx / xb;
    let wf = a.scale_weight(Axle::Front) - delta;
    let wr = a.scale_weight(Axle::Rear) + delta * sr / (sr + st);
    let wt = a.scale_weight(Axle::Tag) + delta * st / (sr + st);
    let ok = [(wf, Axle::Front), (wr, Axle::Rear), (wt, Axle::Tag)]
        .iter()
        .all(|&(w, ax)| w > a.axle_mass(ax));
    if !ok {
        return Err(());
    }
    set_scale_weight(a, Axle::Front, wf);
    set_scale_weight(a, Axle::Rear, wr);
    set_scale_weight(a, Axle::Tag, wt);
    Ok(())
}
