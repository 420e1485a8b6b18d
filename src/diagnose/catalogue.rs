//! The effect catalogue of the mismatch diagnosis (`diagnosis.md`): named physical effects a
//! nominal model may leave out, each with one parameter. The identifiers are part of the output
//! contract: once released, an identifier keeps its meaning. The synthetic generator hides them
//! ([`crate::synth::effects`]) and the diagnosis names them.

use crate::synth::effects::EffectError;
use serde::Serialize;

/// Which model an effect belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Domain {
    /// Longitudinal / driveline.
    Longitudinal,
    /// Axle loads.
    Axle,
}

/// The effect catalogue of diagnosis.md. Identifiers are part of the output contract.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Air drag coefficient·area wrong.
    AeroDrag,
    /// Rolling-resistance coefficients wrong.
    RollingResistance,
    /// Mass / payload wrong.
    VehicleMass,
    /// Slope sensor bias (mounting angle).
    GradeOffset,
    /// Quantised slope sensor excites spurious shuffle.
    SlopeQuantization,
    /// Channels misaligned in time.
    SignalDelay,
    /// Lash in the driveline.
    DrivelineBacklash,
    /// Shaft stiffness wrong.
    DrivelineCompliance,
    /// Reported torque biased (friction, auxiliaries).
    EngineTorqueOffset,
    /// Slip at launch / shift not modelled.
    ClutchSlip,
    /// Drive/brake torque reaction through the trailing arms.
    BogieTorqueReaction,
    /// CG height wrong.
    LoadTransferHeight,
    /// Progressive bellow stiffness (gas law).
    AirSpringNonlinearity,
    /// Static CG position wrong.
    CgPosition,
    /// Tyre vertical stiffness wrong.
    TyreStiffness,
    /// Gravity component on grades omitted.
    GradeLoadTransfer,
}

impl Effect {
    /// The whole catalogue, in diagnosis.md's order.
    pub const ALL: [Effect; 16] = [
        Effect::AeroDrag,
        Effect::RollingResistance,
        Effect::VehicleMass,
        Effect::GradeOffset,
        Effect::SlopeQuantization,
        Effect::SignalDelay,
        Effect::DrivelineBacklash,
        Effect::DrivelineCompliance,
        Effect::EngineTorqueOffset,
        Effect::ClutchSlip,
        Effect::BogieTorqueReaction,
        Effect::LoadTransferHeight,
        Effect::AirSpringNonlinearity,
        Effect::CgPosition,
        Effect::TyreStiffness,
        Effect::GradeLoadTransfer,
    ];

    /// Catalogue identifier.
    pub fn id(self) -> &'static str {
        self.spec().0
    }

    /// Parameter name (with its unit in the name where the unit is not 1).
    pub fn parameter(self) -> &'static str {
        self.spec().1
    }

    /// SI unit of the parameter.
    pub fn unit(self) -> &'static str {
        self.spec().2
    }

    /// What was left out, in the catalogue's words.
    pub fn description(self) -> &'static str {
        self.spec().3
    }

    /// The model the effect belongs to.
    pub fn domain(self) -> Domain {
        use Effect::*;
        match self {
            BogieTorqueReaction
            | LoadTransferHeight
            | AirSpringNonlinearity
            | CgPosition
            | TyreStiffness
            | GradeLoadTransfer => Domain::Axle,
            _ => Domain::Longitudinal,
        }
    }

    /// (id, parameter, unit, description).
    fn spec(self) -> (&'static str, &'static str, &'static str, &'static str) {
        use Effect::*;
        match self {
            AeroDrag => (
                "aero_drag",
                "c_w_a_f_m2",
                "m2",
                "air drag coefficient·area wrong",
            ),
            RollingResistance => (
                "rolling_resistance",
                "c_r1",
                "1",
                "rolling-resistance coefficients wrong",
            ),
            VehicleMass => ("vehicle_mass", "mass_kg", "kg", "mass / payload wrong"),
            GradeOffset => (
                "grade_offset",
                "slope_offset_rad",
                "rad",
                "slope sensor bias (mounting angle)",
            ),
            SlopeQuantization => (
                "slope_quantization",
                "slope_resolution",
                "1",
                "quantised slope sensor excites spurious shuffle",
            ),
            SignalDelay => (
                "signal_delay",
                "engine_torque_delay_s",
                "s",
                "channels misaligned in time",
            ),
            DrivelineBacklash => (
                "driveline_backlash",
                "drive_shaft_lash_rad",
                "rad",
                "lash in the driveline",
            ),
            DrivelineCompliance => (
                "driveline_compliance",
                "k_d_nm_per_rad",
                "N.m/rad",
                "shaft stiffness / damping wrong",
            ),
            EngineTorqueOffset => (
                "engine_torque_offset",
                "engine_torque_offset_nm",
                "N.m",
                "reported torque biased (friction, auxiliaries)",
            ),
            ClutchSlip => (
                "clutch_slip",
                "clutch_max_torque_nm",
                "N.m",
                "slip at launch / shift not modelled",
            ),
            BogieTorqueReaction => (
                "bogie_torque_reaction",
                "torque_reaction_fraction",
                "1",
                "drive/brake torque reaction through the trailing arms",
            ),
            LoadTransferHeight => (
                "load_transfer_height",
                "chassis_cg_height_m",
                "m",
                "CG height wrong",
            ),
            AirSpringNonlinearity => (
                "air_spring_nonlinearity",
                "bellow_progression_per_m",
                "1/m",
                "progressive bellow stiffness (gas law)",
            ),
            CgPosition => (
                "cg_position",
                "chassis_cg_shift_m",
                "m",
                "static CG position wrong",
            ),
            TyreStiffness => (
                "tyre_stiffness",
                "tyre_stiffness_factor",
                "1",
                "tyre vertical stiffness wrong",
            ),
            GradeLoadTransfer => (
                "grade_load_transfer",
                "grade_height_offset_m",
                "m",
                "gravity component on grades omitted",
            ),
        }
    }

    /// The effect with catalogue identifier `id`.
    ///
    /// # Errors
    /// [`EffectError::Unknown`] listing the catalogue.
    pub fn from_id(id: &str) -> Result<Effect, EffectError> {
        Effect::ALL
            .into_iter()
            .find(|e| e.id() == id)
            .ok_or_else(|| EffectError::Unknown {
                id: id.to_string(),
                known: Effect::ALL.map(|e| e.id()).join(", "),
            })
    }
}
