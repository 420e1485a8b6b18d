//! Units at the edges: conversion of source units into the SI units of the canonical drive log.
//!
//! Every canonical column has a *quantity* (see `schemas/drive-log.toml`); a mapping file names
//! the unit its source uses, and [`conversion`] returns how to turn that unit into the column's SI
//! unit. Units are never guessed: an unknown unit, or a unit of another quantity, is an error.
//!
//! Conventions:
//! - `grade` is the road slope as tan(α) (dimensionless). A source in `%` is scaled by 0.01; a
//!   source in `deg` or `rad` is an *angle* and is converted with tan(α), not scaled.
//! - `torque` in `%` is J1939's percent of the engine reference torque (EC1); the mapping must
//!   give `reference_torque_nm`.
//! - Pressures are gauge pressures; no atmospheric offset is added or removed.

use thiserror::Error;

/// A unit conversion into SI: `si = convert(source)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Conversion {
    /// `si = factor · x + offset`.
    Linear {
        /// Multiplier.
        factor: f64,
        /// Additive offset after scaling.
        offset: f64,
    },
    /// An angle (given in units of `to_rad` radians) converted to a grade tan(α).
    AngleToGrade {
        /// Radians per source unit.
        to_rad: f64,
    },
}

impl Conversion {
    /// The identity conversion.
    pub const IDENTITY: Conversion = Conversion::Linear {
        factor: 1.0,
        offset: 0.0,
    };

    /// Applies the conversion to one value (NaN stays NaN).
    #[inline]
    pub fn apply(&self, x: f64) -> f64 {
        match *self {
            Conversion::Linear { factor, offset } => factor * x + offset,
            Conversion::AngleToGrade { to_rad } => (x * to_rad).tan(),
        }
    }
}

/// Why a unit could not be converted.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum UnitError {
    /// The unit string is not one fleetdyn knows.
    #[error("unknown unit `{unit}` for quantity {quantity} (known: {known})")]
    Unknown {
        /// The unit as written.
        unit: String,
        /// The quantity of the target column.
        quantity: String,
        /// The units accepted for that quantity.
        known: String,
    },
    /// `%` torque without the engine reference torque.
    #[error("torque in % needs `reference_torque_nm` (J1939 EC1 engine reference torque)")]
    MissingReferenceTorque,
}

/// Units accepted per quantity: (spellings, conversion into the quantity's SI unit).
fn table(quantity: &str) -> Vec<(&'static [&'static str], Conversion)> {
    use std::f64::consts::PI;
    const fn lin(factor: f64) -> Conversion {
        Conversion::Linear {
            factor,
            offset: 0.0,
        }
    }
    const DEG: f64 = PI / 180.0;
    match quantity {
        "speed" => vec![
            (&["m/s", "mps"], lin(1.0)),
            (&["km/h", "kph", "kmh", "kmph"], lin(1.0 / 3.6)),
            (&["mph"], lin(0.44704)),
        ],
        "angular_speed" | "angular_rate" => vec![
            (&["rad/s"], lin(1.0)),
            (&["rpm", "1/min", "r/min"], lin(2.0 * PI / 60.0)),
            (&["deg/s"], lin(DEG)),
        ],
        "torque" => vec![
            (&["N*m", "Nm", "N·m", "N m"], lin(1.0)),
            (&["kN*m", "kNm", "kN·m"], lin(1000.0)),
        ],
        "grade" => vec![
            (&["1", "tan", "m/m"], lin(1.0)),
            (&["%", "percent"], lin(0.01)),
            (&["deg"], Conversion::AngleToGrade { to_rad: DEG }),
            (&["rad"], Conversion::AngleToGrade { to_rad: 1.0 }),
        ],
        "fraction" => vec![(&["1"], lin(1.0)), (&["%", "percent"], lin(0.01))],
        "force" => vec![(&["N"], lin(1.0)), (&["kN"], lin(1000.0))],
        "pressure" => vec![
            (&["Pa"], lin(1.0)),
            (&["kPa"], lin(1e3)),
            (&["MPa"], lin(1e6)),
            (&["bar"], lin(1e5)),
            (&["mbar"], lin(100.0)),
            (&["psi"], lin(6894.757293168361)),
        ],
        "length" => vec![
            (&["m"], lin(1.0)),
            (&["km"], lin(1000.0)),
            (&["mm"], lin(1e-3)),
            (&["cm"], lin(1e-2)),
            (&["mi"], lin(1609.344)),
            (&["ft"], lin(0.3048)),
        ],
        "acceleration" => vec![
            (&["m/s^2", "m/s2", "m/s²"], lin(1.0)),
            (&["g"], lin(9.80665)),
        ],
        "geo_angle" => vec![(&["deg"], lin(1.0)), (&["rad"], lin(180.0 / PI))],
        "count" => vec![(&["1"], lin(1.0))],
        _ => Vec::new(),
    }
}

/// The conversion from `unit` into the SI unit of `quantity`.
///
/// `reference_torque_nm` is used only for torque given in `%`.
///
/// # Errors
/// [`UnitError::Unknown`] when the unit is not known for that quantity;
/// [`UnitError::MissingReferenceTorque`] for `%` torque without a reference.
pub fn conversion(
    unit: &str,
    quantity: &str,
    reference_torque_nm: Option<f64>,
) -> Result<Conversion, UnitError> {
    let unit = unit.trim();
    if quantity == "torque" && (unit == "%" || unit == "percent") {
        return match reference_torque_nm {
            Some(r) => Ok(Conversion::Linear {
                factor: r / 100.0,
                offset: 0.0,
            }),
            None => Err(UnitError::MissingReferenceTorque),
        };
    }
    let rows = table(quantity);
    for (names, conv) in &rows {
        if names.contains(&unit) {
            return Ok(*conv);
        }
    }
    let mut known: Vec<&str> = rows.iter().flat_map(|(n, _)| n.iter().copied()).collect();
    if quantity == "torque" {
        known.push("% (with reference_torque_nm)");
    }
    Err(UnitError::Unknown {
        unit: unit.to_string(),
        quantity: quantity.to_string(),
        known: known.join(", "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converts_common_fleet_units() {
        let c = conversion("km/h", "speed", None).unwrap();
        assert!((c.apply(90.0) - 25.0).abs() < 1e-12);
        let c = conversion("rpm", "angular_speed", None).unwrap();
        assert!((c.apply(60.0) - 2.0 * std::f64::consts::PI).abs() < 1e-12);
        let c = conversion("bar", "pressure", None).unwrap();
        assert_eq!(c.apply(4.5), 4.5e5);
        let c = conversion("%", "grade", None).unwrap();
        assert!((c.apply(3.0) - 0.03).abs() < 1e-15);
        // An angle is not a percentage: 45 deg is a grade of 1.
        let c = conversion("deg", "grade", None).unwrap();
        assert!((c.apply(45.0) - 1.0).abs() < 1e-12);
        let c = conversion("%", "torque", Some(2600.0)).unwrap();
        assert!((c.apply(50.0) - 1300.0).abs() < 1e-9);
    }

    #[test]
    fn never_guesses() {
        assert!(matches!(
            conversion("furlong/fortnight", "speed", None),
            Err(UnitError::Unknown { .. })
        ));
        // bar is a pressure, not a speed
        assert!(matches!(
            conversion("bar", "speed", None),
            Err(UnitError::Unknown { .. })
        ));
        assert_eq!(
            conversion("%", "torque", None),
            Err(UnitError::MissingReferenceTorque)
        );
    }
}
