//! Output table schemas (`schemas/outputs/*.toml`): what each Parquet result holds.

use super::{drive_log, Dtype, SchemaError};
use serde::Deserialize;
use std::sync::OnceLock;

const FILES: &[(&str, &str)] = &[
    (
        "proof_cases",
        include_str!("../../schemas/outputs/proof-cases.toml"),
    ),
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
    (
        "axle_sim",
        include_str!("../../schemas/outputs/axle-sim.toml"),
    ),
    (
        "road_profile",
        include_str!("../../schemas/outputs/road-profile.toml"),
    ),
    (
        "road_spectrum",
        include_str!("../../schemas/outputs/road-spectrum.toml"),
    ),
    (
        "road_study_psd",
        include_str!("../../schemas/outputs/road-study-psd.toml"),
    ),
    (
        "road_study_knees",
        include_str!("../../schemas/outputs/road-study-knees.toml"),
    ),
    (
        "road_compare",
        include_str!("../../schemas/outputs/road-compare.toml"),
    ),
    (
        "road_compare_psd",
        include_str!("../../schemas/outputs/road-compare-psd.toml"),
    ),
    (
        "road_compare_resonances",
        include_str!("../../schemas/outputs/road-compare-resonances.toml"),
    ),
    (
        "drive_summary",
        include_str!("../../schemas/outputs/drive-summary.toml"),
    ),
    (
        "drive_validation",
        include_str!("../../schemas/outputs/drive-validation.toml"),
    ),
    (
        "fleet_validation",
        include_str!("../../schemas/outputs/fleet-validation.toml"),
    ),
    (
        "mismatch",
        include_str!("../../schemas/outputs/mismatch.toml"),
    ),
    (
        "findings",
        include_str!("../../schemas/outputs/findings.toml"),
    ),
    (
        "parameter_estimates",
        include_str!("../../schemas/outputs/parameter-estimates.toml"),
    ),
    (
        "fleet_vehicles",
        include_str!("../../schemas/outputs/fleet-vehicles.toml"),
    ),
    (
        "fleet_parameters",
        include_str!("../../schemas/outputs/fleet-parameters.toml"),
    ),
    (
        "fleet_changes",
        include_str!("../../schemas/outputs/fleet-changes.toml"),
    ),
    (
        "fleet_trips",
        include_str!("../../schemas/outputs/fleet-trips.toml"),
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
    /// When true the column may be left out (e.g. `timestamp` of a table written both for
    /// recorded drives and for scripted scenarios, which have no wall-clock time).
    #[serde(default)]
    pub optional: bool,
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
    /// one; an `optional` column may be absent, and is recognised by its name); then, only if
    /// `passthrough_drive_log`, drive-log columns with their canonical dtype and unit, or
    /// non-canonical pass-through columns (kept from the source) as f64 with a unit.
    ///
    /// # Errors
    /// [`SchemaError::Mismatch`] naming the first column that differs.
    pub fn check(&self, cols: &[(&str, Dtype, &str)]) -> Result<(), SchemaError> {
        let mismatch = |message: String| SchemaError::Mismatch {
            table: self.name.clone(),
            message,
        };
        let required = self.columns.iter().filter(|c| !c.optional).count();
        if cols.len() < required {
            return Err(mismatch(format!(
                "{} columns, schema has {required} required fixed ones",
                cols.len(),
            )));
        }
        let mut k = 0;
        for spec in &self.columns {
            if spec.optional && cols.get(k).is_none_or(|c| c.0 != spec.name) {
                continue;
            }
            let Some((name, dtype, unit)) = cols.get(k) else {
                return Err(mismatch(format!("missing column {}", spec.name)));
            };
            k += 1;
            if spec.name != *name || spec.dtype != *dtype {
                return Err(mismatch(format!(
                    "column {name} ({dtype}) where the schema has {} ({})",
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
                    "column {name} has unit `{unit}`, schema says `{}`",
                    spec.unit
                )));
            }
        }
        let rest = &cols[k..];
        if !self.passthrough_drive_log && !rest.is_empty() {
            return Err(mismatch(format!("unexpected column {}", rest[0].0)));
        }
        let dl = drive_log();
        for (name, dtype, unit) in rest {
            match dl.column(name) {
                Some(c) if c.dtype != *dtype || c.unit != *unit => {
                    return Err(mismatch(format!(
                        "drive-log column {name} as {dtype} [{unit}], schema says {} [{}]",
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
/// `spectrum`, `bode`, `axle_validation`, `shuffle_sim`, `validation`, `axle_sim`,
/// `road_profile`, `road_spectrum`, `road_study_psd`, `road_study_knees`, `drive_summary`,
/// `drive_validation`, `fleet_validation`), or `None`.
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

    #[test]
    fn optional_columns_may_be_left_out_but_not_misplaced() {
        let s: OutputSchema = toml::from_str(
            r#"
            name = "t"
            passthrough_drive_log = false
            [[columns]]
            name = "timestamp"
            dtype = "timestamp_ns_utc"
            unit = "ns"
            meaning = ""
            optional = true
            [[columns]]
            name = "time"
            dtype = "f64"
            unit = "s"
            meaning = ""
            "#,
        )
        .unwrap();
        let ts = ("timestamp", Dtype::TimestampNsUtc, "ns");
        let time = ("time", Dtype::F64, "s");
        s.check(&[ts, time]).unwrap();
        s.check(&[time]).unwrap();
        assert!(s.check(&[]).is_err(), "the required column is missing");
        assert!(s.check(&[ts]).is_err(), "the required column is missing");
        assert!(
            s.check(&[time, ts]).is_err(),
            "the optional column is out of place"
        );
        assert!(s.check(&[("timestamp", Dtype::F64, "ns"), time]).is_err());
    }
}
