//! Road profiles from real tracks as the `road_profile` table (docs/models/road.md; output
//! schema `schemas/outputs/road-profile.toml`): written atomically with units on every column
//! and the profile's facts in the key–value metadata ([`write_profile`]), and one column read
//! back on its uniform distance grid ([`read_profile_column`]). Distances in m.

use super::profile::{ProfileError, ProfileSource, RoadProfile};
use crate::io::{config_hash, write_table, OutColumn, OutputError, TableMeta};
use crate::table::DriveMeta;
use std::path::Path;

/// Writes a profile as the `road_profile` table (atomically, units on every column, the facts
/// in the key–value metadata).
///
/// # Errors
/// [`OutputError`]; nothing is left at `path` on error.
pub fn write_profile(path: &Path, p: &RoadProfile, fingerprint: &str) -> Result<(), OutputError> {
    let mut cols = vec![
        OutColumn::f64("distance", "m", p.distance_m.clone()),
        OutColumn::f64("elevation", "m", p.elevation_m.clone()),
    ];
    if let Some(z) = &p.elevation_smoothed_m {
        cols.push(OutColumn::f64("elevation_smoothed", "m", z.clone()));
    }
    cols.push(OutColumn::f64("slope", "1", p.slope.clone()));
    if let (Some(la), Some(lo)) = (&p.latitude_deg, &p.longitude_deg) {
        cols.push(OutColumn::f64("latitude", "deg", la.clone()));
        cols.push(OutColumn::f64("longitude", "deg", lo.clone()));
    }
    if let Some(s) = &p.imu_slope {
        cols.push(OutColumn::f64("imu_slope", "1", s.clone()));
    }
    let mut extra = vec![
        ("step_m".to_string(), p.step_m.to_string()),
        ("length_m".to_string(), format!("{:.3}", p.length_m())),
    ];
    match &p.source {
        ProfileSource::Gnss(g) => {
            extra.extend([
                ("profile_source".to_string(), "gnss".to_string()),
                (
                    "distance_formula".to_string(),
                    "sum of chords on the WGS84 ellipsoid surface (horizontal) between track points: moving fixes, and standstill runs at their mean position".to_string(),
                ),
                ("track_distance_m".to_string(), format!("{:.3}", g.distance_m)),
                ("fixes".to_string(), g.fixes.to_string()),
                ("standstill_fixes".to_string(), g.standstill_fixes.to_string()),
                ("elevation_column".to_string(), g.elevation_column.clone()),
                (
                    "elevation_fixes_inaccurate".to_string(),
                    format!(
                        "{} of {} (reported accuracy above {} m in {})",
                        g.elevation_fixes_inaccurate,
                        g.elevation_fixes,
                        g.config.max_elevation_accuracy_m,
                        g.config.elevation_accuracy_column
                    ),
                ),
                (
                    "elevation_held_m".to_string(),
                    format!("{:.3}", g.elevation_held_m),
                ),
                ("smooth_m".to_string(), g.config.smooth_m.to_string()),
                (
                    "smoothing".to_string(),
                    format!(
                        "zero-phase Butterworth low-pass, order {} per pass, cut-off {:e} 1/m (-6 dB), matched edges",
                        g.config.smooth_order,
                        1.0 / g.config.smooth_m
                    ),
                ),
                (
                    "standstill_speed_mps".to_string(),
                    g.config.standstill_speed_mps.to_string(),
                ),
                (
                    "standstill_radius_m".to_string(),
                    g.config.standstill_radius_m.to_string(),
                ),
            ]);
            if let Some(pc) = &g.pitch {
                extra.extend([
                    ("pitch_column".to_string(), pc.column.clone()),
                    (
                        "pitch_mean_offset_deg".to_string(),
                        format!("{:.6}", pc.mean_offset_deg),
                    ),
                    ("slope_imu_pearson_r".to_string(), format!("{:.6}", pc.r)),
                ]);
            }
        }
        ProfileSource::Vdri(v) => {
            extra.extend([
                ("profile_source".to_string(), "vecto-vdri".to_string()),
                ("vdri_rows".to_string(), v.rows.to_string()),
                ("vdri_start_m".to_string(), v.start_m.to_string()),
                (
                    "vdri_spacing_m".to_string(),
                    format!(
                        "min {} median {} max {}",
                        v.spacing_m.0, v.spacing_m.1, v.spacing_m.2
                    ),
                ),
                (
                    "grade_convention".to_string(),
                    "VECTO: <grad> % of row i holds from <s>_i to <s>_i+1; elevation integrated from 0"
                        .to_string(),
                ),
            ]);
        }
    }
    let tm = TableMeta {
        table: "road_profile".into(),
        drive_id: p.meta.drive_id.clone(),
        vehicle_id: p.meta.vehicle_id.clone(),
        source_file: p.meta.source_file.clone(),
        config_hash: config_hash(&[fingerprint.as_bytes()]),
        extra,
    };
    write_table(path, &tm, &cols)
}

/// One column of a road-profile table read back, on its distance grid.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileColumn {
    /// Identification from the table's metadata (`drive_id`, `vehicle_id`, `source_file`).
    pub meta: DriveMeta,
    /// Grid step, m.
    pub step_m: f64,
    /// Column name.
    pub column: String,
    /// Its unit (field metadata).
    pub unit: String,
    /// Values (nulls as NaN).
    pub values: Vec<f64>,
}

/// Reads one column of a `road_profile` Parquet table written by [`write_profile`], checking
/// the table name and that the distance grid is uniform.
///
/// # Errors
/// [`ProfileError::Io`], [`ProfileError::NotAProfile`] (not Parquet, another table, no such
/// column, a non-uniform grid).
pub fn read_profile_column(path: &Path, column: &str) -> Result<ProfileColumn, ProfileError> {
    use arrow::array::{Array, AsArray};
    use arrow::datatypes::Float64Type;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    let file = path.display().to_string();
    let not = |message: String| ProfileError::NotAProfile {
        file: file.clone(),
        message,
    };
    let f = std::fs::File::open(path).map_err(|source| ProfileError::Io {
        file: file.clone(),
        source,
    })?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(f).map_err(|e| not(format!("{e}")))?;
    let schema = builder.schema().clone();
    let kv = schema.metadata();
    if kv.get("table").map(String::as_str) != Some("road_profile") {
        return Err(not(match kv.get("table") {
            Some(t) => format!(
                "table `{t}`, expected road_profile (write one with `fleetdyn road profile`)"
            ),
            None => "no table entry in its metadata, expected road_profile (write one with `fleetdyn road profile`)".to_string(),
        }));
    }
    let unit_of = |name: &str| -> Result<String, ProfileError> {
        let field = schema.field_with_name(name).map_err(|_| {
            not(format!(
                "no column {name} (columns: {})",
                schema
                    .fields()
                    .iter()
                    .map(|f| f.name().as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?;
        Ok(field.metadata().get("unit").cloned().unwrap_or_default())
    };
    let unit = unit_of(column)?;
    unit_of("distance")?;
    let reader = builder.build().map_err(|e| not(format!("{e}")))?;
    let (mut dist, mut values) = (Vec::new(), Vec::new());
    for batch in reader {
        let batch = batch.map_err(|e| not(format!("{e}")))?;
        for (name, out) in [("distance", &mut dist), (column, &mut values)] {
            let arr = batch
                .column_by_name(name)
                .and_then(|a| a.as_primitive_opt::<Float64Type>())
                .ok_or_else(|| not(format!("column {name} is not f64")))?;
            out.extend((0..arr.len()).map(|i| {
                if arr.is_null(i) {
                    f64::NAN
                } else {
                    arr.value(i)
                }
            }));
        }
    }
    if dist.len() < 2 {
        return Err(not(format!("{} grid points", dist.len())));
    }
    let step_m = dist[1] - dist[0];
    let uniform = step_m > 0.0
        && dist
            .iter()
            .enumerate()
            .all(|(k, d)| (d - (dist[0] + k as f64 * step_m)).abs() <= 1e-9 * (1.0 + d.abs()));
    if !uniform {
        return Err(not("the distance grid is not uniform".into()));
    }
    Ok(ProfileColumn {
        meta: DriveMeta {
            drive_id: kv.get("drive_id").cloned().unwrap_or_default(),
            vehicle_id: kv.get("vehicle_id").cloned(),
            source_file: file.clone(),
            segment: None,
        },
        step_m,
        column: column.into(),
        unit,
        values,
    })
}
