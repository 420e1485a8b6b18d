//! The effect catalogue as one data table: the physical effects a nominal vehicle model may
//! leave out, each with one parameter. Every row says what the effect is (id, domain,
//! parameter and unit, what was left out, its fingerprint), how uncertain the vehicle file's
//! value of that parameter is by default ([`ToleranceKind`]), how a proof draws a concealed
//! magnitude ([`DrawRange`]) and how the diagnosis screens and fits it ([`FitRule`]).
//!
//! This module is a leaf: it imports nothing from the rest of the crate. The diagnosis and
//! every generator of synthetic drives read the same rows, so an effect's identifier, unit
//! and ranges cannot drift between the code that hides an effect and the code that names it.
//! The identifiers are part of the output contract: once released, an identifier keeps its
//! meaning (docs/diagnosis/catalogue.md).
//!
//! The table in words is `model::catalogue_table::catalogue_markdown`, which
//! docs/diagnosis/catalogue.md carries.
//!
//! # Model-form allowance
//! No model is the truck: the longitudinal model has one lumped shaft, rigid tyres up to a
//! fitted slip and share, a single-stage clutch damper, an engine whose torque follows the
//! ECU's figure by the vehicle file's lag, no wind, and no tyre temperature unless the file
//! states a warm-up (`model::tyre_warm_up`; the proof's file does not). Its estimate of a
//! parameter on a healthy truck therefore misses the truck's true value by more than its 95 %
//! interval says. The row's `model_form` is that miss, measured on the truth plant's no-effect
//! drives (a virtual truck with that structure, docs/models/truth-plant.md) of calibration
//! seeds that no reported proof figure uses: the largest distance from the truck's value to
//! the estimate's interval, as a fraction of θ₀ or in the parameter's unit, on each side of
//! the truck's value apart and rounded up at two significant figures, measured with every
//! allowance at zero (`fleetdyn prove` prints it per parameter under *Estimates on no-effect
//! drives*; docs/diagnosis/method.md gives the command and seeds), over the full fits only (a
//! finding, or an estimate within the band), which the acceptance rule judges. The sides
//! differ because what the model lacks pushes some estimates one way: wind only adds to the
//! mean drag force, and a clutch that never slips bounds its capacity only from below.
//! `Tolerance::None` on a side where no miss was measured, and on both for the switch, an effect no
//! calibration drive fitted (`signal_delay`) and the axle effects, which the truth plant does not
//! model. The diagnosis names an effect only when its interval lies outside the file's tolerance
//! widened by this allowance, so the model's own error is not reported as the truck's. The row's
//! `model_form_warm_up` is the same measurement with a vehicle file that states the tyres' warm-up,
//! whose models put the cold tyres' extra rolling resistance where it belongs instead of into the
//! drag area and the rolling resistance; a file is judged with the one measured as its models are
//! (`model::tolerance::Tolerances::model_form`). The calibration drives log an altitude and idle
//! declutched, so the two offsets are measured on them (`diagnose::altitude_offset`,
//! `diagnose::idle_torque`), not fitted, as on the proof's drives; their rows' allowances, which
//! apply only to logs the measurements cannot serve, are those of the same seeds diagnosed with the
//! offset fitted instead. The row's `linearised_form` is the same measurement on the first round's
//! linearised estimates of the same drives, whose intervals are a linear approximation and miss by
//! more; a vehicle's pooled estimate pools estimates of both kinds and is judged with the wider of
//! the two on each side (`fleet::evidence::pooled_band`).
//!
//! θ₀ is the vehicle file's value of the parameter (or the effect's "absent" value, 0 for the
//! offsets, lash, delay and axle extensions, 1 for the tyre-stiffness factor).

use std::fmt;

/// Which model an effect belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Domain {
    /// Longitudinal / driveline.
    Longitudinal,
    /// Axle loads.
    Axle,
}

/// One catalogue effect. Identifiers ([`Effect::id`]) are part of the output contract.
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
    /// Clutch capacity below what the file says: slip at launch, at shifts and under full load.
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

/// An identifier that is not in the catalogue.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownEffect {
    /// The identifier given.
    pub id: String,
}

impl fmt::Display for UnknownEffect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let known: Vec<&str> = CATALOGUE.iter().map(|r| r.id).collect();
        write!(
            f,
            "unknown effect `{}`; the catalogue has: {}",
            self.id,
            known.join(", ")
        )
    }
}

impl std::error::Error for UnknownEffect {}

/// What kind of vehicle-file value a parameter is, for its default tolerance
/// ([`ToleranceKind::default_tolerance`]). The `[tolerance]` table of a vehicle file may
/// override the default per parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ToleranceKind {
    /// Vehicle mass (a weighed or declared figure).
    Mass,
    /// Drag area `c_w·A_f`.
    DragArea,
    /// Rolling-resistance coefficient.
    RollingResistance,
    /// A stiffness (shaft, tyre).
    Stiffness,
    /// A damping coefficient.
    Damping,
    /// A rotational inertia.
    Inertia,
    /// Clutch torque capacity.
    ClutchCapacity,
    /// Slope-sensor mounting angle.
    SlopeOffset,
    /// Engine-torque channel offset.
    TorqueOffset,
    /// A channel's delay.
    ChannelDelay,
    /// Driveline play.
    Lash,
    /// Chassis CG height.
    CgHeight,
    /// Chassis CG longitudinal position.
    CgPosition,
    /// Fraction of wheel torque reacted by the chassis.
    TorqueReaction,
    /// Bellow progression.
    BellowProgression,
    /// Height offset of the grade force.
    GradeHeight,
    /// A switch with no continuous value (the slope sensor's resolution is measured from the
    /// recording itself).
    Switch,
}

/// A tolerance band around a nominal value θ₀: `|θ − θ₀| ≤ r·|θ₀|` or `|θ − θ₀| ≤ a`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tolerance {
    /// Relative half-width r (1).
    Relative(f64),
    /// Absolute half-width a, in the parameter's unit.
    Absolute(f64),
    /// No band: any departure counts (a switch).
    None,
}

/// The model-form allowance of a catalogue row, side by side: how far beyond its 95 % interval
/// a healthy truck's estimate may lie below and above the truck's value (module documentation,
/// *Model-form allowance*). A side on which no miss was measured has `Tolerance::None`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelForm {
    /// The largest miss measured with the estimate below the truck's value.
    pub below: Tolerance,
    /// The largest miss measured with the estimate above the truck's value.
    pub above: Tolerance,
}

impl ModelForm {
    /// No allowance on either side.
    pub const NONE: ModelForm = ModelForm::sides(Tolerance::None, Tolerance::None);

    /// An allowance of `below` under θ₀ and `above` over it.
    pub const fn sides(below: Tolerance, above: Tolerance) -> Self {
        ModelForm { below, above }
    }

    /// The widths `(below, above)` it adds to the band around `nominal`, in the parameter's
    /// unit.
    pub fn widths(self, nominal: f64) -> (f64, f64) {
        (
            self.below.half_width(nominal),
            self.above.half_width(nominal),
        )
    }
}

impl Tolerance {
    /// Half-width of the band around `nominal`, in the parameter's unit.
    pub fn half_width(self, nominal: f64) -> f64 {
        match self {
            Tolerance::Relative(r) => r * nominal.abs(),
            Tolerance::Absolute(a) => a,
            Tolerance::None => 0.0,
        }
    }
}

impl ToleranceKind {
    /// The documented default tolerance of this kind of value (docs/diagnosis/catalogue.md):
    /// what a vehicle file's nominal value is typically off by on a healthy truck.
    ///
    /// | kind | default | why |
    /// |---|---|---|
    /// | mass | ±3 % | declared or weighed mass: fuel, driver, load securing |
    /// | drag area | ±5 % | body and mirror variants, wind-tunnel to road |
    /// | rolling resistance | ±10 % | within one EU tyre-label class; tread wear, pressure |
    /// | stiffness, damping | ±10 % | component tolerances and ageing of rubber parts |
    /// | inertia | ±5 % | component variants |
    /// | clutch capacity | ±10 % | facing friction coefficient between new and bedded-in |
    /// | slope-sensor offset | ±0.002 rad (0.11°) | mounting after calibration |
    /// | torque offset | ±25 N·m | about 1 % of a heavy engine's reference torque |
    /// | channel delay | ±0.02 s | one message period of a 50 Hz CAN message |
    /// | lash | ±0.005 rad | new-driveline play referred to the wheels |
    /// | CG height, CG position | ±0.05 m | loading variation of a rigid body |
    /// | torque reaction | ±0.05 | torque-rod geometry |
    /// | bellow progression | ±0.5 1/m | polytropic exponent between 1.0 and 1.4 at small travel |
    /// | grade height | ±0.1 m | as the CG height |
    pub const fn default_tolerance(self) -> Tolerance {
        use ToleranceKind::*;
        match self {
            Mass => Tolerance::Relative(0.03),
            DragArea => Tolerance::Relative(0.05),
            RollingResistance => Tolerance::Relative(0.10),
            Stiffness | Damping => Tolerance::Relative(0.10),
            Inertia => Tolerance::Relative(0.05),
            ClutchCapacity => Tolerance::Relative(0.10),
            SlopeOffset => Tolerance::Absolute(0.002),
            TorqueOffset => Tolerance::Absolute(25.0),
            ChannelDelay => Tolerance::Absolute(0.02),
            Lash => Tolerance::Absolute(0.005),
            CgHeight | CgPosition => Tolerance::Absolute(0.05),
            TorqueReaction => Tolerance::Absolute(0.05),
            BellowProgression => Tolerance::Absolute(0.5),
            GradeHeight => Tolerance::Absolute(0.1),
            Switch => Tolerance::None,
        }
    }
}

/// How a proof draws a concealed magnitude of an effect's parameter (θ₀ the nominal value,
/// `U(lo, hi)` uniform, `s = ±1` at random).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DrawRange {
    /// `θ = θ₀ · (1 + s·U(lo, hi))` (`s = −1` only when `down_only`).
    Relative {
        /// Smallest relative change.
        lo: f64,
        /// Largest relative change.
        hi: f64,
        /// Only decreases are physical.
        down_only: bool,
    },
    /// `θ = s·U(lo, hi)` (`s = +1` unless `signed`), θ₀ being 0.
    Absolute {
        /// Smallest magnitude.
        lo: f64,
        /// Largest magnitude.
        hi: f64,
        /// Both signs physical.
        signed: bool,
    },
    /// `θ = θ₀ + s·U(lo, hi)`.
    Additive {
        /// Smallest change.
        lo: f64,
        /// Largest change.
        hi: f64,
    },
    /// `θ = U(lo, hi)` whatever θ₀.
    Set {
        /// Smallest value.
        lo: f64,
        /// Largest value.
        hi: f64,
    },
}

/// Whether a [`FitRule`]'s numbers are multiples of θ₀ or values in the parameter's unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Multiples of the nominal value θ₀.
    Relative,
    /// Values in the parameter's unit.
    Absolute,
}

/// How the diagnosis screens and fits an effect's parameter (the screen's finite-difference
/// step, the physical domain of the fit, its start grid and screen ladder; the diagnosis's
/// fit module documents how each is used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitRule {
    /// Whether `step`, `lo`, `hi` and `grid` scale with θ₀.
    pub scale: Scale,
    /// Screen step (for a relative rule, a fraction of θ₀: the probe is θ₀·(1 + step)).
    pub step: f64,
    /// Lower end of the physical domain.
    pub lo: f64,
    /// Upper end of the physical domain.
    pub hi: f64,
    /// A switch rather than a continuous parameter.
    pub switch: bool,
    /// Start grid `[first, last, step]`, for costs with narrow side basins.
    pub grid: Option<[f64; 3]>,
    /// Multiples of `step` the screen probes.
    pub ladder: &'static [f64],
}

impl FitRule {
    /// What `step`, `lo`, `hi` and `grid` are multiplied by for a parameter whose nominal value
    /// is `nominal`: `nominal` for a [`Scale::Relative`] rule, 1 for a [`Scale::Absolute`] one.
    pub fn factor(&self, nominal: f64) -> f64 {
        match self.scale {
            Scale::Relative => nominal,
            Scale::Absolute => 1.0,
        }
    }
}

/// The screen's probe steps, as multiples of [`FitRule::step`], for the effects whose outputs
/// respond to their parameter by a threshold or a shift rather than in proportion: a clutch
/// slips only once its capacity falls below the torque it carries, a lash acts only where the
/// torque reverses across it, a delay moves every torque ramp against the events it meets. One
/// finite difference reads such a response at one arbitrary point; half, once and one and a
/// half times the step bracket the realistic range.
pub const SCREEN_LADDER: [f64; 3] = [0.5, 1.0, 1.5];

/// `signal_delay`'s start grid, s: 0 … 0.6 s in 25 ms steps. The cost in the delay has basins
/// about 0.05 s wide (the torque ramps of each shift against the clutch, and the torque
/// reversals), in which a fit started from no delay stops; two grid points fall in each basin.
/// Beyond the grid the fit may still move up to the domain's 2 s.
pub const DELAY_GRID_S: [f64; 3] = [0.0, 0.6, 0.025];

/// `clutch_slip`'s start grid, as fractions of the nominal capacity: 50 … 100 % in 1.5 %
/// steps. The cost in the capacity is a staircase of basins, one per set of launches and
/// shifts whose transmitted torque exceeds it, each about 3 % of the capacity wide; the step
/// puts two points in each basin. From the grid's best point the fit may move over the whole
/// domain.
pub const CLUTCH_GRID: [f64; 3] = [0.5, 1.0, 0.015];

/// Upper end of `rolling_resistance`'s fit domain, as a multiple of the vehicle file's `c_r1`:
/// the span of the EU tyre label's rolling-resistance classes for truck tyres (class A at most
/// 4.0 N/kN, class E at least 7.1 N/kN; Regulation (EU) 2020/740), so a truck on the label's
/// worst tyres against a file of its best, with a wet road or low pressure on top. A constant
/// force ∝ m·g beyond it is not a rolling resistance; it is left to the effects with the same
/// fingerprint (a slope-sensor mounting angle, `grade_offset`) or to `unexplained`.
pub const ROLLING_RESISTANCE_MAX: f64 = 2.5;

/// One row of the catalogue.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectSpec {
    /// The effect.
    pub effect: Effect,
    /// Catalogue identifier (output contract).
    pub id: &'static str,
    /// The model it belongs to.
    pub domain: Domain,
    /// Parameter name, with its unit in the name where the unit is not 1.
    pub parameter: &'static str,
    /// SI unit of the parameter.
    pub unit: &'static str,
    /// What was left out.
    pub description: &'static str,
    /// How the mismatch looks.
    pub fingerprint: &'static str,
    /// Kind of value, for the default tolerance.
    pub tolerance: ToleranceKind,
    /// The models' own error in the estimate (the model-form allowance): how far a healthy
    /// truck's estimate may lie from the truck's true value beyond its 95 % interval, because
    /// the models leave out structure every truck has. An estimate is named only outside the
    /// file's tolerance widened by it (module documentation, *Model-form allowance*).
    pub model_form: ModelForm,
    /// The same allowance measured with the tyres' warm-up stated in the vehicle file
    /// (`tyre_cold_excess` > 0: the models' rolling resistance falls as the tyres warm,
    /// `model::tyre_warm_up`), on the same calibration seeds: what a file that states it is
    /// judged with (`model::tolerance::Tolerances::model_form`).
    pub model_form_warm_up: ModelForm,
    /// The same allowance measured on the first round's linearised estimates of the same
    /// drives, whose intervals are a linear approximation and miss by more: what a vehicle's
    /// pooled estimate, which pools estimates of both kinds, is judged with
    /// (`fleet::evidence`; module documentation, *Model-form allowance*).
    pub linearised_form: ModelForm,
    /// How a proof draws a concealed magnitude.
    pub draw: DrawRange,
    /// How the diagnosis screens and fits it.
    pub fit: FitRule,
}

const fn rel_fit(step: f64, lo: f64, hi: f64) -> FitRule {
    FitRule {
        scale: Scale::Relative,
        step,
        lo,
        hi,
        switch: false,
        grid: None,
        ladder: &[1.0],
    }
}

const fn abs_fit(step: f64, lo: f64, hi: f64) -> FitRule {
    FitRule {
        scale: Scale::Absolute,
        step,
        lo,
        hi,
        switch: false,
        grid: None,
        ladder: &[1.0],
    }
}

const fn rel_draw(lo: f64, hi: f64) -> DrawRange {
    DrawRange::Relative {
        lo,
        hi,
        down_only: false,
    }
}

const fn abs_draw(lo: f64, hi: f64, signed: bool) -> DrawRange {
    DrawRange::Absolute { lo, hi, signed }
}

/// The catalogue, in the contract's order.
pub const CATALOGUE: [EffectSpec; 16] = [
    EffectSpec {
        effect: Effect::AeroDrag,
        id: "aero_drag",
        domain: Domain::Longitudinal,
        parameter: "c_w_a_f_m2",
        unit: "m2",
        description: "air drag coefficient·area wrong",
        fingerprint: "residual force grows with v²",
        tolerance: ToleranceKind::DragArea,
        model_form: ModelForm::sides(Tolerance::Relative(0.21), Tolerance::Relative(0.82)),
        model_form_warm_up: ModelForm::sides(Tolerance::Relative(0.30), Tolerance::Relative(0.23)),
        linearised_form: ModelForm::sides(Tolerance::Relative(0.16), Tolerance::Relative(1.9)),
        draw: rel_draw(0.15, 0.40),
        fit: rel_fit(0.25, 0.25, 4.0),
    },
    EffectSpec {
        effect: Effect::RollingResistance,
        id: "rolling_resistance",
        domain: Domain::Longitudinal,
        parameter: "c_r1",
        unit: "1",
        description: "rolling-resistance coefficients wrong",
        fingerprint: "residual force constant plus a term in v, in proportion to the load",
        tolerance: ToleranceKind::RollingResistance,
        model_form: ModelForm::sides(Tolerance::None, Tolerance::Relative(0.44)),
        model_form_warm_up: ModelForm::sides(Tolerance::Relative(0.13), Tolerance::Relative(0.36)),
        linearised_form: ModelForm::sides(Tolerance::Relative(0.16), Tolerance::Relative(0.35)),
        draw: rel_draw(0.20, 0.50),
        fit: rel_fit(0.30, 0.25, ROLLING_RESISTANCE_MAX),
    },
    EffectSpec {
        effect: Effect::VehicleMass,
        id: "vehicle_mass",
        domain: Domain::Longitudinal,
        parameter: "mass_kg",
        unit: "kg",
        description: "mass / payload wrong",
        fingerprint: "residual force in proportion to a + g·sin α",
        tolerance: ToleranceKind::Mass,
        model_form: ModelForm::sides(Tolerance::Relative(0.0041), Tolerance::Relative(0.030)),
        model_form_warm_up: ModelForm::sides(
            Tolerance::Relative(0.013),
            Tolerance::Relative(0.022),
        ),
        linearised_form: ModelForm::sides(Tolerance::Relative(0.017), Tolerance::Relative(0.042)),
        draw: rel_draw(0.08, 0.25),
        fit: rel_fit(0.15, 0.5, 2.5),
    },
    EffectSpec {
        effect: Effect::GradeOffset,
        id: "grade_offset",
        domain: Domain::Longitudinal,
        parameter: "slope_offset_rad",
        unit: "rad",
        description: "slope sensor bias (mounting angle)",
        fingerprint: "residual force in proportion to m·g, constant in distance",
        tolerance: ToleranceKind::SlopeOffset,
        model_form: ModelForm::sides(Tolerance::Absolute(0.0026), Tolerance::Absolute(0.00098)),
        model_form_warm_up: ModelForm::sides(
            Tolerance::Absolute(0.0026),
            Tolerance::Absolute(0.00098),
        ),
        linearised_form: ModelForm::sides(Tolerance::Absolute(0.002), Tolerance::Absolute(0.00064)),
        draw: abs_draw(0.005, 0.02, true),
        fit: abs_fit(0.01, -0.1, 0.1),
    },
    EffectSpec {
        effect: Effect::SlopeQuantization,
        id: "slope_quantization",
        domain: Domain::Longitudinal,
        parameter: "slope_resolution",
        unit: "1",
        description: "quantised slope sensor excites spurious shuffle",
        fingerprint: "simulated oscillation at the driveline resonance after slope steps that \
                      the recording lacks; cured by the spatial zero-phase slope filter",
        tolerance: ToleranceKind::Switch,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: DrawRange::Set { lo: 0.01, hi: 0.02 },
        fit: FitRule {
            switch: true,
            ..abs_fit(0.0, 0.0, 0.0)
        },
    },
    EffectSpec {
        effect: Effect::SignalDelay,
        id: "signal_delay",
        domain: Domain::Longitudinal,
        parameter: "engine_torque_delay_s",
        unit: "s",
        description: "channels misaligned in time",
        fingerprint: "input–residual cross-correlation peaks at a non-zero lag",
        tolerance: ToleranceKind::ChannelDelay,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::sides(Tolerance::None, Tolerance::Absolute(0.057)),
        draw: abs_draw(0.1, 0.4, false),
        fit: FitRule {
            grid: Some(DELAY_GRID_S),
            ladder: &SCREEN_LADDER,
            ..abs_fit(0.2, 0.0, 2.0)
        },
    },
    EffectSpec {
        effect: Effect::DrivelineBacklash,
        id: "driveline_backlash",
        domain: Domain::Longitudinal,
        parameter: "drive_shaft_lash_rad",
        unit: "rad",
        description: "lash in the driveline",
        fingerprint: "mismatch concentrated at torque sign changes",
        tolerance: ToleranceKind::Lash,
        model_form: ModelForm::sides(Tolerance::None, Tolerance::Absolute(0.0013)),
        model_form_warm_up: ModelForm::sides(Tolerance::None, Tolerance::Absolute(0.0014)),
        linearised_form: ModelForm::sides(Tolerance::None, Tolerance::Absolute(0.0043)),
        draw: abs_draw(0.015, 0.05, false),
        fit: FitRule {
            ladder: &SCREEN_LADDER,
            ..abs_fit(0.03, 0.0, 0.2)
        },
    },
    EffectSpec {
        effect: Effect::DrivelineCompliance,
        id: "driveline_compliance",
        domain: Domain::Longitudinal,
        parameter: "k_d_nm_per_rad",
        unit: "N.m/rad",
        description: "shaft stiffness / damping wrong",
        fingerprint: "shuffle frequency or decay mismatch",
        tolerance: ToleranceKind::Stiffness,
        model_form: ModelForm::sides(Tolerance::Relative(0.20), Tolerance::Relative(0.085)),
        model_form_warm_up: ModelForm::sides(Tolerance::Relative(0.20), Tolerance::Relative(0.084)),
        linearised_form: ModelForm::sides(Tolerance::Relative(0.089), Tolerance::Relative(0.055)),
        draw: rel_draw(0.25, 0.50),
        fit: rel_fit(-0.35, 0.1, 4.0),
    },
    EffectSpec {
        effect: Effect::EngineTorqueOffset,
        id: "engine_torque_offset",
        domain: Domain::Longitudinal,
        parameter: "engine_torque_offset_nm",
        unit: "N.m",
        description: "reported torque biased (friction, auxiliaries)",
        fingerprint: "residual force in proportion to the gear ratio, constant in torque",
        tolerance: ToleranceKind::TorqueOffset,
        model_form: ModelForm::sides(Tolerance::None, Tolerance::Absolute(0.044)),
        model_form_warm_up: ModelForm::sides(Tolerance::Absolute(9.6), Tolerance::Absolute(6.6)),
        linearised_form: ModelForm::sides(Tolerance::Absolute(7.3), Tolerance::Absolute(120.0)),
        draw: abs_draw(40.0, 150.0, true),
        fit: abs_fit(100.0, -500.0, 500.0),
    },
    EffectSpec {
        effect: Effect::ClutchSlip,
        id: "clutch_slip",
        domain: Domain::Longitudinal,
        parameter: "clutch_max_torque_nm",
        unit: "N.m",
        description: "clutch capacity below the file's: slip not modelled",
        fingerprint: "engine speed flares above the wheels' while the clutch is actuated and, \
                      with the pedal engaged, under high torque",
        tolerance: ToleranceKind::ClutchCapacity,
        model_form: ModelForm::sides(Tolerance::None, Tolerance::Relative(0.074)),
        model_form_warm_up: ModelForm::sides(Tolerance::None, Tolerance::Relative(0.069)),
        linearised_form: ModelForm::sides(Tolerance::Relative(0.021), Tolerance::Relative(0.054)),
        draw: DrawRange::Relative {
            lo: 0.20,
            hi: 0.40,
            down_only: true,
        },
        fit: FitRule {
            grid: Some(CLUTCH_GRID),
            ladder: &SCREEN_LADDER,
            ..rel_fit(-0.30, 0.1, 2.0)
        },
    },
    EffectSpec {
        effect: Effect::BogieTorqueReaction,
        id: "bogie_torque_reaction",
        domain: Domain::Axle,
        parameter: "torque_reaction_fraction",
        unit: "1",
        description: "drive/brake torque reaction through the trailing arms",
        fingerprint: "driven-axle pressure residual in proportion to axle torque, mirrored in \
                      braking",
        tolerance: ToleranceKind::TorqueReaction,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: abs_draw(0.2, 0.6, false),
        fit: abs_fit(0.4, -1.0, 1.0),
    },
    EffectSpec {
        effect: Effect::LoadTransferHeight,
        id: "load_transfer_height",
        domain: Domain::Axle,
        parameter: "chassis_cg_height_m",
        unit: "m",
        description: "CG height wrong",
        fingerprint: "pitch and pressure residual in proportion to longitudinal acceleration",
        tolerance: ToleranceKind::CgHeight,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: DrawRange::Additive { lo: 0.15, hi: 0.40 },
        fit: abs_fit(0.25, 0.1, 4.0),
    },
    EffectSpec {
        effect: Effect::AirSpringNonlinearity,
        id: "air_spring_nonlinearity",
        domain: Domain::Axle,
        parameter: "bellow_progression_per_m",
        unit: "1/m",
        description: "progressive bellow stiffness (gas law)",
        fingerprint: "pressure residual in proportion to travel², asymmetric",
        tolerance: ToleranceKind::BellowProgression,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: abs_draw(2.0, 6.0, false),
        fit: abs_fit(4.0, 0.0, 20.0),
    },
    EffectSpec {
        effect: Effect::CgPosition,
        id: "cg_position",
        domain: Domain::Axle,
        parameter: "chassis_cg_shift_m",
        unit: "m",
        description: "static CG position wrong",
        fingerprint: "constant pressure offset front against rear and tag, opposite signs",
        tolerance: ToleranceKind::CgPosition,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: abs_draw(0.10, 0.35, true),
        fit: abs_fit(0.2, -1.5, 1.5),
    },
    EffectSpec {
        effect: Effect::TyreStiffness,
        id: "tyre_stiffness",
        domain: Domain::Axle,
        parameter: "tyre_stiffness_factor",
        unit: "1",
        description: "tyre vertical stiffness wrong",
        fingerprint: "phase and amplitude mismatch in the axle-hop band",
        tolerance: ToleranceKind::Stiffness,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: rel_draw(0.20, 0.40),
        fit: rel_fit(-0.30, 0.2, 4.0),
    },
    EffectSpec {
        effect: Effect::GradeLoadTransfer,
        id: "grade_load_transfer",
        domain: Domain::Axle,
        parameter: "grade_height_offset_m",
        unit: "m",
        description: "gravity component on grades omitted",
        fingerprint: "pressure residual in proportion to sin α",
        tolerance: ToleranceKind::GradeHeight,
        model_form: ModelForm::NONE,
        model_form_warm_up: ModelForm::NONE,
        linearised_form: ModelForm::NONE,
        draw: abs_draw(0.4, 1.0, true),
        fit: abs_fit(0.7, -3.0, 3.0),
    },
];

impl Effect {
    /// The whole catalogue, in the contract's order.
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

    /// This effect's row of [`CATALOGUE`].
    pub fn spec(self) -> &'static EffectSpec {
        // CATALOGUE is in the enum's declaration order (pinned by a test).
        &CATALOGUE[self as usize]
    }

    /// Catalogue identifier.
    pub fn id(self) -> &'static str {
        self.spec().id
    }

    /// Parameter name (with its unit in the name where the unit is not 1).
    pub fn parameter(self) -> &'static str {
        self.spec().parameter
    }

    /// SI unit of the parameter.
    pub fn unit(self) -> &'static str {
        self.spec().unit
    }

    /// What was left out, in the catalogue's words.
    pub fn description(self) -> &'static str {
        self.spec().description
    }

    /// The model the effect belongs to.
    pub fn domain(self) -> Domain {
        self.spec().domain
    }

    /// The effect with catalogue identifier `id`.
    ///
    /// # Errors
    /// [`UnknownEffect`] for an identifier outside the catalogue (its message lists the
    /// catalogue).
    pub fn from_id(id: &str) -> Result<Effect, UnknownEffect> {
        CATALOGUE
            .iter()
            .find(|r| r.id == id)
            .map(|r| r.effect)
            .ok_or_else(|| UnknownEffect { id: id.to_string() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_in_declaration_order_and_ids_unique() {
        for (i, (row, e)) in CATALOGUE.iter().zip(Effect::ALL).enumerate() {
            assert_eq!(row.effect, e, "row {i}");
            assert_eq!(e as usize, i);
            assert_eq!(Effect::from_id(row.id), Ok(e));
        }
        let mut ids: Vec<&str> = CATALOGUE.iter().map(|r| r.id).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), CATALOGUE.len());
    }

    #[test]
    fn fit_domains_hold_their_steps_and_the_absent_value() {
        for row in CATALOGUE.iter().filter(|r| !r.fit.switch) {
            let f = row.fit;
            assert!(f.lo < f.hi, "{}", row.id);
            let probe = match f.scale {
                Scale::Relative => 1.0 + f.step,
                Scale::Absolute => f.step,
            };
            assert!(probe >= f.lo && probe <= f.hi, "{}: probe {probe}", row.id);
            let nominal = match f.scale {
                Scale::Relative => 1.0,
                Scale::Absolute => 0.0,
            };
            // the nominal value is inside the fit domain unless the parameter has no zero
            // (CG height: its nominal is the file's own, not 0)
            if row.effect != Effect::LoadTransferHeight {
                assert!(nominal >= f.lo && nominal <= f.hi, "{}", row.id);
            }
        }
    }

    #[test]
    fn unknown_ids_list_the_catalogue() {
        let e = Effect::from_id("aero").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("`aero`") && msg.contains("grade_load_transfer"),
            "{msg}"
        );
    }
}
