//! Concealed effects: how each longitudinal effect of the diagnosis catalogue, and three effects
//! outside it, show up in the truth plant — as they would on a real truck.
//!
//! # Catalogue effects (ids and parameter names as the catalogue spells them)
//! | id | in this plant | parameter (unit) | draw |
//! |---|---|---|---|
//! | `aero_drag` | drag area scaled | `c_w_a_f_m2` (m²) | ×(1 ± U[0.15, 0.40]) |
//! | `rolling_resistance` | warm c_r1 scaled | `c_r1` (1) | ×(1 ± U[0.20, 0.50]) |
//! | `vehicle_mass` | payload differs | `mass_kg` (kg) | ×(1 ± U[0.08, 0.25]) |
//! | `grade_offset` | slope sensor mounting angle: reads tan(α + δ) | `slope_offset_rad` (rad) | δ = ±U[0.3°, 1.1°] |
//! | `slope_quantization` | coarser slope sensor resolution on the bus | `slope_resolution` (1) | U[0.0125, 0.02] instead of 0.01 |
//! | `signal_delay` | engine-torque CAN channel lags | `engine_torque_delay_s` (s) | U[0.1, 0.4] |
//! | `driveline_backlash` | free play in each drive shaft (dead zone, located contact events) | `drive_shaft_lash_rad` (rad) | U[0.015, 0.05] |
//! | `driveline_compliance` | lumped flexibility scaled: shafts k_s and tyre carcass C_κ/σ (σ ÷ f) both ×f | `k_d_nm_per_rad` (N·m/rad) | ×(1 ± U[0.25, 0.50]) |
//! | `engine_torque_offset` | reported − produced torque offset (map error) | `engine_torque_offset_nm` (N·m) | ±U[40, 150] |
//! | `clutch_slip` | worn clutch: kinetic capacity reduced, glazed facings (k_µ = 1.0) | `clutch_max_torque_nm` (N·m) | ×U[0.55, 0.65] |
//!
//! Signs (±) are drawn with probability ½ each. The truth value reported is the plant's value
//! after the per-drive tolerance draw and the effect (so a harness scores against what the
//! truck really had). `clutch_slip`'s range is narrower than "60–80 % of nominal" on purpose: the
//! file's nominal capacity is 3500 N·m against a 2600 N·m engine, so only a capacity below about
//! 2400 N·m (the torque the clutch carries at full load in a low gear, engine inertia torque
//! subtracted) slips at full load with the pedal engaged; 0.55–0.65 × 3500 = 1925–2275 N·m does.
//!
//! # Out-of-catalogue effects (each with its stretch [start_m, end_m] along the road)
//! - [`OutOfCatalogue::WetSurface`]: c_r1 ×U[1.3, 1.6] on a stretch of 15–30 % of the road
//!   (wet or broken surface: water displacement and deformation, +30–60 %).
//! - [`OutOfCatalogue::StuckSpeedSensor`]: the wheel-based speed channel freezes at its value
//!   at the stretch start for U[150, 400] m of travel, then jumps back to the true speed.
//! - [`OutOfCatalogue::HiddenRetarder`]: a retarder the logs do not report drags at its first
//!   step, U[300, 600] N·m on the gearbox output, on a stretch of 20–40 % of the road.

use super::params::TruckParams;
use super::TruthError;
use crate::rng::Xoshiro256StarStar;

/// The longitudinal catalogue effects this plant can conceal: (id, parameter name, unit).
pub const CATALOGUE: [(&str, &str, &str); 10] = [
    ("aero_drag", "c_w_a_f_m2", "m2"),
    ("rolling_resistance", "c_r1", "1"),
    ("vehicle_mass", "mass_kg", "kg"),
    ("grade_offset", "slope_offset_rad", "rad"),
    ("slope_quantization", "slope_resolution", "1"),
    ("signal_delay", "engine_torque_delay_s", "s"),
    ("driveline_backlash", "drive_shaft_lash_rad", "rad"),
    ("driveline_compliance", "k_d_nm_per_rad", "N.m/rad"),
    ("engine_torque_offset", "engine_torque_offset_nm", "N.m"),
    ("clutch_slip", "clutch_max_torque_nm", "N.m"),
];

/// Effects outside the catalogue.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutOfCatalogue {
    /// Extra rolling resistance on one stretch.
    WetSurface,
    /// A stuck wheel-speed channel on one stretch.
    StuckSpeedSensor,
    /// An unreported retarder dragging on one stretch.
    HiddenRetarder,
}

impl OutOfCatalogue {
    /// All kinds.
    pub const ALL: [OutOfCatalogue; 3] = [
        OutOfCatalogue::WetSurface,
        OutOfCatalogue::StuckSpeedSensor,
        OutOfCatalogue::HiddenRetarder,
    ];

    /// Identifier.
    pub fn id(self) -> &'static str {
        match self {
            OutOfCatalogue::WetSurface => "wet_surface",
            OutOfCatalogue::StuckSpeedSensor => "stuck_speed_sensor",
            OutOfCatalogue::HiddenRetarder => "hidden_retarder",
        }
    }

    /// What it is, in words.
    pub fn description(self) -> &'static str {
        match self {
            OutOfCatalogue::WetSurface => {
                "wet or broken surface: extra rolling resistance on one stretch"
            }
            OutOfCatalogue::StuckSpeedSensor => {
                "wheel-speed channel stuck on one stretch, then jumps back"
            }
            OutOfCatalogue::HiddenRetarder => {
                "a retarder the logs do not report, dragging on one stretch"
            }
        }
    }
}

/// The effect a drive conceals (the request).
#[derive(Debug, Clone, PartialEq)]
pub enum TruthEffect {
    /// None: a nominal truck (tolerance draws only).
    None,
    /// A catalogue effect by id; `Some(v)` fixes the parameter's truth value (its unit), `None`
    /// draws it.
    Catalogue(String, Option<f64>),
    /// An out-of-catalogue effect.
    OutOfCatalogue(OutOfCatalogue),
    /// One of the ten catalogue effects or three out-of-catalogue ones, drawn from the seed.
    Random,
}

/// What a drive concealed (the answer).
#[derive(Debug, Clone, PartialEq)]
pub enum Concealed {
    /// Nothing.
    None,
    /// A catalogue effect.
    Catalogue {
        /// Catalogue id.
        id: &'static str,
        /// Parameter name (catalogue's).
        parameter: &'static str,
        /// Unit.
        unit: &'static str,
        /// Value the nominal model assumes (vehicle file, or 0 / 0.01 for sensor effects).
        nominal: f64,
        /// Value the truck really had.
        truth: f64,
    },
    /// An out-of-catalogue effect on a stretch.
    OutOfCatalogue {
        /// Kind.
        kind: OutOfCatalogue,
        /// Stretch start, m from the road start.
        start_m: f64,
        /// Stretch end, m.
        end_m: f64,
        /// Magnitude: c_r1 factor (wet), stretch length m (sensor), retarder N·m (retarder).
        magnitude: f64,
    },
}

/// Sensor and bus settings an effect changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSetup {
    /// Slope sensor mounting angle δ, rad (reads tan(α + δ)).
    pub slope_offset_rad: f64,
    /// Slope channel resolution, tan α units.
    pub slope_resolution: f64,
    /// Engine-torque channel delay, s.
    pub torque_delay_s: f64,
    /// Stuck speed channel stretch, m.
    pub speed_stuck: Option<(f64, f64)>,
}

impl Default for SensorSetup {
    fn default() -> Self {
        Self {
            slope_offset_rad: 0.0,
            slope_resolution: 0.01,
            torque_delay_s: 0.0,
            speed_stuck: None,
        }
    }
}

/// Plant-side extras an effect adds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlantExtras {
    /// Extra rolling resistance stretch `(start_m, end_m, factor)`.
    pub surface: Option<(f64, f64, f64)>,
    /// Hidden retarder `(start_m, end_m, torque_nm)`.
    pub retarder: Option<(f64, f64, f64)>,
}

fn signed(rng: &mut Xoshiro256StarStar, lo: f64, hi: f64) -> f64 {
    let m = rng.uniform(lo, hi);
    if rng.next_f64() < 0.5 {
        -m
    } else {
        m
    }
}

fn stretch(rng: &mut Xoshiro256StarStar, length_m: f64, len: f64) -> (f64, f64) {
    let len = len.min(0.9 * length_m);
    let a = rng.uniform(
        0.05 * length_m,
        (0.95 * length_m - len).max(0.05 * length_m),
    );
    (a, a + len)
}

/// Applies `effect` to the drawn truck `p` (nominal values from `nominal`), returning the
/// answer, the sensor setup and the plant extras. `rng` is the effect's own stream.
///
/// # Errors
/// [`TruthError::UnknownEffect`] for an id outside [`CATALOGUE`];
/// [`TruthError::BadParameter`] for a given value that is not finite or not physical.
pub fn apply(
    effect: &TruthEffect,
    nominal: &TruckParams,
    p: &mut TruckParams,
    length_m: f64,
    rng: &mut Xoshiro256StarStar,
) -> Result<(Concealed, SensorSetup, PlantExtras), TruthError> {
    let mut sensors = SensorSetup::default();
    let mut extras = PlantExtras::default();
    let chosen = match effect {
        TruthEffect::Random => {
            let k = (rng.next_f64() * 13.0).floor() as usize;
            if k < 10 {
                TruthEffect::Catalogue(CATALOGUE[k].0.to_string(), None)
            } else {
                TruthEffect::OutOfCatalogue(OutOfCatalogue::ALL[(k - 10).min(2)])
            }
        }
        e => e.clone(),
    };
    let concealed = match chosen {
        TruthEffect::None | TruthEffect::Random => Concealed::None,
        TruthEffect::OutOfCatalogue(kind) => {
            let (start_m, end_m, magnitude) = match kind {
                OutOfCatalogue::WetSurface => {
                    let frac = rng.uniform(0.15, 0.30);
                    let f = rng.uniform(1.3, 1.6);
                    let (a, b) = stretch(rng, length_m, frac * length_m);
                    extras.surface = Some((a, b, f));
                    (a, b, f)
                }
                OutOfCatalogue::StuckSpeedSensor => {
                    let len = rng.uniform(150.0, 400.0);
                    let (a, b) = stretch(rng, length_m, len);
                    sensors.speed_stuck = Some((a, b));
                    (a, b, b - a)
                }
                OutOfCatalogue::HiddenRetarder => {
                    let frac = rng.uniform(0.20, 0.40);
                    let m = rng.uniform(300.0, 600.0);
                    let (a, b) = stretch(rng, length_m, frac * length_m);
                    extras.retarder = Some((a, b, m));
                    (a, b, m)
                }
            };
            Concealed::OutOfCatalogue {
                kind,
                start_m,
                end_m,
                magnitude,
            }
        }
        TruthEffect::Catalogue(id, value) => {
            let Some(&(id, parameter, unit)) = CATALOGUE.iter().find(|c| c.0 == id) else {
                return Err(TruthError::UnknownEffect {
                    id,
                    known: CATALOGUE.map(|c| c.0).join(", "),
                });
            };
            if let Some(v) = value {
                // offsets may have either sign; a delay or a lash may be zero; the rest are
                // positive physical quantities
                let ok = v.is_finite()
                    && match id {
                        "grade_offset" | "engine_torque_offset" => true,
                        "signal_delay" | "driveline_backlash" => v >= 0.0,
                        _ => v > 0.0,
                    };
                if !ok {
                    return Err(TruthError::BadParameter {
                        parameter,
                        value: v,
                    });
                }
            }
            let pick = |rng: &mut Xoshiro256StarStar, base: f64, lo: f64, hi: f64| {
                value.unwrap_or_else(|| base * (1.0 + signed(rng, lo, hi)))
            };
            let (nom, truth) = match id {
                "aero_drag" => {
                    p.c_w_a_f_m2 = pick(rng, p.c_w_a_f_m2, 0.15, 0.40);
                    (nominal.c_w_a_f_m2, p.c_w_a_f_m2)
                }
                "rolling_resistance" => {
                    let f = match value {
                        Some(v) => v / p.c_r1,
                        None => 1.0 + signed(rng, 0.20, 0.50),
                    };
                    p.c_r1 *= f;
                    p.c_r2_s_per_m *= f;
                    (nominal.c_r1, p.c_r1)
                }
                "vehicle_mass" => {
                    let m = pick(rng, p.mass_kg, 0.08, 0.25);
                    p.tyre.fz_n *= m / p.mass_kg;
                    p.mass_kg = m;
                    (nominal.mass_kg, p.mass_kg)
                }
                "grade_offset" => {
                    let d = value.unwrap_or_else(|| signed(rng, 0.3, 1.1).to_radians());
                    sensors.slope_offset_rad = d;
                    (0.0, d)
                }
                "slope_quantization" => {
                    let r = value.unwrap_or_else(|| rng.uniform(0.0125, 0.02));
                    sensors.slope_resolution = r;
                    (0.01, r)
                }
                "signal_delay" => {
                    let d = value.unwrap_or_else(|| rng.uniform(0.1, 0.4));
                    sensors.torque_delay_s = d;
                    (0.0, d)
                }
                "driveline_backlash" => {
                    let b = value.unwrap_or_else(|| rng.uniform(0.015, 0.05));
                    p.lash_rad = b;
                    (0.0, b)
                }
                "driveline_compliance" => {
                    // the lumped flexibility (shafts in series with the tyres' carcass) scales
                    // by f: both the shafts and the tyres' carcass stiffness C_κ/σ (σ ÷ f, C_κ
                    // kept: the steady slip is unchanged) scale by f
                    let k0 = p.lumped_stiffness();
                    let f = match value {
                        Some(k) => k / k0,
                        None => 1.0 + signed(rng, 0.25, 0.50),
                    };
                    p.k_s *= f;
                    p.tyre.relaxation_m /= f;
                    (nominal.lumped_stiffness(), p.lumped_stiffness())
                }
                "engine_torque_offset" => {
                    let o = value.unwrap_or_else(|| signed(rng, 40.0, 150.0));
                    p.engine.map_offset_nm += o;
                    (0.0, p.engine.map_offset_nm)
                }
                _ => {
                    // clutch_slip
                    let c = value
                        .unwrap_or_else(|| nominal.clutch_kinetic_nm * rng.uniform(0.55, 0.65));
                    p.clutch_kinetic_nm = c;
                    p.clutch_static_ratio = 1.0;
                    (nominal.clutch_kinetic_nm, c)
                }
            };
            Concealed::Catalogue {
                id,
                parameter,
                unit,
                nominal: nom,
                truth,
            }
        }
    };
    p.validate()?;
    Ok((concealed, sensors, extras))
}
