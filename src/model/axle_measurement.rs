//! Axle-model parameters from measurements (axle-load thesis, §3.3; docs/models/axle.md): a
//! measurement file (scale weights, static bellow pressures, bellow force–displacement tests,
//! damper datasheets) is read, checked, and run through the estimation functions of
//! [`axle_estimation`](super::axle_estimation) with the geometry and axle masses of a vehicle
//! file's `[axles]` section. The result compares with the vehicle file and writes the estimated
//! `[axles]` keys as a TOML snippet (`fleetdyn estimate axle`).
//!
//! # Measurement file
//!
//! TOML, SI units, the unit in every key; unknown keys are errors. Example with every section:
//! `fixtures/measurements/seed002-static.toml`.
//!
//! ```toml
//! [scale]                  # required: axle scale weights of the vehicle at rest, kg
//! front_kg = 7600.0
//! rear_kg = 6800.0
//! tag_kg = 4300.0
//!
//! [static_pressure]        # optional, each key optional: bellow gauge pressure at rest on
//! front_pa = 600000.0      # the scale (the state the scale weights were taken in), Pa
//! rear_pa = 500000.0
//! tag_pa = 350000.0
//!
//! [[bellow_test]]          # optional, repeatable: force–displacement test of one axle's bellows
//! axle = "tag"             # "front" | "rear" | "tag"
//! displacement_m = [-0.02, 0.0, 0.02]   # bellow compression, m, + = the bellow shortens
//! pressure_pa = [318900.0, 350800.0, 382700.0]
//! # or force_n = [...]     # bellow force, N; give exactly one of force_n and pressure_pa
//!
//! [[damper_datasheet]]     # optional, at most one per axle: force–velocity points
//! axle = "rear"
//! velocity_m_per_s = [-0.52, -0.26, 0.26, 0.52]    # + = extension, − = compression
//! force_n = [-5300.0, -3500.0, 10600.0, 16000.0]   # the sign of its velocity
//! ```
//!
//! Conventions, as in the vehicle file: a bellow force, area, stiffness or damper force is the
//! axle's, both sides together (a one-damper datasheet is scaled by the number of dampers on the
//! axle before it goes here); pressures are gauge pressures; bellow displacement and stiffness
//! are at the bellow. Array entries are numbered from 0 in errors (`bellow_test[0]`).
//!
//! # Estimation (axle-load thesis, §3.3)
//!
//! With the scale weights `w_i` (N_i = w_i·g), the axle positions `x_r`, `x_t` behind the front
//! axle, the axle masses `m_ai` and the arm levers `l_a`, `l_b` of the vehicle file:
//! - total mass `m = Σ w_i` and vehicle CG `x_CG = (N_r x_r + N_t x_t)/(m g)` (eq. 3.3.2);
//! - chassis load on each axle `m_i = w_i − m_ai` (eq. 3.3.8), chassis mass `m_c = Σ m_i`, and
//!   chassis CG `x_c = Σ m_i x_i / m_c` (eq. 3.3.2 applied to the chassis loads: the axle masses
//!   sit at their axles);
//! - static bellow force `F_s = m_i g l_a/l_b` from each arm's moment balance (eq. 3.3.9); the
//!   front bellow acts directly above its axle, `F_s = m_f g` (eq. 3.3.5);
//! - effective bellow area `A_eff = F_s/p_s` where a static pressure is given (eq. 3.3.10);
//! - bellow stiffness: slope of the least-squares force–displacement line of each test (eq.
//!   3.3.6, thesis fig. 3.10), pressures converted to forces with `F = p·A_eff` (eq. 3.3.7) and
//!   the area estimated from the static state, as the thesis does; several tests of one axle are
//!   reported each, and the snippet takes the mean of their slopes;
//! - damper coefficients per branch, least squares through the origin (§3.3.3), and the
//!   datasheet points as the vehicle file's damper tables: extension (`v > 0`) and compression
//!   (`v < 0`) branches, both with positive speeds and forces, sorted by speed.

use super::axle::{Axle, AxleParams, DamperTable};
use super::axle_estimation::{
    bellow_stiffness, cg_from_scale_weights, damper_coefficients, effective_bellow_area,
    static_bellow_force, DamperFit, EstimationError, LineFit,
};
use super::vehicle::{VehicleError, VehicleFile};
use serde::Deserialize;
use std::fmt;
use std::path::Path;
use thiserror::Error;

/// A measurement file or an estimate that cannot be used; names the file and the key.
#[derive(Debug, Error)]
pub enum MeasurementError {
    /// Read error.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Syntax, unknown key, missing key or wrong type.
    #[error("{file}: {source}")]
    Parse {
        /// File.
        file: String,
        /// Cause (names the key and line).
        #[source]
        source: toml::de::Error,
    },
    /// A value outside its physical range.
    #[error("{file}: {key} = {value}: {rule}")]
    Value {
        /// File.
        file: String,
        /// Key, e.g. `scale.front_kg` or `bellow_test[0].pressure_pa`.
        key: String,
        /// Its value.
        value: String,
        /// The rule it breaks.
        rule: String,
    },
    /// An estimation step that the values of this key make impossible.
    #[error("{file}: {key}: {source}")]
    Estimate {
        /// File (measurement or vehicle file).
        file: String,
        /// Key whose values the step used.
        key: String,
        /// Why the estimate cannot be made.
        #[source]
        source: EstimationError,
    },
    /// The vehicle file has no `[axles]` section, or it cannot take the estimates.
    #[error("{source}")]
    Vehicle {
        /// Cause (names the file and key).
        #[source]
        source: VehicleError,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    scale: RawScale,
    static_pressure: Option<RawPressure>,
    #[serde(default)]
    bellow_test: Vec<RawBellowTest>,
    #[serde(default)]
    damper_datasheet: Vec<RawDatasheet>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScale {
    front_kg: f64,
    rear_kg: f64,
    tag_kg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPressure {
    front_pa: Option<f64>,
    rear_pa: Option<f64>,
    tag_pa: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBellowTest {
    axle: Axle,
    displacement_m: Vec<f64>,
    force_n: Option<Vec<f64>>,
    pressure_pa: Option<Vec<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDatasheet {
    axle: Axle,
    velocity_m_per_s: Vec<f64>,
    force_n: Vec<f64>,
}

/// What a bellow test measured alongside the displacement.
#[derive(Debug, Clone, PartialEq)]
pub enum BellowLoad {
    /// Bellow force, N.
    ForceN(Vec<f64>),
    /// Bellow gauge pressure, Pa (converted with `F = p·A_eff`, axle-load thesis, eq. 3.3.7).
    PressurePa(Vec<f64>),
}

/// A force–displacement test of one axle's bellows.
#[derive(Debug, Clone, PartialEq)]
pub struct BellowTest {
    /// Axle.
    pub axle: Axle,
    /// Bellow compression, m, + = the bellow shortens.
    pub displacement_m: Vec<f64>,
    /// Force or pressure at each displacement.
    pub load: BellowLoad,
}

/// A damper datasheet: force–velocity points of one axle's dampers.
#[derive(Debug, Clone, PartialEq)]
pub struct DamperDatasheet {
    /// Axle.
    pub axle: Axle,
    /// Velocity, m/s, + = extension.
    pub velocity_m_per_s: Vec<f64>,
    /// Force, N, with the sign of its velocity.
    pub force_n: Vec<f64>,
}

/// A checked measurement file (format in the module doc). Per-axle arrays are in
/// [`Axle::ALL`] order: front, rear, tag.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurements {
    /// The file, as named in errors and in the snippet's header.
    pub file: String,
    /// Scale weights, kg.
    pub scale_weight_kg: [f64; 3],
    /// Static bellow gauge pressures, Pa, where measured.
    pub static_pressure_pa: [Option<f64>; 3],
    /// Bellow force–displacement tests.
    pub bellow_tests: Vec<BellowTest>,
    /// Damper datasheets, at most one per axle.
    pub damper_datasheets: Vec<DamperDatasheet>,
}

impl Measurements {
    /// Reads and checks a measurement file.
    ///
    /// # Errors
    /// [`MeasurementError`] naming the file and the offending key.
    pub fn load(path: &Path) -> Result<Self, MeasurementError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| MeasurementError::Io {
            file: file.clone(),
            source: e,
        })?;
        Self::parse(&text, &file)
    }

    /// Parses and checks measurement-file text; `file` names it in errors.
    ///
    /// # Errors
    /// [`MeasurementError::Parse`] for syntax, unknown, missing or mistyped keys;
    /// [`MeasurementError::Value`] for a scale weight or static pressure that is not positive and
    /// finite, a bellow test with both or neither of `force_n` and `pressure_pa`, a negative or
    /// non-finite test pressure, or two damper datasheets for one axle.
    pub fn parse(text: &str, file: &str) -> Result<Self, MeasurementError> {
        let raw: RawFile = toml::from_str(text).map_err(|e| MeasurementError::Parse {
            file: file.into(),
            source: e,
        })?;
        let value = |key: String, value: String, rule: &str| MeasurementError::Value {
            file: file.into(),
            key,
            value,
            rule: rule.into(),
        };
        let scale = [raw.scale.front_kg, raw.scale.rear_kg, raw.scale.tag_kg];
        for (a, w) in Axle::ALL.iter().zip(scale) {
            if !(w.is_finite() && w > 0.0) {
                return Err(value(
                    format!("scale.{}_kg", a.name()),
                    w.to_string(),
                    "a scale weight must be positive and finite",
                ));
            }
        }
        let pressure = match raw.static_pressure {
            Some(p) => [p.front_pa, p.rear_pa, p.tag_pa],
            None => [None; 3],
        };
        for (a, p) in Axle::ALL.iter().zip(pressure) {
            if let Some(p) = p {
                if !(p.is_finite() && p > 0.0) {
                    return Err(value(
                        format!("static_pressure.{}_pa", a.name()),
                        p.to_string(),
                        "a static gauge pressure must be positive and finite: a bellow carrying load is above ambient pressure",
                    ));
                }
            }
        }
        let mut bellow_tests = Vec::with_capacity(raw.bellow_test.len());
        for (k, t) in raw.bellow_test.into_iter().enumerate() {
            let load = match (t.force_n, t.pressure_pa) {
                (Some(f), None) => BellowLoad::ForceN(f),
                (None, Some(p)) => {
                    if let Some(bad) = p.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                        return Err(value(
                            format!("bellow_test[{k}].pressure_pa"),
                            bad.to_string(),
                            "gauge pressures must be finite and not negative",
                        ));
                    }
                    BellowLoad::PressurePa(p)
                }
                (f, p) => {
                    return Err(value(
                        format!("bellow_test[{k}]"),
                        format!(
                            "force_n {}, pressure_pa {}",
                            if f.is_some() { "given" } else { "absent" },
                            if p.is_some() { "given" } else { "absent" }
                        ),
                        "give exactly one of force_n and pressure_pa",
                    ))
                }
            };
            bellow_tests.push(BellowTest {
                axle: t.axle,
                displacement_m: t.displacement_m,
                load,
            });
        }
        let mut damper_datasheets: Vec<DamperDatasheet> = Vec::new();
        for (k, d) in raw.damper_datasheet.into_iter().enumerate() {
            if let Some(j) = damper_datasheets.iter().position(|e| e.axle == d.axle) {
                return Err(value(
                    format!("damper_datasheet[{k}].axle"),
                    format!("\"{}\"", d.axle.name()),
                    &format!("damper_datasheet[{j}] is already for this axle; give one datasheet per axle"),
                ));
            }
            damper_datasheets.push(DamperDatasheet {
                axle: d.axle,
                velocity_m_per_s: d.velocity_m_per_s,
                force_n: d.force_n,
            });
        }
        Ok(Self {
            file: file.into(),
            scale_weight_kg: scale,
            static_pressure_pa: pressure,
            bellow_tests,
            damper_datasheets,
        })
    }
}

/// Bellow stiffness from one test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StiffnessEstimate {
    /// Axle.
    pub axle: Axle,
    /// Index of the test in the file's `[[bellow_test]]` entries.
    pub test: usize,
    /// Force–displacement line: slope N/m (the stiffness), intercept N, R².
    pub fit: LineFit,
    /// Whether the forces came from pressures (`F = p·A_eff`).
    pub from_pressure: bool,
}

/// Damper estimates from one datasheet.
#[derive(Debug, Clone, PartialEq)]
pub struct DamperEstimate {
    /// Axle.
    pub axle: Axle,
    /// Index of the datasheet in the file's `[[damper_datasheet]]` entries.
    pub datasheet: usize,
    /// Linear coefficients per branch, N·s/m.
    pub fit: DamperFit,
    /// The datasheet points as the vehicle file's tables (positive speeds and forces).
    pub table: DamperTable,
}

/// Every estimate of the axle-load thesis, §3.3, SI units (the unit is in each name); per-axle
/// arrays in [`Axle::ALL`] order.
#[derive(Debug, Clone, PartialEq)]
pub struct AxleEstimate {
    /// The measurement file.
    pub measurement_file: String,
    /// The vehicle file that gave the geometry and axle masses.
    pub vehicle_file: String,
    /// Scale weights as measured, kg.
    pub scale_weight_kg: [f64; 3],
    /// Total mass `Σ w_i`, kg.
    pub mass_kg: f64,
    /// Vehicle CG behind the front axle (eq. 3.3.2), m.
    pub x_cg_m: f64,
    /// Chassis (sprung) mass `Σ w_i − Σ m_ai`, kg.
    pub chassis_mass_kg: f64,
    /// Chassis CG behind the front axle, m.
    pub chassis_x_cg_m: f64,
    /// Static bellow forces (eq. 3.3.9; front eq. 3.3.5), N.
    pub bellow_force_n: [f64; 3],
    /// Effective bellow areas `F_s/p_s` (eq. 3.3.10) where a static pressure was given, m².
    pub bellow_area_m2: [Option<f64>; 3],
    /// Bellow stiffness per test (eq. 3.3.6).
    pub stiffness: Vec<StiffnessEstimate>,
    /// Damper coefficients and tables per datasheet.
    pub dampers: Vec<DamperEstimate>,
}

/// Arm levers `(l_a, l_b)` of an axle; the front bellow acts directly above its axle, which is
/// the lever ratio 1 (axle-load thesis, eq. 3.3.5).
fn levers(v: &AxleParams, a: Axle) -> (f64, f64) {
    v.arm(a).map_or((1.0, 1.0), |(_, la, lb, _, _)| (la, lb))
}

/// Datasheet points as the vehicle file's branch tables (module doc), checked so that the
/// vehicle file accepts them: signs, at least two points per branch, speeds strictly
/// increasing, forces not falling. A point (0, 0) carries no information and is dropped.
fn datasheet_table(
    d: &DamperDatasheet,
    k: usize,
    file: &str,
) -> Result<DamperTable, MeasurementError> {
    let value = |key: &str, value: String, rule: String| MeasurementError::Value {
        file: file.into(),
        key: format!("damper_datasheet[{k}].{key}"),
        value,
        rule,
    };
    if d.velocity_m_per_s.len() != d.force_n.len() {
        return Err(value(
            "force_n",
            format!("{} values", d.force_n.len()),
            format!(
                "needs one force per velocity ({} velocities)",
                d.velocity_m_per_s.len()
            ),
        ));
    }
    let (mut ext, mut comp) = (Vec::new(), Vec::new());
    for (&v, &f) in d.velocity_m_per_s.iter().zip(&d.force_n) {
        if !(v.is_finite() && f.is_finite()) {
            return Err(value(
                "force_n",
                format!("({v} m/s, {f} N)"),
                "must be finite".into(),
            ));
        }
        if v == 0.0 && f == 0.0 {
            continue;
        }
        if v * f <= 0.0 {
            return Err(value(
                "force_n",
                format!("{f} at {v} m/s"),
                "a damper force has the sign of its velocity (+ extension, − compression) and is not zero".into(),
            ));
        }
        if v > 0.0 {
            ext.push((v, f));
        } else {
            comp.push((-v, -f));
        }
    }
    let branch = |pts: &mut Vec<(f64, f64)>,
                  name: &str|
     -> Result<(Vec<f64>, Vec<f64>), MeasurementError> {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() < 2 {
            return Err(value(
                "velocity_m_per_s",
                format!("{} {name} points", pts.len()),
                format!("the vehicle file's damper tables need at least 2 points per branch ({name}: {})", if name == "extension" { "v > 0" } else { "v < 0" }),
            ));
        }
        if let Some(w) = pts.windows(2).find(|w| w[1].0 == w[0].0) {
            return Err(value(
                "velocity_m_per_s",
                format!("{}", w[0].0),
                format!("two {name} points at the same speed"),
            ));
        }
        if let Some(w) = pts.windows(2).find(|w| w[1].1 < w[0].1) {
            return Err(value(
                "force_n",
                format!(
                    "{} N at {} m/s, {} N at {} m/s",
                    w[0].1, w[0].0, w[1].1, w[1].0
                ),
                format!("the {name} force must not fall as the speed rises"),
            ));
        }
        Ok(pts.iter().copied().unzip())
    };
    let (ext_v, ext_f) = branch(&mut ext, "extension")?;
    let (comp_v, comp_f) = branch(&mut comp, "compression")?;
    Ok(DamperTable {
        ext_v,
        ext_f,
        comp_v,
        comp_f,
    })
}

/// Runs the estimation of the axle-load thesis, §3.3 (module doc) on checked measurements with
/// the geometry and axle masses of a vehicle file's `[axles]` section; `vehicle_file` names it
/// in errors.
///
/// # Errors
/// [`MeasurementError::Estimate`] naming the file and key: scale weights that leave no load on
/// an axle's bellows, the vehicle file's tag axle not behind its driven axle, a degenerate
/// bellow test or datasheet; [`MeasurementError::Value`] for a test pressure without the static
/// pressure of its axle, a falling force–displacement line, or datasheet points the vehicle
/// file's damper tables cannot take.
pub fn estimate(
    m: &Measurements,
    v: &AxleParams,
    vehicle_file: &str,
) -> Result<AxleEstimate, MeasurementError> {
    let file = m.file.as_str();
    let at = |file: &str, key: String| {
        let file = file.to_string();
        move |source| MeasurementError::Estimate { file, key, source }
    };
    let g = v.gravity_m_per_s2;
    let w = m.scale_weight_kg;
    let mut bellow_force_n = [0.0; 3];
    for (k, a) in Axle::ALL.iter().enumerate() {
        let (la, lb) = levers(v, *a);
        bellow_force_n[k] = static_bellow_force(w[k], v.axle_mass(*a), la, lb, g)
            .map_err(at(file, format!("scale.{}_kg", a.name())))?;
    }
    let geometry_key = |e: &EstimationError| match e {
        EstimationError::Value { quantity, .. } if quantity.starts_with("rear") => {
            "axles.rear_axle_x_m"
        }
        _ => "axles.tag_axle_x_m",
    };
    let (xr, xt) = (v.rear_axle_x_m, v.tag_axle_x_m);
    let vehicle = cg_from_scale_weights(w[0], w[1], w[2], xr, xt).map_err(|e| {
        MeasurementError::Estimate {
            file: vehicle_file.into(),
            key: geometry_key(&e).into(),
            source: e,
        }
    })?;
    // the chassis loads m_i = w_i − m_ai are positive (checked with the bellow forces above)
    let load = |k: usize| w[k] - v.axle_mass(Axle::ALL[k]);
    let chassis = cg_from_scale_weights(load(0), load(1), load(2), xr, xt).map_err(|e| {
        MeasurementError::Estimate {
            file: vehicle_file.into(),
            key: geometry_key(&e).into(),
            source: e,
        }
    })?;
    let mut bellow_area_m2 = [None; 3];
    for (k, a) in Axle::ALL.iter().enumerate() {
        if let Some(p) = m.static_pressure_pa[k] {
            let (la, lb) = levers(v, *a);
            bellow_area_m2[k] = Some(
                effective_bellow_area(load(k), la, lb, p, g)
                    .map_err(at(file, format!("static_pressure.{}_pa", a.name())))?,
            );
        }
    }
    let mut stiffness = Vec::with_capacity(m.bellow_tests.len());
    for (k, t) in m.bellow_tests.iter().enumerate() {
        let i = t.axle.index();
        let (force, from_pressure) = match &t.load {
            BellowLoad::ForceN(f) => (f.clone(), false),
            BellowLoad::PressurePa(p) => {
                let area = bellow_area_m2[i].ok_or_else(|| MeasurementError::Value {
                    file: file.into(),
                    key: format!("bellow_test[{k}].pressure_pa"),
                    value: format!("{} pressures", p.len()),
                    rule: format!(
                        "converting pressure to force (F = p·A_eff, seed 002 eq. 3.3.7) needs A_eff from the static state: give static_pressure.{}_pa, or give force_n instead",
                        t.axle.name()
                    ),
                })?;
                (p.iter().map(|p| p * area).collect(), true)
            }
        };
        let fit = bellow_stiffness(&t.displacement_m, &force)
            .map_err(at(file, format!("bellow_test[{k}]")))?;
        if fit.slope <= 0.0 {
            return Err(MeasurementError::Value {
                file: file.into(),
                key: format!("bellow_test[{k}].displacement_m"),
                value: format!("slope {} N/m", fit.slope),
                rule: "the bellow force must rise with the displacement: displacement_m is the bellow's compression (+ = shortening)".into(),
            });
        }
        stiffness.push(StiffnessEstimate {
            axle: t.axle,
            test: k,
            fit,
            from_pressure,
        });
    }
    let mut dampers = Vec::with_capacity(m.damper_datasheets.len());
    for (k, d) in m.damper_datasheets.iter().enumerate() {
        let table = datasheet_table(d, k, file)?;
        let fit = damper_coefficients(&d.velocity_m_per_s, &d.force_n)
            .map_err(at(file, format!("damper_datasheet[{k}]")))?;
        dampers.push(DamperEstimate {
            axle: d.axle,
            datasheet: k,
            fit,
            table,
        });
    }
    Ok(AxleEstimate {
        measurement_file: m.file.clone(),
        vehicle_file: vehicle_file.into(),
        scale_weight_kg: w,
        mass_kg: vehicle.mass_kg,
        x_cg_m: vehicle.x_cg_m,
        chassis_mass_kg: chassis.mass_kg,
        chassis_x_cg_m: chassis.x_cg_m,
        bellow_force_n,
        bellow_area_m2,
        stiffness,
        dampers,
    })
}

/// Damper coefficients of a vehicle file's tables, fitted as a datasheet would be.
fn table_coefficients(t: &DamperTable) -> Option<DamperFit> {
    let v: Vec<f64> = t
        .ext_v
        .iter()
        .copied()
        .chain(t.comp_v.iter().map(|x| -x))
        .collect();
    let f: Vec<f64> = t
        .ext_f
        .iter()
        .copied()
        .chain(t.comp_f.iter().map(|x| -x))
        .collect();
    damper_coefficients(&v, &f).ok()
}

/// One row of the comparison with the vehicle file.
#[derive(Debug, Clone, PartialEq)]
pub struct ComparisonRow {
    /// What was estimated, with its source.
    pub quantity: String,
    /// The estimate.
    pub estimate: f64,
    /// Its unit.
    pub unit: &'static str,
    /// The vehicle file's value (given or derived by its static state), if it has one.
    pub vehicle: Option<f64>,
}

/// The estimates beside the vehicle file's values; `Display` prints the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Rows in print order.
    pub rows: Vec<ComparisonRow>,
}

/// `x` with 6 significant digits, trailing zeros dropped; scientific outside 1e-3 … 1e7.
fn sig6(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor();
    if !(-3.0..7.0).contains(&mag) {
        return format!("{x:.5e}");
    }
    let s = format!("{:.*}", (5.0 - mag).max(0.0) as usize, x);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `x` rounded to 6 significant digits, as a TOML float.
fn toml6(x: f64) -> String {
    let r: f64 = format!("{x:.5e}").parse().unwrap_or(x);
    format!("{r:?}")
}

fn toml_list(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
    format!("[{}]", items.join(", "))
}

impl AxleEstimate {
    /// The bellow stiffness the snippet takes for an axle: the mean slope of its tests, N/m.
    pub fn bellow_stiffness_n_per_m(&self, a: Axle) -> Option<f64> {
        let s: Vec<f64> = self
            .stiffness
            .iter()
            .filter(|s| s.axle == a)
            .map(|s| s.fit.slope)
            .collect();
        (!s.is_empty()).then(|| s.iter().sum::<f64>() / s.len() as f64)
    }

    /// The damper estimate of an axle, if a datasheet was given.
    pub fn damper(&self, a: Axle) -> Option<&DamperEstimate> {
        self.dampers.iter().find(|d| d.axle == a)
    }

    /// Every estimate beside the vehicle file's value: its keys, or what its static state derives
    /// from them (CGs, bellow forces), or a fit of its damper tables.
    pub fn comparison(&self, v: &AxleParams) -> Comparison {
        let st = v.static_state();
        let mut rows = Vec::new();
        let mut row =
            |quantity: String, estimate: f64, unit: &'static str, vehicle: Option<f64>| {
                rows.push(ComparisonRow {
                    quantity,
                    estimate,
                    unit,
                    vehicle,
                })
            };
        for (k, a) in Axle::ALL.iter().enumerate() {
            row(
                format!("scale weight {}", a.name()),
                self.scale_weight_kg[k],
                "kg",
                Some(v.scale_weight(*a)),
            );
        }
        row(
            "total mass (sum of scale weights)".into(),
            self.mass_kg,
            "kg",
            Some(v.mass_kg()),
        );
        row(
            "vehicle CG x behind front axle (eq. 3.3.2)".into(),
            self.x_cg_m,
            "m",
            Some(st.x_cg_m),
        );
        row(
            "chassis mass (scale weights - axle masses)".into(),
            self.chassis_mass_kg,
            "kg",
            Some(v.chassis_mass_kg),
        );
        row(
            "chassis CG x behind front axle".into(),
            self.chassis_x_cg_m,
            "m",
            Some(st.chassis_x_cg_m),
        );
        for (k, a) in Axle::ALL.iter().enumerate() {
            let eq = if *a == Axle::Front { "3.3.5" } else { "3.3.9" };
            row(
                format!("static bellow force {} (eq. {eq})", a.name()),
                self.bellow_force_n[k],
                "N",
                Some(st.bellow_n[k]),
            );
        }
        for (k, a) in Axle::ALL.iter().enumerate() {
            if let Some(area) = self.bellow_area_m2[k] {
                row(
                    format!("bellow area {} (eq. 3.3.10)", a.name()),
                    area,
                    "m^2",
                    Some(v.bellow_area(*a)),
                );
            }
        }
        for s in &self.stiffness {
            row(
                format!(
                    "bellow stiffness {}, bellow_test[{}] (R^2 {:.6})",
                    s.axle.name(),
                    s.test,
                    s.fit.r2
                ),
                s.fit.slope,
                "N/m",
                Some(v.bellow_stiffness(s.axle)),
            );
        }
        for d in &self.dampers {
            let current = table_coefficients(&v.damper(d.axle));
            for (branch, c, cur) in [
                (
                    "extension",
                    d.fit.extension_ns_per_m,
                    current.map(|f| f.extension_ns_per_m),
                ),
                (
                    "compression",
                    d.fit.compression_ns_per_m,
                    current.map(|f| f.compression_ns_per_m),
                ),
            ] {
                row(
                    format!(
                        "damper {} {branch}, damper_datasheet[{}]",
                        d.axle.name(),
                        d.datasheet
                    ),
                    c,
                    "N*s/m",
                    cur,
                );
            }
        }
        Comparison { rows }
    }

    /// The estimates as a TOML snippet of `[axles]` keys, with a header comment that says where
    /// each came from: `scale_weight_*_kg` and `chassis_mass_kg` always, `bellow_area_*_m2`
    /// where static pressures were given, `bellow_stiffness_*_n_per_m` where tests were,
    /// `damper_*` tables where datasheets were. Estimated values carry 6 significant digits,
    /// measured values are copied as written.
    pub fn snippet(&self) -> String {
        let mut s = String::new();
        let mut line = |l: &str| {
            s.push_str(l);
            s.push('\n');
        };
        line("# [axles] keys estimated by `fleetdyn estimate axle` (seed 002 §3.3, physics.md §3)");
        line(&format!("#   measurements: {}", self.measurement_file));
        line(&format!(
            "#   vehicle file: {} (axle positions, arm levers, axle masses, gravity)",
            self.vehicle_file
        ));
        line("# Replace these keys in the vehicle file's [axles] section.");
        line("#   scale_weight_*_kg: [scale] as weighed");
        line("#   chassis_mass_kg: sum of the scale weights minus the axle masses (eq. 3.3.8)");
        if self.bellow_area_m2.iter().any(Option::is_some) {
            line("#   bellow_area_*_m2: A_eff = F_s/p_s (eq. 3.3.10), F_s from the arm's moment balance");
            line("#     (eq. 3.3.9; front eq. 3.3.5) and p_s from [static_pressure]");
        }
        if !self.stiffness.is_empty() {
            line("#   bellow_stiffness_*_n_per_m: slope of the force-displacement line (eq. 3.3.6) of");
            line("#     [[bellow_test]] (mean over an axle's tests), pressures as F = p·A_eff (eq. 3.3.7)");
        }
        if !self.dampers.is_empty() {
            line("#   damper_*: [[damper_datasheet]] points split into extension (v > 0) and");
            line("#     compression (v < 0) branches, positive speeds and forces");
        }
        line(&format!(
            "# Derived, for reference (not keys): vehicle CG {} m and chassis CG {} m behind the front axle.",
            sig6(self.x_cg_m),
            sig6(self.chassis_x_cg_m)
        ));
        line("[axles]");
        for (k, a) in Axle::ALL.iter().enumerate() {
            line(&format!(
                "scale_weight_{}_kg = {:?}",
                a.name(),
                self.scale_weight_kg[k]
            ));
        }
        line(&format!(
            "chassis_mass_kg = {}",
            toml6(self.chassis_mass_kg)
        ));
        for (k, a) in Axle::ALL.iter().enumerate() {
            if let Some(area) = self.bellow_area_m2[k] {
                line(&format!(
                    "bellow_area_{}_m2 = {}   # static_pressure.{}_pa",
                    a.name(),
                    toml6(area),
                    a.name()
                ));
            }
        }
        for a in Axle::ALL {
            if let Some(c) = self.bellow_stiffness_n_per_m(a) {
                let tests: Vec<String> = self
                    .stiffness
                    .iter()
                    .filter(|s| s.axle == a)
                    .map(|s| format!("bellow_test[{}] R^2 {:.6}", s.test, s.fit.r2))
                    .collect();
                line(&format!(
                    "bellow_stiffness_{}_n_per_m = {}   # {}",
                    a.name(),
                    toml6(c),
                    tests.join(", ")
                ));
            }
        }
        for d in &self.dampers {
            let n = d.axle.name();
            line(&format!("# damper_datasheet[{}]", d.datasheet));
            for (key, vals) in [
                ("extension_velocity_m_per_s", &d.table.ext_v),
                ("extension_force_n", &d.table.ext_f),
                ("compression_velocity_m_per_s", &d.table.comp_v),
                ("compression_force_n", &d.table.comp_f),
            ] {
                line(&format!("damper_{n}_{key} = {}", toml_list(vals)));
            }
        }
        s
    }

    /// The vehicle file with the snippet's keys replacing those in its `[axles]` section, checked
    /// as a vehicle file (comments are not kept: this is for checking, not for writing back).
    ///
    /// # Errors
    /// [`MeasurementError::Vehicle`] when the text is not a vehicle file with an `[axles]` table,
    /// or when the merged file breaks a rule of `schemas/vehicle.toml` or of the axle model
    /// (naming the key).
    pub fn merged_vehicle(
        &self,
        vehicle_text: &str,
        vehicle_file: &str,
    ) -> Result<VehicleFile, MeasurementError> {
        let label = format!("{vehicle_file} with the estimated [axles] keys");
        let parse = |source| MeasurementError::Vehicle {
            source: VehicleError::Parse {
                file: label.clone(),
                source,
            },
        };
        let mut doc: toml::Table = toml::from_str(vehicle_text).map_err(parse)?;
        let snippet: toml::Table = toml::from_str(&self.snippet()).map_err(parse)?;
        let missing = || MeasurementError::Vehicle {
            source: VehicleError::Range {
                file: vehicle_file.into(),
                key: "axles".into(),
                value: "missing".into(),
                rule: "the estimates go into an [axles] section".into(),
            },
        };
        let axles = doc
            .get_mut("axles")
            .and_then(toml::Value::as_table_mut)
            .ok_or_else(missing)?;
        if let Some(new) = snippet.get("axles").and_then(toml::Value::as_table) {
            for (k, val) in new {
                axles.insert(k.clone(), val.clone());
            }
        }
        let text = toml::to_string(&doc).map_err(|e| MeasurementError::Vehicle {
            source: VehicleError::Range {
                file: label.clone(),
                key: "axles".into(),
                value: String::new(),
                rule: e.to_string(),
            },
        })?;
        VehicleFile::parse(&text, &label).map_err(|source| MeasurementError::Vehicle { source })
    }
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let cells: Vec<[String; 5]> = self
            .rows
            .iter()
            .map(|r| {
                let (cur, diff) = match r.vehicle {
                    Some(c) => {
                        let d = r.estimate - c;
                        let rel = if c != 0.0 {
                            format!(" ({:+.2} %)", 100.0 * d / c)
                        } else {
                            String::new()
                        };
                        (sig6(c), format!("{}{rel}", sig6(d)))
                    }
                    None => ("-".into(), "-".into()),
                };
                [
                    r.quantity.clone(),
                    sig6(r.estimate),
                    r.unit.to_string(),
                    cur,
                    diff,
                ]
            })
            .collect();
        let head = ["quantity", "estimate", "unit", "vehicle file", "difference"];
        let width = |i: usize| {
            cells
                .iter()
                .map(|c| c[i].chars().count())
                .chain([head[i].len()])
                .max()
                .unwrap_or(0)
        };
        let w = [width(0), width(1), width(2), width(3)];
        let mut row = |c: [&str; 5]| {
            writeln!(
                f,
                "{:<w0$}  {:>w1$}  {:<w2$}  {:>w3$}  {}",
                c[0],
                c[1],
                c[2],
                c[3],
                c[4],
                w0 = w[0],
                w1 = w[1],
                w2 = w[2],
                w3 = w[3]
            )
        };
        row(head)?;
        for c in &cells {
            row([&c[0], &c[1], &c[2], &c[3], &c[4]])?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig6(18700.0), "18700");
        assert_eq!(sig6(0.1087), "0.1087");
        assert_eq!(sig6(1.234567891), "1.23457");
        assert_eq!(sig6(-1.5e-9), "-1.50000e-9");
        assert_eq!(toml6(0.109_706_123), "0.109706");
        assert_eq!(toml6(15800.0), "15800.0");
    }

    #[test]
    fn datasheet_branches_become_positive_tables() {
        let d = DamperDatasheet {
            axle: Axle::Rear,
            velocity_m_per_s: vec![0.52, -0.13, 0.0, 0.13, -0.52],
            force_n: vec![16000.0, -2300.0, 0.0, 6800.0, -5300.0],
        };
        let t = datasheet_table(&d, 0, "m.toml").unwrap();
        assert_eq!(t.ext_v, [0.13, 0.52]);
        assert_eq!(t.ext_f, [6800.0, 16000.0]);
        assert_eq!(t.comp_v, [0.13, 0.52]);
        assert_eq!(t.comp_f, [2300.0, 5300.0]);
        let bad = DamperDatasheet {
            force_n: vec![16000.0, 2300.0, 0.0, 6800.0, -5300.0],
            ..d
        };
        let e = datasheet_table(&bad, 3, "m.toml").unwrap_err().to_string();
        assert!(e.contains("m.toml: damper_datasheet[3].force_n"), "{e}");
    }
}
