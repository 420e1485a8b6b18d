//! Road profiles from real tracks: distance, elevation and slope on a uniform distance grid,
//! from GNSS fixes (latitude, longitude, GNSS or barometric altitude) or from a VECTO
//! distance-based driving cycle ([`super::vdri`]).
//!
//! # Conventions
//! - Distance `x` is *horizontal* distance along the track, m, from the first fix; the grid is
//!   `x_k = k·step_m`, k = 0 … ⌊x_end/step_m⌋. Horizontal distance makes the slope exactly
//!   tan α; an odometer measures along the road, longer by 1/cos α (2·10⁻⁴ at a 2 % grade).
//! - Elevation `z`, m; slope `s = dz/dx = tan α` (1), positive uphill in the direction of travel.
//! - Latitude and longitude are WGS84 degrees; longitudes are unwrapped across ±180° for
//!   interpolation and written back in (−180, 180].
//!
//! # Distance between fixes
//! Each step is the straight-line (chord) length between the two fixes placed on the WGS84
//! ellipsoid surface (a = 6 378 137 m, f = 1/298.257 223 563; altitude ignored, so the distance
//! is horizontal), from their Earth-centred Earth-fixed coordinates
//! `X = (N+0)·cos φ·cos λ, Y = N·cos φ·sin λ, Z = N·(1−e²)·sin φ`, `N = a/√(1−e² sin² φ)`.
//! On a surface of radius of curvature R the chord is shorter than the geodesic arc by
//! `c³/(24 R²)` (from `arc = 2R·asin(c/2R)`): relative 1·10⁻¹² for the 20 m steps of 1 Hz fixes
//! at 72 km/h, 4·10⁻¹¹ at 200 m, 1·10⁻⁸ for a 2 km gap in the fixes — far below the GNSS
//! position noise. A sphere (haversine with R = 6 371 008.8 m) would instead be off by the
//! ratio of the ellipsoid's radii of curvature to the mean radius, which depends on latitude
//! and heading: −0.56 % … +0.41 % (at 56° N +0.13 % north–south, +0.34 % east–west); on the
//! car drive haversine between the same points gives 40 496 m against 40 588 m (−0.23 %).
//! Position noise σ lengthens each step of length d by about σ²/d (2σ² of cross-track variance
//! over 2d): with σ ≈ 1 m and 20 m steps up to 0.25 %; on the car drive the chords are 0.14 %
//! longer than the integral of the receiver's Doppler speed. The track between two fixes is
//! taken as straight, so a curve driven
//! between fixes is cut short: by `(c/ρ)²/24` relative on a curve of radius ρ (2·10⁻³ for a 20 m
//! step on a 90 m roundabout radius, 2·10⁻⁵ on a 900 m motorway curve). Rounding of the ECEF
//! coordinates (≈ 10⁻⁹ m) is 5·10⁻¹¹ of a 20 m step.
//!
//! # Standstill
//! A receiver at rest wanders by metres (measured on the car drive: up to 3.6 m in 13 s), which
//! summed fix by fix would add distance that was never driven. Each fix is therefore classed:
//! - where `vehicle_speed` is known at the fix, it stands when the speed is below
//!   `standstill_speed_mps` (default 0.2 m/s: this receiver's Doppler speed read
//!   0.003–0.091 m/s at rest);
//! - otherwise it stands when it lies within `standstill_radius_m` (default 10 m, about three
//!   times the measured wander) of the anchor, the last moving fix; slow motion is then taken
//!   in chunks of that length, not lost.
//!
//! Each moving fix is a track point; each run of standing fixes is *one* point at the run's
//! mean position, and the run's altitude and pitch are its means too, so the profile depends
//! neither on how long the vehicle stood nor on one fix's wander. Distance is the sum of chords
//! between consecutive points; all fixes of a run share its distance (they *collapse*).
//!
//! # Unconverged altitude
//! Right after it acquires a fix, a receiver's altitude converges: on the car drive it read
//! 137 → 212 → 130 m over the first 47 s while its own vertical accuracy estimate fell from
//! 92 m to 6 m; for the rest of the drive the estimate never exceeded 5 m (median 2 m).
//! Where the log has an accuracy column (`elevation_accuracy_column`, default
//! `altitude_accuracy_m` as the `css-gnss-wide` mapping passes it through), elevation fixes
//! reporting more than `max_elevation_accuracy_m` (default 5 m: exactly those 47 fixes on that
//! drive) are dropped; their positions still count for distance. A 5 m error over half the
//! default smoothing wavelength (150 m) would already be a 3 % slope error. Before the first
//! and after the last usable elevation fix the elevation is held ([`GnssFacts::elevation_held_m`]).
//!
//! # Elevation, smoothing, slope
//! The elevation column (`altitude` by default; any column in m, e.g. a barometric altitude) is
//! interpolated linearly in distance between the collapsed fixes onto the grid (`elevation`).
//! GNSS altitude is noisy (0.1 m steps, reported accuracy 1–4 m, errors correlated over tens
//! of seconds), and differentiating it amplifies the noise at short wavelengths, so it is
//! smoothed by a zero-phase Butterworth low-pass in distance before the slope is taken:
//! order `smooth_order` (default 3, as the road-slope filter), design cut-off
//! `1/smooth_m` 1/m, run forward and backward ([`crate::signal::sosfiltfilt`], matched edges),
//! so the magnitude is |H|²: −6 dB at the cut-off, −120 dB/decade beyond.
//!
//! *Default `smooth_m` = 300 m, from the data.* On the measured car drive
//! (`fixtures/real/css-car-drive-164`, 40.6 km), comparing the slope of the unsmoothed GNSS
//! altitude band by band (half-octaves) with the slope from the receiver's IMU pitch: the IMU
//! slope's power exceeds the power of the difference (signal-to-noise ratio 1.6–13) at wavelengths
//! above 440 m, the ratio is 0.46 and 0.96 in the two bands between 220 and 440 m, and below 220 m
//! the difference dominates (0.40 at 160–220 m, 0.22 at 110–160 m, 0.08 at 55–78 m;
//! `fixtures/gen/make_road_profile_reference.py`). A cut-off at 50–100 m wavelength would pass the
//! bands from 55 to 220 m, where the difference carries 2.5–12 times the IMU slope's power; 300 m
//! sits in the crossover, and it is close to the road-slope filter's own cut-off (4·10⁻³ 1/m = 250
//! m), which removes what lies beyond anyway before the slope drives a model. A hillier road or a
//! better receiver (RTK, barometer) moves the crossover; pass `smooth_m` accordingly.
//!
//! `slope` is the central difference of `elevation_smoothed`, `(z[k+1] − z[k−1])/(2·step_m)`,
//! one-sided at the two ends. Within about two cut-off wavelengths of either end (600 m at the
//! default) the zero-phase filter sees one side only and the matched edge continues a straight
//! line: on a noise-free 15 m hill of 2 km wavelength the smoothed elevation is off by up to
//! 0.47 m and the slope by 1.4·10⁻² at the very ends, by 5·10⁻³ m and 1.6·10⁻⁵ farther in
//! (`tests/it/road_profile.rs`).
//!
//! # IMU pitch (optional)
//! A pitch column (deg or rad, positive nose up) gives an independent slope: its mean over the
//! grid (the sensor's mounting offset plus the track's mean grade, (z_end − z_start)/length,
//! which is tiny over a drive) is removed, then `imu_slope = tan(pitch − mean)` goes through
//! the same low-pass, and the Pearson correlation `r` with `slope` on the grid is reported.
//! Body pitch under acceleration and braking is part of the IMU signal, and the receiver may
//! fuse its own GNSS into its attitude estimate, so r measures agreement, not independent
//! truth. On the car drive: mean pitch 0.033°, r = 0.87 (positive: nose up is uphill).
//!
//! # Errors
//! [`ProfileError`]: no latitude/longitude/elevation column, fewer than 3 valid fixes, a track
//! that never moves, settings out of range; each names the file and column.

use crate::ingest::{IngestError, Ingested};
use crate::io::{config_hash, write_table, OutColumn, OutputError, TableMeta};
use crate::signal::{butter, sosfiltfilt, BandType, EdgeMode, SignalError};
use crate::table::{DriveLog, DriveMeta};
use crate::units::conversion;
use std::path::Path;
use thiserror::Error;

/// WGS84 semi-major axis, m.
pub const WGS84_A_M: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// Settings of a GNSS road profile; units in the names.
#[derive(Debug, Clone, PartialEq)]
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
        format!("road_profile:gnss:v1 {self:?}")
    }

    fn check(&self) -> Result<(), ProfileError> {
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
    #[error("{file}: column {column} has unit {unit:?}; expected {expected}")]
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
    #[error("{file}: line {line}, column {column}: {message} (value {value:?})")]
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

/// Earth-centred Earth-fixed coordinates of a point on the WGS84 ellipsoid surface, m.
pub fn ecef_on_ellipsoid(lat_deg: f64, lon_deg: f64) -> [f64; 3] {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let (phi, lam) = (lat_deg.to_radians(), lon_deg.to_radians());
    let n = WGS84_A_M / (1.0 - e2 * phi.sin().powi(2)).sqrt();
    [
        n * phi.cos() * lam.cos(),
        n * phi.cos() * lam.sin(),
        n * (1.0 - e2) * phi.sin(),
    ]
}

/// Chord length between two points on the WGS84 ellipsoid surface, m: the step distance of the
/// module doc (shorter than the geodesic by c³/(24 R²)).
pub fn chord_distance_m(lat1_deg: f64, lon1_deg: f64, lat2_deg: f64, lon2_deg: f64) -> f64 {
    let (a, b) = (
        ecef_on_ellipsoid(lat1_deg, lon1_deg),
        ecef_on_ellipsoid(lat2_deg, lon2_deg),
    );
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Zero-phase Butterworth low-pass of a grid signal: order `order`, cut-off wavelength
/// `cutoff_m` (frequency 1/cutoff_m), forward and backward with matched edges (|H|², −6 dB at
/// the cut-off).
///
/// # Errors
/// [`SignalError`] when the cut-off is not below the grid's Nyquist frequency.
pub fn lowpass_zero_phase(
    values: &[f64],
    step_m: f64,
    cutoff_m: f64,
    order: usize,
) -> Result<Vec<f64>, SignalError> {
    let sos = butter(order, 1.0 / cutoff_m, 1.0 / step_m, BandType::Lowpass)?;
    sosfiltfilt(
        &sos,
        values,
        &EdgeMode::Matched {
            padlen: None,
            fit_len: None,
        },
    )
}

/// Central differences `(z[k+1] − z[k−1])/(2h)`, one-sided first differences at the ends (as
/// `numpy.gradient` with `edge_order=1`); zeros for fewer than 2 samples.
pub fn central_difference(z: &[f64], h: f64) -> Vec<f64> {
    let n = z.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let mut d = vec![0.0; n];
    d[0] = (z[1] - z[0]) / h;
    d[n - 1] = (z[n - 1] - z[n - 2]) / h;
    for k in 1..n - 1 {
        d[k] = (z[k + 1] - z[k - 1]) / (2.0 * h);
    }
    d
}

/// Pearson correlation of two equally long series (NaN when either is constant or they are
/// shorter than 2).
pub fn pearson_r(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return f64::NAN;
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (da, db) = (a[i] - ma, b[i] - mb);
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    if saa == 0.0 || sbb == 0.0 {
        return f64::NAN;
    }
    sab / (saa * sbb).sqrt()
}

/// Linear interpolation of the points `(xs, ys)` (xs strictly increasing, at least one point)
/// at the ascending grid `grid`; values outside `[xs0, xs_last]` hold the end values.
fn interp_on_grid(xs: &[f64], ys: &[f64], grid: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(grid.len());
    let mut j = 0;
    let last = xs.len() - 1;
    for &x in grid {
        if x <= xs[0] {
            out.push(ys[0]);
            continue;
        }
        if x >= xs[last] {
            out.push(ys[last]);
            continue;
        }
        while xs[j + 1] < x {
            j += 1;
        }
        let w = (x - xs[j]) / (xs[j + 1] - xs[j]);
        out.push(ys[j] + w * (ys[j + 1] - ys[j]));
    }
    out
}

/// Means of `values` over the runs of fixes sharing one distance (`groups`: index ranges),
/// ignoring NaN; returns the `(x, mean)` points of the runs that have a value.
fn group_means(x: &[f64], groups: &[(usize, usize)], values: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for &(a, b) in groups {
        let (mut sum, mut n) = (0.0, 0usize);
        for v in &values[a..b] {
            if v.is_finite() {
                sum += v;
                n += 1;
            }
        }
        if n > 0 {
            xs.push(x[a]);
            ys.push(sum / n as f64);
        }
    }
    (xs, ys)
}

/// A road profile from the GNSS fixes of an ingested drive. For multi-rate sources (aligned at
/// ingest, so the fixes are interpolated onto the fastest channel's time base) the fix count
/// checked against `min_fixes` is the number of latitude samples in the source.
///
/// # Errors
/// See [`gnss_profile`].
pub fn gnss_profile_of(
    ing: &Ingested,
    cfg: &GnssProfileConfig,
) -> Result<RoadProfile, ProfileError> {
    let source_fixes = ing
        .report
        .channel_rates
        .iter()
        .find(|c| c.0 == "latitude")
        .map(|c| c.1);
    profile_inner(&ing.log, cfg, source_fixes)
}

/// A road profile from the GNSS fixes of a drive log, per the module doc.
///
/// # Errors
/// [`ProfileError::Setting`] for settings out of range; [`ProfileError::NoGnss`] without
/// latitude, longitude or the elevation column; [`ProfileError::TooFewFixes`] below
/// `min_fixes` valid fixes; [`ProfileError::NeverMoves`] for a track shorter than
/// `min_distance_m`; [`ProfileError::Unit`] for an elevation not in m or a pitch not in deg/rad.
pub fn gnss_profile(log: &DriveLog, cfg: &GnssProfileConfig) -> Result<RoadProfile, ProfileError> {
    profile_inner(log, cfg, None)
}

fn profile_inner(
    log: &DriveLog,
    cfg: &GnssProfileConfig,
    source_fixes: Option<usize>,
) -> Result<RoadProfile, ProfileError> {
    cfg.check()?;
    let file = log.meta.source_file.clone();
    let column = |name: &str| {
        log.signals
            .iter()
            .find(|s| s.name == name && s.values.iter().any(|v| v.is_finite()))
            .ok_or_else(|| ProfileError::NoGnss {
                file: file.clone(),
                column: name.into(),
            })
    };
    let lat = &column("latitude")?.values;
    let lon = &column("longitude")?.values;
    let elev_sig = column(&cfg.elevation_column)?;
    if elev_sig.unit != "m" {
        return Err(ProfileError::Unit {
            file,
            column: elev_sig.name.clone(),
            unit: elev_sig.unit.clone(),
            expected: "m".into(),
        });
    }
    let pitch = match &cfg.pitch_column {
        Some(name) => {
            let s = log
                .signals
                .iter()
                .find(|s| &s.name == name)
                .ok_or_else(|| ProfileError::NoPitch {
                    file: file.clone(),
                    column: name.clone(),
                })?;
            let conv = conversion(&s.unit, "geo_angle", None).map_err(|_| ProfileError::Unit {
                file: file.clone(),
                column: name.clone(),
                unit: s.unit.clone(),
                expected: "deg or rad".into(),
            })?;
            Some((
                name.clone(),
                s.values
                    .iter()
                    .map(|v| conv.apply(*v))
                    .collect::<Vec<f64>>(),
            ))
        }
        None => None,
    };
    let speed = log.signal("vehicle_speed");

    // the fixes: rows with a position
    let rows: Vec<usize> = (0..log.len())
        .filter(|&i| lat[i].is_finite() && lon[i].is_finite())
        .collect();
    let fixes = rows.len().min(source_fixes.unwrap_or(usize::MAX));
    if fixes < cfg.min_fixes {
        return Err(ProfileError::TooFewFixes {
            file,
            column: "latitude".into(),
            fixes,
            min: cfg.min_fixes,
        });
    }
    let elevation_fixes = rows
        .iter()
        .filter(|&&i| elev_sig.values[i].is_finite())
        .count();
    // the receiver's own accuracy estimate, where it reports one, rejects unconverged altitude
    let mut elev = elev_sig.values.clone();
    let mut inaccurate = 0;
    if let Some(acc) = log.signal(&cfg.elevation_accuracy_column) {
        for &i in &rows {
            if elev[i].is_finite() && acc[i] > cfg.max_elevation_accuracy_m {
                elev[i] = f64::NAN;
                inaccurate += 1;
            }
        }
    }
    let usable = elevation_fixes - inaccurate;
    if usable < cfg.min_fixes {
        return Err(ProfileError::TooFewFixes {
            file,
            column: if inaccurate > 0 {
                format!(
                    "{} (with {} <= {} m)",
                    cfg.elevation_column,
                    cfg.elevation_accuracy_column,
                    cfg.max_elevation_accuracy_m
                )
            } else {
                cfg.elevation_column.clone()
            },
            fixes: usable,
            min: cfg.min_fixes,
        });
    }

    let n = rows.len();
    let at_fixes = |v: &[f64]| rows.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let lat_f = at_fixes(lat);
    // longitudes unwrapped across ±180° so means and interpolation never jump
    let mut lon_u = at_fixes(lon);
    for j in 1..n {
        let d = lon_u[j] - lon_u[j - 1];
        lon_u[j] -= 360.0 * (d / 360.0).round();
    }

    // standstill fixes: by speed where known, else within the radius of the anchor (the last
    // moving fix)
    let mut still = vec![false; n];
    let (mut by_speed, mut by_radius) = (0, 0);
    let mut anchor = 0;
    for j in 0..n {
        still[j] = match speed.map(|v| v[rows[j]]).filter(|v| v.is_finite()) {
            Some(v) => {
                by_speed += 1;
                v < cfg.standstill_speed_mps
            }
            None => {
                by_radius += 1;
                j > 0
                    && chord_distance_m(lat_f[anchor], lon_u[anchor], lat_f[j], lon_u[j])
                        <= cfg.standstill_radius_m
            }
        };
        if !still[j] {
            anchor = j;
        }
    }
    let standstill = still.iter().filter(|s| **s).count();
    // track points: each moving fix, and each run of standstill fixes at its mean position;
    // distance is the sum of chords between consecutive points
    let mut x = vec![0.0; n];
    let mut prev: Option<(f64, f64)> = None;
    let (mut dist, mut longest_step): (f64, f64) = (0.0, 0.0);
    let mut j = 0;
    while j < n {
        let a = j;
        j += 1;
        if still[a] {
            while j < n && still[j] {
                j += 1;
            }
        }
        let m = (j - a) as f64;
        let here = (
            lat_f[a..j].iter().sum::<f64>() / m,
            lon_u[a..j].iter().sum::<f64>() / m,
        );
        if let Some(p) = prev {
            let d = chord_distance_m(p.0, p.1, here.0, here.1);
            dist += d;
            longest_step = longest_step.max(d);
        }
        prev = Some(here);
        x[a..j].iter_mut().for_each(|v| *v = dist);
    }
    let total = dist;
    let duration_s = (log.timestamp_ns[rows[n - 1]] - log.timestamp_ns[rows[0]]) as f64 * 1e-9;
    let min_m = cfg.min_distance_m.max(2.0 * cfg.step_m);
    if total < min_m {
        return Err(ProfileError::NeverMoves {
            file,
            distance_m: total,
            fixes: n,
            duration_s,
            min_m,
        });
    }

    // fixes at one distance (a stop, or a repeated position) collapse to one point
    let mut groups = Vec::new();
    let mut a = 0;
    for j in 1..=n {
        if j == n || x[j] != x[a] {
            groups.push((a, j));
            a = j;
        }
    }

    let n_grid = (total / cfg.step_m + 1e-9).floor() as usize + 1;
    let grid: Vec<f64> = (0..n_grid).map(|k| k as f64 * cfg.step_m).collect();
    let on_grid = |values: &[f64]| {
        let (xs, ys) = group_means(&x, &groups, values);
        interp_on_grid(&xs, &ys, &grid)
    };
    let elev_fixes = at_fixes(&elev);
    let elevation = on_grid(&elev_fixes);
    let elevation_held_m = {
        let (xs, _) = group_means(&x, &groups, &elev_fixes);
        xs[0] + (total - xs[xs.len() - 1])
    };
    let latitude = on_grid(&lat_f);
    let longitude: Vec<f64> = on_grid(&lon_u)
        .into_iter()
        .map(|l| {
            let w = (l + 180.0).rem_euclid(360.0) - 180.0;
            if w == -180.0 {
                180.0
            } else {
                w
            }
        })
        .collect();

    let filt = |v: &[f64]| {
        lowpass_zero_phase(v, cfg.step_m, cfg.smooth_m, cfg.smooth_order).map_err(|source| {
            ProfileError::Filter {
                file: file.clone(),
                source,
            }
        })
    };
    let smoothed = filt(&elevation)?;
    let slope = central_difference(&smoothed, cfg.step_m);

    let (imu_slope, pitch_cmp) = match pitch {
        Some((name, p)) => {
            let pf = at_fixes(&p);
            if !pf.iter().any(|v| v.is_finite()) {
                return Err(ProfileError::NoPitch { file, column: name });
            }
            let pg = on_grid(&pf);
            let mean = pg.iter().sum::<f64>() / pg.len() as f64;
            let raw: Vec<f64> = pg.iter().map(|p| (p - mean).to_radians().tan()).collect();
            let imu = filt(&raw)?;
            let r = pearson_r(&slope, &imu);
            (
                Some(imu),
                Some(PitchComparison {
                    column: name,
                    mean_offset_deg: mean,
                    r,
                }),
            )
        }
        None => (None, None),
    };

    Ok(RoadProfile {
        meta: log.meta.clone(),
        source: ProfileSource::Gnss(Box::new(GnssFacts {
            fixes: n,
            standstill_fixes: standstill,
            fixes_classed_by_speed: by_speed,
            fixes_classed_by_radius: by_radius,
            points: groups.len(),
            distance_m: total,
            longest_step_m: longest_step,
            duration_s,
            elevation_column: cfg.elevation_column.clone(),
            elevation_fixes,
            elevation_fixes_inaccurate: inaccurate,
            elevation_held_m,
            config: cfg.clone(),
            pitch: pitch_cmp,
        })),
        step_m: cfg.step_m,
        distance_m: grid,
        elevation_m: elevation,
        elevation_smoothed_m: Some(smoothed),
        slope,
        latitude_deg: Some(latitude),
        longitude_deg: Some(longitude),
        imu_slope,
    })
}

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
        return Err(not(format!(
            "table {:?}, expected road_profile (write one with `fleetdyn road profile`)",
            kv.get("table")
        )));
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
        },
        step_m,
        column: column.into(),
        unit,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Meridian arc length from `lat1` to `lat2` on WGS84 by composite Simpson on
    /// M(φ) = a(1−e²)/(1−e² sin²φ)^{3/2} (independent of the chord formula).
    fn meridian_arc_m(lat1: f64, lat2: f64) -> f64 {
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let m = |phi: f64| WGS84_A_M * (1.0 - e2) / (1.0 - e2 * phi.sin().powi(2)).powf(1.5);
        let (a, b) = (lat1.to_radians(), lat2.to_radians());
        let n = 2000;
        let h = (b - a) / n as f64;
        let mut s = m(a) + m(b);
        for k in 1..n {
            s += m(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    #[test]
    fn chord_matches_the_meridian_arc_to_the_stated_error() {
        // c³/(24 R²) with R ≈ 6.39e6 m at 56°: 20 m → 1e-12 relative, 2 km → 1e-8
        // plus rounding: ECEF coordinates of 6.4e6 m carry ~1e-9 m, 5e-11 of a 20 m step
        for (step_m, tol_rel) in [(20.0, 2e-10), (200.0, 1e-10), (2000.0, 2e-8)] {
            let dlat = step_m / 111_000.0;
            let arc = meridian_arc_m(56.0, 56.0 + dlat);
            let chord = chord_distance_m(56.0, 10.0, 56.0 + dlat, 10.0);
            let rel = (arc - chord) / arc;
            assert!(rel >= -1e-13 && rel < tol_rel, "{step_m} m: {rel:e}");
        }
        // along a parallel the chord of a short step equals the arc N cosφ Δλ to (c/ρ)²/24
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let phi = 56f64.to_radians();
        let n = WGS84_A_M / (1.0 - e2 * phi.sin().powi(2)).sqrt();
        let dlon = 0.0005f64; // ≈ 31 m
        let arc = n * phi.cos() * dlon.to_radians();
        let chord = chord_distance_m(56.0, 10.0, 56.0, 10.0 + dlon);
        assert!(((arc - chord) / arc).abs() < 1e-10);
        // across the antimeridian
        let d = chord_distance_m(0.0, 179.9999, 0.0, -179.9999);
        assert!(
            (d - 2.0 * 0.0001f64.to_radians() * WGS84_A_M).abs() < 1e-6,
            "{d}"
        );
    }

    #[test]
    fn central_difference_and_pearson() {
        let z: Vec<f64> = (0..10).map(|k| 0.5 * (k as f64).powi(2)).collect();
        let d = central_difference(&z, 1.0);
        // exact for a parabola in the interior
        for (k, v) in d.iter().enumerate().take(9).skip(1) {
            assert!((v - k as f64).abs() < 1e-12);
        }
        let a = [1.0, 2.0, 3.0, 4.0];
        assert!((pearson_r(&a, &[2.0, 4.0, 6.0, 8.0]) - 1.0).abs() < 1e-12);
        assert!((pearson_r(&a, &[-1.0, -2.0, -3.0, -4.0]) + 1.0).abs() < 1e-12);
        assert!(pearson_r(&a, &[1.0; 4]).is_nan());
    }
}
