//! The noise floor of every compared signal (docs/diagnosis/method.md, step 2): the residual
//! `measured − simulated` that a *correct* model would still leave on this recording, so that
//! [`super::locate`] can tell a mismatch from noise.
//!
//! # Two parts
//! 1. **Measurement noise of the recorded output**, estimated blind from the recording
//!    ([`estimate_sensor_noise`]). CAN signals arrive at their own rate (10–50 Hz) and ingest
//!    puts them on the log's uniform grid by linear interpolation (continuous columns) or
//!    zero-order hold (state-like columns, `schemas/drive-log.toml`). Estimating noise on the
//!    grid would see interpolated, hence smoothed and correlated, values; so the native samples
//!    are recovered first:
//!    - *linear* columns: the knots are the rows where the second difference is non-zero (a
//!      line through the grid rows bends only at a knot). A knot on a row shows as one such row;
//!      a knot between rows `i` and `i+1` as two, and its time and value are recovered exactly
//!      as the intersection of the lines through rows `i−1, i` and `i+1, i+2`;
//!    - *held* columns: the native samples start at the rows where the value changes;
//!    - the native period `P` (rows) is the mean of the spacings between consecutive knots that
//!      are at most 1.5× their 10th percentile (spacings of 2P, 3P… are knots the data could not
//!      show: equal neighbouring values); gaps between knots longer than 1.5 P are filled with
//!      evenly spaced native samples read off the grid. When more than half of the rows are
//!      knots, or fewer than 8 knots exist, every row counts as a native sample (the channel is
//!      as fast as the grid, or it never changes);
//!    - the noise σ is a robust spread of the native second differences,
//!      `σ = 1.4826·MAD(Δ²y)/√6` (`Var Δ²n = 6σ²` for white noise; the MAD ignores the sparse
//!      large values of real signal curvature, gear shifts, braking onsets). Samples at a
//!      physical bound (a brake at rest, whose sensor clamps its noise) are left out
//!      ([`estimate_sensor_noise_in`]);
//!    - quantisation step `q`: [`crate::signal::quantization::estimate_quantization`] on the
//!      recorded native values (not the reconstructed ones), else a tolerant variant (the
//!      commonest small difference, 95 % of the values on its lattice); with a step the second differences lie on its lattice and
//!      the MAD is their median read as grouped data (`grouped_median_abs`: a plain median
//!      of lattice values is a lattice value and puts σ 10 % low for the 0.1 % slope sensor);
//!    - coarse steps (the MAD-σ below `q`): the second differences take the discrete values
//!      0, ±q, ±2q of flicker and their MAD jumps between 0 and q. The flicker rate φ — the
//!      share of native samples off their recorded level (below) — gives the noise instead:
//!      for a true value spread evenly within a step `φ = 2σ/(q√(2π))`, so
//!      `σ_w = √(π/2)·q·φ` (while φ < 0.25; beyond, the noise dithers the rounding and the RMS
//!      of the second differences up to 2q is used, `σ_w² = σ² − q²/12`). Otherwise
//!      `σ_w² = max(0, σ² − q²/12)` (the second differences saw the rounding of dithered
//!      samples as noise);
//!    - the persistent part of the quantisation error is uniform in `±h`,
//!      `h = (q/2)·exp(−2π²σ_w²/q²)`: without noise (`σ_w = 0`) the true value is anywhere
//!      within `±q/2` of the recorded one and stays there, while Gaussian noise dithers the
//!      rounding and the remaining bias `E[Q(s+n)] − s` has the amplitude of the first Fourier
//!      coefficient of the rounding error, damped by the noise's characteristic function
//!      `exp(−2π²σ²/q²)`. It is held constant over each run of equal *recorded level* — the
//!      running median of the native values over ±0.5 s, so that dither flicker does not cut
//!      the runs;
//!    - rest states: a run whose level is within one step (or σ_w) of a physical bound, and
//!      samples in it within `3σ_w + q` of the bound, are the actuator at rest (brake, retarder,
//!      clutch off). A copy sets them to the bound (no persistent error): the recording of a
//!      brake at rest is clamped noise, |N(0, 0.2 kN)| rounded to 0.1 kN on the synthetic bus,
//!      +85 N on average, and a copy at rest differs from the recording as the recording differs
//!      from the truth. Measured on a clean 2 km city drive: that bias alone moves the simulated
//!      speed by 0.043 m/s RMS, the copies at rest by 0.036 m/s.
//! 2. **Input uncertainty propagated through the model** ([`noise_floors`]). The recorded inputs
//!    (engine torque in whole % of the reference torque, slope in whole %, brake force, clutch,
//!    speeds used as initial states …) carry the same kind of errors. Each of `copies`
//!    deterministic Monte-Carlo copies of the log perturbs *every* sensed column — inputs and
//!    outputs alike — by a draw from its estimated sensor error ([`SensorNoise::draw`]: white
//!    noise at the native samples, interpolated or held onto the grid like the recording, plus
//!    the persistent quantisation error), keeps it inside the column's physical range
//!    ([`PerturbedColumn`], e.g. a brake force is never negative, exactly like the sensor), and
//!    runs the models on it. The copy's residual minus the recording's residual,
//!    `e_c = r_c − r`, is one draw of the residual a correct model leaves (a parametric
//!    bootstrap: `r_c − r` has the statistics of `r − r_true` when the error model is right and
//!    the errors are small). Perturbing an output column both as a measurement and as an
//!    initial state in the same copy keeps their correlation (at a window's re-initialisation
//!    the residual is 0 whatever the noise).
//!
//! # What the floor carries
//! [`NoiseFloor`]: the per-row null variance `mean_c e_c²` (unit²), the autocorrelation of the
//! normalised null (for the effective degrees of freedom of a sum of squared residuals over a
//! window, [`NoiseFloor::effective_dof`]), the copies themselves (for a window's own degrees of
//! freedom, [`NoiseFloor::window_dof`]), the null's Welch PSD (for band powers), and the split
//! into measurement and input parts (RMS). The scalar floor (diagnosis.json `noise_floor`) is the
//! RMS of the null over the rows that count.
//!
//! # Assumptions
//! - the sensor error is stationary over the drive and independent between channels and of the
//!   true signal (the CAN generator's own model; real sensors may have level-dependent noise);
//! - native samples are regular (CAN messages have fixed rates); dropouts are gaps (NaN);
//! - the model is smooth enough in its inputs that errors of the recorded size act like the
//!   recording's own (parametric bootstrap);
//! - what is *not* in the floor: a model-structure difference that a correct-parameter model
//!   still has on this recording path (e.g. drive-shaft torque reconstructed from engine torque
//!   and speed while the clutch slips). On clean synthetic drives that part is measured by the
//!   tests (tests/it/diagnose_locate.rs) and reported, not hidden.
//!
//! Units: every σ, floor and RMS is in the signal's SI unit; variances in unit²; times in s.
//! Deterministic: every random stream is seeded from [`NoiseConfig::seed`], the copy and the
//! column name.

use super::compare::{compare_at, Compared};
use super::extended::{AxleModel, ExtendedError, LongitudinalConfig, LongitudinalModel, Theta};
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::signal::{csd_pieces, WelchConfig};
use crate::table::DriveLog;
use rayon::prelude::*;
use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use thiserror::Error;

/// Why a noise floor cannot be estimated.
#[derive(Debug, Error)]
pub enum NoiseError {
    /// A series without any finite value, or no rows at all.
    #[error("{what}: no finite value")]
    Empty {
        /// The series.
        what: String,
    },
    /// Series of different lengths.
    #[error("{what}: {got} values, expected {expected}")]
    Length {
        /// The series.
        what: String,
        /// Expected length.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A setting outside its domain.
    #[error("{parameter} = {value} must be {requirement}")]
    BadConfig {
        /// Setting, with unit.
        parameter: &'static str,
        /// Value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// The models could not be run on the recording or a perturbed copy.
    #[error(transparent)]
    Model(#[from] ExtendedError),
    /// A sensor's noise could not be estimated.
    #[error(transparent)]
    Sensor(#[from] SensorNoiseError),
}

pub use crate::signal::sensor_noise::{
    estimate_sensor_noise, estimate_sensor_noise_in, grid_step_s, stream, SampleKind, SensorNoise,
    SensorNoiseError,
};

/// A column perturbed in the Monte-Carlo copies, with its physical range (the perturbed value
/// is clamped into it, as the sensor clamps its own readings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PerturbedColumn {
    /// Canonical column.
    pub column: String,
    /// Smallest physical value, SI (`None`: unbounded).
    pub min: Option<f64>,
    /// Largest physical value, SI (`None`: unbounded).
    pub max: Option<f64>,
}

impl PerturbedColumn {
    fn new(column: &str, min: Option<f64>, max: Option<f64>) -> Self {
        Self {
            column: column.into(),
            min,
            max,
        }
    }
}

/// Settings of the noise-floor estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseConfig {
    /// Monte-Carlo copies. The window test of [`super::locate`] compares a window's residual
    /// with the copies' mean in the same window, an F test with `copies·ν` denominator degrees
    /// of freedom, so more copies sharpen the test; 12 keep the floor's own sampling error in a
    /// 10 s window near 20 % (ν ≈ 3 in the most correlated signal) at about 12 model runs.
    pub copies: usize,
    /// Seed of every random stream.
    pub seed: u64,
    /// Columns perturbed (those present in the log). Gear is never perturbed: it is an exact
    /// integer state.
    pub columns: Vec<PerturbedColumn>,
    /// Half-width of the moving average that smooths the per-row null variance for normalising
    /// the null before its autocorrelation is taken, s.
    pub smoothing_s: f64,
    /// Longest lag of the null autocorrelation kept, s (covers the longitudinal model's 20 s
    /// re-initialisation windows).
    pub max_lag_s: f64,
    /// Welch segment of the null PSD, s (0.1 Hz resolution at 10 s).
    pub psd_segment_s: f64,
    /// Event channels whose sample phase is uncertain: each copy shifts them in time by a
    /// uniform draw within ± half their native period (after the noise draw). A 10 Hz clutch
    /// actuator places a shift's clutch opening and closing only to ±0.05 s; with ~19 kN of
    /// drive force in a middle gear that is an impulse error of ~0.05 m/s per edge, which the
    /// windowed speed residual carries to the window's end (on clean synthetic drives:
    /// 0.08–0.12 m/s in windows with upshifts on a climb, 3–5× a floor without it). The 50 Hz
    /// engine torque too: where a torque step falls between two rows decides how their linear
    /// interpolation renders it (on a clean proof drive with every input at its truth, a
    /// tip-out to engine braking rings the engine speed by 1.19 rad/s RMS for a second at the
    /// log's sampling phase, 0.14 rad/s with the truth read 10 ms earlier or later;
    /// `research/studies/truth_residual.rs`).
    pub phase_jitter_columns: Vec<String>,
}

impl Default for NoiseConfig {
    /// 12 copies, seed 7, the driveline and axle inputs and outputs with their physical ranges
    /// (brake force, retarder torque, speeds and pressures ≥ 0, clutch 0…1), 1 s smoothing,
    /// 30 s of lags, 10 s PSD segments, phase jitter on clutch, brake, retarder and engine
    /// torque.
    fn default() -> Self {
        let z = Some(0.0);
        Self {
            copies: 12,
            seed: 7,
            columns: vec![
                PerturbedColumn::new("vehicle_speed", z, None),
                PerturbedColumn::new("engine_speed", z, None),
                PerturbedColumn::new("engine_torque", None, None),
                PerturbedColumn::new("road_slope", None, None),
                PerturbedColumn::new("clutch_position", z, Some(1.0)),
                PerturbedColumn::new("brake_force", z, None),
                PerturbedColumn::new("retarder_torque", z, None),
                PerturbedColumn::new("longitudinal_acceleration", None, None),
                PerturbedColumn::new("bellow_pressure_front", z, None),
                PerturbedColumn::new("bellow_pressure_rear", z, None),
                PerturbedColumn::new("bellow_pressure_tag", z, None),
            ],
            smoothing_s: 1.0,
            max_lag_s: 30.0,
            psd_segment_s: 10.0,
            phase_jitter_columns: vec![
                "clutch_position".into(),
                "brake_force".into(),
                "retarder_torque".into(),
                "engine_torque".into(),
            ],
        }
    }
}

impl NoiseConfig {
    fn validate(&self) -> Result<(), NoiseError> {
        let bad = |parameter, value: f64, requirement| {
            Err(NoiseError::BadConfig {
                parameter,
                value,
                requirement,
            })
        };
        if self.copies < 2 {
            return bad("copies", self.copies as f64, "at least 2");
        }
        for (p, v) in [
            ("smoothing_s", self.smoothing_s),
            ("max_lag_s", self.max_lag_s),
            ("psd_segment_s", self.psd_segment_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(p, v, "finite and > 0");
            }
        }
        Ok(())
    }
}

/// The null PSD of a floor (mean over the copies).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NullPsd {
    /// Bin frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// One-sided PSD, unit²/Hz.
    pub psd: Vec<f64>,
    /// Equivalent degrees of freedom per bin (all copies' segments).
    pub dof: f64,
    /// Segment length, rows.
    pub nperseg: usize,
    /// Power of the segment means, which Welch's per-segment detrend removes: what lies below
    /// the first bin (slower than a segment), unit² ([`segment_mean_square`]).
    pub dc_power: f64,
}

/// Mean over Welch segments (`nperseg` rows, half overlap, as [`csd_pieces`] cuts them) of the
/// squared segment mean of each piece: the power slower than one segment, which the Welch PSD
/// leaves out (0 without a full segment).
pub fn segment_mean_square(pieces: &[&[f64]], nperseg: usize) -> f64 {
    let step = (nperseg - nperseg / 2).max(1);
    let (mut s, mut k) = (0.0, 0usize);
    for x in pieces {
        if nperseg == 0 || x.len() < nperseg {
            continue;
        }
        let m = (x.len() - nperseg / 2) / step;
        for j in 0..m {
            let seg = &x[j * step..j * step + nperseg];
            let mean = seg.iter().sum::<f64>() / nperseg as f64;
            s += mean * mean;
            k += 1;
        }
    }
    if k == 0 {
        0.0
    } else {
        s / k as f64
    }
}

/// The noise floor of one compared signal (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloor {
    /// Compared signal.
    pub signal: String,
    /// SI unit.
    pub unit: String,
    /// RMS of the null residual over the rows that count, unit (diagnosis.json `noise_floor`).
    pub floor: f64,
    /// RMS of the part from the output's own measurement error, unit (`None` when the copies
    /// were given whole).
    pub measurement_rms: Option<f64>,
    /// RMS of the part propagated from the inputs, unit (`None` when given whole).
    pub input_rms: Option<f64>,
    /// Number of copies behind the estimate.
    pub copies: usize,
    /// Grid step, s.
    pub dt_s: f64,
    /// Squared-correlation time of the null, `dt·Σ_k ρ(k)²` over |k| ≤ the kept lags, s: a long
    /// window holds about `T / τ` degrees of freedom.
    pub correlation_time_s: f64,
    /// The output's own sensor estimate, when it is a recorded column.
    pub sensor: Option<SensorNoise>,
    /// Per-row null variance `mean_c e_c²`, unit² (NaN where the row does not count).
    #[serde(skip)]
    pub null_variance: Vec<f64>,
    /// Autocorrelation of the normalised null, lags 0.. (rows); `ρ(0) = 1`.
    #[serde(skip)]
    pub autocorrelation: Vec<f64>,
    /// The null copies themselves, per copy and row (NaN where the row does not count), kept
    /// in single precision for [`NoiseFloor::window_dof`].
    #[serde(skip)]
    pub null_copies: Vec<Vec<f32>>,
    /// Null PSD (`None` when no valid stretch is as long as a segment).
    #[serde(skip)]
    pub null_psd: Option<NullPsd>,
}

/// Moving average of the finite entries of `x` over ±`hw` rows (NaN where none).
fn moving_mean(x: &[f64], hw: usize) -> Vec<f64> {
    let n = x.len();
    let mut cs = vec![0.0; n + 1];
    let mut cn = vec![0usize; n + 1];
    for i in 0..n {
        let f = x[i].is_finite();
        cs[i + 1] = cs[i] + if f { x[i] } else { 0.0 };
        cn[i + 1] = cn[i] + usize::from(f);
    }
    (0..n)
        .map(|i| {
            let a = i.saturating_sub(hw);
            let b = (i + hw + 1).min(n);
            let c = cn[b] - cn[a];
            if c == 0 {
                f64::NAN
            } else {
                (cs[b] - cs[a]) / c as f64
            }
        })
        .collect()
}

/// Σ_t x(t)·x(t+k) for k = 0..=max_lag, by FFT.
fn autocov_sums(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    if n == 0 {
        return vec![0.0; max_lag + 1];
    }
    let m = (2 * n).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(m);
    let inv = planner.plan_fft_inverse(m);
    let mut buf = fwd.make_input_vec();
    buf[..n].copy_from_slice(x);
    let mut spec = fwd.make_output_vec();
    fwd.process(&mut buf, &mut spec).expect("plan sizes");
    for c in spec.iter_mut() {
        *c = num_complex::Complex64::new(c.norm_sqr(), 0.0);
    }
    let mut out = inv.make_output_vec();
    inv.process(&mut spec, &mut out).expect("plan sizes");
    (0..=max_lag)
        .map(|k| if k < n { out[k] / m as f64 } else { 0.0 })
        .collect()
}

impl NoiseFloor {
    /// The floor of `signal` from null copies `e_c` (each as long as `valid`; rows that do not
    /// count, or where a copy is not finite, are left out).
    ///
    /// # Errors
    /// [`NoiseError::BadConfig`] for fewer than 2 copies or a bad step or setting;
    /// [`NoiseError::Length`] for copies of the wrong length.
    pub fn from_null_copies(
        signal: &str,
        unit: &str,
        dt_s: f64,
        copies: &[Vec<f64>],
        valid: &[bool],
        cfg: &NoiseConfig,
    ) -> Result<NoiseFloor, NoiseError> {
        cfg.validate()?;
        if copies.len() < 2 {
            return Err(NoiseError::BadConfig {
                parameter: "copies",
                value: copies.len() as f64,
                requirement: "at least 2",
            });
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(NoiseError::BadConfig {
                parameter: "dt_s",
                value: dt_s,
                requirement: "finite and > 0",
            });
        }
        let n = valid.len();
        for c in copies {
            if c.len() != n {
                return Err(NoiseError::Length {
                    what: format!("null copy of {signal}"),
                    expected: n,
                    got: c.len(),
                });
            }
        }
        let k = copies.len() as f64;
        let usable: Vec<bool> = (0..n)
            .map(|i| valid[i] && copies.iter().all(|c| c[i].is_finite()))
            .collect();
        let null_variance: Vec<f64> = (0..n)
            .map(|i| {
                if usable[i] {
                    copies.iter().map(|c| c[i] * c[i]).sum::<f64>() / k
                } else {
                    f64::NAN
                }
            })
            .collect();
        let n_use = usable.iter().filter(|u| **u).count();
        let floor = if n_use == 0 {
            f64::NAN
        } else {
            (null_variance.iter().filter(|v| v.is_finite()).sum::<f64>() / n_use as f64).sqrt()
        };
        // autocorrelation of the normalised null, pooled over copies
        let hw = ((cfg.smoothing_s / dt_s).round() as usize).max(1);
        let smooth = moving_mean(&null_variance, hw);
        let max_lag = ((cfg.max_lag_s / dt_s).round() as usize).min(n.saturating_sub(1));
        let mask: Vec<f64> = (0..n)
            .map(|i| {
                if usable[i] && smooth[i] > 0.0 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let pairs = autocov_sums(&mask, max_lag);
        let mut acc = vec![0.0; max_lag + 1];
        for c in copies {
            let z: Vec<f64> = (0..n)
                .map(|i| {
                    if mask[i] > 0.0 {
                        c[i] / smooth[i].sqrt()
                    } else {
                        0.0
                    }
                })
                .collect();
            for (a, s) in acc.iter_mut().zip(autocov_sums(&z, max_lag)) {
                *a += s;
            }
        }
        let mut autocorrelation = Vec::with_capacity(max_lag + 1);
        if pairs.first().copied().unwrap_or(0.0) > 0.5 {
            let r0 = acc[0] / pairs[0];
            for lag in 0..=max_lag {
                // keep lags with at least 10 % of the rows paired (the rest is too noisy)
                if pairs[lag] < 0.1 * pairs[0] || r0 <= 0.0 {
                    break;
                }
                autocorrelation.push((acc[lag] / pairs[lag] / r0).clamp(-1.0, 1.0));
            }
        }
        if autocorrelation.is_empty() {
            autocorrelation.push(1.0);
        }
        let correlation_time_s =
            dt_s * (1.0 + 2.0 * autocorrelation[1..].iter().map(|r| r * r).sum::<f64>());
        // null PSD over every copy's usable stretches
        let nperseg = ((cfg.psd_segment_s / dt_s).round() as usize).max(8);
        let mut pieces: Vec<(&[f64], &[f64])> = Vec::new();
        for c in copies {
            let mut i = 0;
            while i < n {
                if !usable[i] {
                    i += 1;
                    continue;
                }
                let a = i;
                while i < n && usable[i] {
                    i += 1;
                }
                pieces.push((&c[a..i], &c[a..i]));
            }
        }
        let null_psd = csd_pieces(
            &pieces,
            &WelchConfig {
                fs_hz: 1.0 / dt_s,
                nperseg: Some(nperseg),
                noverlap: None,
                confidence: 0.95,
            },
        )
        .ok()
        .map(|c| NullPsd {
            freq_hz: c.freq_hz,
            psd: c.pxx,
            dof: c.dof,
            nperseg,
            dc_power: segment_mean_square(&pieces.iter().map(|p| p.0).collect::<Vec<_>>(), nperseg),
        });
        Ok(NoiseFloor {
            signal: signal.into(),
            unit: unit.into(),
            floor,
            measurement_rms: None,
            input_rms: None,
            copies: copies.len(),
            dt_s,
            correlation_time_s,
            sensor: None,
            null_variance,
            autocorrelation,
            null_copies: copies
                .iter()
                .map(|c| {
                    (0..n)
                        .map(|i| if usable[i] { c[i] as f32 } else { f32::NAN })
                        .collect()
                })
                .collect(),
            null_psd,
        })
    }

    /// A floor made of the output's measurement error alone (no model, no inputs): `copies`
    /// draws of `sensor` on the rows of `valid`. For residuals whose model is exact, e.g.
    /// synthetic tests, or signals no input feeds.
    ///
    /// # Errors
    /// As [`NoiseFloor::from_null_copies`].
    pub fn measurement_only(
        signal: &str,
        sensor: &SensorNoise,
        valid: &[bool],
        cfg: &NoiseConfig,
    ) -> Result<NoiseFloor, NoiseError> {
        cfg.validate()?;
        let copies: Vec<Vec<f64>> = (0..cfg.copies as u64)
            .map(|c| sensor.draw(valid.len(), &mut stream(cfg.seed, c, &sensor.column)))
            .collect();
        let mut f = NoiseFloor::from_null_copies(
            signal,
            &sensor.unit,
            sensor.grid_dt_s,
            &copies,
            valid,
            cfg,
        )?;
        f.measurement_rms = Some(f.floor);
        f.input_rms = Some(0.0);
        f.sensor = Some(sensor.clone());
        Ok(f)
    }

    /// `Σ_{|k|<N} (1 − |k|/N)·ρ(k)²` for a contiguous stretch of `n` rows (lags beyond those kept
    /// count 0).
    pub fn squared_correlation_sum(&self, n: usize) -> f64 {
        let nf = n as f64;
        let mut s = 1.0;
        for (k, r) in self.autocorrelation.iter().enumerate().skip(1) {
            if k >= n {
                break;
            }
            s += 2.0 * (1.0 - k as f64 / nf) * r * r;
        }
        s
    }

    /// Effective degrees of freedom of `Σ r²` over `rows` (sorted row indices where the floor
    /// counts): for each contiguous run, Satterthwaite's `ν = (Σσ²)² / (Σσ⁴ · S_N)` with the
    /// null's per-row variance σ² and the squared-correlation sum `S_N`; runs add up (they are
    /// treated as independent). At least 1 when any row counts, 0 otherwise.
    pub fn effective_dof(&self, rows: &[usize]) -> f64 {
        let mut total = 0.0;
        let mut i = 0;
        while i < rows.len() {
            let mut j = i;
            while j + 1 < rows.len() && rows[j + 1] == rows[j] + 1 {
                j += 1;
            }
            let (mut s1, mut s2) = (0.0, 0.0);
            for &r in &rows[i..=j] {
                let v = self.null_variance.get(r).copied().unwrap_or(f64::NAN);
                if v.is_finite() {
                    s1 += v;
                    s2 += v * v;
                }
            }
            if s2 > 0.0 {
                total += s1 * s1 / (s2 * self.squared_correlation_sum(j - i + 1));
            }
            i = j + 1;
        }
        if rows.is_empty() || total == 0.0 {
            total
        } else {
            total.max(1.0)
        }
    }

    /// Degrees of freedom of a window's `Σ r²` over `rows` for the window test of
    /// [`super::locate`]: the smaller of [`NoiseFloor::effective_dof`] (from the drive-wide
    /// autocorrelation) and Satterthwaite's `ν = (tr Σ)² / tr Σ²` of the window's own null
    /// covariance `Σ` (over `rows`), estimated from the copies (at least 1).
    ///
    /// Why both: the drive-wide autocorrelation is stationary, but the null is not — the
    /// longitudinal null restarts at every re-initialisation window, the input noise it
    /// integrates differs between a steady cruise and a shift sequence — so the pooled
    /// autocorrelation can give a window more degrees of freedom than its own null has. The
    /// copies show the window's own null: on `fleetdyn prove --seed 1001`, a clean drive's
    /// engine-speed window (20–30 s, a climb through gears 5–8; 2.3 × its floor) has ν = 23
    /// from the autocorrelation but 2.0 from its copies; at ν = 23 it tests at p = 4·10⁻¹² as
    /// a mismatch, at ν = 2.0 its p is 0.013, not one after Holm.
    ///
    /// The estimate from the copies uses pairs of distinct copies `c ≠ d` only: for independent
    /// zero-mean copies `E[|e_c|² |e_d|²] = (tr Σ)²` and `E[(e_c·e_d)²] = tr Σ²`, so
    /// `ν̂ = Σ_{c<d} |e_c|² |e_d|² / Σ_{c<d} (e_c·e_d)²` has an unbiased numerator and
    /// denominator, and is exactly 1 for a null that is one shape with a random amplitude (an
    /// offset, a start-state error) whatever the amplitudes drawn. The alternative
    /// `2 E[Q]² / Var[Q]` of the copies' sums `Q_c = |e_c|²` has the same target for Gaussian
    /// copies but reads it off the spread of `K` draws of a skewed χ², which is usually below
    /// its expectation: simulated with 12 copies (400 trials), a Brownian drift over the second
    /// half of a 20 s window (ν = 1.23) reads median 1.68 (10–90 %: 0.91–2.97) that way and
    /// 1.28 (1.14–1.56) from the pairs; a pure offset 1.39 (0.73–2.47) against exactly 1.
    pub fn window_dof(&self, rows: &[usize]) -> f64 {
        let nu_acf = self.effective_dof(rows);
        if self.null_copies.len() < 2 || rows.is_empty() {
            return nu_acf;
        }
        // the copies on the window's rows; a row a copy lacks adds nothing
        let e: Vec<Vec<f64>> = self
            .null_copies
            .iter()
            .map(|c| {
                rows.iter()
                    .map(|&r| f64::from(c.get(r).copied().unwrap_or(f32::NAN)))
                    .map(|x| if x.is_finite() { x } else { 0.0 })
                    .collect()
            })
            .collect();
        let sq: Vec<f64> = e.iter().map(|x| x.iter().map(|v| v * v).sum()).collect();
        let (mut num, mut den) = (0.0, 0.0);
        for c in 0..e.len() {
            for d in c + 1..e.len() {
                let dot: f64 = e[c].iter().zip(&e[d]).map(|(a, b)| a * b).sum();
                num += sq[c] * sq[d];
                den += dot * dot;
            }
        }
        if !(num > 0.0 && den > 0.0) {
            return nu_acf;
        }
        nu_acf.min(num / den).max(1.0)
    }
}

/// The floors of every compared signal, with the sensor estimates behind them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloors {
    /// One per compared signal.
    pub floors: Vec<NoiseFloor>,
    /// Sensor estimates of every perturbed column.
    pub sensors: Vec<SensorNoise>,
    /// Copies.
    pub copies: usize,
    /// Seed.
    pub seed: u64,
}

impl NoiseFloors {
    /// The floor of `signal`.
    pub fn get(&self, signal: &str) -> Option<&NoiseFloor> {
        self.floors.iter().find(|f| f.signal == signal)
    }

    /// `{"<signal>": floor}` of diagnosis.json, unit of each signal.
    pub fn summary(&self) -> BTreeMap<String, f64> {
        self.floors
            .iter()
            .map(|f| (f.signal.clone(), f.floor))
            .collect()
    }
}

/// The models a recording drives and how they are compared (the compare step's settings).
#[derive(Debug, Clone)]
pub struct ModelSet<'a> {
    /// The nominal vehicle.
    pub truth: &'a ExtendedVehicle,
    /// Gear ratios.
    pub ratios: &'a [f64],
    /// Nominal parameters.
    pub nominal: Theta,
    /// Longitudinal model settings (`None`: not run).
    pub longitudinal: Option<LongitudinalConfig>,
    /// Run the axle model.
    pub axle: bool,
    /// Also compare the engine speed on the clutch-actuated rows
    /// ([`super::rows::actuation_channel_rows`], as [`super::rows::ACTUATION_CHANNEL`]):
    /// its floor weights the explain step's clutch-actuation view; it is not located.
    pub actuation: bool,
}

const PRESSURES: [&str; 3] = [
    "bellow_pressure_front",
    "bellow_pressure_rear",
    "bellow_pressure_tag",
];

fn has(log: &DriveLog, c: &str) -> bool {
    log.signal(c)
        .is_some_and(|v| v.iter().any(|x| x.is_finite()))
}

impl<'a> ModelSet<'a> {
    /// The models `log` can drive: longitudinal with vehicle and engine speed, engine torque
    /// and gear; axle with the three bellow pressures and a vehicle with axles.
    pub fn for_log(
        log: &DriveLog,
        truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
    ) -> ModelSet<'a> {
        let long = ["vehicle_speed", "engine_speed", "engine_torque", "gear"]
            .iter()
            .all(|c| has(log, c));
        let axle = truth.axles.is_some() && PRESSURES.iter().all(|c| has(log, c));
        ModelSet {
            truth,
            ratios,
            nominal,
            longitudinal: long.then(LongitudinalConfig::default),
            axle,
            actuation: false,
        }
    }

    /// The compared signals of `log` at `theta` ([`compare_at`]). Rows that count: the
    /// recorded value is a real sample (not a filled gap); for the longitudinal signals also
    /// vehicle speed at least [`LongitudinalConfig::min_speed_mps`], engine speed recorded and
    /// no clutch transition near ([`super::rows::longitudinal_rows`]); for the pressures no
    /// shift near ([`super::rows::axle_rows`]).
    ///
    /// # Errors
    /// [`NoiseError::Model`] when a model cannot be built or run.
    pub fn compared(&self, log: &DriveLog, theta: &Theta) -> Result<Vec<Compared>, NoiseError> {
        let n = log.len();
        let long = match self.longitudinal {
            Some(cfg) => Some(LongitudinalModel::new(
                log,
                self.truth,
                self.ratios,
                self.nominal,
                cfg,
            )?),
            None => None,
        };
        let long_valid: Vec<bool> = match (&self.longitudinal, log.signal("vehicle_speed")) {
            (Some(cfg), Some(v)) => {
                let w = log.signal("engine_speed");
                let steady = super::rows::longitudinal_rows(log);
                (0..n)
                    .map(|i| {
                        v[i].is_finite()
                            && v[i] >= cfg.min_speed_mps
                            && w.is_some_and(|w| w[i].is_finite())
                            && steady[i]
                    })
                    .collect()
            }
            _ => vec![false; n],
        };
        let axle = if self.axle {
            Some(AxleModel::new(log, self.truth, self.ratios, self.nominal)?)
        } else {
            None
        };
        let (mut meas, mut valid): (Vec<Vec<f64>>, Vec<Vec<bool>>) = (Vec::new(), Vec::new());
        if self.axle {
            let steady = super::rows::axle_rows(log);
            for c in PRESSURES {
                let raw = log.signal(c).unwrap_or(&[]);
                valid.push(
                    raw.iter()
                        .zip(&steady)
                        .map(|(x, s)| x.is_finite() && *s)
                        .collect(),
                );
                meas.push(fill_gaps(raw, Interpolation::Linear).unwrap_or_else(|| raw.to_vec()));
            }
        }
        let am: Option<[Vec<f64>; 3]> = meas.try_into().ok();
        let av: Option<[Vec<bool>; 3]> = valid.try_into().ok();
        let engine_valid = super::rows::engine_speed_rows(log);
        let mut out = compare_at(
            long.as_ref(),
            axle.as_ref(),
            theta,
            &long_valid,
            &engine_valid,
            am.as_ref(),
            av.as_ref(),
        )?;
        if let (true, Some(cfg)) = (self.actuation, &self.longitudinal) {
            if let Some(es) = out.iter().find(|c| c.name == "engine_speed") {
                let c = Compared {
                    name: super::rows::ACTUATION_CHANNEL.into(),
                    unit: es.unit.clone(),
                    measured: es.measured.clone(),
                    simulated: es.simulated.clone(),
                    valid: super::rows::actuation_channel_rows(log, cfg.min_speed_mps),
                };
                out.push(c);
            }
        }
        Ok(out)
    }
}

/// The sensor estimates of every column of `cfg` present in `log` with a finite value.
///
/// # Errors
/// As [`grid_step_s`].
pub fn sensor_estimates(log: &DriveLog, cfg: &NoiseConfig) -> Result<Vec<SensorNoise>, NoiseError> {
    let dt = grid_step_s(log)?;
    let mut out = Vec::new();
    for c in &cfg.columns {
        let Some(s) = log.signals.iter().find(|s| s.name == c.column) else {
            continue;
        };
        let range = (
            c.min.unwrap_or(f64::NEG_INFINITY),
            c.max.unwrap_or(f64::INFINITY),
        );
        match estimate_sensor_noise_in(
            &s.name,
            &s.unit,
            &s.values,
            dt,
            SampleKind::of_column(&s.name),
            range,
        ) {
            Ok(e) => out.push(e),
            Err(SensorNoiseError::Empty { .. }) => continue,
            Err(e) => return Err(e.into()),
        }
    }
    Ok(out)
}

/// Copy `copy` of `log` with every sensed column perturbed by a draw of its sensor error,
/// clamped into its physical range, rows at rest set to the rest state
/// ([`SensorNoise::draw_in`]; NaN stays NaN). Returns the log and the perturbation of
/// each column (for the measurement / input split).
pub fn perturbed_log(
    log: &DriveLog,
    sensors: &[SensorNoise],
    cfg: &NoiseConfig,
    copy: u64,
) -> (DriveLog, Vec<(String, Vec<f64>)>) {
    let mut out = log.clone();
    let mut deltas = Vec::new();
    for s in sensors {
        let Some(col) = out.signals.iter_mut().find(|c| c.name == s.column) else {
            continue;
        };
        let range = cfg.columns.iter().find(|c| c.column == s.column);
        let (lo, hi) = (
            range.and_then(|r| r.min).unwrap_or(f64::NEG_INFINITY),
            range.and_then(|r| r.max).unwrap_or(f64::INFINITY),
        );
        let (d, rest) = s.draw_in(
            col.values.len(),
            &mut stream(cfg.seed, copy, &s.column),
            lo,
            hi,
        );
        let mut applied = vec![0.0; d.len()];
        for (i, v) in col.values.iter_mut().enumerate() {
            if v.is_finite() {
                let nv = rest[i].unwrap_or_else(|| (*v + d[i]).clamp(lo, hi));
                applied[i] = nv - *v;
                *v = nv;
            }
        }
        if cfg.phase_jitter_columns.contains(&s.column) && s.native_rate_hz > 0.0 {
            // sample-phase uncertainty of an event channel: the copy's samples stand for events
            // up to half a native period earlier or later
            let half = 0.5 / s.native_rate_hz;
            let tau = stream(cfg.seed, copy, &format!("{}/phase", s.column)).uniform(-half, half);
            let t: Vec<f64> = log.seconds_from_start();
            let before = col.values.clone();
            col.values = super::extended::shifted(&t, &before, tau)
                .into_iter()
                .zip(&before)
                .map(|(x, b)| if b.is_finite() { x.clamp(lo, hi) } else { *b })
                .collect();
            for ((a, b), x) in applied.iter_mut().zip(&before).zip(&col.values) {
                if b.is_finite() && x.is_finite() {
                    *a += x - b;
                }
            }
        }
        deltas.push((s.column.clone(), applied));
    }
    (out, deltas)
}

/// Noise floors of the signals `residuals` compares on `log` (see the module documentation,
/// part 2): `residuals` is run on the recording and on `cfg.copies` perturbed copies (in
/// parallel, results in copy order, so the outcome does not depend on the thread count).
///
/// # Errors
/// [`NoiseError`] from the settings, the sensor estimates or `residuals`.
pub fn noise_floors_with<F>(
    log: &DriveLog,
    cfg: &NoiseConfig,
    residuals: F,
) -> Result<NoiseFloors, NoiseError>
where
    F: Fn(&DriveLog) -> Result<Vec<Compared>, NoiseError> + Sync,
{
    cfg.validate()?;
    let dt = grid_step_s(log)?;
    let sensors = sensor_estimates(log, cfg)?;
    let base = residuals(log)?;
    type Run = (Vec<Compared>, Vec<(String, Vec<f64>)>);
    let runs: Vec<Run> = (0..cfg.copies as u64)
        .into_par_iter()
        .map(|c| {
            let (plog, deltas) = perturbed_log(log, &sensors, cfg, c);
            residuals(&plog).map(|r| (r, deltas))
        })
        .collect::<Result<_, _>>()?;
    let mut floors = Vec::new();
    for b in &base {
        let r0 = b.residual();
        let n = r0.len();
        let mut copies = Vec::with_capacity(runs.len());
        let mut meas = Vec::with_capacity(runs.len());
        for (rs, deltas) in &runs {
            let Some(c) = rs.iter().find(|c| c.name == b.name) else {
                continue;
            };
            let rc = c.residual();
            if rc.len() != n {
                return Err(NoiseError::Length {
                    what: format!("residual of {} in a perturbed copy", b.name),
                    expected: n,
                    got: rc.len(),
                });
            }
            copies.push((0..n).map(|i| rc[i] - r0[i]).collect::<Vec<f64>>());
            meas.push(
                deltas
                    .iter()
                    .find(|d| d.0 == b.name)
                    .map_or_else(|| vec![0.0; n], |d| d.1.clone()),
            );
        }
        let mut f = NoiseFloor::from_null_copies(&b.name, &b.unit, dt, &copies, &b.valid, cfg)?;
        // measurement / input split (RMS over the rows that count)
        let (mut sm, mut si, mut cnt) = (0.0, 0.0, 0usize);
        for (c, m) in copies.iter().zip(&meas) {
            for i in 0..n {
                if f.null_variance[i].is_finite() {
                    sm += m[i] * m[i];
                    si += (c[i] - m[i]).powi(2);
                    cnt += 1;
                }
            }
        }
        if cnt > 0 {
            f.measurement_rms = Some((sm / cnt as f64).sqrt());
            f.input_rms = Some((si / cnt as f64).sqrt());
        }
        f.sensor = sensors.iter().find(|s| s.column == b.name).cloned();
        floors.push(f);
    }
    Ok(NoiseFloors {
        floors,
        sensors,
        copies: cfg.copies,
        seed: cfg.seed,
    })
}

/// [`noise_floors_with`] for the extended models of `models` at parameters `theta`
/// ([`ModelSet::compared`]).
///
/// # Errors
/// As [`noise_floors_with`].
pub fn noise_floors(
    log: &DriveLog,
    models: &ModelSet<'_>,
    theta: &Theta,
    cfg: &NoiseConfig,
) -> Result<NoiseFloors, NoiseError> {
    noise_floors_with(log, cfg, |l| models.compared(l, theta))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    /// A 10 Hz channel with noise σ on a 50 Hz grid (linear), its knots at phase 0.3 rows.
    fn linear_10hz(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256StarStar::seed_from_u64(seed);
        let knots: Vec<(f64, f64)> = (0..n / 5 + 2)
            .map(|k| {
                let p = 0.3 + 5.0 * k as f64;
                (p, 10.0 + (p * 0.002).sin() + sigma * rng.standard_normal())
            })
            .collect();
        (0..n)
            .map(|i| {
                let x = i as f64;
                let k = knots.partition_point(|kn| kn.0 <= x);
                if k == 0 {
                    return knots[0].1;
                }
                let (a, b) = (knots[k - 1], knots[k]);
                a.1 + (x - a.0) / (b.0 - a.0) * (b.1 - a.1)
            })
            .collect()
    }

    #[test]
    fn native_rate_and_sigma_of_an_interpolated_channel() {
        let x = linear_10hz(20_000, 0.05, 1);
        let s =
            estimate_sensor_noise("vehicle_speed", "m/s", &x, 0.02, SampleKind::Linear).unwrap();
        assert!((s.native_rate_hz - 10.0).abs() < 0.05, "{s:?}");
        assert!((s.sigma_raw / 0.05 - 1.0).abs() < 0.08, "{}", s.sigma_raw);
        assert_eq!(s.quantization_step, None);
    }

    #[test]
    fn held_quantised_channel_without_noise_gets_the_persistent_half_step() {
        // slope 10 Hz held on a 50 Hz grid, whole percent, no noise
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let k = i / 5;
                ((0.03 * (k as f64 * 0.003).sin()) * 100.0).round() / 100.0
            })
            .collect();
        let s = estimate_sensor_noise("road_slope", "1", &x, 0.02, SampleKind::Hold).unwrap();
        assert_eq!(s.quantization_step.map(|q| (q * 1e4).round()), Some(100.0));
        assert!(s.sigma_white < 0.002, "{s:?}");
        assert!(s.persistent_half_width > 0.004, "{s:?}");
    }

    #[test]
    fn noise_of_twice_the_step_is_not_read_off_the_lattice() {
        // the proof's slope sensor: 10 Hz held on a 50 Hz grid, σ 0.2 % rounded to 0.1 %
        let mut rng = Xoshiro256StarStar::seed_from_u64(7);
        let (q, sigma) = (0.001, 0.002);
        let native: Vec<f64> = (0..10_000)
            .map(|k| {
                let s = 0.03 * (k as f64 * 0.003).sin() + sigma * rng.standard_normal();
                (s / q).round() * q
            })
            .collect();
        let x: Vec<f64> = (0..50_000).map(|i| native[i / 5]).collect();
        let s = estimate_sensor_noise("road_slope", "1", &x, 0.02, SampleKind::Hold).unwrap();
        assert_eq!(s.quantization_step.map(|v| (v / q).round()), Some(1.0));
        // 10 000 samples: the MAD's own spread is about 1 %; the plain median gives 0.90 σ
        assert!(
            (s.sigma_white / sigma - 1.0).abs() < 0.04,
            "σ_w {} against {sigma}",
            s.sigma_white
        );
    }

    #[test]
    fn a_copy_moves_the_engine_torques_steps_within_half_its_sample_period() {
        // a 1 000 N·m tip-in at 10 s, 50 Hz samples on the 50 Hz grid, no noise: each copy
        // reads the torque up to ±10 ms off, so only the two rows about the step change, by at
        // most half the step
        let n = 1000;
        let torque: Vec<f64> = (0..n).map(|i| if i < 500 { 0.0 } else { 1000.0 }).collect();
        let log = DriveLog {
            meta: crate::table::DriveMeta::default(),
            timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
            signals: vec![crate::table::Signal {
                name: "engine_torque".into(),
                unit: "N*m".into(),
                values: torque,
            }],
        };
        let s = SensorNoise::given(
            "engine_torque",
            "N*m",
            SampleKind::Linear,
            n,
            0.02,
            1,
            0.0,
            None,
        )
        .unwrap();
        let cfg = NoiseConfig::default();
        let mut moved = 0;
        for copy in 0..12 {
            let (_, deltas) = perturbed_log(&log, std::slice::from_ref(&s), &cfg, copy);
            let d = &deltas[0].1;
            for (i, x) in d.iter().enumerate() {
                if i == 499 || i == 500 {
                    assert!(x.abs() <= 500.0 + 1e-9, "copy {copy} row {i}: {x}");
                } else {
                    assert_eq!(*x, 0.0, "copy {copy} row {i}");
                }
            }
            moved += usize::from(d.iter().any(|x| *x != 0.0));
        }
        assert!(moved >= 11, "{moved} of 12 copies moved the step");
    }

    #[test]
    fn draw_has_the_estimated_spread() {
        let s = SensorNoise::given("x", "1", SampleKind::Hold, 10_000, 0.02, 5, 0.2, None).unwrap();
        let d = s.draw(10_000, &mut stream(1, 0, "x"));
        let rms = (d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt();
        assert!((rms / 0.2 - 1.0).abs() < 0.1, "{rms}");
        // held: constant over each 5-row native interval
        assert_eq!(d[0], d[4]);
        assert_ne!(d[4], d[5]);
    }

    #[test]
    fn empty_and_bad_inputs_are_errors() {
        assert!(matches!(
            estimate_sensor_noise("x", "1", &[], 0.02, SampleKind::Linear),
            Err(SensorNoiseError::Empty { .. })
        ));
        assert!(matches!(
            estimate_sensor_noise("x", "1", &[f64::NAN; 10], 0.02, SampleKind::Linear),
            Err(SensorNoiseError::Empty { .. })
        ));
        assert!(estimate_sensor_noise("x", "1", &[1.0; 10], f64::NAN, SampleKind::Linear).is_err());
        // constant series: zero noise, no error
        let s = estimate_sensor_noise("x", "1", &[1.0; 50], 0.02, SampleKind::Linear).unwrap();
        assert_eq!(s.sigma_raw, 0.0);
        let v = vec![true; 10];
        assert!(NoiseFloor::from_null_copies(
            "x",
            "1",
            0.02,
            &[vec![0.0; 10]],
            &v,
            &NoiseConfig::default()
        )
        .is_err());
        assert!(NoiseFloor::from_null_copies(
            "x",
            "1",
            0.02,
            &[vec![0.0; 10], vec![0.0; 9]],
            &v,
            &NoiseConfig::default()
        )
        .is_err());
    }

    #[test]
    fn white_null_has_about_one_dof_per_row() {
        let cfg = NoiseConfig::default();
        let n = 5000;
        let copies: Vec<Vec<f64>> = (0..12)
            .map(|c| {
                let mut r = stream(3, c, "w");
                (0..n).map(|_| r.standard_normal()).collect()
            })
            .collect();
        let f =
            NoiseFloor::from_null_copies("w", "1", 0.02, &copies, &vec![true; n], &cfg).unwrap();
        assert!((f.floor - 1.0).abs() < 0.02, "{}", f.floor);
        let rows: Vec<usize> = (0..500).collect();
        let nu = f.effective_dof(&rows);
        assert!(nu > 400.0 && nu <= 500.0, "{nu}");
        // the copies agree: white rows keep their degrees of freedom (the pairs' estimate from
        // 12 copies has a relative error of about 0.17 here, √(2/66))
        assert!(f.window_dof(&rows) > 300.0, "{}", f.window_dof(&rows));
    }

    #[test]
    fn a_window_whose_null_is_one_offset_has_about_one_dof_whatever_the_pooled_correlation() {
        // first half white, second half one constant offset per 200-row block (a start-state
        // error held through a re-initialisation window): the pooled autocorrelation is a mix
        // of the two, the copies inside one block are not
        let cfg = NoiseConfig::default();
        let n = 4000;
        let copies: Vec<Vec<f64>> = (0..12)
            .map(|c| {
                let mut r = stream(5, c, "w");
                let mut offset = 0.0;
                (0..n)
                    .map(|i| {
                        if i < n / 2 {
                            r.standard_normal()
                        } else {
                            if (i - n / 2) % 200 == 0 {
                                offset = r.standard_normal();
                            }
                            offset
                        }
                    })
                    .collect()
            })
            .collect();
        let f =
            NoiseFloor::from_null_copies("w", "1", 0.02, &copies, &vec![true; n], &cfg).unwrap();
        let block: Vec<usize> = (2200..2400).collect();
        let (acf, own) = (f.effective_dof(&block), f.window_dof(&block));
        // one shape with a random amplitude: exactly 1 (f32 copies)
        assert!((own - 1.0).abs() < 1e-5, "window_dof {own}");
        assert!(own < acf, "window_dof {own} vs effective_dof {acf}");
    }

    #[test]
    fn a_drift_in_the_second_half_of_its_window_has_the_dof_of_a_brownian_motion() {
        // the longitudinal null's shape: a random walk restarting every 20 s (1000 rows); its
        // second half [10, 20] s has ν = (∫t dt)² / ∫∫ min(s,t)² ds dt = 22 500 / 18 333 = 1.23
        let cfg = NoiseConfig::default();
        let n = 10_000;
        let copies: Vec<Vec<f64>> = (0..12)
            .map(|c| {
                let mut r = stream(9, c, "b");
                let mut w = 0.0;
                (0..n)
                    .map(|i| {
                        if i % 1000 == 0 {
                            w = 0.0;
                        }
                        w += r.standard_normal();
                        w
                    })
                    .collect()
            })
            .collect();
        let f =
            NoiseFloor::from_null_copies("b", "1", 0.02, &copies, &vec![true; n], &cfg).unwrap();
        let half: Vec<usize> = (3500..4000).collect();
        let own = f.window_dof(&half);
        // 12 copies: the pairs' estimate lies within 1.14–1.56 in 80 % of simulated trials
        assert!(own > 1.0 && own < 1.8, "window_dof {own}");
    }
}
