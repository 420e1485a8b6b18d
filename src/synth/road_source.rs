//! Roads for synthetic drives: generated from road-design rules, or read from a file — a
//! Parquet road profile or a VECTO distance-based driving cycle — and cut to a window.
//!
//! # Road files
//! The kind is recognised by content: a Parquet file (magic `PAR1`), or a VECTO `.vdri` cycle
//! ([`crate::road::vdri::vecto_header`]: a `<s>` header cell).
//! - **Parquet**: any table with a numeric `distance` column (m, strictly increasing, any
//!   spacing) and a numeric `slope` column (tan α, within the drive-log schema's ±0.3), and
//!   optionally `elevation` (m) — a `fleetdyn road synth` output, a `fleetdyn road profile`
//!   output, or a table of one's own. Where a column's field metadata names a `unit`, it must be
//!   `m` (distance, elevation) or `1` (slope). Without `elevation` the elevation is the
//!   trapezoidal integral of the slope from 0 m at the first row.
//! - **VECTO**: read as `fleetdyn road profile` reads it ([`crate::road::vdri`]): the grade of
//!   a row holds to the next row and the elevation is its integral. The cycle's target speed
//!   `<v>` is kept as the road's speed limits ([`DriveRoad::speed_limit_mps`], held from its
//!   row like the grade; rows with `<v>` ≤ 0 — VECTO's stops — hold the previous positive
//!   value, leading ones the first), which the driver follows only when asked
//!   ([`super::drive::DriveConfig::road_speed_limits`]); otherwise it cruises at the given
//!   speed limit. The cycle's stops `<stop>` are *not* used: the driver stops where
//!   [`super::driver::DriverConfig`] says.
//!
//! # Window and grid
//! Distances in the file are taken from its first row (0 m there). The window starts at
//! `start_m` and is `length_m` long (default: to the end of the file); it must lie inside the
//! file. The road of the drive is the window resampled onto a 1 m grid ([`ROAD_STEP_M`]) from
//! its start, slope and elevation linearly interpolated between the file's points, so distance
//! 0 of the drive is `start_m` of the file.

use crate::road::profile::ProfileError;
use crate::road::road_table::{read_numeric_columns, RoadFileError};
use crate::road::synth::SyntheticRoad;
use crate::road::vdri::{cycle_profile, read_vdri, vecto_header, VectoCycle, VectoHeader};
use crate::schema::drive_log;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Grid step of a drive's road, m.
pub const ROAD_STEP_M: f64 = 1.0;

/// Why a road file could not be used.
#[derive(Debug, Error)]
pub enum RoadSourceError {
    /// The file could not be read.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Neither Parquet nor a distance-based VECTO cycle.
    #[error("{file}: not a road file (neither Parquet nor a VECTO .vdri cycle with a <s> column)")]
    UnknownFormat {
        /// File.
        file: PathBuf,
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
    /// A column whose `unit` metadata is not the expected one.
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
    /// A value that is missing, not finite or out of range.
    #[error("{file}: column {column}, row {row}: value {value} {problem}")]
    BadValue {
        /// File.
        file: PathBuf,
        /// Column.
        column: String,
        /// Row (0-based).
        row: usize,
        /// The value (NaN for a null).
        value: f64,
        /// What is wrong.
        problem: &'static str,
    },
    /// Fewer than two rows.
    #[error("{file}: {rows} rows; a road needs at least 2")]
    TooShort {
        /// File.
        file: PathBuf,
        /// Rows.
        rows: usize,
    },
    /// A malformed VECTO cycle.
    #[error(transparent)]
    Vdri(#[from] ProfileError),
    /// A window that does not lie inside the road.
    #[error(
        "{file}: {parameter} = {value_m} m: {requirement} (the road is {road_length_m} m long)"
    )]
    Window {
        /// File.
        file: PathBuf,
        /// `start_m` or `length_m`.
        parameter: &'static str,
        /// The value, m.
        value_m: f64,
        /// Length of the road in the file, m.
        road_length_m: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// Another road-table problem (from [`read_numeric_columns`]).
    #[error(transparent)]
    Table(RoadFileError),
}

impl From<RoadFileError> for RoadSourceError {
    /// The column reader's errors under this enum's own variants (same messages).
    fn from(e: RoadFileError) -> Self {
        match e {
            RoadFileError::Io { file, source } => RoadSourceError::Io { file, source },
            RoadFileError::Parquet { file, source } => RoadSourceError::Parquet { file, source },
            RoadFileError::NoColumn {
                file,
                column,
                available,
            } => RoadSourceError::NoColumn {
                file,
                column,
                available,
            },
            RoadFileError::WrongType {
                file,
                column,
                dtype,
            } => RoadSourceError::WrongType {
                file,
                column,
                dtype,
            },
            RoadFileError::WrongUnit {
                file,
                column,
                unit,
                expected,
            } => RoadSourceError::WrongUnit {
                file,
                column,
                unit,
                expected,
            },
            other => RoadSourceError::Table(other),
        }
    }
}

/// Where a drive's road comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum RoadSource {
    /// Generated from a rule set (bundled name or TOML file) with the drive's seed.
    Rules {
        /// Rule set name or file.
        rules: String,
        /// Road length, km.
        length_km: f64,
    },
    /// Read from a Parquet road profile or a VECTO cycle (module doc).
    File {
        /// The file.
        path: PathBuf,
        /// Window start from the file's first row, m.
        start_m: f64,
        /// Window length, km; `None`: to the end of the file.
        length_km: Option<f64>,
    },
}

/// The road of one drive on a uniform grid from 0 m.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveRoad {
    /// What it is, for drive ids: the rule-set name, or the file stem and window.
    pub label: String,
    /// Grid step, m.
    pub step_m: f64,
    /// Distance `k·step_m`, m.
    pub distance_m: Vec<f64>,
    /// Elevation, m.
    pub elevation_m: Vec<f64>,
    /// Slope tan α.
    pub slope: Vec<f64>,
    /// Length the driver drives, m.
    pub length_m: f64,
    /// Design speed of the rule set, m/s (files have none).
    pub design_speed_mps: Option<f64>,
    /// Speed limit on each grid step `[k·step_m, (k+1)·step_m)`, m/s, where the road has
    /// them (a VECTO cycle's `<v>`); `None` otherwise.
    pub speed_limit_mps: Option<Vec<f64>>,
}

impl DriveRoad {
    /// The road of a generated synthetic road (its own grid), labelled with its rule set.
    pub fn from_synthetic(road: &SyntheticRoad) -> Self {
        let p = &road.profile;
        Self {
            label: road.rules.name.clone(),
            step_m: p.step_m,
            distance_m: p.distance_m.clone(),
            elevation_m: p.elevation_m.clone(),
            slope: p.slope.clone(),
            length_m: road.length_m,
            design_speed_mps: road.rules.design_speed_km_per_h.map(|k| k / 3.6),
            speed_limit_mps: None,
        }
    }
}

/// The file's road before windowing: distance from the first row, elevation, slope.
struct FileRoad {
    distance_m: Vec<f64>,
    elevation_m: Vec<f64>,
    slope: Vec<f64>,
    /// Speed limit held from each point to the next, m/s, if the file has them.
    speed_mps: Option<Vec<f64>>,
}

/// Reads the road in `path` and cuts the window `[start_m, start_m + length_m]` (module doc).
///
/// # Errors
/// [`RoadSourceError`], naming the file and, where one is at fault, the column, row and value.
pub fn read_road_file(
    path: &Path,
    start_m: f64,
    length_m: Option<f64>,
) -> Result<DriveRoad, RoadSourceError> {
    use std::io::Read as _;
    let file = path.to_path_buf();
    let mut head = Vec::with_capacity(4096);
    std::fs::File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .map_err(|source| RoadSourceError::Io {
            file: file.clone(),
            source,
        })?;
    let road = if head.starts_with(b"PAR1") {
        read_parquet_road(path)?
    } else {
        match vecto_header(&head) {
            // read_vdri names the time-based header's problem
            Some(VectoHeader::Distance) | Some(VectoHeader::Time) => {
                let c = read_vdri(path)?;
                let p = cycle_profile(&c, ROAD_STEP_M)?;
                let speed_mps = cycle_speed_limits(&c, &p.distance_m);
                FileRoad {
                    distance_m: p.distance_m,
                    elevation_m: p.elevation_m,
                    slope: p.slope,
                    speed_mps,
                }
            }
            None => return Err(RoadSourceError::UnknownFormat { file }),
        }
    };
    window(&file, &road, start_m, length_m)
}

/// The cycle's `<v>` at the grid distances `grid_m` (from its first row), held from each row
/// like the grade (module doc); `None` when no row has a positive `<v>`.
fn cycle_speed_limits(c: &VectoCycle, grid_m: &[f64]) -> Option<Vec<f64>> {
    let first = c
        .target_speed_mps
        .iter()
        .copied()
        .find(|v| v.is_finite() && *v > 0.0)?;
    let mut held = Vec::with_capacity(c.target_speed_mps.len());
    let mut last = first;
    for &v in &c.target_speed_mps {
        if v.is_finite() && v > 0.0 {
            last = v;
        }
        held.push(last);
    }
    let s0 = c.distance_m[0];
    let mut i = 0;
    let n = c.distance_m.len();
    Some(
        grid_m
            .iter()
            .map(|&x| {
                while i + 1 < n && c.distance_m[i + 1] - s0 <= x {
                    i += 1;
                }
                held[i]
            })
            .collect(),
    )
}

fn window(
    file: &Path,
    road: &FileRoad,
    start_m: f64,
    length_m: Option<f64>,
) -> Result<DriveRoad, RoadSourceError> {
    let total = road.distance_m[road.distance_m.len() - 1];
    let bad = |parameter, value_m, requirement| RoadSourceError::Window {
        file: file.to_path_buf(),
        parameter,
        value_m,
        road_length_m: total,
        requirement,
    };
    if !(start_m.is_finite() && start_m >= 0.0 && start_m + 2.0 * ROAD_STEP_M <= total) {
        return Err(bad(
            "start_m",
            start_m,
            "must be finite, >= 0 and at least 2 m before the road's end",
        ));
    }
    let length = length_m.unwrap_or(total - start_m);
    if !(length.is_finite() && length >= 2.0 * ROAD_STEP_M) {
        return Err(bad("length_m", length, "must be finite and >= 2 m"));
    }
    if start_m + length > total + 1e-6 {
        return Err(bad(
            "length_m",
            length,
            "the window start_m + length_m runs beyond the road's end",
        ));
    }
    let n = (length / ROAD_STEP_M + 1e-9).floor() as usize + 1;
    let d = &road.distance_m;
    let mut out = DriveRoad {
        label: format!(
            "{}-from-{}m",
            file.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            start_m
        ),
        step_m: ROAD_STEP_M,
        distance_m: Vec::with_capacity(n),
        elevation_m: Vec::with_capacity(n),
        slope: Vec::with_capacity(n),
        length_m: length,
        design_speed_mps: None,
        speed_limit_mps: road.speed_mps.as_ref().map(|_| Vec::with_capacity(n)),
    };
    let mut i = 0;
    for k in 0..n {
        let x = k as f64 * ROAD_STEP_M;
        let s = start_m + x;
        while i + 2 < d.len() && d[i + 1] <= s {
            i += 1;
        }
        let f = ((s - d[i]) / (d[i + 1] - d[i])).clamp(0.0, 1.0);
        let lerp = |v: &[f64]| v[i] + f * (v[i + 1] - v[i]);
        out.distance_m.push(x);
        out.elevation_m.push(lerp(&road.elevation_m));
        out.slope.push(lerp(&road.slope));
        if let (Some(v), Some(o)) = (&road.speed_mps, out.speed_limit_mps.as_mut()) {
            // held from each point: the later point's once s reaches it
            o.push(if f >= 1.0 { v[i + 1] } else { v[i] });
        }
    }
    Ok(out)
}

fn read_parquet_road(path: &Path) -> Result<FileRoad, RoadSourceError> {
    let file = path.to_path_buf();
    let read = read_numeric_columns(
        path,
        &[("distance", "m"), ("slope", "1")],
        &[("elevation", "m")],
    )?;
    let cols = &read.values;
    let bad = |column: &str, row: usize, value: f64, problem| RoadSourceError::BadValue {
        file: file.clone(),
        column: column.into(),
        row,
        value,
        problem,
    };
    let max_slope = drive_log()
        .column("road_slope")
        .and_then(|c| c.valid_max)
        .unwrap_or(0.3);
    for (name, v) in read.names.iter().zip(cols) {
        if let Some(row) = v.iter().position(|x| !x.is_finite()) {
            return Err(bad(name, row, v[row], "is missing or not finite"));
        }
    }
    let (dist, slope) = (&cols[0], &cols[1]);
    if dist.len() < 2 {
        return Err(RoadSourceError::TooShort {
            file,
            rows: dist.len(),
        });
    }
    for row in 1..dist.len() {
        if dist[row] <= dist[row - 1] {
            return Err(bad(
                "distance",
                row,
                dist[row],
                "is not above the previous row's (distance must increase strictly)",
            ));
        }
    }
    if let Some(row) = slope.iter().position(|s| s.abs() > max_slope) {
        return Err(bad(
            "slope",
            row,
            slope[row],
            "is outside the drive-log schema's road_slope range ±0.3",
        ));
    }
    let d0 = dist[0];
    let distance_m: Vec<f64> = dist.iter().map(|x| x - d0).collect();
    let elevation_m = match cols.get(2) {
        Some(z) => z.clone(),
        None => {
            let mut z = vec![0.0; distance_m.len()];
            for k in 1..z.len() {
                z[k] = z[k - 1]
                    + 0.5 * (slope[k] + slope[k - 1]) * (distance_m[k] - distance_m[k - 1]);
            }
            z
        }
    };
    Ok(FileRoad {
        distance_m,
        elevation_m,
        slope: slope.clone(),
        speed_mps: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycle_speeds_hold_from_their_row_and_skip_stops() {
        let c = VectoCycle {
            file: "c.vdri".into(),
            distance_m: vec![100.0, 103.0, 105.0, 108.0],
            grade: vec![0.0; 4],
            target_speed_mps: vec![0.0, 20.0, 0.0, 10.0],
            stop_s: vec![5.0, 0.0, 3.0, 0.0],
        };
        let grid: Vec<f64> = (0..=9).map(f64::from).collect();
        let v = cycle_speed_limits(&c, &grid).unwrap();
        // leading stop → the first positive speed; the stop at 105 m holds 20 m/s
        assert_eq!(
            v,
            [20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 10.0, 10.0]
        );
        let none = VectoCycle {
            target_speed_mps: vec![f64::NAN; 4],
            ..c
        };
        assert!(cycle_speed_limits(&none, &grid).is_none());
    }

    #[test]
    fn window_resamples_onto_a_1_m_grid_from_its_start() {
        let road = FileRoad {
            distance_m: vec![0.0, 10.0, 30.0],
            elevation_m: vec![0.0, 0.1, 0.5],
            slope: vec![0.01, 0.01, 0.02],
            speed_mps: Some(vec![20.0, 10.0, 15.0]),
        };
        let w = window(Path::new("r.parquet"), &road, 5.0, Some(20.0)).unwrap();
        assert_eq!(w.distance_m.len(), 21);
        assert_eq!(w.distance_m[0], 0.0);
        assert!((w.elevation_m[0] - 0.05).abs() < 1e-12);
        assert!((w.slope[15] - 0.015).abs() < 1e-12); // file 20 m: halfway 10..30
        assert!((w.elevation_m[20] - 0.4).abs() < 1e-12); // file 25 m
                                                          // limits held from each point: file 5..9 m → 20, 10..25 m → 10
        let v = w.speed_limit_mps.as_ref().unwrap();
        assert_eq!((v[0], v[4], v[5], v[20]), (20.0, 20.0, 10.0, 10.0));
        let all = window(Path::new("r.parquet"), &road, 0.0, None).unwrap();
        assert_eq!(all.speed_limit_mps.as_ref().unwrap()[30], 15.0);
        assert_eq!(all.length_m, 30.0);
        assert_eq!(all.distance_m.len(), 31);
        for (start, len) in [
            (-1.0, None),
            (29.0, None),
            (0.0, Some(31.0)),
            (1.0, Some(0.5)),
        ] {
            let e = window(Path::new("r.parquet"), &road, start, len).unwrap_err();
            assert!(matches!(e, RoadSourceError::Window { .. }), "{e}");
        }
    }
}
