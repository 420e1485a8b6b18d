//! Concealable effects for the model-based generator of synthetic drives: a catalogue effect
//! ([`crate::model::catalogue`]) set in the *truth* of a drive — never in the nominal vehicle
//! file written next to it — with a magnitude, recorded in a separate answer file. The truth is
//! the extended vehicle model ([`ExtendedVehicle`], whose module table says what each effect's
//! parameter changes) plus, for drives with an out-of-catalogue effect, a stretch of road with
//! extra rolling resistance ([`ResistanceStretch`]).
//!
//! Because the diagnosis fits the same extended model, a proof on these drives is an inversion
//! check; the independent truth ([`crate::truth`]) is the proof.
//!
//! The driver and the AMT keep the nominal vehicle (they are controllers with the fleet's
//! beliefs); only the plant and the sensors change.
//!
//! # Magnitudes
//! A drawn magnitude comes from the catalogue row's [`DrawRange`] ([`draw_value`]). The ranges
//! are what a fleet meets: drag areas and rolling resistance off by 15–40 % / 20–50 % (body,
//! tyres, trailers), payloads off by 8–25 %, sensor mounting angles of 0.3–1.1°, CAN delays of
//! 0.1–0.4 s, 0.9–2.9° of drive-shaft play, worn clutches at 60–80 % of their capacity, CG
//! heights off by 0.15–0.4 m, bellow progressions of 2–6 1/m (the gas law's
//! `(n + 1) k_b / (2 n B_0)` is 3.5–7.5 1/m for the axle-load thesis' truck's bellows,
//! n = 1–1.4). The draw uses its own PRNG stream (`seed ^ EFFECT_STREAM`), so a drive with an
//! effect and the drive without it share road, driver and sensor noise.

use super::can::{CanBus, Truth};
use crate::io::AtomicFile;
use crate::model::axle::AxleParams;
pub use crate::model::catalogue::{Domain, DrawRange, Effect, UnknownEffect};
use crate::model::driveline::DrivelineParams;
pub use crate::model::extended_vehicle::ParameterError;
use crate::model::extended_vehicle::{ExtendedVehicle, SensorFaults};
use crate::rng::Xoshiro256StarStar;
use serde::Serialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why an effect could not be injected.
#[derive(Debug, Error)]
pub enum EffectError {
    /// An identifier that is not in the catalogue.
    #[error(transparent)]
    Unknown(#[from] UnknownEffect),
    /// A value that is not a number, outside the parameter's domain, or a missing vehicle part.
    #[error(transparent)]
    Parameter(#[from] ParameterError),
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

/// A truth value of `e`'s parameter drawn from its catalogue [`DrawRange`] around `nominal`.
pub fn draw_value(e: Effect, nominal: f64, rng: &mut Xoshiro256StarStar) -> f64 {
    let mut sign = |signed: bool| {
        let u = rng.next_f64();
        if signed && u < 0.5 {
            -1.0
        } else {
            1.0
        }
    };
    match e.spec().draw {
        DrawRange::Relative { lo, hi, down_only } => {
            let s = if down_only { -1.0 } else { sign(true) };
            nominal * (1.0 + s * rng.uniform(lo, hi))
        }
        DrawRange::Absolute { lo, hi, signed } => {
            let s = sign(signed);
            s * rng.uniform(lo, hi)
        }
        DrawRange::Additive { lo, hi } => {
            let s = sign(true);
            nominal + s * rng.uniform(lo, hi)
        }
        DrawRange::Set { lo, hi } => rng.uniform(lo, hi),
    }
}

/// Applies the sensor effects' signal part (slope offset, torque offset) to the truth's
/// columns `road_slope` and `engine_torque` (absent columns are left alone).
pub fn fault_truth(faults: &SensorFaults, truth: &mut Truth) {
    for (name, values) in truth.columns.iter_mut() {
        match name.as_str() {
            "road_slope" if faults.slope_offset_rad != 0.0 => {
                for v in values.iter_mut() {
                    *v = (v.atan() + faults.slope_offset_rad).tan();
                }
            }
            "engine_torque" if faults.engine_torque_offset_nm != 0.0 => {
                for v in values.iter_mut() {
                    *v += faults.engine_torque_offset_nm;
                }
            }
            _ => {}
        }
    }
}

/// Applies the sensor effects' channel part (slope resolution, torque delay) to the bus's
/// `road_slope` and `engine_torque` channels. The slope resolution is converted to the
/// channel's wire unit (`%` → ×100).
pub fn fault_bus(faults: &SensorFaults, bus: &mut CanBus) {
    for c in bus.messages.iter_mut().flat_map(|m| m.channels.iter_mut()) {
        match c.column.as_str() {
            "road_slope" => {
                if let Some(r) = faults.slope_resolution {
                    c.resolution = if c.wire_unit == "%" { 100.0 * r } else { r };
                }
            }
            "engine_torque" => c.delay_s += faults.engine_torque_delay_s,
            _ => {}
        }
    }
}

/// The truth of a model-based synthetic drive: the extended vehicle model it is simulated with,
/// and an out-of-catalogue effect the extended model does not have.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthModel {
    /// The plant's and the sensors' parameters.
    pub vehicle: ExtendedVehicle,
    /// Out-of-catalogue extra rolling resistance on a stretch of road.
    pub stretch: Option<ResistanceStretch>,
}

impl TruthModel {
    /// The truth of a faithful model: the nominal parameters, no extension, no sensor fault.
    pub fn nominal(driveline: &DrivelineParams, axles: Option<&AxleParams>) -> Self {
        Self {
            vehicle: ExtendedVehicle::nominal(driveline, axles),
            stretch: None,
        }
    }
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
    /// [`EffectError::Unknown`] for an id outside the catalogue; [`EffectError::Parameter`] for a
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
            Some(v) => Some(
                v.trim()
                    .parse::<f64>()
                    .map_err(|_| ParameterError::BadValue {
                        effect: e.id(),
                        parameter: e.parameter(),
                        value: f64::NAN,
                        requirement: "a number",
                    })?,
            ),
        };
        Ok(EffectChoice::Given(e, value))
    }
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
    let nom = nominal.vehicle.value_of(effect, bus_slope_resolution)?;
    let truth_value = given.unwrap_or_else(|| draw_value(effect, nom, &mut rng));
    let mut t = nominal.clone();
    t.vehicle.set(effect, truth_value)?;
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
                let v = draw_value(e, nominal, &mut r1);
                assert_eq!(v.to_bits(), draw_value(e, nominal, &mut r2).to_bits());
                let ok = match e.spec().draw {
                    DrawRange::Relative { lo, hi, down_only } => {
                        let r = (v / nominal - 1.0).abs();
                        r >= lo && r <= hi && (!down_only || v < nominal)
                    }
                    DrawRange::Absolute { lo, hi, signed } => {
                        v.abs() >= lo && v.abs() <= hi && (signed || v > 0.0)
                    }
                    DrawRange::Additive { lo, hi } => {
                        let d = (v - nominal).abs();
                        d >= lo && d <= hi
                    }
                    DrawRange::Set { lo, hi } => v >= lo && v <= hi,
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
