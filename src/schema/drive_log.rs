//! The canonical drive-log schema (`schemas/drive-log.toml`, described in docs/inputs.md).

use super::{Dtype, SchemaError};
use serde::Deserialize;
use std::sync::OnceLock;

const DRIVE_LOG_TOML: &str = include_str!("../../schemas/drive-log.toml");

/// How a column is carried between sample times (multi-rate alignment, distance resampling).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Continuous signal: linear interpolation between neighbouring samples.
    Linear,
    /// State-like signal (gear, quantised slope sensor): zero-order hold of the last sample.
    Hold,
    /// The time axis itself.
    None,
}

/// A processing stage that declares which drive-log columns it needs.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Deserialize, serde::Serialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// Ingest itself (needs only the `all` columns).
    Ingest,
    /// Distance resampling.
    Resample,
    /// Road-slope filtering (docs/models/road.md).
    Slope,
    /// Driveline shuffle simulation (docs/models/driveline.md).
    Driveline,
    /// Axle-load simulation (docs/models/axle.md).
    Axle,
}

impl Stage {
    /// Parses a stage name as used in CLI flags and pipeline files.
    pub fn parse(name: &str) -> Option<Stage> {
        match name {
            "ingest" => Some(Stage::Ingest),
            "resample" => Some(Stage::Resample),
            "slope" => Some(Stage::Slope),
            "driveline" => Some(Stage::Driveline),
            "axle" => Some(Stage::Axle),
            _ => None,
        }
    }

    /// The stage's name as written in `needed_by`.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Ingest => "ingest",
            Stage::Resample => "resample",
            Stage::Slope => "slope",
            Stage::Driveline => "driveline",
            Stage::Axle => "axle",
        }
    }
}

/// One canonical column.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnSpec {
    /// Fixed column name.
    pub name: String,
    /// Logical type.
    pub dtype: Dtype,
    /// SI unit, written to the Parquet field metadata `unit`.
    pub unit: String,
    /// Physical quantity (decides the convertible source units, see [`crate::units`]).
    pub quantity: String,
    /// Stage names that need the column; `"all"` means every stage.
    pub needed_by: Vec<String>,
    /// Interpolation kind between samples.
    pub interpolation: Interpolation,
    /// Smallest physically possible value (SI).
    #[serde(default)]
    pub valid_min: Option<f64>,
    /// Largest physically possible value (SI).
    #[serde(default)]
    pub valid_max: Option<f64>,
    /// One line for humans.
    pub meaning: String,
}

impl ColumnSpec {
    /// True when `stage` needs this column.
    pub fn needed_by(&self, stage: Stage) -> bool {
        self.needed_by
            .iter()
            .any(|s| s == "all" || s == stage.name())
    }
}

/// The parsed drive-log schema.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveLogSchema {
    /// Semantic version written into every output's `schema_version` metadata.
    pub schema_version: String,
    /// Known stage names.
    pub stages: Vec<String>,
    /// Columns in canonical order; `timestamp` first.
    pub columns: Vec<ColumnSpec>,
}

impl DriveLogSchema {
    /// Parses and checks a schema document.
    ///
    /// # Errors
    /// [`SchemaError`] when the TOML is malformed, `timestamp` is not first, a name repeats, or
    /// a `needed_by` entry names an unknown stage.
    pub fn parse(text: &str) -> Result<Self, SchemaError> {
        let schema: DriveLogSchema = toml::from_str(text).map_err(|e| SchemaError::Parse {
            name: "drive-log.toml".into(),
            source: e,
        })?;
        let invalid = |message: String| SchemaError::Invalid {
            name: "drive-log.toml".into(),
            message,
        };
        if schema.columns.first().map(|c| c.name.as_str()) != Some("timestamp") {
            return Err(invalid("the first column must be `timestamp`".into()));
        }
        for (i, c) in schema.columns.iter().enumerate() {
            if schema.columns[..i].iter().any(|d| d.name == c.name) {
                return Err(invalid(format!("column {} appears twice", c.name)));
            }
            for s in &c.needed_by {
                if s != "all" && !schema.stages.contains(s) {
                    return Err(invalid(format!("column {}: unknown stage {s}", c.name)));
                }
            }
            if let (Some(lo), Some(hi)) = (c.valid_min, c.valid_max) {
                if lo >= hi {
                    return Err(invalid(format!(
                        "column {}: valid_min >= valid_max",
                        c.name
                    )));
                }
            }
        }
        Ok(schema)
    }

    /// Looks a column up by name.
    pub fn column(&self, name: &str) -> Option<&ColumnSpec> {
        self.columns.iter().find(|c| c.name == name)
    }

    /// Position of a column in canonical order.
    pub fn position(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c.name == name)
    }

    /// Signal columns (all but `timestamp`) required by any of `stages`.
    pub fn required_for(&self, stages: &[Stage]) -> Vec<&ColumnSpec> {
        self.columns
            .iter()
            .skip(1)
            .filter(|c| stages.iter().any(|s| c.needed_by(*s)))
            .collect()
    }
}

/// The embedded canonical drive-log schema, parsed once.
///
/// # Panics
/// Never in a released build: the embedded file is checked by the test suite
/// (`schema_files_parse`), so a malformed edit fails CI before it can ship.
pub fn drive_log() -> &'static DriveLogSchema {
    static SCHEMA: OnceLock<DriveLogSchema> = OnceLock::new();
    SCHEMA.get_or_init(|| {
        DriveLogSchema::parse(DRIVE_LOG_TOML).expect("embedded schemas/drive-log.toml is valid")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schema_files_parse() {
        let s = drive_log();
        assert_eq!(s.columns[0].name, "timestamp");
        assert_eq!(
            s.column("road_slope").unwrap().interpolation,
            Interpolation::Hold
        );
        assert_eq!(s.column("vehicle_speed").unwrap().unit, "m/s");
        let slope: Vec<_> = s
            .required_for(&[Stage::Slope])
            .iter()
            .map(|c| c.name.clone())
            .collect();
        assert_eq!(slope, ["vehicle_speed", "road_slope"]);
    }

    #[test]
    fn rejects_inconsistent_schema() {
        let bad = DRIVE_LOG_TOML.replace(
            "needed_by = [\"slope\", \"driveline\"]",
            "needed_by = [\"slop\"]",
        );
        assert!(matches!(
            DriveLogSchema::parse(&bad),
            Err(SchemaError::Invalid { .. })
        ));
    }
}
