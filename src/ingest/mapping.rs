//! Mapping files (`schemas/mappings/*.toml`): how a source's names and units become canonical.
//!
//! ```toml
//! name = "fleet-portal-export"
//! format = "parquet-wide"          # parquet-wide | parquet-long | mcap-json
//! detect_columns = ["Time", "VehSpd_kmh"]   # optional: auto-select for Parquet inputs
//!
//! [time]
//! column = "Time"                  # Parquet: time column; Arrow timestamp or numeric
//! unit = "ms"                      # numeric time columns only: s | ms | us | ns since the epoch
//!
//! [long]                           # parquet-long only
//! signal_column = "signal"
//! value_column = "value"
//!
//! [signals.vehicle_speed]
//! source = "VehSpd_kmh"            # wide: column name; long: signal name
//! unit = "km/h"
//!
//! [signals.engine_torque]          # MCAP: topic + JSON field (dotted path for nesting)
//! topic = "/can/eec1"
//! field = "ActualEnginePercentTorque"
//! unit = "%"
//! reference_torque_nm = 2600.0
//!
//! [passthrough_units]              # optional units of kept non-canonical columns
//! FuelRate_lph = "l/h"
//! ```
//!
//! Raw CAN (`format = "can-dbc"`, see [`crate::ingest::can::mapping`]): each signal names a DBC
//! `message` and `signal`, optionally `valid_signal`, `reference_torque_from` and
//! `source_address`; `[passthrough_signals.NAME]` keeps extra decoded signals.
//!
//! Unknown keys, unknown canonical names and unknown units are errors that name the mapping.

use super::IngestError;
use crate::schema::drive_log;
use crate::units::{conversion, Conversion};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Source layout a mapping describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum SourceFormat {
    /// Parquet, one column per signal on one time base.
    #[serde(rename = "parquet-wide")]
    ParquetWide,
    /// Parquet, one row per sample: (time, signal name, value).
    #[serde(rename = "parquet-long")]
    ParquetLong,
    /// MCAP with JSON-encoded messages, one topic per CAN message group.
    #[serde(rename = "mcap-json")]
    McapJson,
    /// Raw CAN frames (MDF4 bus logging, MCAP frames) decoded with DBC files; signals name a
    /// DBC `message` and `signal` (see [`crate::ingest::can`]).
    #[serde(rename = "can-dbc")]
    CanDbc,
}

impl SourceFormat {
    /// The format's name as mapping files write it: `parquet-wide`, `parquet-long`, `mcap-json`,
    /// `can-dbc`.
    pub fn name(self) -> &'static str {
        match self {
            SourceFormat::ParquetWide => "parquet-wide",
            SourceFormat::ParquetLong => "parquet-long",
            SourceFormat::McapJson => "mcap-json",
            SourceFormat::CanDbc => "can-dbc",
        }
    }
}

/// Time column settings.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Parquet time column name (default `timestamp`).
    pub column: Option<String>,
    /// Unit of a numeric time column (`s`, `ms`, `us`, `ns` since the Unix epoch).
    pub unit: Option<String>,
}

/// Long-layout settings.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LongSpec {
    /// Column holding the signal name.
    pub signal_column: String,
    /// Column holding the value.
    pub value_column: String,
}

/// Where one canonical signal comes from.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SignalSource {
    /// Parquet column (wide) or signal name (long).
    pub source: Option<String>,
    /// MCAP topic.
    pub topic: Option<String>,
    /// JSON field within the message (dotted path).
    pub field: Option<String>,
    /// Source unit.
    pub unit: String,
    /// Engine reference torque for `%` torque, N·m.
    pub reference_torque_nm: Option<f64>,
    /// `can-dbc`: DBC message name.
    pub message: Option<String>,
    /// `can-dbc`: signal name within `message`.
    pub signal: Option<String>,
    /// `can-dbc`, `%` torque: the decoded signal (`MESSAGE.SIGNAL`, e.g.
    /// `EC1.EngineReferenceTorque`) that holds the reference torque in N·m, instead of a fixed
    /// `reference_torque_nm`. A log without that message is an error naming it.
    pub reference_torque_from: Option<String>,
    /// `can-dbc`: a signal of the same message that flags the value valid (non-zero) or not
    /// (zero: the sample is missing), e.g. `PositionValid` of a GNSS message.
    pub valid_signal: Option<String>,
    /// `can-dbc`, J1939: only frames from this source address (default: the address that sent
    /// the message most often).
    pub source_address: Option<u8>,
}

/// A parsed mapping file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mapping {
    /// Mapping name.
    pub name: String,
    /// One line on what exports it fits.
    #[serde(default)]
    pub description: String,
    /// Source layout.
    pub format: SourceFormat,
    /// Parquet columns whose presence selects this mapping automatically.
    #[serde(default)]
    pub detect_columns: Vec<String>,
    /// Vehicle id to record when the source names none.
    pub vehicle_id: Option<String>,
    /// Time settings.
    #[serde(default)]
    pub time: TimeSpec,
    /// Long-layout settings.
    pub long: Option<LongSpec>,
    /// Canonical column → source.
    pub signals: BTreeMap<String, SignalSource>,
    /// Units of non-canonical columns that are passed through.
    #[serde(default)]
    pub passthrough_units: BTreeMap<String, String>,
    /// `can-dbc`: non-canonical columns decoded and kept as they are (column name with its
    /// unit → message, signal, `unit`).
    #[serde(default)]
    pub passthrough_signals: BTreeMap<String, SignalSource>,
    /// Where the mapping came from (set by the loader).
    #[serde(skip)]
    pub origin: String,
    /// SHA-256 of the mapping text (set by the loader), for output config hashes.
    #[serde(skip)]
    pub text_sha256: String,
}

/// A resolved signal: canonical column, where to find it, how to convert it.
#[derive(Debug, Clone)]
pub struct ResolvedSignal {
    /// Canonical column name.
    pub column: String,
    /// Source column / long-layout signal name, or MCAP `topic`.
    pub source: String,
    /// MCAP JSON field path, split at dots.
    pub field_path: Vec<String>,
    /// Conversion into the canonical SI unit.
    pub conversion: Conversion,
    /// `can-dbc` `%` torque: the `MESSAGE.SIGNAL` holding the reference torque (N·m); the
    /// `conversion` then still has to be scaled by reference / 100.
    pub reference_torque_from: Option<String>,
}

const EMBEDDED: &[(&str, &str)] = &[
    (
        "j1939-json-mcap",
        include_str!("../../schemas/mappings/j1939-json-mcap.toml"),
    ),
    (
        "fleet-portal-export",
        include_str!("../../schemas/mappings/fleet-portal-export.toml"),
    ),
    (
        "j1939-long-export",
        include_str!("../../schemas/mappings/j1939-long-export.toml"),
    ),
    (
        "css-obd2-long",
        include_str!("../../schemas/mappings/css-obd2-long.toml"),
    ),
    (
        "css-gnss-wide",
        include_str!("../../schemas/mappings/css-gnss-wide.toml"),
    ),
    (
        "can-j1939",
        include_str!("../../schemas/mappings/can-j1939.toml"),
    ),
    (
        "can-css-gnss-obd2",
        include_str!("../../schemas/mappings/can-css-gnss-obd2.toml"),
    ),
];

impl Mapping {
    /// Parses mapping text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`IngestError::Mapping`] for syntax errors, unknown keys or canonical names, missing
    /// source keys; [`IngestError::Unit`] for units that cannot be converted.
    pub fn parse(text: &str, origin: &str) -> Result<Self, IngestError> {
        let mut m: Mapping = toml::from_str(text).map_err(|e| IngestError::Mapping {
            mapping: origin.into(),
            message: e.to_string(),
        })?;
        m.origin = origin.into();
        m.text_sha256 = crate::io::config_hash(&[text.as_bytes()]);
        m.resolve()?;
        Ok(m)
    }

    /// Reads and parses a mapping file.
    ///
    /// # Errors
    /// As [`Mapping::parse`], plus [`IngestError::Io`].
    pub fn load(path: &Path) -> Result<Self, IngestError> {
        let text = std::fs::read_to_string(path).map_err(|e| IngestError::Io {
            file: path.into(),
            source: e,
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// The mappings shipped in `schemas/mappings/` (embedded at build time).
    pub fn embedded() -> Vec<Mapping> {
        EMBEDDED
            .iter()
            .map(|(name, text)| {
                Self::parse(text, &format!("<embedded:{name}>"))
                    .expect("embedded mappings are checked by the test suite")
            })
            .collect()
    }

    /// Checks every signal and returns how to read and convert it.
    ///
    /// # Errors
    /// See [`Mapping::parse`].
    pub fn resolve(&self) -> Result<Vec<ResolvedSignal>, IngestError> {
        let schema = drive_log();
        let err = |message: String| IngestError::Mapping {
            mapping: self.origin.clone(),
            message,
        };
        if self.format == SourceFormat::ParquetLong && self.long.is_none() {
            return Err(err("format parquet-long needs a [long] table".into()));
        }
        let mut out = Vec::with_capacity(self.signals.len());
        for (column, src) in &self.signals {
            let spec = schema
                .column(column)
                .filter(|c| c.name != "timestamp")
                .ok_or_else(|| err(format!("unknown canonical column `{column}`")))?;
            let deferred = self.format == SourceFormat::CanDbc
                && src.reference_torque_from.is_some()
                && src.reference_torque_nm.is_none();
            if src.reference_torque_from.is_some() && !deferred {
                return Err(err(format!(
                    "{column}: reference_torque_from is for can-dbc mappings without reference_torque_nm"
                )));
            }
            // a deferred reference torque is applied at decode time: 1 %/unit until then
            let reference = if deferred {
                Some(100.0)
            } else {
                src.reference_torque_nm
            };
            let conversion = conversion(&src.unit, &spec.quantity, reference).map_err(|e| {
                IngestError::Unit {
                    mapping: self.origin.clone(),
                    column: column.clone(),
                    source: e,
                }
            })?;
            let (source, field_path) =
                match self.format {
                    SourceFormat::McapJson => {
                        let topic = src.topic.clone().ok_or_else(|| {
                            err(format!("{column}: `topic` is required for MCAP"))
                        })?;
                        let field = src.field.clone().ok_or_else(|| {
                            err(format!("{column}: `field` is required for MCAP"))
                        })?;
                        (topic, field.split('.').map(str::to_string).collect())
                    }
                    SourceFormat::CanDbc => match (&src.message, &src.signal) {
                        (Some(m), Some(s)) => (format!("{m}.{s}"), Vec::new()),
                        _ => {
                            return Err(err(format!(
                                "{column}: `message` and `signal` are required for can-dbc"
                            )))
                        }
                    },
                    _ => (
                        src.source
                            .clone()
                            .ok_or_else(|| err(format!("{column}: `source` is required")))?,
                        Vec::new(),
                    ),
                };
            out.push(ResolvedSignal {
                column: column.clone(),
                source,
                field_path,
                conversion,
                reference_torque_from: if deferred {
                    src.reference_torque_from.clone()
                } else {
                    None
                },
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_mappings_parse() {
        let all = Mapping::embedded();
        assert_eq!(all.len(), EMBEDDED.len());
    }

    #[test]
    fn unknown_unit_names_mapping_and_column() {
        let text = r#"
            name = "x"
            format = "parquet-wide"
            [signals.vehicle_speed]
            source = "v"
            unit = "knots-ish"
        "#;
        let e = Mapping::parse(text, "bad.toml").unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, IngestError::Unit { .. }), "{msg}");
        assert!(
            msg.contains("bad.toml") && msg.contains("vehicle_speed") && msg.contains("knots-ish")
        );
    }

    #[test]
    fn unknown_keys_and_columns_are_errors() {
        let text = "name = \"x\"\nformat = \"parquet-wide\"\ncolour = 1\n[signals]\n";
        assert!(Mapping::parse(text, "m").is_err());
        let text = "name = \"x\"\nformat = \"parquet-wide\"\n[signals.warp_speed]\nsource = \"a\"\nunit = \"1\"\n";
        assert!(Mapping::parse(text, "m")
            .unwrap_err()
            .to_string()
            .contains("warp_speed"));
    }
}
