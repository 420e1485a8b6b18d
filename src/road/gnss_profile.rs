//! Road profiles from the GNSS fixes of a drive ([`gnss_profile`], docs/models/road.md): track
//! distance, elevation and slope on a uniform distance grid in the conventions of
//! [`super::profile`], with the settings [`GnssProfileConfig`].
//!
//! # Distance between fixes
//! Each step is the straight-line (chord) length between the two fixes placed on the WGS84
//! ellipsoid surface ([`chord_distance_m`]; altitude ignored, so the distance is horizontal):
//! shorter than the geodesic by 1·10⁻⁸ relative for a 2 km gap in the fixes and far less for the
//! steps of 1 Hz fixes (its error against the geodesic and a sphere: [`super::wgs84`]).
//! Position noise σ lengthens each step of length d by about σ²/d (2σ² of cross-track variance
//! over 2d): with σ ≈ 1 m and 20 m steps up to 0.25 %; on the car drive the chords are 0.14 %
//! longer than the integral of the receiver's Doppler speed. The track between two fixes is
//! taken as straight, so a curve driven
//! between fixes is cut short: by `(c/ρ)²/24` relative on a curve of radius ρ (2·10⁻³ for a 20 m
//! step on a 90 m roundabout radius, 2·10⁻⁵ on a 900 m motorway curve).
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

use super::profile::{
    GnssFacts, GnssProfileConfig, PitchComparison, ProfileError, ProfileSource, RoadProfile,
};
use super::wgs84::chord_distance_m;
use crate::ingest::Ingested;
use crate::signal::{butter, sosfiltfilt, BandType, EdgeMode, SignalError};
use crate::table::DriveLog;
use crate::units::conversion;

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

#[cfg(test)]
mod tests {
    use super::*;

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
