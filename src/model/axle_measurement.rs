//! Measurement files of axle-model parameters (axle-load thesis, §3.3; docs/models/axle.md): a
//! measurement file (scale weights, static bellow pressures, bellow force–displacement tests,
//! damper datasheets) is read and checked into [`Measurements`]. The estimation that runs on
//! them is [`super::axle_estimate`]; its comparison with the vehicle file and the estimated
//! `[axles]` keys as a TOML snippet (`fleetdyn estimate axle`) are
//! [`super::axle_estimate_output`].
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

use super::axle::Axle;
use super::axle_estimation::EstimationError;
use super::vehicle::VehicleError;
use serde::Deserialize;
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
