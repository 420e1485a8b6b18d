//! Road profiles as Parquet: writing a synthetic road (output schema `road_profile`:
//! `distance` m, `elevation` m, `slope` 1 on a uniform distance grid, with the rule set, seed
//! and length in the file metadata) and reading one distance-domain slope column back from any
//! Parquet file that has a uniform `distance` grid (a synthetic road, or the
//! `slope_distance.parquet` of `fleetdyn slope`).

use super::synth::SyntheticRoad;
use crate::io::{config_hash, write_table, OutColumn, OutputError, TableMeta};
use arrow::array::{Array, AsArray};
use arrow::compute::cast;
use arrow::datatypes::{DataType, Float64Type};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ProjectionMask;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Version tag of the generator, part of every road's metadata and configuration hash: bump it
/// whenever the same rules and seed would give a different road.
pub const GENERATOR: &str = "fleetdyn road synth v1 (Myklebust & Eriksson 2012, §4; xoshiro256** seeded by SplitMix64; lengthen segments that cannot hold their curves)";

/// Writes a synthetic road as Parquet (schema `road_profile`), atomically. `rules_origin` says
/// where the rules came from (a bundled name or a file path) for the metadata.
///
/// # Errors
/// [`OutputError`]; nothing is left at `path` on error.
pub fn write_road(
    path: &Path,
    road: &SyntheticRoad,
    rules_origin: &str,
) -> Result<(), OutputError> {
    let p = &road.profile;
    let rules_toml = road.rules.canonical_toml();
    let fp = format!(
        "{GENERATOR}\nseed={}\nlength_m={}\nstep_m={}\n{rules_toml}",
        road.seed, road.length_m, p.step_m
    );
    let max_abs = p.slope.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let (zmin, zmax) = p
        .elevation_m
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
            (a.min(z), b.max(z))
        });
    let meta = TableMeta {
        table: "road_profile".into(),
        drive_id: format!("synthetic-{}-seed-{}", road.rules.name, road.seed),
        vehicle_id: None,
        source_file: String::new(),
        config_hash: config_hash(&[fp.as_bytes()]),
        extra: vec![
            ("generator".into(), GENERATOR.into()),
            ("rule_set".into(), road.rules.name.clone()),
            ("rules_origin".into(), rules_origin.into()),
            ("rules_source".into(), road.rules.source.clone()),
            ("rules_toml".into(), rules_toml),
            ("seed".into(), road.seed.to_string()),
            ("length_m".into(), road.length_m.to_string()),
            ("step_m".into(), p.step_m.to_string()),
            (
                "grade_segments".into(),
                road.alignment.grades.len().to_string(),
            ),
            (
                "vertical_curves".into(),
                road.alignment.radii_m.len().to_string(),
            ),
            (
                "lengthened_segments".into(),
                road.lengthened_segments.to_string(),
            ),
            ("max_abs_slope".into(), max_abs.to_string()),
            ("elevation_min_m".into(), zmin.to_string()),
            ("elevation_max_m".into(), zmax.to_string()),
        ],
    };
    let cols = vec![
        OutColumn::f64("distance", "m", p.distance_m.clone()),
        OutColumn::f64("elevation", "m", p.elevation_m.clone()),
        OutColumn::f64("slope", "1", p.slope.clone()),
    ];
    write_table(path, &meta, &cols)
}

/// Why a distance-domain column could not be read.
#[derive(Debug, Error)]
pub enum RoadFileError {
    /// File could not be opened.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Not a readable Parquet file.
    #[error("{file}: not a readable Parquet file: {source}")]
    Parquet {
        /// File.
        file: PathBuf,
        /// Cause.
        #[source]
        source: parquet::errors::ParquetError,
    },
    /// A needed column is absent.
    #[error("{file}: no column {column} (columns: {available})")]
    NoColumn {
        /// File.
        file: PathBuf,
        /// Column.
        column: String,
        /// Columns present, comma separated.
        available: String,
    },
    /// A column that is not numeric.
    #[error("{file}: column {column} is {dtype}, expected a number")]
    WrongType {
        /// File.
        file: PathBuf,
        /// Column.
        column: String,
        /// Its Arrow type.
        dtype: String,
    },
    /// A column whose `unit` metadata is not the one the analysis needs.
    #[error("{file}: column {column} has unit `{unit}`, expected `{expected}`")]
    WrongUnit {
        /// File.
        file: PathBuf,
        /// Column.
        column: String,
        /// Unit found.
        unit: String,
        /// Unit needed.
        expected: &'static str,
    },
    /// A missing or non-finite value.
    #[error("{file}: column {column} has a missing or non-finite value at row {row}")]
    Missing {
        /// File.
        file: PathBuf,
        /// Column.
        column: String,
        /// First offending row.
        row: usize,
    },
    /// Fewer than two rows.
    #[error("{file}: {rows} rows; a spectrum needs a distance grid of at least 2 samples")]
    TooShort {
        /// File.
        file: PathBuf,
        /// Rows.
        rows: usize,
    },
    /// `distance` not a uniform increasing grid.
    #[error("{file}: distance is not a uniform increasing grid: step {found_m} m at row {row}, the grid's mean step is {step_m} m")]
    NonUniform {
        /// File.
        file: PathBuf,
        /// Row where the step differs.
        row: usize,
        /// Step found there, m.
        found_m: f64,
        /// Mean step, m.
        step_m: f64,
    },
}

/// One slope column on a uniform distance grid, as read.
#[derive(Debug, Clone)]
pub struct DistanceColumn {
    /// Source file.
    pub file: PathBuf,
    /// Column read.
    pub column: String,
    /// Grid step, m.
    pub step_m: f64,
    /// Values (tan α).
    pub values: Vec<f64>,
    /// The file's key–value metadata.
    pub kv: HashMap<String, String>,
}

/// Numeric columns read from a Parquet file, as f64 (nulls as NaN).
#[derive(Debug, Clone)]
pub struct NumericColumns {
    /// Names in the order read: the required ones, then the optional ones present.
    pub names: Vec<String>,
    /// Values per column.
    pub values: Vec<Vec<f64>>,
    /// The file's key–value metadata.
    pub kv: HashMap<String, String>,
}

/// Reads the `required` columns and those of `optional` that exist, each `(name, unit)`: a
/// column must be numeric, and a `unit` field-metadata entry, where present, must be the one
/// given (a missing entry is taken as that unit). Only these columns are decoded.
///
/// # Errors
/// [`RoadFileError::Io`], [`RoadFileError::Parquet`], [`RoadFileError::NoColumn`] (a required
/// column), [`RoadFileError::WrongType`], [`RoadFileError::WrongUnit`].
pub fn read_numeric_columns(
    path: &Path,
    required: &[(&str, &'static str)],
    optional: &[(&str, &'static str)],
) -> Result<NumericColumns, RoadFileError> {
    let file = path.to_path_buf();
    let f = std::fs::File::open(path).map_err(|source| RoadFileError::Io {
        file: file.clone(),
        source,
    })?;
    let pq = |source| RoadFileError::Parquet {
        file: file.clone(),
        source,
    };
    let builder = ParquetRecordBatchReaderBuilder::try_new(f).map_err(pq)?;
    let kv: HashMap<String, String> = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|v| {
            v.iter()
                .map(|e| (e.key.clone(), e.value.clone().unwrap_or_default()))
                .collect()
        })
        .unwrap_or_default();
    let schema = builder.schema().clone();
    let names: Vec<String> = schema.fields().iter().map(|f| f.name().clone()).collect();
    let wanted: Vec<(&str, &'static str)> = required
        .iter()
        .copied()
        .chain(
            optional
                .iter()
                .copied()
                .filter(|(n, _)| names.iter().any(|x| x == n)),
        )
        .collect();
    let mut roots = Vec::new();
    for &(name, unit) in &wanted {
        let Some(i) = names.iter().position(|n| n == name) else {
            return Err(RoadFileError::NoColumn {
                file,
                column: name.into(),
                available: names.join(", "),
            });
        };
        let field = schema.field(i);
        if !field.data_type().is_numeric() {
            return Err(RoadFileError::WrongType {
                file,
                column: name.into(),
                dtype: field.data_type().to_string(),
            });
        }
        if let Some(u) = field.metadata().get("unit") {
            if u != unit {
                return Err(RoadFileError::WrongUnit {
                    file,
                    column: name.into(),
                    unit: u.clone(),
                    expected: unit,
                });
            }
        }
        roots.push(i);
    }
    let mask = ProjectionMask::roots(builder.parquet_schema(), roots);
    let reader = builder.with_projection(mask).build().map_err(pq)?;
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); wanted.len()];
    for batch in reader {
        let batch = batch.map_err(|e| pq(parquet::errors::ParquetError::General(e.to_string())))?;
        for (&(name, _), out) in wanted.iter().zip(values.iter_mut()) {
            let arr = batch
                .column_by_name(name)
                .expect("projected column is in the batch");
            let v = cast(arr, &DataType::Float64).expect("numeric casts to f64");
            let v = v.as_primitive::<Float64Type>();
            out.extend((0..v.len()).map(|i| if v.is_null(i) { f64::NAN } else { v.value(i) }));
        }
    }
    Ok(NumericColumns {
        names: wanted.iter().map(|(n, _)| n.to_string()).collect(),
        values,
        kv,
    })
}

/// Reads `distance` and `column` from a Parquet file: both numeric without gaps, `distance` a
/// uniform increasing grid (each step within 10⁻⁶ of the mean step, relative — the grid is
/// written as `k·step`, so only rounding separates the steps) in m, `column` a slope (unit `1`).
/// A missing `unit` metadata entry is taken as the expected SI unit.
///
/// # Errors
/// [`RoadFileError`].
pub fn read_distance_column(path: &Path, column: &str) -> Result<DistanceColumn, RoadFileError> {
    let file = path.to_path_buf();
    let mut cols = read_numeric_columns(path, &[("distance", "m"), (column, "1")], &[])?;
    let kv = std::mem::take(&mut cols.kv);
    let vals = cols.values.pop().expect("two columns asked");
    let dist = cols.values.pop().expect("two columns asked");
    for (name, v) in [("distance", &dist), (column, &vals)] {
        if let Some(row) = v.iter().position(|x| !x.is_finite()) {
            return Err(RoadFileError::Missing {
                file,
                column: name.into(),
                row,
            });
        }
    }
    let n = dist.len();
    if n < 2 {
        return Err(RoadFileError::TooShort { file, rows: n });
    }
    let step_m = (dist[n - 1] - dist[0]) / (n - 1) as f64;
    for (row, w) in dist.windows(2).enumerate() {
        let d = w[1] - w[0];
        if !(step_m > 0.0 && (d - step_m).abs() <= 1e-6 * step_m) {
            return Err(RoadFileError::NonUniform {
                file,
                row: row + 1,
                found_m: d,
                step_m,
            });
        }
    }
    Ok(DistanceColumn {
        file,
        column: column.into(),
        step_m,
        values: vals,
        kv,
    })
}
