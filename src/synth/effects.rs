//! Concealable effects (issue 5 point 5): the physics of the diagnosis catalogue
//! (`diagnosis.md`), injected into the *truth* of a synthetic drive — never into the nominal
//! vehicle file written next to it — with a magnitude, and recorded in a separate answer file.
//!
//! # What an injection changes
//! Each [`Effect`] has one parameter ([`Effect::parameter`], SI unit [`Effect::unit`]) whose
//! nominal value is the vehicle file's (or the effect's "absent" value) and whose truth value is
//! the injection's. Where the truth differs from the nominal vehicle:
//!
//! | id | truth | parameter (unit) |
//! |---|---|---|
//! | `aero_drag` | drag area | `c_w_a_f_m2` (m²) |
//! | `rolling_resistance` | both rolling-resistance coefficients, same factor | `c_r1` (1) |
//! | `vehicle_mass` | payload on the chassis at its CG (driveline mass, chassis mass, scale weights) | `mass_kg` (kg) |
//! | `grade_offset` | slope sensor reads `tan(α + δ)` | `slope_offset_rad` (rad) |
//! | `slope_quantization` | slope sensor resolution | `slope_resolution` (1, tan α per step) |
//! | `signal_delay` | the engine-torque channel lags the truth | `engine_torque_delay_s` (s) |
//! | `driveline_backlash` | total drive-shaft play ([`FastDriveline::with_lash`]) | `drive_shaft_lash_rad` (rad) |
//! | `driveline_compliance` | drive-shaft stiffness | `k_d_nm_per_rad` (N·m/rad) |
//! | `engine_torque_offset` | reported torque = delivered + offset | `engine_torque_offset_nm` (N·m) |
//! | `clutch_slip` | clutch capacity (the AMT still commands the nominal clutch map) | `clutch_max_torque_nm` (N·m) |
//! | `bogie_torque_reaction` | [`AxleExtensions::torque_reaction`] | `torque_reaction_fraction` (1) |
//! | `load_transfer_height` | chassis CG height | `chassis_cg_height_m` (m) |
//! | `air_spring_nonlinearity` | [`AxleExtensions::bellow_progression_per_m`] | `bellow_progression_per_m` (1/m) |
//! | `cg_position` | sprung load moved rearwards by the shift (scale weights) | `chassis_cg_shift_m` (m) |
//! | `tyre_stiffness` | all tyre stiffnesses, same factor | `tyre_stiffness_factor` (1) |
//! | `grade_load_transfer` | [`AxleExtensions::grade_height_offset_m`] | `grade_height_offset_m` (m) |
//!
//! The driver and the AMT keep the nominal vehicle (they are controllers with the fleet's
//! beliefs); only the plant and the sensors change.
//!
//! # Magnitudes
//! A drawn magnitude comes from [`Effect::range`]: a relative change `±U(lo, hi)` of the nominal
//! value, or an absolute value `±U(lo, hi)` (sign random where both signs are physical). The
//! ranges are what a fleet meets: drag areas and rolling resistance off by 15–40 % / 20–50 %
//! (body, tyres, trailers), payloads off by 8–25 %, sensor mounting angles of 0.3–1.1°, CAN
//! delays of 0.1–0.4 s, 0.9–2.9° of drive-shaft play, worn clutches at 60–80 % of their
//! capacity, CG heights off by 0.15–0.4 m, bellow progressions of 2–6 1/m (the gas law's
//! `(n + 1) k_b / (2 n B_0)` is 3.5–7.5 1/m for the seed 002 truck's bellows, n = 1–1.4). The draw uses its own PRNG stream
//! (`seed ^ EFFECT_STREAM`), so a drive with an effect and the drive without it share road,
//! driver and sensor noise.
//!
//! [`FastDriveline::with_lash`]: crate::sim::fast::FastDriveline::with_lash

use super::can::{CanBus, Truth};
pub use crate::diagnose::catalogue::{Domain, Effect};
use crate::io::AtomicFile;
use crate::model::axle::{Axle, AxleParams};
use crate::model::driveline::DrivelineParams;
use crate::road::rng::Xoshiro256StarStar;
use crate::sim::axle::AxleExtensions;
use serde::Serialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why an effect could not be injected.
#[derive(Debug, Error)]
pub enum EffectError {
    /// An identifier that is not in the catalogue.
    #[error("unknown effect `{id}`; the catalogue has: {known}")]
    Unknown {
        /// The identifier given.
        id: String,
        /// The catalogue's identifiers, comma separated.
        known: String,
    },
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
    /// The answer file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// How a magnitude is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Range {
    /// `truth = nominal · (1 + s·U(lo, hi))`, `s = ±1` at random (or −1 only with `down_only`).
    Relative {
        /// Smallest relative change.
        lo: f64,
        /// Largest relative change.
        hi: f64,
        /// Only decreases are physical.
        down_only: bool,
    },
    /// `truth = s·U(lo, hi)` (`s = ±1` at random when `signed`, else +1), the nominal being 0.
    Absolute {
        /// Smallest magnitude.
        lo: f64,
        /// Largest magnitude.
        hi: f64,
        /// Both signs physical.
        signed: bool,
    },
    /// `truth = nominal + s·U(lo, hi)` (`s = ±1` at random).
    Additive {
        /// Smallest change.
        lo: f64,
        /// Largest change.
        hi: f64,
    },
    /// `truth = U(lo, hi)` regardless of the nominal value.
    Set {
        /// Smallest value.
        lo: f64,
        /// Largest value.
        hi: f64,
    },
}

// Magnitudes of the catalogue's effects for the generator (the catalogue itself is
// crate::diagnose::catalogue).
impl Effect {
    /// Magnitude range of a drawn injection (see the module documentation).
    pub fn range(self) -> Range {
        use Effect::*;
        let rel = |lo, hi| Range::Relative {
            lo,
            hi,
            down_only: false,
        };
        let abs = |lo, hi, signed| Range::Absolute { lo, hi, signed };
        match self {
            AeroDrag => rel(0.15, 0.40),
            RollingResistance => rel(0.20, 0.50),
            VehicleMass => rel(0.08, 0.25),
            GradeOffset => abs(0.005, 0.02, true),
            SlopeQuantization => Range::Set { lo: 0.01, hi: 0.02 },
            SignalDelay => abs(0.1, 0.4, false),
            DrivelineBacklash => abs(0.015, 0.05, false),
            DrivelineCompliance => rel(0.25, 0.50),
            EngineTorqueOffset => abs(40.0, 150.0, true),
            ClutchSlip => Range::Relative {
                lo: 0.20,
                hi: 0.40,
                down_only: true,
            },
            BogieTorqueReaction => abs(0.2, 0.6, false),
            LoadTransferHeight => Range::Additive { lo: 0.15, hi: 0.40 },
            AirSpringNonlinearity => abs(2.0, 6.0, false),
            CgPosition => abs(0.10, 0.35, true),
            TyreStiffness => rel(0.20, 0.40),
            GradeLoadTransfer => abs(0.4, 1.0, true),
        }
    }

    /// A truth value drawn from [`Effect::range`] around `nominal`.
    pub fn draw(self, nominal: f64, rng: &mut Xoshiro256StarStar) -> f64 {
        let mut sign = |signed: bool| {
            let u = rng.next_f64();
            if signed && u < 0.5 {
                -1.0
            } else {
                1.0
            }
        };
        match self.range() {
            Range::Relative { lo, hi, down_only } => {
                let s = if down_only { -1.0 } else { sign(true) };
                nominal * (1.0 + s * rng.uniform(lo, hi))
            }
            Range::Absolute { lo, hi, signed } => {
                let s = sign(signed);
                s * rng.uniform(lo, hi)
            }
            Range::Additive { lo, hi } => {
                let s = sign(true);
                nominal + s * rng.uniform(lo, hi)
            }
            Range::Set { lo, hi } => rng.uniform(lo, hi),
        }
    }
}

/// Sensor-side faults of the truth: applied to the truth signals and the CAN bus before
/// sampling. All zero (and no resolution override) is a faithful sensor set.
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

impl SensorFaults {
    /// Applies the signal faults (slope offset, torque offset) to the truth's columns
    /// `road_slope` and `engine_torque` (absent columns are left alone).
    pub fn apply_to_truth(&self, truth: &mut Truth) {
        for (name, values) in truth.columns.iter_mut() {
            match name.as_str() {
                "road_slope" if self.slope_offset_rad != 0.0 => {
                    for v in values.iter_mut() {
                        *v = (v.atan() + self.slope_offset_rad).tan();
                    }
                }
                "engine_torque" if self.engine_torque_offset_nm != 0.0 => {
                    for v in values.iter_mut() {
                        *v += self.engine_torque_offset_nm;
                    }
                }
                _ => {}
            }
        }
    }

    /// Applies the channel faults (slope resolution, torque delay) to the bus's
    /// `road_slope` and `engine_torque` channels. The slope resolution is converted to the
    /// channel's wire unit (`%` → ×100).
    pub fn apply_to_bus(&self, bus: &mut CanBus) {
        for c in bus.messages.iter_mut().flat_map(|m| m.channels.iter_mut()) {
            match c.column.as_str() {
                "road_slope" => {
                    if let Some(r) = self.slope_resolution {
                        c.resolution = if c.wire_unit == "%" { 100.0 * r } else { r };
                    }
                }
                "engine_torque" => c.delay_s += self.engine_torque_delay_s,
                _ => {}
            }
        }
    }
}

/// The truth model of a synthetic drive: the plant's parameters and the sensors' faults.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthModel {
    /// Driveline parameters of the plant.
    pub driveline: DrivelineParams,
    /// Axle parameters of the plant (if the vehicle has axles).
    pub axles: Option<AxleParams>,
    /// Total drive-shaft play, rad.
    pub lash_rad: f64,
    /// Axle-model extensions.
    pub axle_ext: AxleExtensions,
    /// Sensor faults.
    pub sensors: SensorFaults,
    /// Out-of-catalogue extra rolling resistance on a stretch of road.
    pub stretch: Option<ResistanceStretch>,
}

/// One injected effect with its parameter's nominal and truth values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Injection {
    /// The effect.
    pub effect: Effect,
    /// The parameter's value in the nominal vehicle (or its "absent" value).
    pub nominal: f64,
    /// The parameter's value in the truth.
    pub truth: f64,
}

/// Stream constant xored into the drive seed for the magnitude draw.
pub const EFFECT_STREAM: u64 = 0xE1FE_C7ED_5EED_0001;

/// Which effect a synthetic drive hides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EffectChoice {
    /// No effect (the answer file says so).
    None,
    /// One of the catalogue's effects or none, drawn by the seed (each of the 17 outcomes
    /// equally likely), with a drawn magnitude.
    Random,
    /// This effect, with the given truth value of its parameter or a drawn one.
    Given(Effect, Option<f64>),
    /// An effect outside the catalogue: rolling resistance that rises on one stretch of road
    /// only (wet or broken surface), [`ResistanceStretch`], drawn by the seed. The diagnosis must
    /// not explain it with a catalogue effect.
    LocalRollingResistance,
}

/// Identifier of the out-of-catalogue effect [`EffectChoice::LocalRollingResistance`].
pub const LOCAL_ROLLING_RESISTANCE: &str = "local_rolling_resistance";

/// Extra rolling resistance on one stretch of road: `ΔF = Δc_r m g cos α` against the motion
/// while the truck is between `start_m` and `end_m` (travelled distance).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ResistanceStretch {
    /// Start, m.
    pub start_m: f64,
    /// End, m.
    pub end_m: f64,
    /// Extra rolling-resistance coefficient Δc_r (1).
    pub c_r_extra: f64,
}

impl ResistanceStretch {
    /// A stretch of a road of `length_m` drawn with `seed` (its own stream): it starts in the
    /// 20–60 % part of the road, is 15–30 % of the road long, and adds 1–2 times the vehicle's
    /// `c_r1` (a wet or broken surface).
    pub fn draw(length_m: f64, c_r1: f64, seed: u64) -> Self {
        let mut rng = Xoshiro256StarStar::seed_from_u64(seed ^ EFFECT_STREAM ^ 0x5AFE);
        let start = rng.uniform(0.2, 0.6) * length_m;
        let len = rng.uniform(0.15, 0.30) * length_m;
        Self {
            start_m: start,
            end_m: (start + len).min(length_m),
            c_r_extra: rng.uniform(1.0, 2.0) * c_r1,
        }
    }

    /// The extra force against the motion at travelled distance `x_m`, N.
    pub fn force_n(&self, x_m: f64, mass_kg: f64, g: f64, slope: f64) -> f64 {
        if x_m >= self.start_m && x_m < self.end_m {
            self.c_r_extra * mass_kg * g * slope.atan().cos()
        } else {
            0.0
        }
    }
}

impl EffectChoice {
    /// Parses `none`, `random`, `local_rolling_resistance`, `ID` or `ID=VALUE` (VALUE in the
    /// parameter's unit).
    ///
    /// # Errors
    /// [`EffectError::Unknown`] for an id outside the catalogue; [`EffectError::BadValue`] for a
    /// value that is not a number.
    pub fn parse(s: &str) -> Result<EffectChoice, EffectError> {
        match s {
            "none" => return Ok(EffectChoice::None),
            "random" => return Ok(EffectChoice::Random),
            LOCAL_ROLLING_RESISTANCE => return Ok(EffectChoice::LocalRollingResistance),
            _ => {}
        }
        let (id, value) = match s.split_once('=') {
            Some((i, v)) => (i, Some(v)),
            None => (s, None),
        };
        let e = Effect::from_id(id.trim())?;
        let value = match value {
            None => None,
            Some(v) => Some(v.trim().parse::<f64>().map_err(|_| EffectError::BadValue {
                effect: e.id(),
                parameter: e.parameter(),
                value: f64::NAN,
                requirement: "a number",
            })?),
        };
        Ok(EffectChoice::Given(e, value))
    }
}

impl TruthModel {
    /// The truth of a faithful model: the nominal parameters, no extension, no sensor fault.
    pub fn nominal(driveline: &DrivelineParams, axles: Option<&AxleParams>) -> Self {
        Self {
            driveline: driveline.clone(),
            axles: axles.cloned(),
            lash_rad: 0.0,
            axle_ext: AxleExtensions::default(),
            sensors: SensorFaults::default(),
            stretch: None,
        }
    }

    /// The nominal value of `e`'s parameter in this (nominal) model; `bus_slope_resolution` is
    /// the slope channel's resolution in tan α.
    ///
    /// # Errors
    /// [`EffectError::MissingPart`] for an axle effect on a vehicle without axles.
    pub fn nominal_value(&self, e: Effect, bus_slope_resolution: f64) -> Result<f64, EffectError> {
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

    fn axles(&self, e: Effect) -> Result<&AxleParams, EffectError> {
        self.axles.as_ref().ok_or(EffectError::MissingPart {
            effect: e.id(),
            part: "axles",
        })
    }

    /// Sets `e`'s parameter to `value` in the truth (see the module table).
    ///
    /// # Errors
    /// [`EffectError::BadValue`] outside the parameter's physical domain;
    /// [`EffectError::MissingPart`] for an axle effect on a vehicle without axles.
    pub fn inject(&mut self, e: Effect, value: f64) -> Result<(), EffectError> {
        use Effect::*;
        let bad = |requirement: &'static str| EffectError::BadValue {
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
                let a = self.axles.as_mut().ok_or(EffectError::MissingPart {
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
                let a = self.axles.as_mut().ok_or(EffectError::MissingPart {
                    effect: e.id(),
                    part: "axles",
                })?;
                shift_cg(a, value).map_err(|_| bad("a shift that leaves every axle loaded"))?;
            }
            TyreStiffness => {
                let a = self.axles.as_mut().ok_or(EffectError::MissingPart {
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

/// Resolves `choice` for a drive with `seed`: the injection (or none) and the truth model.
///
/// # Errors
/// [`EffectError`] for values outside the parameter's domain or a missing vehicle part.
pub fn resolve(
    choice: EffectChoice,
    nominal: &TruthModel,
    bus_slope_resolution: f64,
    seed: u64,
) -> Result<(Option<Injection>, TruthModel), EffectError> {
    let mut rng = Xoshiro256StarStar::seed_from_u64(seed ^ EFFECT_STREAM);
    let (effect, given) = match choice {
        EffectChoice::None | EffectChoice::LocalRollingResistance => {
            return Ok((None, nominal.clone()))
        }
        EffectChoice::Random => {
            let k = (rng.next_u64() % (Effect::ALL.len() as u64 + 1)) as usize;
            match Effect::ALL.get(k) {
                Some(&e) => (e, None),
                None => return Ok((None, nominal.clone())),
            }
        }
        EffectChoice::Given(e, v) => (e, v),
    };
    let nom = nominal.nominal_value(effect, bus_slope_resolution)?;
    let truth_value = given.unwrap_or_else(|| effect.draw(nom, &mut rng));
    let mut t = nominal.clone();
    t.inject(effect, truth_value)?;
    Ok((
        Some(Injection {
            effect,
            nominal: nom,
            truth: truth_value,
        }),
        t,
    ))
}

/// The answer file's effect entry.
#[derive(Debug, Clone, Serialize)]
pub struct AnswerEffect {
    /// Catalogue id.
    pub id: &'static str,
    /// Model it belongs to.
    pub domain: Domain,
    /// What was left out.
    pub description: &'static str,
    /// Parameter name.
    pub parameter: &'static str,
    /// Its SI unit.
    pub unit: &'static str,
    /// Value in the nominal vehicle (or the "absent" value).
    pub nominal: f64,
    /// Value in the truth.
    pub truth: f64,
    /// `truth / nominal − 1` where the nominal is not 0.
    pub relative_change: Option<f64>,
}

/// The answer file of a synthetic drive (`answer.json`), kept apart from the drive: what the
/// truth hid.
#[derive(Debug, Clone, Serialize)]
pub struct Answer {
    /// The drive's id (as in its log's metadata).
    pub drive_id: String,
    /// Generator seed.
    pub seed: u64,
    /// Generator and version.
    pub generator: String,
    /// The hidden catalogue effect, `null` for a drive without one.
    pub effect: Option<AnswerEffect>,
    /// A hidden effect outside the catalogue, `null` for none.
    pub out_of_catalogue: Option<OutOfCatalogue>,
}

/// The answer file's out-of-catalogue entry.
#[derive(Debug, Clone, Serialize)]
pub struct OutOfCatalogue {
    /// What it is ([`LOCAL_ROLLING_RESISTANCE`]).
    pub kind: &'static str,
    /// In words.
    pub description: &'static str,
    /// The stretch.
    pub stretch: ResistanceStretch,
}

impl Answer {
    /// The answer for `injection` (or none) of drive `drive_id`.
    pub fn new(drive_id: &str, seed: u64, injection: Option<&Injection>) -> Self {
        Self {
            drive_id: drive_id.to_string(),
            seed,
            generator: format!("fleetdyn {} synth drive", env!("CARGO_PKG_VERSION")),
            effect: injection.map(|i| AnswerEffect {
                id: i.effect.id(),
                domain: i.effect.domain(),
                description: i.effect.description(),
                parameter: i.effect.parameter(),
                unit: i.effect.unit(),
                nominal: i.nominal,
                truth: i.truth,
                relative_change: (i.nominal != 0.0).then(|| i.truth / i.nominal - 1.0),
            }),
            out_of_catalogue: None,
        }
    }

    /// Writes the answer as pretty JSON to `path`, atomically.
    ///
    /// # Errors
    /// [`EffectError::Io`].
    pub fn write(&self, path: &Path) -> Result<(), EffectError> {
        let mut text = serde_json::to_string_pretty(self).expect("plain data serialises");
        text.push('\n');
        AtomicFile::write_all(path, text.as_bytes()).map_err(|source| EffectError::Io {
            path: path.to_path_buf(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_lists_catalogue() {
        for e in Effect::ALL {
            assert_eq!(Effect::from_id(e.id()).unwrap(), e);
        }
        let err = Effect::from_id("wind_gust").unwrap_err().to_string();
        assert!(
            err.contains("wind_gust")
                && err.contains("aero_drag")
                && err.contains("grade_load_transfer")
        );
    }

    #[test]
    fn draws_stay_in_range_and_are_deterministic() {
        for e in Effect::ALL {
            let nominal = 2.0;
            let mut r1 = Xoshiro256StarStar::seed_from_u64(5);
            let mut r2 = Xoshiro256StarStar::seed_from_u64(5);
            for _ in 0..200 {
                let v = e.draw(nominal, &mut r1);
                assert_eq!(v.to_bits(), e.draw(nominal, &mut r2).to_bits());
                let ok = match e.range() {
                    Range::Relative { lo, hi, down_only } => {
                        let r = (v / nominal - 1.0).abs();
                        r >= lo && r <= hi && (!down_only || v < nominal)
                    }
                    Range::Absolute { lo, hi, signed } => {
                        v.abs() >= lo && v.abs() <= hi && (signed || v > 0.0)
                    }
                    Range::Additive { lo, hi } => {
                        let d = (v - nominal).abs();
                        d >= lo && d <= hi
                    }
                    Range::Set { lo, hi } => v >= lo && v <= hi,
                };
                assert!(ok, "{}: {v}", e.id());
            }
        }
    }

    #[test]
    fn parse_choices() {
        assert_eq!(EffectChoice::parse("none").unwrap(), EffectChoice::None);
        assert_eq!(EffectChoice::parse("random").unwrap(), EffectChoice::Random);
        assert_eq!(
            EffectChoice::parse("aero_drag=6.5").unwrap(),
            EffectChoice::Given(Effect::AeroDrag, Some(6.5))
        );
        assert_eq!(
            EffectChoice::parse("clutch_slip").unwrap(),
            EffectChoice::Given(Effect::ClutchSlip, None)
        );
        assert!(EffectChoice::parse("aero_drag=x").is_err());
        assert!(EffectChoice::parse("nope").is_err());
    }
}
