//! The slope sensor's offset measured against the recorded altitude (docs/diagnosis/method.md,
//! "The slope sensor against the altitude").
//!
//! A slope sensor with a mounting angle `δ` reads `s = tan(α + δ)` on a road of angle `α`. Over
//! the travelled distance `x` (∫ v dt of the measured speed, the path length) the road climbs
//! `dz = sin α dx = sin(atan s − δ) dx`, so the altitude `h` the log records is
//!
//! `h(x) = a + cos δ · H(x) − sin δ · C(x) + e(x)`,  `H = ∫ sin(atan s) dx`, `C = ∫ cos(atan s) dx`,
//!
//! with `a` the altitude at the start and `e` the altitude's own error. `δ` is fitted by least
//! squares on `(1, C)` with `cos δ` taken from the previous iterate (three iterations from
//! `δ = 0`; the first is exact to `δ²/2 · H`, 2·10⁻⁴ · H at δ = 0.02).
//!
//! # Why the altitude
//! A slope-sensor offset and a rolling-resistance change both add a nearly constant force at
//! cruise (`m g δ` against `m g Δc_r`), so the driving signals alone tell them apart poorly. The
//! altitude does not see the rolling resistance: the height the slope readings integrate to
//! against the height the receiver reads measures `δ` alone.
//!
//! # Interval
//! Two errors wander along the drive: the altitude's own (GNSS: atmosphere and satellite
//! geometry over tens of seconds to minutes; barometric: the weather) and the slope readings'
//! integrated error (a sensor with whole-percent steps reads a grade between its steps as the
//! step, and over a stretch of constant grade that error accumulates in height like a random
//! walk). Two standard errors of the slope are formed from the fit's residual `r` and the larger
//! taken:
//! - Newey–West's, with a Bartlett kernel of [`HAC_LAG_S`] (rows within 300 s of each other
//!   count as correlated): right for an error that is stationary over minutes;
//! - a random walk's, `√(Σ_k (r_{k+1} − r_k)²) / S` over the residual's increments between
//!   blocks of [`BLOCK_S`] (120 s), `S` the distance: right for an error that accumulates.
//!
//! A drift slower than the drive shows in neither (the residual of a fitted trend does not
//! show it), so [`DRIFT_M`] (3 m: an uncorrected receiver's vertical error wanders by metres
//! over tens of minutes) over the drive's length is added in quadrature:
//! `σ² = max(σ_NW, σ_RW)² + (3 m / S)²`. The interval is `δ̂ ± 1.96 σ`. A wheel-speed scale
//! error `k` reads as `k · Δz/S` (2 % on a road that climbs 50 m in 10 km: 10⁻⁴ rad) and is
//! not in the interval.
//!
//! The slope the caller passes is best the readings reconstructed between the sensor's steps
//! ([`super::slope_grid::SlopeGrid::cured`]), which the diagnosis does; the recorded readings
//! carry more of the step error.
//!
//! # When there is no measurement
//! No `altitude` column, or fewer than [`MIN_DISTANCE_M`] travelled or [`MIN_DURATION_S`]
//! recorded between the first and last usable row, or an altitude that does not follow the
//! slope readings (residual RMS above [`MAX_RESIDUAL_RMS_M`]: a frozen channel, a receiver
//! that lost its fix), or an offset beyond [`MAX_OFFSET_RAD`]. Rows whose
//! `altitude_accuracy_m` (when the log has it) exceeds [`MAX_ACCURACY_M`] are not used (an
//! unconverged receiver). The reason is reported.

use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;
use serde::Serialize;

/// Bartlett kernel half-width of the Newey–West standard error, s.
pub const HAC_LAG_S: f64 = 300.0;
/// Block of the random-walk standard error, s.
pub const BLOCK_S: f64 = 120.0;
/// Standard deviation of the altitude error's drift over a whole drive that the lag does not
/// cover, m (module doc, "Interval").
pub const DRIFT_M: f64 = 3.0;
/// Least travelled distance between the first and last usable row, m.
pub const MIN_DISTANCE_M: f64 = 2000.0;
/// Least time between the first and last usable row, s.
pub const MIN_DURATION_S: f64 = 120.0;
/// Largest RMS of the altitude about the fitted height, m: beyond it the altitude does not
/// follow the slope readings.
pub const MAX_RESIDUAL_RMS_M: f64 = 10.0;
/// Largest offset taken as a measurement, rad (5.7°, the catalogue's fit domain of
/// `slope_offset_rad`): beyond it the altitude and the slope readings disagree by more than a
/// mounting angle can (another quantity logged as altitude, a slope channel in other units).
pub const MAX_OFFSET_RAD: f64 = 0.1;
/// Largest reported vertical accuracy of a usable row, m (as the road-profile reader's).
pub const MAX_ACCURACY_M: f64 = 5.0;
/// Least time between the rows used, s: a receiver reports its altitude at 1–10 Hz, and rows
/// closer than a second carry the same error.
pub const ROW_SPACING_S: f64 = 1.0;
/// The 95 % two-sided normal quantile.
const Z95: f64 = 1.959_963_984_540_054;

/// The measured offset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AltitudeOffset {
    /// Slope-sensor offset δ, rad (the sensor reads tan(α + δ); the catalogue's
    /// `slope_offset_rad`).
    pub value_rad: f64,
    /// Standard error, rad (module doc, "Interval").
    pub std_error_rad: f64,
    /// 95 % interval, lower end, rad.
    pub ci_low_rad: f64,
    /// 95 % interval, upper end, rad.
    pub ci_high_rad: f64,
    /// Rows used.
    pub rows: usize,
    /// Travelled distance between the first and last row used, m.
    pub distance_m: f64,
    /// Time between the first and last row used, s.
    pub duration_s: f64,
    /// RMS of the altitude about the fitted height, m.
    pub residual_rms_m: f64,
    /// The start altitude `a` fitted, m.
    pub start_altitude_m: f64,
}

/// The measurement, or why there is none.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AltitudeOutcome {
    /// Measured.
    Measured(AltitudeOffset),
    /// Not measured, and why.
    NotMeasured(String),
}

impl AltitudeOutcome {
    /// The measurement, if any.
    pub fn measured(&self) -> Option<&AltitudeOffset> {
        match self {
            AltitudeOutcome::Measured(m) => Some(m),
            AltitudeOutcome::NotMeasured(_) => None,
        }
    }
}

/// Measures the slope sensor's offset of `log` against its `altitude` column (module doc),
/// with the slope on each row `slope` (tan α; `None`: the recorded `road_slope`).
pub fn altitude_offset(log: &DriveLog, slope: Option<&[f64]>) -> AltitudeOutcome {
    let no = |why: String| AltitudeOutcome::NotMeasured(why);
    let Some(alt) = log.signal("altitude") else {
        return no("the log has no altitude column".into());
    };
    let col = |c: &str| {
        log.signal(c)
            .and_then(|v| fill_gaps(v, Interpolation::Linear))
    };
    let slope = match slope {
        Some(s) if s.len() == log.len() => Some(s.to_vec()),
        _ => col("road_slope"),
    };
    let (Some(speed), Some(slope)) = (col("vehicle_speed"), slope) else {
        return no("the log lacks vehicle_speed or road_slope".into());
    };
    let accuracy = log.signal("altitude_accuracy_m");
    let t = log.seconds_from_start();
    // H and C: trapezoids over the rows
    let n = t.len();
    let (mut x, mut hs, mut cs) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for i in 1..n {
        let dx = 0.5 * (speed[i].max(0.0) + speed[i - 1].max(0.0)) * (t[i] - t[i - 1]);
        let (a, b) = (slope[i].atan(), slope[i - 1].atan());
        x[i] = x[i - 1] + dx;
        hs[i] = hs[i - 1] + 0.5 * (a.sin() + b.sin()) * dx;
        cs[i] = cs[i - 1] + 0.5 * (a.cos() + b.cos()) * dx;
    }
    // usable rows, at most one per [`ROW_SPACING_S`]
    let mut rows: Vec<usize> = Vec::new();
    for i in 0..n {
        let usable = alt[i].is_finite()
            && accuracy.is_none_or(|a| a[i].is_nan() || a[i] <= MAX_ACCURACY_M)
            && speed[i].is_finite()
            && slope[i].is_finite();
        if usable
            && rows
                .last()
                .is_none_or(|&j| t[i] - t[j] >= ROW_SPACING_S - 1e-6)
        {
            rows.push(i);
        }
    }
    let (Some(&first), Some(&last)) = (rows.first(), rows.last()) else {
        return no("no row has a usable altitude".into());
    };
    let (distance_m, duration_s) = (x[last] - x[first], t[last] - t[first]);
    if distance_m < MIN_DISTANCE_M || duration_s < MIN_DURATION_S {
        return no(format!(
            "{distance_m:.0} m and {duration_s:.0} s of usable altitude; at least \
             {MIN_DISTANCE_M} m and {MIN_DURATION_S} s are needed"
        ));
    }
    let c: Vec<f64> = rows.iter().map(|&i| cs[i]).collect();
    let c_mean = c.iter().sum::<f64>() / c.len() as f64;
    let cc: Vec<f64> = c.iter().map(|v| v - c_mean).collect();
    let sxx: f64 = cc.iter().map(|v| v * v).sum();
    let mut delta = 0.0f64;
    let mut a = 0.0;
    let mut resid = vec![0.0; rows.len()];
    for _ in 0..3 {
        // y = h − cos δ · H = a − sin δ · C
        let y: Vec<f64> = rows.iter().map(|&i| alt[i] - delta.cos() * hs[i]).collect();
        let y_mean = y.iter().sum::<f64>() / y.len() as f64;
        let b = cc
            .iter()
            .zip(&y)
            .map(|(u, v)| u * (v - y_mean))
            .sum::<f64>()
            / sxx;
        delta = (-b).clamp(-1.0, 1.0).asin();
        a = y_mean - b * c_mean;
        for (r, (yi, ci)) in resid.iter_mut().zip(y.iter().zip(&c)) {
            *r = yi - a - b * ci;
        }
    }
    let residual_rms_m = (resid.iter().map(|r| r * r).sum::<f64>() / resid.len() as f64).sqrt();
    if residual_rms_m > MAX_RESIDUAL_RMS_M {
        return no(format!(
            "the altitude departs from the height the slope readings integrate to by \
             {residual_rms_m:.1} m RMS (at most {MAX_RESIDUAL_RMS_M} m)"
        ));
    }
    if delta.abs() > MAX_OFFSET_RAD {
        return no(format!(
            "the altitude and the slope readings disagree by {delta:.3} rad, more than a \
             mounting angle can (at most {MAX_OFFSET_RAD} rad)"
        ));
    }
    // Newey–West: Var(b) = Σ_j w_j Σ_i u_i u_{i+j} / Sxx², u = (C − C̄) r, w_j = 1 − |j|/(L+1)
    let u: Vec<f64> = cc.iter().zip(&resid).map(|(p, r)| p * r).collect();
    let ts: Vec<f64> = rows.iter().map(|&i| t[i]).collect();
    let mut s = u.iter().map(|v| v * v).sum::<f64>();
    for i in 0..u.len() {
        for j in i + 1..u.len() {
            let lag = ts[j] - ts[i];
            if lag >= HAC_LAG_S {
                break;
            }
            s += 2.0 * (1.0 - lag / HAC_LAG_S) * u[i] * u[j];
        }
    }
    // d δ / d b = −1 / cos δ; the drift over the drive's length in quadrature
    let nw = s.max(0.0).sqrt() / sxx / delta.cos();
    // a random walk's: the residual's increments between blocks of BLOCK_S
    let mut ss = 0.0;
    let (mut k0, mut r0) = (ts[0], resid[0]);
    for (k, (&tk, &rk)) in ts.iter().zip(&resid).enumerate() {
        if tk - k0 >= BLOCK_S - 1e-6 || k + 1 == ts.len() {
            ss += (rk - r0).powi(2);
            (k0, r0) = (tk, rk);
        }
    }
    let rw = ss.sqrt() / distance_m / delta.cos();
    let std_error_rad = nw.max(rw).hypot(DRIFT_M / distance_m);
    AltitudeOutcome::Measured(AltitudeOffset {
        value_rad: delta,
        std_error_rad,
        ci_low_rad: delta - Z95 * std_error_rad,
        ci_high_rad: delta + Z95 * std_error_rad,
        rows: rows.len(),
        distance_m,
        duration_s,
        residual_rms_m,
        start_altitude_m: a,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    /// A 10 Hz drive at `v` m/s over a rolling road (grade `g · sin(2π x / 2 km)`) for `dur_s`,
    /// the sensor reading tan(α + δ), the altitude the road's height plus `err(t)`.
    fn hilly(g: f64, delta: f64, v: f64, dur_s: f64, err: impl Fn(f64) -> f64) -> DriveLog {
        let n = (dur_s * 10.0) as usize;
        let (mut sp, mut sl, mut h) = (vec![], vec![], vec![]);
        for k in 0..n {
            let t = k as f64 / 10.0;
            let x = v * t;
            let w = std::f64::consts::TAU / 2000.0;
            // dz/dx = tan α; sin α dx is the climb along the path: the path here is x
            let grade = g * (w * x).sin();
            let alpha = grade.atan();
            let z = g / w * (1.0 - (w * x).cos());
            sp.push(v);
            sl.push((alpha + delta).tan());
            h.push(z + err(t));
        }
        DriveLog::from_columns(
            100_000_000,
            vec![
                ("vehicle_speed", "m/s", sp),
                ("road_slope", "1", sl),
                ("altitude", "m", h),
            ],
        )
    }

    fn drive(delta: f64, v: f64, dur_s: f64, err: impl Fn(f64) -> f64) -> DriveLog {
        hilly(0.03, delta, v, dur_s, err)
    }

    #[test]
    fn a_mounting_angle_is_read_off_the_altitude_and_a_clean_sensor_reads_none() {
        for delta in [0.0, 0.005, -0.012, 0.02] {
            let m = altitude_offset(&drive(delta, 20.0, 1000.0, |_| 0.0), None);
            let m = *m.measured().expect("measured");
            // no altitude error: what is left is the road's height taken as ∫ tan α dx where the
            // estimator integrates sin α (α³/2 at a 3 % grade, 1.4·10⁻⁵ at most, averaging to
            // less over the hills)
            assert!((m.value_rad - delta).abs() < 1e-5, "{delta}: {m:?}");
            // rows a second apart: the last used is at 999 s
            assert!(
                (m.distance_m - 20.0 * 999.0).abs() < 1e-6,
                "{}",
                m.distance_m
            );
        }
    }

    #[test]
    fn the_interval_covers_the_offset_under_a_correlated_altitude_error() {
        // a 20 km drive with the error of an automotive receiver (2.5 m over 10 min plus 1 m
        // over 20 s): over 200 drives the 95 % interval must cover the true offset on at least
        // 85 % of them (measured: all 200; the random walk's standard error is the larger and
        // is conservative for a stationary error), and the error's RMS must stay below
        // 2.5·10⁻⁴ rad (measured 1.8·10⁻⁴: about the slow error's 2.5 m over the 20 km)
        let mut covered = 0;
        let mut errs = Vec::new();
        for seed in 0..200u64 {
            let mut rng = Xoshiro256StarStar::seed_from_u64(seed);
            let n = 10_001;
            let (mut slow, mut fast) = (2.5 * rng.standard_normal(), rng.standard_normal());
            let mut e = Vec::with_capacity(n);
            for _ in 0..n {
                e.push(slow + fast);
                let (ps, pf) = ((-0.1f64 / 600.0).exp(), (-0.1f64 / 20.0).exp());
                slow = ps * slow + 2.5 * (1.0 - ps * ps).sqrt() * rng.standard_normal();
                fast = pf * fast + (1.0 - pf * pf).sqrt() * rng.standard_normal();
            }
            let log = drive(0.008, 20.0, 1000.0, |t| {
                e[((t * 10.0).round() as usize).min(n - 1)]
            });
            let m = altitude_offset(&log, None);
            let m = *m.measured().expect("measured");
            covered += usize::from(m.ci_low_rad <= 0.008 && 0.008 <= m.ci_high_rad);
            errs.push(m.value_rad - 0.008);
        }
        assert!(covered >= 170, "{covered} of 200 covered");
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        assert!(rms < 2.5e-4, "{rms}");
    }

    #[test]
    fn the_interval_covers_the_error_a_stepped_slope_sensor_accumulates() {
        // grades held over 400 m, drawn in ±4 %, read by a sensor of whole-percent steps (no
        // noise), the altitude exact: the height the readings integrate to wanders like a
        // random walk. Over 200 drives of 15 km the interval must cover the offset on at least
        // 90 % (measured: 185)
        let mut covered = 0;
        for seed in 0..200u64 {
            let mut rng = Xoshiro256StarStar::seed_from_u64(1000 + seed);
            let grades: Vec<f64> = (0..40).map(|_| 0.08 * (rng.next_f64() - 0.5)).collect();
            let (v, n) = (20.0, 7500);
            let (mut sp, mut sl, mut h) = (vec![], vec![], vec![]);
            let mut z = 0.0;
            for k in 0..n {
                let x = v * k as f64 / 10.0;
                let g = grades[((x / 400.0) as usize).min(39)];
                if k > 0 {
                    z += (g.atan()).sin() * v / 10.0;
                }
                sp.push(v);
                sl.push(((g.atan() + 0.004).tan() * 100.0).round() / 100.0);
                h.push(z);
            }
            let log = DriveLog::from_columns(
                100_000_000,
                vec![
                    ("vehicle_speed", "m/s", sp),
                    ("road_slope", "1", sl),
                    ("altitude", "m", h),
                ],
            );
            let m = *altitude_offset(&log, None).measured().expect("measured");
            covered += usize::from(m.ci_low_rad <= 0.004 && 0.004 <= m.ci_high_rad);
        }
        assert!(covered >= 180, "{covered} of 200 covered");
    }

    #[test]
    fn no_measurement_without_an_altitude_that_follows_the_road() {
        // a road of ±6 % grades, 38 m from trough to crest
        let mut log = hilly(0.06, 0.0, 20.0, 1000.0, |_| 0.0);
        // too short
        let short = drive(0.0, 20.0, 60.0, |_| 0.0);
        assert!(matches!(
            altitude_offset(&short, None),
            AltitudeOutcome::NotMeasured(w) if w.contains("needed")
        ));
        // a frozen receiver on a hilly road
        for v in log.signal_mut("altitude").unwrap() {
            *v = 300.0;
        }
        let road = drive(0.0, 20.0, 1000.0, |_| 0.0);
        assert!(matches!(
            altitude_offset(&log, None),
            AltitudeOutcome::NotMeasured(w) if w.contains("RMS")
        ));
        // an altitude that climbs 3 km over the 20 km the slope readings call rolling
        let mut steep = drive(0.0, 20.0, 1000.0, |t| 0.15 * 20.0 * t);
        assert!(matches!(
            altitude_offset(&steep, None),
            AltitudeOutcome::NotMeasured(w) if w.contains("mounting angle")
        ));
        steep = drive(0.05, 20.0, 1000.0, |_| 0.0);
        assert!(altitude_offset(&steep, None).measured().is_some());
        // no column, or every row unconverged
        let bare = road.with_columns(Some(&["vehicle_speed", "road_slope"]));
        assert!(altitude_offset(&bare, None).measured().is_none());
        let mut unconverged = drive(0.0, 20.0, 1000.0, |_| 0.0);
        let n = unconverged.len();
        unconverged = DriveLog::from_columns(
            100_000_000,
            vec![
                ("vehicle_speed", "m/s", vec![20.0; n]),
                (
                    "road_slope",
                    "1",
                    unconverged.signal("road_slope").unwrap().to_vec(),
                ),
                (
                    "altitude",
                    "m",
                    unconverged.signal("altitude").unwrap().to_vec(),
                ),
                ("altitude_accuracy_m", "m", vec![12.0; n]),
            ],
        );
        assert!(matches!(
            altitude_offset(&unconverged, None),
            AltitudeOutcome::NotMeasured(w) if w.contains("no row")
        ));
    }
}
