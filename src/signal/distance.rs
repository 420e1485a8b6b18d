//! Resampling a drive from time to travelled distance (docs/models/road.md: the spatial
//! coordinate is `x(t) = ∫ v dt`, or the odometer where present).
//!
//! # The distance map
//! [`DistanceMap`] holds the travelled distance at each of the drive's own sample times: a
//! non-decreasing function `x(t)`. Its inverse, [`DistanceMap::time_at`], returns the *earliest*
//! time the vehicle reached a distance, so it is a function too even where `x(t)` is flat.
//!
//! # Rules
//! - **Source.** `auto` uses the `odometer` column when present, finite throughout, and finer
//!   than the grid step (a J1939 odometer with 5 m resolution would turn the map into a
//!   staircase); otherwise the trapezoidal integral of `vehicle_speed`. Which one was used is
//!   reported.
//! - **Standstill adds no distance.** Speeds with |v| below `standstill_speed_mps` count as zero,
//!   so sensor noise at rest does not creep the vehicle forward. All samples of a stop map to the
//!   same distance and *collapse*: the grid point at that distance takes the arrival instant
//!   (earliest time) and the signal values interpolated there; the samples during the stop do not
//!   appear on the distance grid. [`DistanceLog::collapsed_samples`] counts them.
//! - **Reverse motion** (v < −`reverse_speed_mps`): [`ReversePolicy::Error`] fails the drive,
//!   naming the first row; [`ReversePolicy::Exclude`] treats it like standstill (no distance, the
//!   samples collapse) and counts it, so the map stays monotone. Speeds between the two
//!   thresholds are sensor noise around zero and count as zero.
//! - **Missing speed.** Short NaN runs (ingest limits their length) are bridged linearly; NaN
//!   at the edges takes the nearest valid value.
//! - **Grid.** `x_k = k·step_m`, k = 0 … ⌊x_end/step_m⌋, starting at the drive's first sample.
//!   Linear columns are interpolated in time at `t(x_k)`, hold columns take the last sample at or
//!   before `t(x_k)`; NaN stays NaN.
//! - **Back to time.** [`DistanceMap::to_time_axis`] evaluates a grid signal at each original
//!   sample's distance (linear interpolation on the grid), e.g. to put a filtered slope back onto
//!   the time axis.

use crate::schema::{drive_log, Interpolation};
use crate::signal::quantization::estimate_quantization;
use crate::table::{DriveLog, DriveMeta, Signal};
use crate::time_fmt::rfc3339_ns;
use std::borrow::Cow;
use thiserror::Error;

/// Where distance comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DistanceSource {
    /// Odometer if usable, else ∫v dt.
    #[default]
    Auto,
    /// The `odometer` column (error if absent or decreasing).
    Odometer,
    /// Trapezoidal integral of `vehicle_speed`.
    Speed,
}

impl DistanceSource {
    /// The source's name as configuration files write it: `auto`, `odometer`, `speed`.
    pub fn name(self) -> &'static str {
        match self {
            DistanceSource::Auto => "auto",
            DistanceSource::Odometer => "odometer",
            DistanceSource::Speed => "speed",
        }
    }
}

/// What to do with reverse motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReversePolicy {
    /// Fail the drive at the first reverse sample.
    #[default]
    Error,
    /// Count reverse samples as standstill (no distance) and report how many.
    Exclude,
}

/// Distance-resampling settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ResampleConfig {
    /// Grid step, m.
    pub step_m: f64,
    /// Distance source.
    pub distance_source: DistanceSource,
    /// Reverse-motion policy.
    pub reverse: ReversePolicy,
    /// |v| below this is standstill, m/s.
    pub standstill_speed_mps: f64,
    /// v below minus this is reverse motion, m/s.
    pub reverse_speed_mps: f64,
    /// A drive shorter than this has "no distance" and fails, m.
    pub min_distance_m: f64,
}

impl Default for ResampleConfig {
    fn default() -> Self {
        Self {
            step_m: 1.0,
            distance_source: DistanceSource::Auto,
            reverse: ReversePolicy::Error,
            // J1939 CCVS resolves 1/256 km/h; wheel-speed sensors read 0 below ~0.5 km/h, so
            // anything under 0.1 m/s (0.36 km/h) is noise at rest.
            standstill_speed_mps: 0.1,
            reverse_speed_mps: 0.5,
            min_distance_m: 10.0,
        }
    }
}

/// Why a drive cannot be put on a distance grid.
#[derive(Debug, Error, PartialEq)]
pub enum ResampleError {
    /// Grid step not positive and finite.
    #[error("grid step {step_m} m must be positive and finite")]
    InvalidStep {
        /// Configured step.
        step_m: f64,
    },
    /// Column needed for distance is absent or empty.
    #[error("{file}: no usable {column} column to compute distance")]
    MissingColumn {
        /// Source file.
        file: String,
        /// Column.
        column: String,
    },
    /// The vehicle never moved far enough.
    #[error("{file}: the vehicle never moves: it travelled {distance_m:.2} m in {duration_s:.1} s (minimum {min_m} m), no distance to resample")]
    NoDistance {
        /// Source file.
        file: String,
        /// Distance travelled.
        distance_m: f64,
        /// Drive duration.
        duration_s: f64,
        /// Configured minimum.
        min_m: f64,
    },
    /// Reverse motion with [`ReversePolicy::Error`].
    #[error("{file}: reverse motion at row {row} ({}): vehicle_speed = {speed_mps} m/s; set reverse to exclude ([resample] reverse, or --reverse exclude) to collapse it", rfc3339_ns(*time_ns))]
    ReverseMotion {
        /// Source file.
        file: String,
        /// Row of the drive log.
        row: usize,
        /// Time.
        time_ns: i64,
        /// Speed.
        speed_mps: f64,
    },
    /// The odometer goes backwards.
    #[error("{file}: odometer decreases at row {row} ({}): {value_m} m after {previous_m} m", rfc3339_ns(*time_ns))]
    OdometerDecreasing {
        /// Source file.
        file: String,
        /// Row.
        row: usize,
        /// Time.
        time_ns: i64,
        /// Value.
        value_m: f64,
        /// Value before.
        previous_m: f64,
    },
}

/// Travelled distance at each sample time of a drive.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceMap {
    /// Sample times, ns (the drive log's own).
    pub t_ns: Vec<i64>,
    /// Distance at each time, m; starts at 0, non-decreasing.
    pub x_m: Vec<f64>,
    /// Which source was used.
    pub source: DistanceSource,
    /// Samples that added no distance (standstill or excluded reverse), after the first.
    pub standstill_samples: usize,
    /// Samples of excluded reverse motion.
    pub reverse_samples: usize,
}

/// Fills missing values (NaN) as the column's interpolation kind allows: `linear` bridges gaps
/// linearly, `hold` repeats the previous valid value; leading gaps take the first valid value and
/// trailing gaps the last. `None` when no value is valid. Used where a stage allows filling the
/// short gaps ingest accepted (the ingest NaN-run limit bounds their length).
pub fn fill_gaps(values: &[f64], interpolation: Interpolation) -> Option<Vec<f64>> {
    let first = values.iter().position(|v| v.is_finite())?;
    let last = values.iter().rposition(|v| v.is_finite())?;
    let mut out = values.to_vec();
    out[..first].fill(values[first]);
    out[last + 1..].fill(values[last]);
    // each gap between two valid samples a < b (no index list: a long drive's would be 8 B/row)
    let mut a = first;
    for b in first + 1..=last {
        if !values[b].is_finite() {
            continue;
        }
        for (i, o) in out.iter_mut().enumerate().take(b).skip(a + 1) {
            *o = match interpolation {
                Interpolation::Linear => {
                    let f = (i - a) as f64 / (b - a) as f64;
                    values[a] + f * (values[b] - values[a])
                }
                Interpolation::Hold | Interpolation::None => values[a],
            };
        }
        a = b;
    }
    Some(out)
}

/// [`fill_gaps`], borrowing `values` when there is no gap to fill (no copy of a long drive's
/// column that is already complete).
pub fn fill_gaps_borrowed(values: &[f64], interpolation: Interpolation) -> Option<Cow<'_, [f64]>> {
    if !values.is_empty() && values.iter().all(|v| v.is_finite()) {
        Some(Cow::Borrowed(values))
    } else {
        fill_gaps(values, interpolation).map(Cow::Owned)
    }
}

/// The column `name` of `log` with its gaps (NaN) filled as the canonical schema's
/// interpolation kind says (linear for pass-through columns; [`fill_gaps`]); borrowed when
/// nothing is missing. `None` when the column is absent or has no finite value.
pub fn filled_column<'a>(log: &'a DriveLog, name: &str) -> Option<Cow<'a, [f64]>> {
    let kind = drive_log()
        .column(name)
        .map_or(Interpolation::Linear, |c| c.interpolation);
    fill_gaps_borrowed(log.signal(name)?, kind)
}

impl DistanceMap {
    /// Builds the map of a drive per the module rules.
    ///
    /// # Errors
    /// [`ResampleError`] for missing columns, reverse motion (policy `error`), a decreasing
    /// odometer, or a drive shorter than `min_distance_m`.
    pub fn from_log(log: &DriveLog, cfg: &ResampleConfig) -> Result<Self, ResampleError> {
        let file = log.meta.source_file.clone();
        if !(cfg.step_m > 0.0 && cfg.step_m.is_finite()) {
            return Err(ResampleError::InvalidStep { step_m: cfg.step_m });
        }
        let odo = log
            .signal("odometer")
            .filter(|o| !o.is_empty() && o.iter().all(|v| v.is_finite()));
        let odo_usable =
            odo.is_some_and(|o| estimate_quantization(o).is_none_or(|q| q.step <= cfg.step_m));
        let use_odo = match cfg.distance_source {
            DistanceSource::Odometer => {
                if odo.is_none() {
                    return Err(ResampleError::MissingColumn {
                        file,
                        column: "odometer".into(),
                    });
                }
                true
            }
            DistanceSource::Speed => false,
            DistanceSource::Auto => odo_usable,
        };
        let n = log.len();
        let mut x = vec![0.0; n];
        let mut standstill = 0;
        let mut reverse = 0;
        let source;
        if use_odo {
            source = DistanceSource::Odometer;
            let o = odo.expect("checked");
            for i in 1..n {
                if o[i] < o[i - 1] {
                    return Err(ResampleError::OdometerDecreasing {
                        file,
                        row: i,
                        time_ns: log.timestamp_ns[i],
                        value_m: o[i],
                        previous_m: o[i - 1],
                    });
                }
                x[i] = o[i] - o[0];
                if o[i] == o[i - 1] {
                    standstill += 1;
                }
            }
        } else {
            source = DistanceSource::Speed;
            let v = log
                .signal("vehicle_speed")
                .filter(|v| v.iter().any(|x| x.is_finite()))
                .ok_or_else(|| ResampleError::MissingColumn {
                    file: file.clone(),
                    column: "vehicle_speed".into(),
                })?;
            let v = fill_gaps_borrowed(v, Interpolation::Linear).expect("has a finite value");
            let mut eff = vec![0.0; n];
            for i in 0..n {
                if v[i] < -cfg.reverse_speed_mps {
                    if cfg.reverse == ReversePolicy::Error {
                        return Err(ResampleError::ReverseMotion {
                            file,
                            row: i,
                            time_ns: log.timestamp_ns[i],
                            speed_mps: v[i],
                        });
                    }
                    reverse += 1;
                } else if v[i].abs() >= cfg.standstill_speed_mps {
                    eff[i] = v[i].max(0.0);
                }
            }
            for i in 1..n {
                let dt = (log.timestamp_ns[i] - log.timestamp_ns[i - 1]) as f64 * 1e-9;
                let dx = 0.5 * (eff[i - 1] + eff[i]) * dt;
                if dx == 0.0 {
                    standstill += 1;
                }
                x[i] = x[i - 1] + dx;
            }
        }
        let total = x.last().copied().unwrap_or(0.0);
        if total < cfg.min_distance_m.max(cfg.step_m) {
            return Err(ResampleError::NoDistance {
                file,
                distance_m: total,
                duration_s: log.duration_s(),
                min_m: cfg.min_distance_m,
            });
        }
        Ok(Self {
            t_ns: log.timestamp_ns.clone(),
            x_m: x,
            source,
            standstill_samples: standstill,
            reverse_samples: reverse,
        })
    }

    /// Total distance, m.
    pub fn total_m(&self) -> f64 {
        self.x_m.last().copied().unwrap_or(0.0)
    }

    /// Position of distance `x` between samples: `(i, w)` with `x` reached at
    /// `t_ns[i] + w·(t_ns[i+1] − t_ns[i])`, earliest such time; `None` beyond the drive.
    fn locate(&self, x: f64, from: usize) -> Option<(usize, f64)> {
        let n = self.x_m.len();
        if n == 0 || x < 0.0 || x > self.total_m() {
            return None;
        }
        let mut i = from.min(n - 1);
        // first index with x_m[i] >= x
        while i < n && self.x_m[i] < x {
            i += 1;
        }
        if i == 0 || self.x_m[i] == x {
            // earliest sample at exactly this distance
            while i > 0 && self.x_m[i - 1] == x {
                i -= 1;
            }
            return Some((i, 0.0));
        }
        let (a, b) = (self.x_m[i - 1], self.x_m[i]);
        Some((i - 1, (x - a) / (b - a)))
    }

    /// Earliest time the vehicle reached distance `x_m` (the distance → time map), ns;
    /// `None` outside `[0, total]`.
    pub fn time_at(&self, x_m: f64) -> Option<i64> {
        self.locate(x_m, 0).map(|(i, w)| self.interp_time(i, w))
    }

    fn interp_time(&self, i: usize, w: f64) -> i64 {
        if w == 0.0 {
            return self.t_ns[i];
        }
        let dt = (self.t_ns[i + 1] - self.t_ns[i]) as f64;
        self.t_ns[i] + (w * dt).round() as i64
    }

    /// Distance at time `t_ns` (the time → distance map, linear between samples), m; clamped to
    /// the drive's span.
    pub fn distance_at(&self, t_ns: i64) -> f64 {
        let k = self.t_ns.partition_point(|&t| t <= t_ns);
        if k == 0 {
            return 0.0;
        }
        if k == self.t_ns.len() {
            return self.total_m();
        }
        let (t0, t1) = (self.t_ns[k - 1], self.t_ns[k]);
        let w = (t_ns - t0) as f64 / (t1 - t0) as f64;
        self.x_m[k - 1] + w * (self.x_m[k] - self.x_m[k - 1])
    }

    /// Evaluates a signal given on the uniform grid `x_k = k·step_m` at every original sample's
    /// distance (linear interpolation; the sub-step tail beyond the last grid point holds the last
    /// value).
    pub fn to_time_axis(&self, grid_values: &[f64], step_m: f64) -> Vec<f64> {
        let last = grid_values.len().saturating_sub(1);
        self.x_m
            .iter()
            .map(|&x| {
                if grid_values.is_empty() {
                    return f64::NAN;
                }
                let f = x / step_m;
                let k = (f.floor() as usize).min(last);
                if k == last {
                    return grid_values[last];
                }
                let w = f - k as f64;
                grid_values[k] + w * (grid_values[k + 1] - grid_values[k])
            })
            .collect()
    }
}

/// A drive on a uniform distance grid.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceLog {
    /// Drive identification.
    pub meta: DriveMeta,
    /// Grid step, m.
    pub step_m: f64,
    /// Grid distances `k·step_m`, m.
    pub distance_m: Vec<f64>,
    /// Earliest time at each grid distance, ns.
    pub timestamp_ns: Vec<i64>,
    /// Signals at the grid points (canonical order, pass-through columns last).
    pub signals: Vec<Signal>,
    /// The time ↔ distance map of the drive.
    pub map: DistanceMap,
    /// Drive samples that collapsed (standstill and excluded reverse), not on the grid.
    pub collapsed_samples: usize,
}

impl DistanceLog {
    /// Values of a grid column by name.
    pub fn signal(&self, name: &str) -> Option<&[f64]> {
        self.signals
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.values.as_slice())
    }
}

/// Resamples a drive to a uniform distance grid (see the module rules).
///
/// # Errors
/// See [`DistanceMap::from_log`].
pub fn resample_to_distance(
    log: &DriveLog,
    cfg: &ResampleConfig,
) -> Result<DistanceLog, ResampleError> {
    resample_columns_to_distance(log, None, cfg)
}

/// [`resample_to_distance`] for the columns named in `keep` alone (all with `None`): the
/// same grid, map and values, without the others' memory.
///
/// # Errors
/// See [`DistanceMap::from_log`].
pub fn resample_columns_to_distance(
    log: &DriveLog,
    keep: Option<&[&str]>,
    cfg: &ResampleConfig,
) -> Result<DistanceLog, ResampleError> {
    let map = DistanceMap::from_log(log, cfg)?;
    let n_grid = (map.total_m() / cfg.step_m).floor() as usize + 1;
    let mut pos = Vec::with_capacity(n_grid);
    let mut from = 0;
    for k in 0..n_grid {
        let x = k as f64 * cfg.step_m;
        let (i, w) = map.locate(x, from).expect("grid lies within [0, total]");
        from = i;
        pos.push((i, w));
    }
    let timestamp_ns = pos.iter().map(|&(i, w)| map.interp_time(i, w)).collect();
    let schema = drive_log();
    let signals = log
        .signals
        .iter()
        .filter(|s| keep.is_none_or(|k| k.contains(&s.name.as_str())))
        .map(|s| {
            let interp = schema
                .column(&s.name)
                .map_or(Interpolation::Linear, |c| c.interpolation);
            let values = pos
                .iter()
                .map(|&(i, w)| match interp {
                    _ if w == 0.0 => s.values[i],
                    Interpolation::Linear => s.values[i] + w * (s.values[i + 1] - s.values[i]),
                    Interpolation::Hold | Interpolation::None => s.values[i],
                })
                .collect();
            Signal {
                name: s.name.clone(),
                unit: s.unit.clone(),
                values,
            }
        })
        .collect();
    Ok(DistanceLog {
        meta: log.meta.clone(),
        step_m: cfg.step_m,
        distance_m: (0..n_grid).map(|k| k as f64 * cfg.step_m).collect(),
        timestamp_ns,
        signals,
        collapsed_samples: map.standstill_samples,
        map,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_are_filled_by_the_column_kind_and_complete_columns_are_borrowed() {
        let nan = f64::NAN;
        let v = [
            nan,
            nan,
            1.0,
            nan,
            nan,
            nan,
            2.5,
            f64::INFINITY,
            -0.7,
            nan,
            3.0,
            nan,
        ];
        // by hand: leading gap takes the first valid value, trailing gap the last, inner gaps
        // linear from the valid sample before to the one after (or held)
        let lin = fill_gaps(&v, Interpolation::Linear).unwrap();
        let third = |a: f64, b: f64, k: f64| a + (k / 4.0) * (b - a);
        let want = [
            1.0,
            1.0,
            1.0,
            third(1.0, 2.5, 1.0),
            third(1.0, 2.5, 2.0),
            third(1.0, 2.5, 3.0),
            2.5,
            2.5 + 0.5 * (-0.7 - 2.5),
            -0.7,
            -0.7 + 0.5 * (3.0 + 0.7),
            3.0,
            3.0,
        ];
        for (k, (a, b)) in lin.iter().zip(want).enumerate() {
            assert_eq!(a.to_bits(), b.to_bits(), "linear, sample {k}");
        }
        let held = fill_gaps(&v, Interpolation::Hold).unwrap();
        let want = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.5, 2.5, -0.7, -0.7, 3.0, 3.0];
        assert_eq!(held, want);
        assert_eq!(fill_gaps(&[nan, nan], Interpolation::Linear), None);
        assert_eq!(fill_gaps_borrowed(&[nan], Interpolation::Hold), None);
        assert_eq!(fill_gaps_borrowed(&[], Interpolation::Hold), None);
        let complete = [1.0, -2.0, 3.0];
        let c = fill_gaps_borrowed(&complete, Interpolation::Linear).unwrap();
        assert!(matches!(c, Cow::Borrowed(_)) && *c == complete);
        let g = fill_gaps_borrowed(&v, Interpolation::Linear).unwrap();
        assert!(matches!(g, Cow::Owned(_)) && *g == *lin);
    }

    fn log(t_s: &[f64], v: &[f64], slope: &[f64]) -> DriveLog {
        DriveLog {
            meta: DriveMeta {
                drive_id: "d".into(),
                vehicle_id: None,
                source_file: "test".into(),
                segment: None,
            },
            timestamp_ns: t_s.iter().map(|t| (t * 1e9) as i64).collect(),
            signals: vec![
                Signal {
                    name: "vehicle_speed".into(),
                    unit: "m/s".into(),
                    values: v.to_vec(),
                },
                Signal {
                    name: "road_slope".into(),
                    unit: "1".into(),
                    values: slope.to_vec(),
                },
            ],
        }
    }

    #[test]
    fn constant_speed_gives_exact_grid_times() {
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        let v = vec![20.0; t.len()];
        let s: Vec<f64> = t
            .iter()
            .map(|x| if *x < 5.0 { 0.01 } else { 0.02 })
            .collect();
        let d = resample_to_distance(&log(&t, &v, &s), &ResampleConfig::default()).unwrap();
        assert_eq!(d.distance_m.len(), 201); // 200 m in 10 s
                                             // 1 m at 20 m/s is 50 ms
        assert_eq!(d.timestamp_ns[1], 50_000_000);
        assert_eq!(d.timestamp_ns[200], 10_000_000_000);
        // hold: slope switches at 5 s = 100 m; at 99 m the sample before 5 s holds
        let slope = d.signal("road_slope").unwrap();
        assert_eq!(slope[99], 0.01);
        assert_eq!(slope[100], 0.02);
        // inverse maps
        assert_eq!(d.map.time_at(100.0), Some(5_000_000_000));
        assert!((d.map.distance_at(2_500_000_000) - 50.0).abs() < 1e-9);
    }

    #[test]
    fn standstill_collapses_to_the_arrival_time() {
        // 10 m/s for 2 s, stop for 3 s, 10 m/s for 2 s.
        let t: Vec<f64> = (0..=70).map(|k| k as f64 * 0.1).collect();
        let v: Vec<f64> = t
            .iter()
            .map(|&x| {
                if (2.05..=4.95).contains(&x) {
                    0.0
                } else {
                    10.0
                }
            })
            .collect();
        let s = vec![0.0; t.len()];
        let d = resample_to_distance(&log(&t, &v, &s), &ResampleConfig::default()).unwrap();
        // samples 2.1 … 4.9 s stand still: the 28 intervals between them add no distance
        assert_eq!(d.collapsed_samples, 28);
        // distance reached at the stop: every stop sample maps to it; grid times never go back
        assert!(d.timestamp_ns.windows(2).all(|w| w[1] >= w[0]));
        // no grid point lies strictly inside the stop (2.05 s, 4.95 s)
        assert!(!d
            .timestamp_ns
            .iter()
            .any(|&t| t > 2_100_000_000 && t < 4_950_000_000));
    }

    #[test]
    fn reverse_motion_errors_or_is_excluded() {
        let t: Vec<f64> = (0..=50).map(|k| k as f64 * 0.1).collect();
        let mut v = vec![10.0; t.len()];
        v[20] = -2.0;
        let s = vec![0.0; t.len()];
        let e = resample_to_distance(&log(&t, &v, &s), &ResampleConfig::default()).unwrap_err();
        assert!(
            matches!(e, ResampleError::ReverseMotion { row: 20, .. }),
            "{e}"
        );
        let cfg = ResampleConfig {
            reverse: ReversePolicy::Exclude,
            ..Default::default()
        };
        let d = resample_to_distance(&log(&t, &v, &s), &cfg).unwrap();
        assert_eq!(d.map.reverse_samples, 1);
    }

    #[test]
    fn a_parked_drive_has_no_distance() {
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        let v: Vec<f64> = (0..=100)
            .map(|k| if k % 2 == 0 { 0.05 } else { -0.05 })
            .collect();
        let s = vec![0.0; t.len()];
        let e = resample_to_distance(&log(&t, &v, &s), &ResampleConfig::default()).unwrap_err();
        assert!(matches!(e, ResampleError::NoDistance { .. }), "{e}");
    }

    #[test]
    fn to_time_axis_round_trips_linear_signals() {
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        let v: Vec<f64> = t.iter().map(|x| 5.0 + x).collect();
        let s = vec![0.0; t.len()];
        let d = resample_to_distance(&log(&t, &v, &s), &ResampleConfig::default()).unwrap();
        // a signal linear in distance survives the trip grid -> time exactly
        let grid: Vec<f64> = d.distance_m.iter().map(|x| 3.0 * x).collect();
        let back = d.map.to_time_axis(&grid, d.step_m);
        let last_grid = *d.distance_m.last().unwrap();
        for (b, x) in back.iter().zip(&d.map.x_m) {
            if *x <= last_grid {
                assert!((b - 3.0 * x).abs() < 1e-9);
            }
        }
    }
}
