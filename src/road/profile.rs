//! Road profiles from real tracks: distance, elevation and slope on a uniform distance grid
//! ([`RoadProfile`], docs/models/road.md), from GNSS fixes ([`super::gnss_profile`]: latitude,
//! longitude, GNSS or barometric altitude) or from a VECTO distance-based driving cycle
//! ([`super::vdri`]); written and read back as the `road_profile` table by
//! [`super::profile_table`]. This module holds the profile, where it came from, the GNSS
//! settings and the error.
//!
//! # Conventions
//! - Distance `x` is *horizontal* distance along the track, m, from the first fix; the grid is
//!   `x_k = k·step_m`, k = 0 … ⌊x_end/step_m⌋. Horizontal distance makes the slope exactly
//!   tan α; an odometer measures along the road, longer by 1/cos α (2·10⁻⁴ at a 2 % grade).
//! - Elevation `z`, m; slope `s = dz/dx = tan α` (1), positive uphill in the direction of travel.
//! - Latitude and longitude are WGS84 degrees; longitudes are unwrapped across ±180° for
//!   interpolation and written back in (−180, 180].
//!
//! # Errors
//! [`ProfileError`]: no latitude/longitude/elevation column, fewer than 3 valid fixes, a track
//! that never moves, settings out of range; each names the file and column.

use crate::ingest::IngestError;
use crate::signal::SignalError;
use crate::table::DriveMeta;
use thiserror::Error;

/// Settings of a GNSS road profile; units in the names.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GnssProfileConfig {
    /// Distance grid step, m.
    pub step_m: f64,
    /// Cut-off wavelength of the elevation low-pass, m (cut-off frequency 1/smooth_m 1/m).
    pub smooth_m: f64,
    /// Butterworth order of the low-pass (each of the two passes).
    pub smooth_order: usize,
    /// A step with both end speeds below this is standstill, m/s.
    pub standstill_speed_mps: f64,
    /// Without speed, a fix within this radius of the anchor adds no distance, m.
    pub standstill_radius_m: f64,
    /// Column with the elevation (m): `altitude` or e.g. a barometric altitude.
    pub elevation_column: String,
    /// Column with the receiver's vertical accuracy estimate (m), used when the log has it.
    pub elevation_accuracy_column: String,
    /// Elevation fixes whose reported accuracy is worse than this are dropped, m.
    pub max_elevation_accuracy_m: f64,
    /// Optional IMU pitch column (deg or rad), compared with the GNSS slope.
    pub pitch_column: Option<String>,
    /// Fewer valid fixes than this is an error.
    pub min_fixes: usize,
    /// A track shorter than this (or than two grid steps) "never moves", m.
    pub min_distance_m: f64,
}

impl Default for GnssProfileConfig {
    fn default() -> Self {
        Self {
            step_m: 1.0,
            smooth_m: 300.0,
            smooth_order: 3,
            standstill_speed_mps: 0.2,
            standstill_radius_m: 10.0,
            elevation_column: "altitude".into(),
            elevation_accuracy_column: "altitude_accuracy_m".into(),
            max_elevation_accuracy_m: 5.0,
            pitch_column: None,
            min_fixes: 3,
            min_distance_m: 10.0,
        }
    }
}

impl GnssProfileConfig {
    /// Canonical text of the settings, for the output's config hash.
    pub fn fingerprint(&self) -> String {
        crate::io::canonical("road_profile:gnss:v2", self)
    }

    pub(super) fn check(&self) -> Result<(), ProfileError> {
        let bad = |key: &str, value: f64, rule: &str| {
            Err(ProfileError::Setting {
                key: key.into(),
                value: value.to_string(),
                rule: rule.into(),
            })
        };
        if !(self.step_m.is_finite() && self.step_m > 0.0) {
            return bad("step_m", self.step_m, "must be positive and finite");
        }
        if !(self.smooth_m.is_finite() && self.smooth_m > 2.0 * self.step_m) {
            return bad(
                "smooth_m",
                self.smooth_m,
                &format!(
                    "must be finite and longer than two grid steps ({} m): the cut-off 1/smooth_m must lie below the grid's Nyquist frequency",
                    2.0 * self.step_m
                ),
            );
        }
        if !(1..=8).contains(&self.smooth_order) {
            return bad("smooth_order", self.smooth_order as f64, "must be 1 … 8");
        }
        if !(self.standstill_speed_mps.is_finite() && self.standstill_speed_mps >= 0.0) {
            return bad(
                "standstill_speed_mps",
                self.standstill_speed_mps,
                "must be >= 0",
            );
        }
        if self.max_elevation_accuracy_m.is_nan() || self.max_elevation_accuracy_m <= 0.0 {
            return bad(
                "max_elevation_accuracy_m",
                self.max_elevation_accuracy_m,
                "must be positive (inf keeps every fix)",
            );
        }
        if !(self.standstill_radius_m.is_finite() && self.standstill_radius_m >= 0.0) {
            return bad(
                "standstill_radius_m",
                self.standstill_radius_m,
                "must be >= 0",
            );
        }
        Ok(())
    }
}

/// Why a road profile could not be made (or read back).
#[derive(Debug, Error)]
pub enum ProfileError {
    /// The input has no GNSS track: a needed column is absent or has no value at all.
    #[error("{file}: no GNSS track: column {column} is missing or empty (a road profile needs latitude, longitude and an elevation column)")]
    NoGnss {
        /// Source file.
        file: String,
        /// The missing column.
        column: String,
    },
    /// The pitch column asked for is absent or has no value.
    #[error("{file}: pitch column {column} is missing or empty")]
    NoPitch {
        /// Source file.
        file: String,
        /// The column asked for.
        column: String,
    },
    /// Fewer valid fixes than a profile needs.
    #[error("{file}: only {fixes} valid fixes in column {column} (rows with a finite value); a road profile needs at least {min}")]
    TooFewFixes {
        /// Source file.
        file: String,
        /// Column counted.
        column: String,
        /// Valid fixes found.
        fixes: usize,
        /// Minimum.
        min: usize,
    },
    /// The track never moves (or too little for a grid).
    #[error("{file}: the track never moves: {distance_m:.2} m over {fixes} fixes in {duration_s:.1} s (minimum {min_m} m)")]
    NeverMoves {
        /// Source file.
        file: String,
        /// Distance travelled.
        distance_m: f64,
        /// Fixes used.
        fixes: usize,
        /// Time from the first to the last fix (0 for a driving cycle).
        duration_s: f64,
        /// Required minimum.
        min_m: f64,
    },
    /// A pitch or elevation column in a unit that cannot be used.
    #[error("{file}: column {column} has unit `{unit}`; expected {expected}")]
    Unit {
        /// Source file.
        file: String,
        /// Column.
        column: String,
        /// Its unit.
        unit: String,
        /// Accepted units.
        expected: String,
    },
    /// A setting out of its range.
    #[error("road profile setting {key} = {value}: {rule}")]
    Setting {
        /// Setting name (with its unit).
        key: String,
        /// Value given.
        value: String,
        /// What is allowed.
        rule: String,
    },
    /// Filter design or filtering failed.
    #[error("{file}: elevation low-pass: {source}")]
    Filter {
        /// Source file.
        file: String,
        /// Cause.
        #[source]
        source: SignalError,
    },
    /// A VECTO driving-cycle file that cannot be read.
    #[error("{file}: line {line}, column {column}: {message} (value `{value}`)")]
    Vdri {
        /// Source file.
        file: String,
        /// 1-based line number in the file.
        line: usize,
        /// Column header (`<s>`, `<grad>`, …) or `-` for the whole line.
        column: String,
        /// The offending text.
        value: String,
        /// What is wrong.
        message: String,
    },
    /// The input could not be ingested (not MCAP/Parquet, bad mapping, …).
    #[error(transparent)]
    Ingest(#[from] IngestError),
    /// The file could not be read.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A Parquet file that is not a road-profile table (reading a profile back).
    #[error("{file}: not a usable road profile table: {message}")]
    NotAProfile {
        /// File.
        file: String,
        /// What is wrong.
        message: String,
    },
}

/// Facts of a GNSS profile.
#[derive(Debug, Clone, PartialEq)]
pub struct GnssFacts {
    /// Rows with finite latitude and longitude.
    pub fixes: usize,
    /// Fixes classed as standstill (collapsed into the mean position of their run).
    pub standstill_fixes: usize,
    /// Fixes classed by their speed.
    pub fixes_classed_by_speed: usize,
    /// Fixes classed by the anchor radius (no speed at that fix).
    pub fixes_classed_by_radius: usize,
    /// Distinct distance points after collapsing stops.
    pub points: usize,
    /// Track length (sum of chords between track points), m; the grid ends at the last whole
    /// step at or below it.
    pub distance_m: f64,
    /// Longest distance between consecutive moving fixes, m.
    pub longest_step_m: f64,
    /// Time from the first to the last fix, s.
    pub duration_s: f64,
    /// Elevation column used.
    pub elevation_column: String,
    /// Fixes with a finite elevation (before the accuracy limit).
    pub elevation_fixes: usize,
    /// Of those, fixes dropped for a reported accuracy above the limit.
    pub elevation_fixes_inaccurate: usize,
    /// Grid distance before the first and after the last usable elevation fix, where the
    /// elevation is held (slope 0 before smoothing), m.
    pub elevation_held_m: f64,
    /// Settings used.
    pub config: GnssProfileConfig,
    /// The IMU comparison, when a pitch column was given.
    pub pitch: Option<PitchComparison>,
}

/// The GNSS slope against an IMU pitch column.
#[derive(Debug, Clone, PartialEq)]
pub struct PitchComparison {
    /// Pitch column.
    pub column: String,
    /// Mean pitch over the grid, removed before tan, deg.
    pub mean_offset_deg: f64,
    /// Pearson correlation of `slope` and `imu_slope` on the grid.
    pub r: f64,
}

/// Facts of a VECTO driving-cycle profile.
#[derive(Debug, Clone, PartialEq)]
pub struct VdriFacts {
    /// Data rows in the file.
    pub rows: usize,
    /// First `<s>` of the file, m (the profile's distance 0).
    pub start_m: f64,
    /// Last `<s>` minus the first, m.
    pub length_m: f64,
    /// Smallest, median and largest row spacing, m.
    pub spacing_m: (f64, f64, f64),
}

/// Where a profile came from.
#[derive(Debug, Clone, PartialEq)]
pub enum ProfileSource {
    /// GNSS fixes of a drive log.
    Gnss(Box<GnssFacts>),
    /// A VECTO distance-based driving cycle.
    Vdri(VdriFacts),
}

/// A road profile on a uniform distance grid (columns of the `road_profile` output schema).
#[derive(Debug, Clone, PartialEq)]
pub struct RoadProfile {
    /// Identification of the source.
    pub meta: DriveMeta,
    /// How it was made.
    pub source: ProfileSource,
    /// Grid step, m.
    pub step_m: f64,
    /// Grid distances `k·step_m`, m.
    pub distance_m: Vec<f64>,
    /// Elevation, m.
    pub elevation_m: Vec<f64>,
    /// Smoothed elevation, m (GNSS).
    pub elevation_smoothed_m: Option<Vec<f64>>,
    /// Slope tan α.
    pub slope: Vec<f64>,
    /// Latitude, deg (GNSS).
    pub latitude_deg: Option<Vec<f64>>,
    /// Longitude, deg (GNSS).
    pub longitude_deg: Option<Vec<f64>>,
    /// Low-passed tan(pitch − mean) (GNSS with a pitch column).
    pub imu_slope: Option<Vec<f64>>,
}

impl RoadProfile {
    /// Total distance covered by the grid, m.
    pub fn length_m(&self) -> f64 {
        self.distance_m.last().copied().unwrap_or(0.0)
    }

    /// A few lines for humans: source, length, elevation and slope ranges, and for GNSS tracks
    /// the standstill, accuracy, smoothing and IMU facts.
    pub fn summary(&self) -> String {
        use std::fmt::Write as _;
        let range = |v: &[f64]| {
            v.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(*x), b.max(*x))
                })
        };
        let (z0, z1) = range(&self.elevation_m);
        let (s0, s1) = range(&self.slope);
        let mut out = String::new();
        match &self.source {
            ProfileSource::Vdri(v) => {
                let _ = writeln!(
                    out,
                    "{}: VECTO distance-based cycle, {} rows (spacing {} … {} m, median {} m), {:.3} km",
                    self.meta.drive_id, v.rows, v.spacing_m.0, v.spacing_m.2, v.spacing_m.1,
                    v.length_m / 1000.0
                );
                let _ = writeln!(
                    out,
                    "  elevation {z0:.1} … {z1:.1} m integrated from <grad>; slope {s0:.4} … {s1:.4}"
                );
            }
            ProfileSource::Gnss(g) => {
                let _ = writeln!(
                    out,
                    "{}: GNSS track, {} fixes ({} at standstill) over {:.0} s, {:.3} km (chords on WGS84), longest step {:.1} m",
                    self.meta.drive_id, g.fixes, g.standstill_fixes, g.duration_s,
                    g.distance_m / 1000.0, g.longest_step_m
                );
                let _ = writeln!(
                    out,
                    "  elevation {z0:.1} … {z1:.1} m from {} ({} of {} fixes dropped for reported accuracy > {} m; held over {:.0} m at the ends)",
                    g.elevation_column, g.elevation_fixes_inaccurate, g.elevation_fixes,
                    g.config.max_elevation_accuracy_m, g.elevation_held_m
                );
                let _ = writeln!(
                    out,
                    "  smoothed at {} m (zero-phase Butterworth order {}, -6 dB at {:.3e} 1/m); slope {s0:.4} … {s1:.4}",
                    g.config.smooth_m, g.config.smooth_order, 1.0 / g.config.smooth_m
                );
                if let Some(pc) = &g.pitch {
                    let _ = writeln!(
                        out,
                        "  slope vs IMU {}: Pearson r = {:.3} on {} grid points (mean pitch {:.3} deg removed, same low-pass)",
                        pc.column, pc.r, self.distance_m.len(), pc.mean_offset_deg
                    );
                }
            }
        }
        out
    }
}
