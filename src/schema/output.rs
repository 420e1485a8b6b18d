//! Output table schemas (`schemas/outputs/*.toml`): what each Parquet result holds.

use super::{drive_log, Dtype, SchemaError};
use serde::Deserialize;
use std::sync::OnceLock;

const FILES: &[(&str, &str)] = &[
    (
        "distance_log",
        include_str!("../../schemas/outputs/distance-log.toml"),
    ),
    (
        "slope_distance",
        include_str!("../../schemas/outputs/slope-distance.toml"),
    ),
    (
        "slope_time",
        include_str!("../../schemas/outputs/slope-time.toml"),
    ),
    (
        "spectrum",
        include_str!("../../schemas/outputs/spectrum.toml"),
    ),
    ("bode", include_str!("../../schemas/outputs/bode.toml")),
    (
        "axle_validation",
        include_str!("../../schemas/outputs/axle-validation.toml"),
    ),
    (
        "shuffle_sim",
        include_str!("../../schemas/outputs/shuffle-sim.toml"),
    ),
    (
        "validation",
        include_str!("../../schemas/outputs/validation.toml"),
    ),
];

/// One column of an output table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputColumn {
    /// Column name.
    pub name: String,
    /// Logical type.
    pub dtype: Dtype,
    /// Unit written to the field metadata; `"from_run"` when it depends on the input signal.
    pub unit: String,
    /// One line for humans.
    pub meaning: String,
}

/// An output table's schema.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSchema {
    /// Table name (also the key in [`output_schema`]).
    pub name: String,
    /// When true, drive-log columns may follow the fixed ones, with drive-log names and units.
    pub passthrough_drive_log: bool,
    /// Fixed leading columns, in order.
    pub columns: Vec<OutputColumn>,
}

impl OutputSchema {
    /// Checks an ordered list of `(name, dtype, unit)` against this schema: the fixed columns
    /// first, in order, with their dtype and unit (`from_run` accepts any unit but not an empty
    /// one); then, only if `passthrough_drive_log`, drive-log columns with their canonical dtype
    /// and unit, or non-canonical pass-through columns (kept from the source) as f64 with a unit.
    ///
    /// # Errors
    /// [`SchemaError::Mismatch`] naming the first column that differs.
    pub fn check(&self, cols: &[(&str, Dtype, &str)]) -> Result<(), SchemaError> {
        let mismatch = |message: String| SchemaError::Mismatch {
            table: self.name.clone(),
            message,
        };
        if cols.len() < self.columns.len() {
            return Err(mismatch(format!(
                "{} columns, schema has {} fixed ones",
                cols.len(),
                self.columns.len()
            )));
        }
        for (spec, (name, dtype, unit)) in self.columns.iter().zip(cols) {
            if spec.name != *name || spec.dtype != *dtype {
                return Err(mismatch(format!(
                    "column {name} ({dtype:?}) where the schema has {} ({:?})",
                    spec.name, spec.dtype
                )));
            }
            let unit_ok = if spec.unit == "from_run" {
                !unit.is_empty()
            } else {
                spec.unit == *unit
            };
            if !unit_ok {
                return Err(mismatch(format!(
                    "column {name} has unit {unit:?}, schema says {:?}",
                    spec.unit
                )));
            }
        }
        let rest = &cols[self.columns.len()..];
        if !self.passthrough_drive_log && !rest.is_empty() {
            return Err(mismatch(format!("unexpected column {}", rest[0].0)));
        }
        let dl = drive_log();
        for (name, dtype, unit) in rest {
            match dl.column(name) {
                Some(c) if c.dtype != *dtype || c.unit != *unit => {
                    return Err(mismatch(format!(
                        "drive-log column {name} as {dtype:?} [{unit}], schema says {:?} [{}]",
                        c.dtype, c.unit
                    )))
                }
                Some(_) => {}
                None if *dtype != Dtype::F64 || unit.is_empty() => {
                    return Err(mismatch(format!(
                        "pass-through column {name} must be f64 with a unit"
                    )))
                }
                None => {}
            }
        }
        Ok(())
    }
}

/// The embedded output schema called `name` (`distance_log`, `slope_distance`, `slope_time`,
/// `spectrum`, `bode`, `shuffle_sim`, `validation`), or `None`.
///
/// # Panics
/// Never in a released build: every embedded schema is parsed by the test suite.
pub fn output_schema(name: &str) -> Option<&'static OutputSchema> {
    static ALL: OnceLock<Vec<OutputSchema>> = OnceLock::new();
    ALL.get_or_init(|| {
        FILES
            .iter()
            .map(|(key, text)| {
                let s: OutputSchema = toml::from_str(text)
                    .map_err(|e| SchemaError::Parse {
                        name: format!("{key}.toml"),
                        source: e,
                    })
                    .expect("embedded output schema is valid");
                assert_eq!(&s.name, key, "output schema name matches its key");
                s
            })
            .collect()
    })
    .iter()
    .find(|s| s.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_output_schema_parses() {
        for (key, _) in FILES {
            let s = output_schema(key).unwrap();
            assert!(!s.columns.is_empty());
        }
    }

    #[test]
    fn check_enforces_names_units_and_passthrough() {
        let s = output_schema("distance_log").unwrap();
        let ok = [
            ("distance", Dtype::F64, "m"),
            ("timestamp", Dtype::TimestampNsUtc, "ns"),
            ("vehicle_speed", Dtype::F64, "m/s"),
            ("gear", Dtype::I16, "1"),
            ("FuelRate_lph", Dtype::F64, "l/h"),
        ];
        s.check(&ok).unwrap();
        let bad_unit = [
            ("distance", Dtype::F64, "m"),
            ("timestamp", Dtype::TimestampNsUtc, "ns"),
            ("vehicle_speed", Dtype::F64, "km/h"),
        ];
        assert!(s.check(&bad_unit).is_err());
        let t = output_schema("slope_time").unwrap();
        assert!(t.check(&ok).is_err());
    }
}
