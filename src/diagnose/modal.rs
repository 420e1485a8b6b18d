//! Shuffle modes per clutch engagement, measured against simulated (docs/diagnosis/method.md, steps
//! 2 and 3 for the driveline effects): after a clutch closes, the locked driveline rings at its
//! first torsional ("shuffle") mode, whose frequency is set by the drive-shaft stiffness `k_d` and
//! the inertias of the engaged gear (docs/models/driveline.md). A change of `k_d`
//! (`driveline_compliance`) moves that frequency; it hides in the time-domain engine-speed residual
//! (whose floor is input-driven, 0.33–0.43 rad/s on the proof drives) but not in the frequency of
//! the ringing.
//!
//! # Method
//! 1. [`engagements`]: every clutch closing after which the clutch stays closed, the gear stays
//!    engaged and unchanged, and the engine speed has no gap over the analysis window
//!    ([`ModalConfig::window_start_s`]…[`ModalConfig::window_end_s`] after the closing).
//! 2. [`fit_damped_sinusoid`]: on the window's engine speed, the model
//!    `y(τ) = c₀ + c₁τ + c₂τ² + A e^{−σ τ} sin(ωτ + φ)` (τ from the window start, s) — the
//!    quadratic trend is fitted jointly, not removed first, so that it cannot absorb part of the
//!    ringing. Start: variable projection on a grid of `(ω, σ)` (the five linear coefficients
//!    solved by least squares at each grid point); then Levenberg–Marquardt on all seven
//!    parameters with the analytic Jacobian. Standard errors from `s² (JᵀJ)⁻¹` (white-residual
//!    assumption: the residual is partly input-driven and correlated, so they are lower bounds).
//! 3. [`compare_modes`]: the same fit on the nominal model's simulated engine speed
//!    ([`super::extended::LongitudinalModel::simulate`], the comparison of step 1) on the same
//!    rows, so that the window and the method's bias cancel in `Δf = f_measured − f_simulated`.
//! 4. Significance ([`DriveModalTest`]): the relative shift `r = Δf / f_simulated` of every
//!    engagement with both fits accepted, one-sample two-sided Student t-test of `mean r = 0`
//!    over the drive's engagements (one test per drive, false-alarm rate
//!    [`ModalConfig::alpha`] when the engagements' shifts are independent with zero mean), and
//!    a practical margin [`ModalConfig::min_relative_shift`] the mean must also exceed. Per gear
//!    the mean and spread of `Δf` and `Δσ` are reported, with Holm-corrected per-gear t-tests
//!    where a gear has at least two engagements.
//!
//! # Conventions
//! Frequencies are the observed (damped) frequency `ω/2π`, Hz; the decay rate `σ` is the
//! exponent of the envelope `e^{−σ τ}`, 1/s (not the damping ratio; `ζ = σ/√(σ² + ω²)`).
//! Amplitude in the unit of the fitted signal (rad/s for the engine speed) at the window start.
//!
//! ## Reference
//! Golub & Pereyra, "The differentiation of pseudo-inverses and nonlinear least squares problems
//! whose variables separate", SIAM J. Numer. Anal. 10 (1973) — variable projection;
//! Marquardt, J. SIAM 11 (1963) — the damped Gauss–Newton step (`λ·diag(JᵀJ)` scaling);
//! Holm, Scand. J. Statist. 6 (1979) — the step-down correction.

use super::tyre_slip::{DRIVEN_LOAD_SHARE, TYRE_FRICTION};
use crate::model::catalogue::Tolerance;
use crate::model::driveline::DrivelineParams;
use crate::model::tolerance::Tolerances;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};
use std::ops::Range;

/// Settings of the modal comparison.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModalConfig {
    /// Clutch position at or below which the clutch counts as closed, fraction of travel
    /// (0.02: the 2 % the comparison uses for a clutch transition,
    /// [`super::rows::longitudinal_rows`]).
    pub clutch_closed_max: f64,
    /// Start of the analysis window after the first closed clutch sample, s. 0.2 s: the clutch
    /// position comes at 10 Hz, so the closing is known to 0.1 s; one more sample makes sure
    /// the clutch has locked and the window holds the free ringing, not the engagement.
    pub window_start_s: f64,
    /// End of the analysis window after the closing, s. 2.5 s: at the measured decay rates
    /// (4–6 1/s in gears 7–12, ~1 1/s in gear 1) the ringing has died into the noise well before,
    /// and a longer window lets the next torque change into the fit.
    pub window_end_s: f64,
    /// Lowest measured vehicle speed at the window start, m/s (the model has no creep mode,
    /// [`super::setup::MIN_SPEED_MPS`]).
    pub min_speed_mps: f64,
    /// Frequency band searched, Hz: 0.8–12 Hz holds the shuffle of every gear of a heavy
    /// truck (measured 1.3–8.3 Hz on the proof drives, gear 1 with a 38 % softer shaft to
    /// gear 12) and stays below the 25 Hz Nyquist frequency of a 50 Hz engine speed.
    pub band_hz: (f64, f64),
    /// Largest decay rate accepted, 1/s: above it the window holds less than a cycle of
    /// ringing at 4 Hz and the frequency is not determined.
    pub max_decay_per_s: f64,
    /// Smallest share of the detrended variance the oscillation must explain (R²). 0.6: the
    /// proof drives' engagements reach 0.8–0.99; a window with no ringing explains noise only
    /// (R² ≈ 4/n ≈ 0.05 for a 115-sample window).
    pub min_r2: f64,
    /// Smallest amplitude at the window start, rad/s (the engine speed's unit; a signal in
    /// another unit needs its own value). 0.3 rad/s: 3× the 1 rpm (0.105 rad/s) noise σ of a J1939 EEC1 engine speed; the
    /// proof drives' engagements ring at 0.46–1.9 rad/s.
    pub min_amplitude_rad_s: f64,
    /// False-alarm rate of the drive-level test (and family-wise rate of the per-gear tests).
    pub alpha: f64,
    /// Smallest mean relative frequency shift the drive-level test reports, fraction: 0.03,
    /// about 3× the per-gear repeatability (0.05 Hz at 4–8 Hz) measured within a drive, and a
    /// third of the shift a 25 % shaft-stiffness change gives (`f ∝ √k_d` at most: 12 %).
    pub min_relative_shift: f64,
    /// Fewest engagements with both fits accepted for a drive-level test.
    pub min_engagements: usize,
    /// Largest ratio (either way) of a measured mode's frequency to its reference for the
    /// two to be the same mode. 1.6: the catalogue's shaft-stiffness changes (±25–50 %) move
    /// the shuffle by a factor of at most √1.5 ≈ 1.22 (or 1/√0.5 ≈ 1.41); a mode further off
    /// is another motion — measured on a proof drive with a slipping clutch, a 0.95 Hz drift
    /// fitted in gear 12, whose shuffle is at 8.3 Hz.
    pub max_mode_ratio: f64,
}

impl Default for ModalConfig {
    fn default() -> Self {
        Self {
            clutch_closed_max: 0.02,
            window_start_s: 0.2,
            window_end_s: 2.5,
            min_speed_mps: 1.0,
            band_hz: (0.8, 12.0),
            max_decay_per_s: 20.0,
            min_r2: 0.6,
            min_amplitude_rad_s: 0.3,
            alpha: 0.01,
            min_relative_shift: 0.03,
            min_engagements: 3,
            max_mode_ratio: 1.6,
        }
    }
}

/// One clutch closing with a usable analysis window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Engagement {
    /// Time of the first closed clutch sample, s from the first row.
    pub t_close_s: f64,
    /// Gear held through the window (1-based).
    pub gear: usize,
    /// Rows of the analysis window.
    pub rows: Range<usize>,
    /// Measured vehicle speed at the window start, m/s (NaN without a speed column).
    pub speed_mps: f64,
    /// Mean recorded engine torque over the window, N·m (0 without a torque column; the
    /// finite samples only).
    pub engine_torque_nm: f64,
}

/// The clutch closings of `log` whose analysis window is usable (see [`ModalConfig`] for the
/// thresholds): a row whose clutch position is at or below
/// [`ModalConfig::clutch_closed_max`] after a row above it; from that row to the window end the
/// clutch stays closed (no sample above the threshold, no gap — an unknown clutch is not a
/// closed one), the gear is the same engaged gear on every row (no gap either), and the engine
/// speed has a real sample on every row of the window (a filled dropout carries no ringing);
/// and the measured vehicle speed at the window start is at least
/// [`ModalConfig::min_speed_mps`]. A log without clutch, gear or engine speed has none.
pub fn engagements(log: &DriveLog, cfg: &ModalConfig) -> Vec<Engagement> {
    let (Some(clutch), Some(gear), Some(w)) = (
        log.signal("clutch_position"),
        log.signal("gear"),
        log.signal("engine_speed"),
    ) else {
        return Vec::new();
    };
    let t = log.seconds_from_start();
    let speed = log
        .signal("vehicle_speed")
        .and_then(|v| fill_gaps(v, Interpolation::Linear));
    let torque = log.signal("engine_torque");
    let mean_torque = |r: Range<usize>| {
        let Some(m) = torque else { return 0.0 };
        let (sum, k) = m[r]
            .iter()
            .filter(|x| x.is_finite())
            .fold((0.0, 0usize), |(s, k), x| (s + x, k + 1));
        if k > 0 {
            sum / k as f64
        } else {
            0.0
        }
    };
    let n = t.len();
    let mut out = Vec::new();
    let mut prev_open = false;
    for i in 0..n {
        let c = clutch[i];
        if !c.is_finite() {
            prev_open = false;
            continue;
        }
        let closed = c <= cfg.clutch_closed_max;
        if closed && prev_open {
            let a = t.partition_point(|&x| x < t[i] + cfg.window_start_s);
            let b = t.partition_point(|&x| x <= t[i] + cfg.window_end_s);
            // the window must end inside the log
            let complete = b < n;
            let g0 = gear[i];
            let held = complete
                && g0.is_finite()
                && g0.round() >= 1.0
                && (i..b).all(|k| {
                    clutch[k].is_finite() && clutch[k] <= cfg.clutch_closed_max && gear[k] == g0
                });
            let measured = held && (a..b).all(|k| w[k].is_finite());
            let moving = speed
                .as_ref()
                .is_none_or(|v| a < n && v[a] >= cfg.min_speed_mps);
            if measured && moving && b > a {
                out.push(Engagement {
                    t_close_s: t[i],
                    gear: g0.round() as usize,
                    rows: a..b,
                    speed_mps: speed.as_ref().map_or(f64::NAN, |v| v[a]),
                    engine_torque_nm: mean_torque(a..b),
                });
            }
        }
        prev_open = !closed;
    }
    out
}

/// A damped sinusoid fitted to one window (see the module documentation for the model).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModalFit {
    /// Observed frequency `ω/2π`, Hz.
    pub frequency_hz: f64,
    /// Standard error of the frequency, Hz (white-residual assumption: a lower bound).
    pub frequency_se_hz: f64,
    /// Envelope decay rate `σ`, 1/s.
    pub decay_per_s: f64,
    /// Standard error of the decay rate, 1/s.
    pub decay_se_per_s: f64,
    /// Amplitude at the window start, signal unit.
    pub amplitude: f64,
    /// Phase `φ` at the window start, rad.
    pub phase_rad: f64,
    /// Share of the detrended variance the oscillation explains:
    /// `1 − RSS / RSS(quadratic trend alone)`.
    pub r2: f64,
    /// RMS of the fit residual, signal unit.
    pub residual_rms: f64,
}

/// Why a window has no accepted mode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum ModalReject {
    /// Fewer than 20 samples, or times and values of different lengths or not finite.
    TooShort,
    /// The oscillation explains too little of the detrended variance (R² given).
    NoOscillation(f64),
    /// The amplitude is below [`ModalConfig::min_amplitude_rad_s`] (amplitude given).
    TooSmall(f64),
    /// The refined frequency left the band (Hz given).
    OutOfBand(f64),
    /// The decay rate is negative beyond −0.5 1/s (growing) or above
    /// [`ModalConfig::max_decay_per_s`] (1/s given).
    Decay(f64),
}

/// Model value and its parts at `τ` for `p = [c0, c1, c2, a, b, ω, σ]`.
fn model(p: &[f64; 7], tau: f64) -> f64 {
    let e = (-p[6] * tau).exp();
    let (s, c) = (p[5] * tau).sin_cos();
    p[0] + p[1] * tau + p[2] * tau * tau + e * (p[3] * s + p[4] * c)
}

/// Least squares of `y` on the columns of `x`: coefficients and residual sum of squares.
fn linear_lsq(x: &DMatrix<f64>, y: &DVector<f64>) -> Option<(DVector<f64>, f64)> {
    let svd = x.clone().svd(true, true);
    let beta = svd.solve(y, 1e-12).ok()?;
    let r = y - x * &beta;
    Some((beta, r.norm_squared()))
}

fn basis(tau: &[f64], omega: f64, sigma: f64, oscillating: bool) -> DMatrix<f64> {
    let cols = if oscillating { 5 } else { 3 };
    DMatrix::from_fn(tau.len(), cols, |i, j| {
        let t = tau[i];
        match j {
            0 => 1.0,
            1 => t,
            2 => t * t,
            3 => (-sigma * t).exp() * (omega * t).sin(),
            _ => (-sigma * t).exp() * (omega * t).cos(),
        }
    })
}

/// Decay rates of the variable-projection start grid, 1/s.
const DECAY_GRID_PER_S: [f64; 8] = [0.0, 1.0, 2.0, 3.5, 5.0, 7.0, 10.0, 14.0];
/// Frequency step of the start grid, Hz: a quarter of the 1/T ≈ 0.43 Hz resolution of a
/// 2.3 s window, so the grid's best point lies inside the main lobe of the true frequency.
const GRID_STEP_HZ: f64 = 0.1;

/// Fits `y(t) = c₀ + c₁τ + c₂τ² + A e^{−στ} sin(ωτ + φ)`, `τ = t − t[0]`, to one window and
/// applies the acceptance rule of `cfg` (R² ≥ [`ModalConfig::min_r2`], amplitude ≥
/// [`ModalConfig::min_amplitude_rad_s`], frequency inside [`ModalConfig::band_hz`], decay in
/// [−0.5, [`ModalConfig::max_decay_per_s`]] 1/s).
///
/// # Errors
/// [`ModalReject`] naming the rule the window fails.
pub fn fit_damped_sinusoid(
    t: &[f64],
    y: &[f64],
    cfg: &ModalConfig,
) -> Result<ModalFit, ModalReject> {
    let n = t.len();
    if n < 20 || y.len() != n || t.iter().chain(y).any(|v| !v.is_finite()) {
        return Err(ModalReject::TooShort);
    }
    let tau: Vec<f64> = t.iter().map(|x| x - t[0]).collect();
    let yv = DVector::from_column_slice(y);
    let (_, rss_trend) =
        linear_lsq(&basis(&tau, 0.0, 0.0, false), &yv).ok_or(ModalReject::TooShort)?;
    if rss_trend <= 0.0 {
        return Err(ModalReject::NoOscillation(0.0));
    }
    // variable projection on the (ω, σ) grid
    let (f_lo, f_hi) = cfg.band_hz;
    let steps = ((f_hi - f_lo) / GRID_STEP_HZ).ceil() as usize;
    let mut best: Option<(f64, [f64; 7])> = None;
    for k in 0..=steps {
        let omega = 2.0 * std::f64::consts::PI * (f_lo + k as f64 * GRID_STEP_HZ).min(f_hi);
        for &sigma in &DECAY_GRID_PER_S {
            let Some((beta, rss)) = linear_lsq(&basis(&tau, omega, sigma, true), &yv) else {
                continue;
            };
            if best.as_ref().is_none_or(|(r, _)| rss < *r) {
                best = Some((
                    rss,
                    [beta[0], beta[1], beta[2], beta[3], beta[4], omega, sigma],
                ));
            }
        }
    }
    let (mut rss, mut p) = best.ok_or(ModalReject::TooShort)?;
    // Levenberg–Marquardt on all seven parameters
    let jac = |p: &[f64; 7]| {
        DMatrix::from_fn(n, 7, |i, j| {
            let t = tau[i];
            let e = (-p[6] * t).exp();
            let (s, c) = (p[5] * t).sin_cos();
            match j {
                0 => 1.0,
                1 => t,
                2 => t * t,
                3 => e * s,
                4 => e * c,
                5 => e * t * (p[3] * c - p[4] * s),
                _ => -t * e * (p[3] * s + p[4] * c),
            }
        })
    };
    let resid = |p: &[f64; 7]| DVector::from_fn(n, |i, _| y[i] - model(p, tau[i]));
    let mut lambda = 1e-3;
    for _ in 0..200 {
        let j = jac(&p);
        let r = resid(&p);
        let jtj = j.transpose() * &j;
        let g = j.transpose() * &r;
        let mut improved = false;
        while lambda < 1e12 {
            let mut a = jtj.clone();
            for d in 0..7 {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&g)) else {
                lambda *= 10.0;
                continue;
            };
            let mut q = p;
            for d in 0..7 {
                q[d] += step[d];
            }
            let rss_q = resid(&q).norm_squared();
            if rss_q.is_finite() && rss_q < rss {
                let gain = (rss - rss_q) / rss;
                p = q;
                rss = rss_q;
                lambda = (lambda / 10.0).max(1e-12);
                improved = gain > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let frequency_hz = p[5].abs() / (2.0 * std::f64::consts::PI);
    let amplitude = p[3].hypot(p[4]);
    // sin(ωτ + φ) = sin ωτ cos φ + cos ωτ sin φ, with a = A cos φ, b = A sin φ (ω ≥ 0)
    let (a, b) = if p[5] < 0.0 {
        (-p[3], p[4])
    } else {
        (p[3], p[4])
    };
    let phase_rad = b.atan2(a);
    let r2 = 1.0 - rss / rss_trend;
    let dof = (n - 7) as f64;
    let s2 = rss / dof;
    let j = jac(&p);
    let cov = (j.transpose() * &j).try_inverse();
    let se = |d: usize| {
        cov.as_ref()
            .map_or(f64::INFINITY, |c| (s2 * c[(d, d)]).max(0.0).sqrt())
    };
    let fit = ModalFit {
        frequency_hz,
        frequency_se_hz: se(5) / (2.0 * std::f64::consts::PI),
        decay_per_s: p[6],
        decay_se_per_s: se(6),
        amplitude,
        phase_rad,
        r2,
        residual_rms: (rss / n as f64).sqrt(),
    };
    if fit.r2.is_nan() || fit.r2 < cfg.min_r2 {
        return Err(ModalReject::NoOscillation(fit.r2));
    }
    if fit.amplitude.is_nan() || fit.amplitude < cfg.min_amplitude_rad_s {
        return Err(ModalReject::TooSmall(fit.amplitude));
    }
    if !(frequency_hz >= f_lo && frequency_hz <= f_hi) {
        return Err(ModalReject::OutOfBand(frequency_hz));
    }
    if !(fit.decay_per_s >= -0.5 && fit.decay_per_s <= cfg.max_decay_per_s) {
        return Err(ModalReject::Decay(fit.decay_per_s));
    }
    Ok(fit)
}

/// A mode of the linearised locked-clutch driveline ([`locked_mode`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LockedMode {
    /// Damped frequency `|Im λ|/2π`, Hz.
    pub frequency_hz: f64,
    /// Decay rate `−Re λ`, 1/s.
    pub decay_per_s: f64,
}

/// What the measured modes are compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Reference {
    /// The same fit on the nominal model's simulated engine speed on the same rows.
    Simulated,
    /// The first torsional mode of the nominal driveline linearised in the engagement's gear at
    /// its measured speed ([`locked_mode`]).
    Linearised,
}

/// The modes of one engagement: measured, simulated and linearised.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EngagementModes {
    /// The engagement.
    pub engagement: Engagement,
    /// Fit on the measured engine speed.
    pub measured: Result<ModalFit, ModalReject>,
    /// Fit on the simulated engine speed.
    pub simulated: Result<ModalFit, ModalReject>,
    /// The nominal linearised mode (`None` without driveline parameters or without a mode).
    pub linearised: Option<LockedMode>,
}

impl EngagementModes {
    /// The reference mode of `reference`, when there is one (an accepted simulated fit, a
    /// linearised mode).
    pub fn reference(&self, reference: Reference) -> Option<LockedMode> {
        match reference {
            Reference::Simulated => self.simulated.as_ref().ok().map(|s| LockedMode {
                frequency_hz: s.frequency_hz,
                decay_per_s: s.decay_per_s,
            }),
            Reference::Linearised => self.linearised,
        }
    }

    /// The accepted measured fit with the reference mode of `reference`, when both exist and
    /// their frequencies are within a factor `max_mode_ratio` of each other
    /// ([`ModalConfig::max_mode_ratio`]).
    pub fn pair(
        &self,
        reference: Reference,
        max_mode_ratio: f64,
    ) -> Option<(&ModalFit, LockedMode)> {
        let m = self.measured.as_ref().ok()?;
        let r = self.reference(reference)?;
        let ratio = m.frequency_hz / r.frequency_hz;
        (ratio <= max_mode_ratio && ratio * max_mode_ratio >= 1.0).then_some((m, r))
    }
}

/// Measured minus reference modes of one gear.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GearModes {
    /// Gear (1-based).
    pub gear: usize,
    /// Engagements with both fits accepted.
    pub n: usize,
    /// Mean measured frequency, Hz.
    pub measured_hz: f64,
    /// Mean reference frequency, Hz.
    pub reference_hz: f64,
    /// Mean `Δf = f_measured − f_reference`, Hz.
    pub delta_f_hz: f64,
    /// Sample standard deviation of `Δf` (NaN for one engagement), Hz.
    pub delta_f_sd_hz: f64,
    /// Mean `Δσ = σ_measured − σ_reference`, 1/s.
    pub delta_decay_per_s: f64,
    /// Sample standard deviation of `Δσ` (NaN for one engagement), 1/s.
    pub delta_decay_sd_per_s: f64,
    /// Two-sided t-test p-value of `mean Δf = 0`, Holm-adjusted over the gears tested (NaN for
    /// one engagement).
    pub p_holm: f64,
}

/// The drive-level test on the relative frequency shifts `r = Δf / f_reference`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriveModalTest {
    /// Engagements in the test.
    pub n: usize,
    /// Mean relative shift, fraction.
    pub mean_shift: f64,
    /// Its standard error, fraction.
    pub shift_se: f64,
    /// Student t statistic, `n − 1` degrees of freedom.
    pub t: f64,
    /// Two-sided p-value.
    pub p_value: f64,
    /// `p_value < alpha` and `|mean_shift| ≥ min_relative_shift`.
    pub flagged: bool,
}

/// The modal comparison of one drive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalComparison {
    /// What the measured modes were compared with.
    pub reference: Reference,
    /// Every usable engagement with its two fits.
    pub engagements: Vec<EngagementModes>,
    /// Per gear, gears ascending, gears with at least one accepted pair.
    pub gears: Vec<GearModes>,
    /// The drive-level test (`None` with fewer than [`ModalConfig::min_engagements`] pairs).
    pub test: Option<DriveModalTest>,
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let sd = if x.len() > 1 {
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    };
    (m, sd)
}

/// Two-sided one-sample t-test p-value of mean 0 (`None` below two samples; a zero spread with
/// a non-zero mean gives 0).
fn t_test(x: &[f64]) -> Option<(f64, f64, f64)> {
    if x.len() < 2 {
        return None;
    }
    let (m, sd) = mean_sd(x);
    let se = sd / (x.len() as f64).sqrt();
    if se == 0.0 {
        return Some((m, se, if m == 0.0 { 1.0 } else { 0.0 }));
    }
    let t = m / se;
    let dist = StudentsT::new(0.0, 1.0, (x.len() - 1) as f64).ok()?;
    Some((t, se, 2.0 * dist.cdf(-t.abs())))
}

/// Fits the mode of every usable engagement of `log` ([`engagements`]) on the measured engine
/// speed `measured` and the simulated `simulated` (rad/s on the log's rows; the same rows for
/// both), adds the nominal linearised mode when `nominal` (driveline parameters, gear ratios
/// and the drive's tyre share of the main flexibility, [`tyre_mode`]) is given, and compares the measured modes with `reference` per gear and for the
/// drive (see the module documentation).
pub fn compare_modes(
    log: &DriveLog,
    measured: &[f64],
    simulated: &[f64],
    nominal: Option<(&DrivelineParams, &[f64], f64)>,
    reference: Reference,
    cfg: &ModalConfig,
) -> ModalComparison {
    let t = log.seconds_from_start();
    let fits: Vec<EngagementModes> = engagements(log, cfg)
        .into_iter()
        .map(|e| {
            let r = e.rows.clone();
            EngagementModes {
                measured: fit_damped_sinusoid(&t[r.clone()], &measured[r.clone()], cfg),
                simulated: fit_damped_sinusoid(&t[r.clone()], &simulated[r], cfg),
                linearised: nominal.and_then(|(p, ratios, share)| {
                    (e.gear <= ratios.len() && e.speed_mps.is_finite())
                        .then(|| {
                            tyre_mode(p, ratios, e.gear, e.speed_mps, e.engine_torque_nm, share)
                        })
                        .flatten()
                }),
                engagement: e,
            }
        })
        .collect();
    summarise(fits, reference, cfg)
}

/// Per-gear figures and the drive-level test of already fitted engagements.
pub fn summarise(
    fits: Vec<EngagementModes>,
    reference: Reference,
    cfg: &ModalConfig,
) -> ModalComparison {
    let mut by_gear: std::collections::BTreeMap<usize, Vec<(&ModalFit, LockedMode)>> =
        std::collections::BTreeMap::new();
    for e in &fits {
        if let Some(p) = e.pair(reference, cfg.max_mode_ratio) {
            by_gear.entry(e.engagement.gear).or_default().push(p);
        }
    }
    let mut gears = Vec::new();
    let mut raw_p = Vec::new();
    for (&gear, pairs) in &by_gear {
        let df: Vec<f64> = pairs
            .iter()
            .map(|(m, s)| m.frequency_hz - s.frequency_hz)
            .collect();
        let dd: Vec<f64> = pairs
            .iter()
            .map(|(m, s)| m.decay_per_s - s.decay_per_s)
            .collect();
        let (delta_f_hz, delta_f_sd_hz) = mean_sd(&df);
        let (delta_decay_per_s, delta_decay_sd_per_s) = mean_sd(&dd);
        let fm: Vec<f64> = pairs.iter().map(|(m, _)| m.frequency_hz).collect();
        let fs: Vec<f64> = pairs.iter().map(|(_, s)| s.frequency_hz).collect();
        raw_p.push(t_test(&df).map_or(f64::NAN, |(_, _, p)| p));
        gears.push(GearModes {
            gear,
            n: pairs.len(),
            measured_hz: mean_sd(&fm).0,
            reference_hz: mean_sd(&fs).0,
            delta_f_hz,
            delta_f_sd_hz,
            delta_decay_per_s,
            delta_decay_sd_per_s,
            p_holm: f64::NAN,
        });
    }
    let tested: Vec<usize> = (0..raw_p.len()).filter(|&i| raw_p[i].is_finite()).collect();
    let adjusted = super::locate::holm(&tested.iter().map(|&i| raw_p[i]).collect::<Vec<_>>());
    for (k, &i) in tested.iter().enumerate() {
        gears[i].p_holm = adjusted[k];
    }
    let shifts: Vec<f64> = fits
        .iter()
        .filter_map(|e| e.pair(reference, cfg.max_mode_ratio))
        .map(|(m, s)| (m.frequency_hz - s.frequency_hz) / s.frequency_hz)
        .collect();
    let test = if shifts.len() >= cfg.min_engagements.max(2) {
        t_test(&shifts).map(|(t, se, p)| {
            let mean_shift = mean_sd(&shifts).0;
            DriveModalTest {
                n: shifts.len(),
                mean_shift,
                shift_se: se,
                t,
                p_value: p,
                flagged: p < cfg.alpha && mean_shift.abs() >= cfg.min_relative_shift,
            }
        })
    } else {
        None
    };
    ModalComparison {
        reference,
        engagements: fits,
        gears,
        test,
    }
}

impl ModalComparison {
    /// The drive's modal mismatch as a located stretch of the engine speed, when the drive-level
    /// test flags it (`None` otherwise): from the first to the last analysis window compared,
    /// `band_hz` the range of the measured mode frequencies, the gears and the mean shift in
    /// words, `rms_residual` the RMS of `measured − simulated` engine speed (rad/s) over those
    /// windows, `significance` the test's p-value (its own test at [`ModalConfig::alpha`], not
    /// in the Holm family of the window tests), `floor_rms` the mean RMS left around the fitted
    /// modes, `windows` the engagements. `t_s`, `distance_m` (empty: NaN), `measured` and
    /// `simulated` are on the log's rows.
    pub fn mismatch(
        &self,
        cfg: &ModalConfig,
        t_s: &[f64],
        distance_m: &[f64],
        measured: &[f64],
        simulated: &[f64],
    ) -> Option<super::locate::Mismatch> {
        let test = self.test.filter(|t| t.flagged)?;
        let used: Vec<(&Engagement, &ModalFit)> = self
            .engagements
            .iter()
            .filter_map(|e| {
                e.pair(self.reference, cfg.max_mode_ratio)
                    .map(|(m, _)| (&e.engagement, m))
            })
            .collect();
        let (first, last) = (used.first()?.0, used.last()?.0);
        let (a, b) = (first.rows.start, last.rows.end - 1);
        let dist = |i: usize| distance_m.get(i).copied().unwrap_or(f64::NAN);
        let f_lo = used
            .iter()
            .map(|(_, m)| m.frequency_hz)
            .fold(f64::INFINITY, f64::min);
        let f_hi = used.iter().map(|(_, m)| m.frequency_hz).fold(0.0, f64::max);
        let (mut ss, mut n) = (0.0, 0usize);
        for (e, _) in &used {
            for i in e.rows.clone() {
                let r = measured[i] - simulated[i];
                if r.is_finite() {
                    ss += r * r;
                    n += 1;
                }
            }
        }
        let mut gears: Vec<usize> = used.iter().map(|(e, _)| e.gear).collect();
        gears.dedup();
        gears.sort_unstable();
        gears.dedup();
        let gears: Vec<String> = gears.iter().map(|g| g.to_string()).collect();
        let what = match self.reference {
            Reference::Simulated => "the nominal model's simulated ringing",
            Reference::Linearised => "the nominal driveline's linearised mode",
        };
        Some(super::locate::Mismatch {
            signal: "engine_speed".into(),
            start_s: t_s[a],
            end_s: t_s[b],
            start_m: dist(a),
            end_m: dist(b),
            band_hz: [f_lo, f_hi],
            condition: format!(
                "after clutch engagements in gear {}: the driveline shuffle rings {:+.1} % off {what} ({} engagements)",
                gears.join(", "),
                100.0 * test.mean_shift,
                test.n
            ),
            rms_residual: if n > 0 { (ss / n as f64).sqrt() } else { f64::NAN },
            significance: test.p_value,
            floor_rms: used.iter().map(|(_, m)| m.residual_rms).sum::<f64>() / used.len() as f64,
            windows: used.len(),
        })
    }
}

/// The first torsional mode of the locked-clutch driveline linearised in `gear` at `v0_mps`
/// ([`crate::model::linear::linearize`], open loop): the complex eigenvalue pair of lowest
/// frequency. `None` when the system has no oscillating mode.
pub fn locked_mode(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
) -> Option<LockedMode> {
    if gear == 0 || gear > ratios.len() {
        return None;
    }
    lowest_mode(&crate::model::linear::linearize(p, ratios, gear, v0_mps).open)
}

/// The lowest-frequency complex eigenvalue pair of `ss` as a mode.
fn lowest_mode(ss: &crate::model::linear::StateSpace) -> Option<LockedMode> {
    ss.eigenvalues()
        .into_iter()
        .filter(|l| l.im > 1e-6)
        .min_by(|a, b| a.im.total_cmp(&b.im))
        .map(|l| LockedMode {
            frequency_hz: l.im / (2.0 * std::f64::consts::PI),
            decay_per_s: -l.re,
        })
}

/// The driven tyres of `p` taking the share `share` of the main flexibility `k_d`
/// ([`crate::model::linear::DrivenTyres`]) under the recorded engine torque `engine_torque_nm`
/// in `gear`: traction force `F_x = M_e·i_t·i_f/r_w` against `F_x,max` =
/// [`TYRE_FRICTION`]` · `[`DRIVEN_LOAD_SHARE`]` · m g` (|ρ| at most 0.95; constants of
/// [`super::tyre_slip`]), relaxation length `r_w` (the order of magnitude Pacejka §7.2 gives:
/// of the tyre's radius), driven-wheel inertia [`DRIVEN_LOAD_SHARE`]` · J_w`.
pub fn driven_tyres(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    engine_torque_nm: f64,
    share: f64,
) -> crate::model::linear::DrivenTyres {
    let i = ratios.get(gear.wrapping_sub(1)).copied().unwrap_or(1.0) * p.final_drive_ratio;
    let f_x = engine_torque_nm * i / p.wheel_radius_m;
    let f_max = TYRE_FRICTION * DRIVEN_LOAD_SHARE * p.mass_kg * p.gravity_m_per_s2;
    crate::model::linear::DrivenTyres {
        share,
        traction_ratio: if f_max > 0.0 && f_x.is_finite() {
            (f_x / f_max).clamp(-0.95, 0.95)
        } else {
            0.0
        },
        relaxation_length_m: p.wheel_radius_m,
        wheel_inertia_kg_m2: DRIVEN_LOAD_SHARE * p.j_w_kg_m2,
    }
}

/// [`locked_mode`] with the driven tyres taking the share `share` of the main flexibility
/// under the engine torque `engine_torque_nm` ([`driven_tyres`],
/// [`crate::model::linear::linearize_with_tyres`]): the tyres' relaxation at speed, their
/// stiffness falling with the traction force and the driven wheels' inertia inside the
/// flexibility all move the shuffle mode. `share = 0` is [`locked_mode`].
pub fn tyre_mode(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
    engine_torque_nm: f64,
    share: f64,
) -> Option<LockedMode> {
    if gear == 0 || gear > ratios.len() {
        return None;
    }
    if share <= 0.0 {
        return locked_mode(p, ratios, gear, v0_mps);
    }
    let t = driven_tyres(p, ratios, gear, engine_torque_nm, share);
    lowest_mode(&crate::model::linear::linearize_with_tyres(
        p, ratios, gear, v0_mps, &t,
    ))
}

/// The relative shift of the first torsional mode (the driven tyres taking `share` of the main
/// flexibility, no traction, [`tyre_mode`]) that the vehicle file's tolerances allow in `gear`
/// at `v0_mps`: each stiffness (`k_c`, `k_p`, `k_d`) and each inertia (`J_e`,
/// `J_c`, `J_t`, `J_p`, `J_f`, `J_d`, `J_w`) and the mass moved alone to the edge of its band
/// ([`Tolerances::of_key`]), the relative change of the linearised frequency taken in
/// magnitude, and the magnitudes summed: the largest shift a driveline whose every value lies
/// in its band can show to first order (the worst corner, not a spread). 0 without a mode.
///
/// A measured shuffle frequency this close to the nominal model's is consistent with the
/// vehicle file; [`ModalConfig::min_relative_shift`] is raised to it (docs/diagnosis/method.md,
/// "Model-form residual").
pub fn tolerance_shift(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
    share: f64,
    tolerances: &Tolerances,
) -> f64 {
    let mode = |q: &DrivelineParams| tyre_mode(q, ratios, gear, v0_mps, 0.0, share);
    let Some(f0) = mode(p).map(|m| m.frequency_hz) else {
        return 0.0;
    };
    type Set = fn(&mut DrivelineParams, f64);
    let keys: [(&str, Set); 11] = [
        ("k_c_nm_per_rad", |q, f| q.k_c_nm_per_rad *= f),
        ("k_p_nm_per_rad", |q, f| q.k_p_nm_per_rad *= f),
        ("k_d_nm_per_rad", |q, f| q.k_d_nm_per_rad *= f),
        ("j_e_kg_m2", |q, f| q.j_e_kg_m2 *= f),
        ("j_c_kg_m2", |q, f| q.j_c_kg_m2 *= f),
        ("j_t_kg_m2", |q, f| {
            q.j_t_kg_m2.iter_mut().for_each(|j| *j *= f)
        }),
        ("j_p_kg_m2", |q, f| q.j_p_kg_m2 *= f),
        ("j_f_kg_m2", |q, f| q.j_f_kg_m2 *= f),
        ("j_d_kg_m2", |q, f| q.j_d_kg_m2 *= f),
        ("j_w_kg_m2", |q, f| q.j_w_kg_m2 *= f),
        ("mass_kg", |q, f| q.mass_kg *= f),
    ];
    keys.iter()
        .filter_map(|(key, set)| {
            let r = match tolerances.of_key(key)? {
                Tolerance::Relative(r) => r,
                // an absolute band on a positive value, as a fraction of the nominal
                Tolerance::Absolute(a) => {
                    let mut q = p.clone();
                    set(&mut q, 1.0);
                    a / nominal_of(key, &q)?
                }
                Tolerance::None => return None,
            };
            let shift = |factor: f64| {
                let mut q = p.clone();
                set(&mut q, factor);
                mode(&q).map(|m| (m.frequency_hz / f0 - 1.0).abs())
            };
            Some(
                shift(1.0 + r)
                    .unwrap_or(0.0)
                    .max(shift(1.0 - r).unwrap_or(0.0)),
            )
        })
        .sum()
}

/// The scalar value of a vehicle-file key of [`tolerance_shift`] (`J_t` of the first gear).
fn nominal_of(key: &str, q: &DrivelineParams) -> Option<f64> {
    Some(match key {
        "k_c_nm_per_rad" => q.k_c_nm_per_rad,
        "k_p_nm_per_rad" => q.k_p_nm_per_rad,
        "k_d_nm_per_rad" => q.k_d_nm_per_rad,
        "j_e_kg_m2" => q.j_e_kg_m2,
        "j_c_kg_m2" => q.j_c_kg_m2,
        "j_t_kg_m2" => *q.j_t_kg_m2.first()?,
        "j_p_kg_m2" => q.j_p_kg_m2,
        "j_f_kg_m2" => q.j_f_kg_m2,
        "j_d_kg_m2" => q.j_d_kg_m2,
        "j_w_kg_m2" => q.j_w_kg_m2,
        "mass_kg" => q.mass_kg,
        _ => return None,
    })
    .filter(|v| *v > 0.0)
}

/// The drive-shaft stiffness that makes the linearised modes match the measured ones.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StiffnessFit {
    /// Fitted `k_d`, N·m/rad.
    pub k_d_nm_per_rad: f64,
    /// 95 % confidence interval of `k_d` (Student t on the fit's `ln k_d` standard error,
    /// `n − 1` degrees of freedom), N·m/rad.
    pub ci95_nm_per_rad: (f64, f64),
    /// Engagements used.
    pub n: usize,
    /// RMS of the remaining `ln f_measured − ln f_linearised`.
    pub rms_log_residual: f64,
}

/// Fits the drive-shaft stiffness `k_d` (`driveline_compliance`) to the accepted measured modes
/// of `fits`: least squares of `ln f_measured − ln f_linearised(k_d)` over the engagements
/// (each at its gear and measured speed, [`locked_mode`] on `p` with `k_d` replaced), in
/// `x = ln(k_d / k_d,nominal)` by Gauss–Newton with a central-difference derivative (20
/// iterations at most, `x` kept within ±2). Engagements whose measured mode is not within a
/// factor [`ModalConfig::max_mode_ratio`] of the nominal linearised one are left out. `None`
/// below two engagements.
pub fn fit_shaft_stiffness(
    fits: &[EngagementModes],
    p: &DrivelineParams,
    ratios: &[f64],
    cfg: &ModalConfig,
) -> Option<StiffnessFit> {
    let obs: Vec<(usize, f64, f64)> = fits
        .iter()
        .filter_map(|e| {
            let m = e.measured.as_ref().ok()?;
            let (g, v) = (e.engagement.gear, e.engagement.speed_mps);
            let ratio = m.frequency_hz / locked_mode(p, ratios, g, v)?.frequency_hz;
            (v.is_finite() && ratio <= cfg.max_mode_ratio && ratio * cfg.max_mode_ratio >= 1.0)
                .then_some((g, v, m.frequency_hz.ln()))
        })
        .collect();
    let n = obs.len();
    if n < 2 {
        return None;
    }
    let k0 = p.k_d_nm_per_rad;
    let residuals = |x: f64| -> Option<Vec<f64>> {
        let mut q = p.clone();
        q.k_d_nm_per_rad = k0 * x.exp();
        obs.iter()
            .map(|&(g, v, lf)| Some(lf - locked_mode(&q, ratios, g, v)?.frequency_hz.ln()))
            .collect()
    };
    let mut x = 0.0;
    let h = 0.01;
    let mut jac = Vec::new();
    for _ in 0..20 {
        let (rp, rm) = (residuals(x + h)?, residuals(x - h)?);
        // d r / d x = −d ln f / d x
        jac = rp
            .iter()
            .zip(&rm)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect();
        let r = residuals(x)?;
        let jtj: f64 = jac.iter().map(|j| j * j).sum();
        if jtj <= 0.0 {
            return None;
        }
        let step = -jac.iter().zip(&r).map(|(j, r)| j * r).sum::<f64>() / jtj;
        x = (x + step).clamp(-2.0, 2.0);
        if step.abs() < 1e-6 {
            break;
        }
    }
    let r = residuals(x)?;
    let rss: f64 = r.iter().map(|v| v * v).sum();
    let jtj: f64 = jac.iter().map(|j| j * j).sum();
    let se = (rss / (n - 1) as f64 / jtj).sqrt();
    let tq = StudentsT::new(0.0, 1.0, (n - 1) as f64)
        .ok()?
        .inverse_cdf(0.975);
    Some(StiffnessFit {
        k_d_nm_per_rad: k0 * x.exp(),
        ci95_nm_per_rad: (k0 * (x - tq * se).exp(), k0 * (x + tq * se).exp()),
        n,
        rms_log_residual: (rss / n as f64).sqrt(),
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A deterministic Gaussian-ish noise (sum of 12 uniforms − 6, xorshift), unit variance.
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed.max(1);
        (0..n)
            .map(|_| {
                let mut acc = 0.0;
                for _ in 0..12 {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    acc += (s >> 11) as f64 / (1u64 << 53) as f64;
                }
                acc - 6.0
            })
            .collect()
    }

    /// Engine speed after a closing: 1300 rpm rising, ringing at `f` with decay `sigma`,
    /// 1 rpm noise, quantised to 0.125 rpm (J1939 EEC1), 50 Hz, 2.3 s.
    fn window(f: f64, sigma: f64, amp: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let rpm = std::f64::consts::PI / 30.0;
        let t: Vec<f64> = (0..115).map(|k| 10.0 + k as f64 * 0.02).collect();
        let e = noise(t.len(), seed);
        let y = t
            .iter()
            .zip(&e)
            .map(|(&x, n)| {
                let tau = x - 10.0;
                let w = 136.0 + 2.0 * tau - 0.3 * tau * tau
                    + amp
                        * (-sigma * tau).exp()
                        * (2.0 * std::f64::consts::PI * f * tau + 0.7).sin()
                    + n * rpm;
                (w / (0.125 * rpm)).round() * 0.125 * rpm
            })
            .collect();
        (t, y)
    }

    #[test]
    fn recovers_frequency_and_decay_of_a_noisy_quantised_ringing() {
        let cfg = ModalConfig::default();
        // gear-1-like, mid-gear and top-gear shuffle; amplitude 1 rad/s (the proof drives'
        // engagements: 0.46–1.9 rad/s)
        for (k, &(f, sigma)) in [(1.7, 0.8), (4.3, 5.0), (8.3, 4.2)].iter().enumerate() {
            for seed in 1..=5 {
                let (t, y) = window(f, sigma, 1.0, seed + 10 * k as u64);
                let fit = fit_damped_sinusoid(&t, &y, &cfg).expect("a clear ringing is accepted");
                // tolerances: the error within 4 of the fit's own standard errors (white noise
                // here, so they are honest; 4 rather than 3 because 15 draws are checked and the
                // worst, gear 1 seed 5, is measured at 3.05), and those standard errors small enough for the
                // comparison: measured at 1 rpm noise, 0.01 Hz in gear 1 (slow decay, many
                // cycles) and 0.06–0.12 Hz in the fast-decaying top gears, against the 0.4–0.6 Hz
                // a 38 % shaft-stiffness change moves them
                assert!(
                    (fit.frequency_hz - f).abs() < 4.0 * fit.frequency_se_hz,
                    "f {f}: {fit:?}"
                );
                assert!(fit.frequency_se_hz < 0.15, "f {f}: {fit:?}");
                assert!(
                    (fit.decay_per_s - sigma).abs() < 4.0 * fit.decay_se_per_s,
                    "σ {sigma}: {fit:?}"
                );
                assert!((fit.amplitude - 1.0).abs() < 0.2, "{fit:?}");
                assert!(fit.r2 > cfg.min_r2, "{fit:?}");
            }
        }
    }

    #[test]
    fn frequency_error_is_within_a_few_standard_errors() {
        // 20 noise draws of the mid-gear window: the error over the standard error has an RMS
        // of order 1 (the residual is white here); bound 3 allows for the quantisation
        let cfg = ModalConfig::default();
        let mut z2 = 0.0;
        for seed in 1..=20 {
            let (t, y) = window(4.3, 5.0, 1.5, 100 + seed);
            let fit = fit_damped_sinusoid(&t, &y, &cfg).expect("accepted");
            z2 += ((fit.frequency_hz - 4.3) / fit.frequency_se_hz).powi(2);
        }
        let z_rms = (z2 / 20.0).sqrt();
        assert!(z_rms < 3.0, "z rms {z_rms}");
    }

    #[test]
    fn a_window_without_ringing_is_rejected() {
        let cfg = ModalConfig::default();
        for seed in 1..=10 {
            let (t, y) = window(4.3, 5.0, 0.0, 200 + seed);
            let r = fit_damped_sinusoid(&t, &y, &cfg);
            assert!(
                matches!(
                    r,
                    Err(ModalReject::NoOscillation(_) | ModalReject::TooSmall(_))
                ),
                "{r:?}"
            );
        }
    }

    #[test]
    fn a_ringing_below_the_amplitude_floor_is_rejected() {
        let cfg = ModalConfig::default();
        let (t, y) = window(4.3, 5.0, 0.15, 7);
        assert!(fit_damped_sinusoid(&t, &y, &cfg).is_err());
    }

    fn log_with(clutch: Vec<f64>, gear: Vec<f64>, w: Vec<f64>) -> DriveLog {
        let n = clutch.len();
        DriveLog::from_columns(
            20_000_000,
            vec![
                ("clutch_position", "1", clutch),
                ("gear", "1", gear),
                ("engine_speed", "rad/s", w),
                ("vehicle_speed", "m/s", vec![10.0; n]),
            ],
        )
    }

    /// 10 s at 50 Hz: clutch open until 3 s, then closed; gear 7; ringing engine speed.
    fn engagement_log() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = 500;
        let clutch: Vec<f64> = (0..n).map(|k| if k < 150 { 1.0 } else { 0.0 }).collect();
        let gear = vec![7.0; n];
        let w: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * 0.02;
                let tau = (t - 3.0).max(0.0);
                140.0 + (-5.0 * tau).exp() * (2.0 * std::f64::consts::PI * 4.3 * tau).sin()
            })
            .collect();
        (clutch, gear, w)
    }

    #[test]
    fn finds_a_closing_with_its_window() {
        let (c, g, w) = engagement_log();
        let log = log_with(c, g, w.clone());
        let cfg = ModalConfig::default();
        let e = engagements(&log, &cfg);
        assert_eq!(e.len(), 1, "{e:?}");
        assert!((e[0].t_close_s - 3.0).abs() < 1e-9);
        assert_eq!(e[0].gear, 7);
        // rows 3.2 s … 5.5 s at 50 Hz
        assert_eq!(e[0].rows, 160..276);
        assert_eq!(e[0].speed_mps, 10.0);
        let cmp = compare_modes(&log, &w, &w, None, Reference::Simulated, &cfg);
        let (m, s) = cmp.engagements[0]
            .pair(Reference::Simulated, cfg.max_mode_ratio)
            .expect("noise-free ringing accepted");
        assert!((m.frequency_hz - 4.3).abs() < 1e-3);
        assert_eq!(m.frequency_hz, s.frequency_hz);
        assert!(cmp.engagements[0]
            .pair(Reference::Linearised, cfg.max_mode_ratio)
            .is_none());
    }

    #[test]
    fn a_clutch_opening_inside_the_window_skips_the_engagement() {
        let (mut c, g, w) = engagement_log();
        // opens again 1.5 s after the closing, inside the 2.5 s window
        for x in &mut c[225..260] {
            *x = 0.4;
        }
        let log = log_with(c, g, w);
        let e = engagements(&log, &ModalConfig::default());
        // the re-closing at 5.2 s has its own window (5.4–7.7 s) and counts; the first does not
        assert_eq!(e.len(), 1, "{e:?}");
        assert!((e[0].t_close_s - 5.2).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn a_gear_change_or_an_engine_speed_gap_skips_the_engagement() {
        let (c, mut g, w) = engagement_log();
        for x in &mut g[200..] {
            *x = 8.0;
        }
        assert!(
            engagements(&log_with(c.clone(), g, w.clone()), &ModalConfig::default()).is_empty()
        );
        let (_, g, mut w2) = engagement_log();
        w2[200] = f64::NAN;
        assert!(engagements(&log_with(c, g, w2), &ModalConfig::default()).is_empty());
    }

    #[test]
    fn the_drive_test_flags_a_consistent_shift_and_not_noise() {
        let cfg = ModalConfig::default();
        let fit = |f: f64| ModalFit {
            frequency_hz: f,
            frequency_se_hz: 0.01,
            decay_per_s: 5.0,
            decay_se_per_s: 0.1,
            amplitude: 1.0,
            phase_rad: 0.0,
            r2: 0.9,
            residual_rms: 0.1,
        };
        let e = |gear: usize, fm: f64, fs: f64| EngagementModes {
            engagement: Engagement {
                t_close_s: 0.0,
                gear,
                rows: 0..1,
                speed_mps: 10.0,
                engine_torque_nm: 0.0,
            },
            measured: Ok(fit(fm)),
            simulated: Ok(fit(fs)),
            linearised: None,
        };
        // +10 % in every gear, ±0.05 Hz scatter: flagged
        let shifted = vec![
            e(7, 4.78, 4.32),
            e(7, 4.72, 4.32),
            e(8, 5.80, 5.25),
            e(8, 5.75, 5.25),
            e(1, 1.90, 1.71),
        ];
        let s = summarise(shifted, Reference::Simulated, &cfg);
        let t = s.test.expect("five pairs");
        assert!(t.flagged && t.mean_shift > 0.09, "{t:?}");
        assert_eq!(s.gears.len(), 3);
        assert!(s.gears[0].p_holm.is_nan(), "gear 1 has one engagement");
        // the flagged drive is a located engine-speed mismatch over its engagements
        let m = s
            .mismatch(&cfg, &[0.0], &[0.0], &[1.0], &[0.5])
            .expect("flagged");
        assert_eq!((m.signal.as_str(), m.windows), ("engine_speed", 5));
        assert_eq!(m.band_hz, [1.90, 5.80]);
        assert_eq!(m.significance, t.p_value);
        assert!((m.rms_residual - 0.5).abs() < 1e-12);
        assert!(m.condition.contains("gear 1, 7, 8"), "{}", m.condition);
        // ±0.05 Hz scatter around no shift: not flagged
        let clean = vec![
            e(7, 4.37, 4.32),
            e(7, 4.27, 4.32),
            e(8, 5.30, 5.25),
            e(8, 5.20, 5.25),
            e(1, 1.72, 1.71),
        ];
        // a slow drift fitted in gear 12 (0.95 Hz against an 8.3 Hz shuffle) is not the mode:
        // left out of the comparison, so it cannot swing the test
        let mut clean = clean;
        clean.push(e(12, 0.95, 8.30));
        assert!(clean[5]
            .pair(Reference::Simulated, cfg.max_mode_ratio)
            .is_none());
        let c = summarise(clean, Reference::Simulated, &cfg);
        assert!(!c.test.expect("five pairs").flagged);
        assert!(c.mismatch(&cfg, &[0.0], &[0.0], &[1.0], &[0.5]).is_none());
        // a significant but tiny shift (1 %) stays below the practical margin
        let tiny = vec![
            e(7, 4.363, 4.32),
            e(7, 4.364, 4.32),
            e(8, 5.302, 5.25),
            e(8, 5.303, 5.25),
        ];
        let t = summarise(tiny, Reference::Simulated, &cfg)
            .test
            .expect("four pairs");
        assert!(t.p_value < cfg.alpha && !t.flagged, "{t:?}");
    }

    /// The proof's vehicle (the diesel variant of the axle-load thesis 6×2): driveline parameters
    /// and gear ratios.
    pub(crate) fn vehicle() -> (DrivelineParams, Vec<f64>) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/vehicles/seed002-6x2-diesel.toml");
        let vf = crate::model::vehicle::VehicleFile::load(&path).expect("bundled vehicle");
        (vf.driveline.expect("has a driveline"), vf.gearbox.ratios)
    }

    #[test]
    fn the_locked_mode_follows_the_shaft_stiffness() {
        let (p, ratios) = vehicle();
        let mut stiff = p.clone();
        stiff.k_d_nm_per_rad *= 1.4;
        for gear in [1, 7, 12] {
            let a = locked_mode(&p, &ratios, gear, 10.0).expect("a shuffle mode");
            let b = locked_mode(&stiff, &ratios, gear, 10.0).expect("a shuffle mode");
            // in the shuffle band, and a stiffer shaft raises it by at most √1.4 (the shaft
            // is one of the mode's springs in series) and by more than 0.5 %: measured 1.15 in
            // gear 1, where the drive shaft dominates the mode, falling to 1.01 in gear 12,
            // where the engine-side shafts (seen through a small ratio) soften it as much
            assert!(a.frequency_hz > 0.8 && a.frequency_hz < 12.0, "{a:?}");
            let ratio = b.frequency_hz / a.frequency_hz;
            assert!(
                ratio > 1.005 && ratio <= 1.4f64.sqrt() + 1e-9,
                "gear {gear}: {ratio}"
            );
            assert!(a.decay_per_s > 0.0, "{a:?}");
        }
        assert!(locked_mode(&p, &ratios, 0, 10.0).is_none());
        assert!(locked_mode(&p, &ratios, ratios.len() + 1, 10.0).is_none());
    }

    #[test]
    fn the_stiffness_fit_inverts_the_linearised_modes() {
        let (p, ratios) = vehicle();
        let mut truth = p.clone();
        truth.k_d_nm_per_rad *= 0.7;
        let fit = |f: f64| ModalFit {
            frequency_hz: f,
            frequency_se_hz: 0.05,
            decay_per_s: 5.0,
            decay_se_per_s: 0.5,
            amplitude: 1.0,
            phase_rad: 0.0,
            r2: 0.9,
            residual_rms: 0.1,
        };
        // measured modes of a drive whose shaft is 30 % softer, each off by ±0.03 Hz
        let fits: Vec<EngagementModes> = [(1, 3.0), (7, 14.0), (8, 16.0), (9, 18.0), (12, 24.0)]
            .iter()
            .enumerate()
            .map(|(k, &(gear, v))| {
                let f = locked_mode(&truth, &ratios, gear, v).unwrap().frequency_hz;
                let jitter = if k % 2 == 0 { 0.03 } else { -0.03 };
                EngagementModes {
                    engagement: Engagement {
                        t_close_s: 0.0,
                        gear,
                        rows: 0..1,
                        speed_mps: v,
                        engine_torque_nm: 0.0,
                    },
                    measured: Ok(fit(f + jitter)),
                    simulated: Err(ModalReject::TooShort),
                    linearised: None,
                }
            })
            .collect();
        let k = fit_shaft_stiffness(&fits, &p, &ratios, &ModalConfig::default())
            .expect("five engagements");
        let t = truth.k_d_nm_per_rad;
        // a 0.03 Hz jitter on 1.5–8 Hz modes is < 2 % of ln f; with d ln f / d ln k ≈ 0.2–0.5
        // the fitted k_d lands within a few per cent, and the interval holds the truth
        assert!((k.k_d_nm_per_rad / t - 1.0).abs() < 0.05, "{k:?} vs {t}");
        assert!(
            k.ci95_nm_per_rad.0 < t && t < k.ci95_nm_per_rad.1,
            "{k:?} vs {t}"
        );
        assert_eq!(k.n, 5);
        // without jitter it is exact
        let exact: Vec<EngagementModes> = fits
            .into_iter()
            .map(|mut e| {
                let f = locked_mode(&truth, &ratios, e.engagement.gear, e.engagement.speed_mps)
                    .unwrap()
                    .frequency_hz;
                e.measured = Ok(fit(f));
                e
            })
            .collect();
        let k = fit_shaft_stiffness(&exact, &p, &ratios, &ModalConfig::default())
            .expect("five engagements");
        assert!((k.k_d_nm_per_rad / t - 1.0).abs() < 1e-4, "{k:?} vs {t}");
    }

    #[test]
    fn the_tolerance_shift_follows_the_square_root_law_and_adds_the_bands() {
        let (p, ratios) = vehicle();
        let zero = |keys: &[&str]| {
            let text: String = keys
                .iter()
                .map(|k| format!("{k} = {{ relative = 0.0 }}\n"))
                .collect();
            let t: toml::Table = toml::from_str(&text).unwrap();
            Tolerances::from_table(&t, |_| true).unwrap()
        };
        let all = [
            "k_c_nm_per_rad",
            "k_p_nm_per_rad",
            "k_d_nm_per_rad",
            "j_e_kg_m2",
            "j_c_kg_m2",
            "j_t_kg_m2",
            "j_p_kg_m2",
            "j_f_kg_m2",
            "j_d_kg_m2",
            "j_w_kg_m2",
            "mass_kg",
        ];
        // every band closed: no shift allowed
        assert_eq!(tolerance_shift(&p, &ratios, 1, 3.0, 0.0, &zero(&all)), 0.0);
        // only k_d's ±10 % open: at most the square-root law's 1 − √0.9 = 5.1 %, and most of
        // it, since the drive shafts are the main flexibility
        let only_kd: Vec<&str> = all
            .iter()
            .copied()
            .filter(|k| *k != "k_d_nm_per_rad")
            .collect();
        let s = tolerance_shift(&p, &ratios, 1, 3.0, 0.0, &zero(&only_kd));
        assert!(s > 0.03 && s <= 1.0 - 0.9_f64.sqrt() + 1e-12, "{s}");
        // the default bands add the others' shifts on top
        let d = tolerance_shift(&p, &ratios, 1, 3.0, 0.0, &Tolerances::default());
        assert!(d > s && d < 0.15, "{d} vs {s}");
    }

    /// The margin docs/diagnosis/method.md quotes for the bundled truck files (gears 1–4 at
    /// 1200 rpm, default tolerances): the shaft stiffness's ±10 % gives up to 5.1 % (square-root
    /// law), the inertias' ±5 % and the mass's ±3 % the rest. Printed with
    /// `cargo test --release --lib tolerance_margin_of_the_bundled -- --nocapture`.
    #[test]
    fn tolerance_margin_of_the_bundled_trucks() {
        use crate::model::resonance::{vehicle_speed_at, OPERATING_ENGINE_SPEED_RAD_S};
        for file in ["truck-40t.toml", "seed002-6x2-diesel.toml"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures/vehicles")
                .join(file);
            let vf = crate::model::vehicle::VehicleFile::load(&path).unwrap();
            let d = vf.driveline.as_ref().unwrap();
            let r = &vf.gearbox.ratios;
            let margin = (1..=4)
                .map(|g| {
                    let v0 = vehicle_speed_at(d, r, g, OPERATING_ENGINE_SPEED_RAD_S);
                    tolerance_shift(d, r, g, v0, 0.0, &vf.tolerance)
                })
                .fold(0.0, f64::max);
            eprintln!("{file}: modal tolerance margin {:.2} %", 100.0 * margin);
            assert!(margin > 0.06 && margin < 0.09, "{file}: {margin}");
        }
    }
}
