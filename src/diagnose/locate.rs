//! Step 2 of the diagnosis, locate (docs/diagnosis/method.md): where, at what frequencies and under
//! which operating conditions the residual `measured − simulated` of a [`Comparison`] stands above
//! its noise floor ([`super::noise`]).
//!
//! # In time and distance
//! The drive is cut into windows ([`WindowAxis`], default 10 s: ≥ 100 native samples of a
//! 10 Hz channel, short enough to localise a launch, a shift or ~150 m of road). Per window and
//! signal, `F = Σ r² / Σ σ²` over the rows that count, σ² the floor's per-row null variance
//! (the mean of the Monte-Carlo copies' squared null residuals in the same rows). Under "no
//! mismatch" `Σ r²` is a scaled χ²_ν and the copies' mean a scaled χ²_{Kν}/K, so
//! `F ~ F(ν, K·ν)`; ν is the window's effective degrees of freedom, the smaller of the one
//! from the null's autocorrelation (the longitudinal null is correlated over the model's 20 s
//! re-initialisation windows, so ν is small there) and the one the copies' own covariance in
//! the window gives ([`NoiseFloor::window_dof`]: the pooled autocorrelation is stationary, the
//! null is not), so the test claims no more evidence than the null shows. The
//! p-values of **every window of every signal** of the drive form one family, corrected by
//! Holm's step-down method at α = [`LocateConfig::alpha`] (0.01): the chance that a drive
//! without mismatch shows any significant window is at most α. A window is a mismatch when its
//! Holm-adjusted p ≤ α **and** its RMS residual exceeds [`LocateConfig::practical_ratio`]
//! (1.5) × its floor RMS: a residual within 1.5× the floor is not worth explaining, and the
//! rule keeps a floor underestimated by up to a third from turning into findings. Adjacent
//! mismatch windows of one signal merge into a stretch — also across one window with too few
//! counting rows to be tested (a shift, a stop or a CAN dropout leaves such windows) — one
//! [`Mismatch`] record of the output contract each; its `significance` is the smallest Holm-adjusted p-value of its windows
//! (smaller = more significant).
//!
//! # In frequency
//! - residual power by band ([`BandPower`]): quasi-static (below 0.5 Hz), the driveline
//!   shuffle band around the vehicle's resonances ([`shuffle_band_hz`]), the bands between, and
//!   the axle-hop band (8–15 Hz) where the signal's native rate resolves it; each against the
//!   floor's null power in the same band (F test with Welch degrees of freedom);
//! - input → residual magnitude-squared coherence ([`InputCoherence`], Welch with 10 s
//!   segments over the stretches where both exist), with the null threshold
//!   `1 − (α/m)^{1/(n_d−1)}` for `n_d` equivalent independent segments and `m` bins per band;
//! - input–residual cross-correlation ([`InputLag`]) of the first differences (differencing
//!   whitens the slowly varying drive signals so the peak is sharp) within ±2 s; the peak lag
//!   is where the residual *follows* the input (positive: the residual lags). Threshold:
//!   Bartlett's variance `Σ_j ρ_xx(j)ρ_rr(j) / N`, Bonferroni over the lags.
//!
//! # By operating condition
//! Cells gear × torque sign × speed band × grade band × braking × clutch actuated
//! ([`ConditionCell`]), each with rows, mean and RMS residual and an F test like the windows'
//! (Holm over the signal's cells). Plain statements ([`Statement`]) come from the data: the
//! residual is regressed on candidate shapes — constant, speed, speed², acceleration, grade,
//! engine torque, gear ratio — each in addition to a constant, and for the longitudinal
//! signals (whose residual integrates a force error from each re-initialisation,
//! [`LocateConfig::integrated_signals`]) on the shapes integrated from each window start. A
//! shape is stated when it adds at least [`LocateConfig::min_share`] (10 %) of the residual
//! energy to the constant's fit with an F-test p ≤ α / (number of shapes) on the effective
//! degrees of freedom; its reported share is what shape and constant explain together, and
//! statements are ranked by it. Indicator shapes (torque sign changes, clutch actuated,
//! braking, gear shifts) give "only …" statements when the residual is significant and
//! practically above the floor inside them, they cover at most half of the rows, and at least
//! 80 % of the excess energy `Σ(r² − σ²)` lies inside (or at least half of it, with the rows
//! outside within the practical ratio). Statements are only made for signals with a mismatch.
//!
//! All quantities SI (s, m, m/s, the signal's unit); grades as tan α (text in %); frequencies in
//! Hz. Deterministic. Bad input (lengths that differ, bad settings) is a [`LocateError`]; empty
//! or all-NaN residuals give empty results.

use super::compare::{Compared, Comparison, Conditions};
use super::noise::NoiseFloor;
use super::noise::{segment_mean_square, NoiseFloors};
use crate::model::driveline::DrivelineParams;
use crate::model::resonance::{resonance, Path};
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::signal::stats::runs;
use crate::signal::{csd_pieces, WelchConfig};
use crate::table::DriveLog;
use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, FisherSnedecor, Normal};
use std::collections::BTreeMap;
use thiserror::Error;

/// Why locating cannot run.
#[derive(Debug, Error)]
pub enum LocateError {
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
    /// Series of different lengths.
    #[error("{what}: {got} rows, expected {expected}")]
    Length {
        /// The series.
        what: String,
        /// Rows of the comparison.
        expected: usize,
        /// Rows given.
        got: usize,
    },
}

/// How the drive is cut into windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowAxis {
    /// Windows of `window_s` seconds from the first row.
    Time {
        /// Window length, s.
        window_s: f64,
    },
    /// Windows of `window_m` metres of travelled distance.
    Distance {
        /// Window length, m.
        window_m: f64,
    },
}

/// Settings of [`locate`] (every threshold is stated in the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocateConfig {
    /// Windows.
    pub window: WindowAxis,
    /// Family-wise error rate of the window tests (Holm), also the level of the other tests.
    pub alpha: f64,
    /// A mismatch needs its RMS residual above this multiple of the floor RMS.
    pub practical_ratio: f64,
    /// A window is tested when at least this share of its rows counts.
    pub min_valid_fraction: f64,
    /// Upper edge of the quasi-static band, Hz.
    pub quasi_static_hz: f64,
    /// Driveline shuffle band, Hz ([`shuffle_band_hz`]; `None`: not split out).
    pub shuffle_band_hz: Option<[f64; 2]>,
    /// Axle-hop band, Hz.
    pub hop_band_hz: [f64; 2],
    /// Cross-correlation lags searched, ± s.
    pub max_lag_s: f64,
    /// Width of the speed bands of the condition cells, m/s.
    pub speed_band_mps: f64,
    /// Edges of the grade bands, tan α, increasing.
    pub grade_edges: Vec<f64>,
    /// Engine torque within ± this is "zero" (neither drive nor engine brake), N·m.
    pub torque_zero_nm: f64,
    /// A condition cell is tested with at least this much data, s.
    pub min_cell_s: f64,
    /// Half-width of the event masks (torque sign changes, gear shifts), s.
    pub event_halfwidth_s: f64,
    /// Signals whose residual integrates a force error from each re-initialisation.
    pub integrated_signals: Vec<String>,
    /// Re-initialisation window of the integrated signals, s (the compare step's).
    pub reinit_window_s: f64,
    /// Re-initialisation times of the integrated signals, s, increasing (the compare step's
    /// [`super::extended::window_starts`]); empty: every `reinit_window_s`.
    pub reinit_times_s: Vec<f64>,
    /// Smallest share of the residual energy a stated shape explains.
    pub min_share: f64,
    /// Gear ratios (gear 1 first) for the gear-ratio shape; empty: no such shape.
    pub gear_ratios: Vec<f64>,
}

impl Default for LocateConfig {
    /// 10 s windows, α = 0.01, 1.5× the floor, half of a window's rows, 0.5 Hz quasi-static
    /// edge, no shuffle band, hop band 8–15 Hz, ±2 s lags, 5 m/s speed bands, grade bands at
    /// −4, −1, +1, +4 %, ±20 N·m zero torque (≈ 1 % of a heavy truck's reference torque, the
    /// sensor's step), 5 s per cell, ±1 s event masks, vehicle and engine speed integrated over
    /// the longitudinal model's 20 s windows, 10 % share, no gear ratios.
    fn default() -> Self {
        Self {
            window: WindowAxis::Time { window_s: 10.0 },
            alpha: 0.01,
            practical_ratio: 1.5,
            min_valid_fraction: 0.5,
            quasi_static_hz: 0.5,
            shuffle_band_hz: None,
            hop_band_hz: [8.0, 15.0],
            max_lag_s: 2.0,
            speed_band_mps: 5.0,
            grade_edges: vec![-0.04, -0.01, 0.01, 0.04],
            torque_zero_nm: 20.0,
            min_cell_s: 5.0,
            event_halfwidth_s: 1.0,
            integrated_signals: vec!["vehicle_speed".into(), "engine_speed".into()],
            reinit_window_s: 20.0,
            reinit_times_s: Vec::new(),
            min_share: 0.1,
            gear_ratios: Vec::new(),
        }
    }
}

impl LocateConfig {
    fn validate(&self) -> Result<(), LocateError> {
        let bad = |parameter, value: f64, requirement| {
            Err(LocateError::BadConfig {
                parameter,
                value,
                requirement,
            })
        };
        let w = match self.window {
            WindowAxis::Time { window_s } => window_s,
            WindowAxis::Distance { window_m } => window_m,
        };
        if !(w.is_finite() && w > 0.0) {
            return bad("window length", w, "finite and > 0");
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return bad("alpha", self.alpha, "in (0, 1)");
        }
        if !(self.practical_ratio.is_finite() && self.practical_ratio >= 1.0) {
            return bad("practical_ratio", self.practical_ratio, "finite and ≥ 1");
        }
        if !(self.min_valid_fraction > 0.0 && self.min_valid_fraction <= 1.0) {
            return bad("min_valid_fraction", self.min_valid_fraction, "in (0, 1]");
        }
        for (p, v) in [
            ("quasi_static_hz", self.quasi_static_hz),
            ("max_lag_s", self.max_lag_s),
            ("speed_band_mps", self.speed_band_mps),
            ("reinit_window_s", self.reinit_window_s),
            ("min_cell_s", self.min_cell_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(p, v, "finite and > 0");
            }
        }
        for (p, v) in [
            ("torque_zero_nm", self.torque_zero_nm),
            ("event_halfwidth_s", self.event_halfwidth_s),
            ("min_share", self.min_share),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(p, v, "finite and ≥ 0");
            }
        }
        let bands = [Some(self.hop_band_hz), self.shuffle_band_hz];
        for b in bands.into_iter().flatten() {
            if !(b[0].is_finite() && b[1].is_finite() && 0.0 <= b[0] && b[0] < b[1]) {
                return bad("band edge, Hz", b[0], "finite with 0 ≤ lo < hi");
            }
        }
        if self
            .grade_edges
            .windows(2)
            .any(|w| w[0].partial_cmp(&w[1]) != Some(std::cmp::Ordering::Less))
        {
            return bad("grade_edges", f64::NAN, "increasing");
        }
        Ok(())
    }
}

/// The driveline shuffle band of a vehicle: from 0.8× the lowest to 1.25× the highest engine-torque
/// → speed resonance over all gears ([`resonance`]; Myklebust & Eriksson (2012), §3); `None` when
/// no gear has a peak.
pub fn shuffle_band_hz(p: &DrivelineParams, ratios: &[f64]) -> Option<[f64; 2]> {
    let peaks: Vec<f64> = (1..=ratios.len())
        .filter_map(|g| resonance(p, ratios, g, Path::EngineTorqueOpen).peak_hz)
        .collect();
    let lo = peaks.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = peaks.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo.is_finite() && hi.is_finite()).then_some([0.8 * lo, 1.25 * hi])
}

/// A named input series on the comparison's rows (NaN where missing).
#[derive(Debug, Clone, PartialEq)]
pub struct NamedSeries {
    /// Name (canonical column).
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Values.
    pub values: Vec<f64>,
}

/// The recorded inputs of a log as named series (gaps filled as the schema's kind says):
/// engine torque, road slope, vehicle speed, brake force, retarder torque, clutch position,
/// those present.
pub fn inputs_from_log(log: &DriveLog) -> Vec<NamedSeries> {
    let cols = [
        ("engine_torque", Interpolation::Linear),
        ("road_slope", Interpolation::Hold),
        ("vehicle_speed", Interpolation::Linear),
        ("brake_force", Interpolation::Linear),
        ("retarder_torque", Interpolation::Linear),
        ("clutch_position", Interpolation::Linear),
    ];
    cols.iter()
        .filter_map(|(c, k)| {
            let s = log.signals.iter().find(|s| s.name == *c)?;
            Some(NamedSeries {
                name: s.name.clone(),
                unit: s.unit.clone(),
                values: fill_gaps(&s.values, *k)?,
            })
        })
        .collect()
}

/// The test of one window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowTest {
    /// Index of the window along its axis.
    pub index: i64,
    /// First row's time, s.
    pub start_s: f64,
    /// Last row's time, s.
    pub end_s: f64,
    /// Distance at the first row, m.
    pub start_m: f64,
    /// Distance at the last row, m.
    pub end_m: f64,
    /// Rows that count.
    pub rows: usize,
    /// RMS residual over those rows, unit.
    pub rms_residual: f64,
    /// Floor RMS over those rows, unit.
    pub floor_rms: f64,
    /// `rms_residual / floor_rms`.
    pub ratio: f64,
    /// Effective degrees of freedom ν.
    pub dof: f64,
    /// Unadjusted p-value of `F(ν, K·ν)`.
    pub p_value: f64,
    /// Holm-adjusted p-value (family: every window of every signal).
    pub p_holm: f64,
    /// Holm-adjusted p ≤ α and ratio ≥ the practical ratio.
    pub significant: bool,
}

/// A stretch of significant mismatch: one record of diagnosis.json's `mismatch` list.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mismatch {
    /// Compared signal.
    pub signal: String,
    /// Start, s from the first row.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// Start, m of travelled distance.
    pub start_m: f64,
    /// End, m.
    pub end_m: f64,
    /// The band with the largest residual-to-floor power ratio in the stretch, Hz.
    pub band_hz: [f64; 2],
    /// Operating condition of the stretch, in words.
    pub condition: String,
    /// RMS residual, unit of the signal.
    pub rms_residual: f64,
    /// Smallest Holm-adjusted p-value of its windows (smaller = more significant).
    pub significance: f64,
    /// Floor RMS in the stretch, unit.
    pub floor_rms: f64,
    /// Windows merged.
    pub windows: usize,
}

/// Residual power in one frequency band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandPower {
    /// `quasi_static`, `transition`, `shuffle`, `high`, `dynamic`, `axle_hop`.
    pub band: String,
    /// Lower edge, Hz.
    pub lo_hz: f64,
    /// Upper edge, Hz.
    pub hi_hz: f64,
    /// Whether the signal's native rate resolves the band (power reported only then).
    pub observable: bool,
    /// Residual power in the band, unit².
    pub residual_power: Option<f64>,
    /// Null (floor) power in the band, unit².
    pub null_power: Option<f64>,
    /// `residual_power / null_power`.
    pub ratio: Option<f64>,
    /// p-value of the ratio (F test, Welch degrees of freedom).
    pub p_value: Option<f64>,
}

/// Coherence of one input with the residual in one band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandCoherence {
    /// Band name (as [`BandPower::band`]).
    pub band: String,
    /// Lower edge, Hz.
    pub lo_hz: f64,
    /// Upper edge, Hz.
    pub hi_hz: f64,
    /// Mean magnitude-squared coherence over the band's bins.
    pub mean: f64,
    /// Largest coherence in the band.
    pub peak: f64,
    /// Its frequency, Hz.
    pub peak_hz: f64,
    /// Null threshold at α (Bonferroni over the band's bins).
    pub threshold: f64,
    /// `peak > threshold`.
    pub significant: bool,
}

/// Input → residual coherence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputCoherence {
    /// Input name.
    pub input: String,
    /// Welch segments averaged.
    pub segments: usize,
    /// Per band.
    pub bands: Vec<BandCoherence>,
}

/// Input–residual cross-correlation (first differences).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputLag {
    /// Input name.
    pub input: String,
    /// Lag of the largest |ρ|, s (positive: the residual follows the input).
    pub lag_s: f64,
    /// ρ at that lag.
    pub value: f64,
    /// ρ at lag 0.
    pub zero_lag_value: f64,
    /// Null threshold of |ρ| at α (Bonferroni over the lags).
    pub threshold: f64,
    /// `|value| > threshold`.
    pub significant: bool,
}

/// Sign of the engine torque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TorqueSign {
    /// Engine braking (below −zero band).
    Brake,
    /// Within ± the zero band.
    Zero,
    /// Driving.
    Drive,
    /// No torque recorded.
    Unknown,
}

/// One operating-condition cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConditionCell {
    /// Gear (`None`: not recorded).
    pub gear: Option<i64>,
    /// Torque sign.
    pub torque: TorqueSign,
    /// Speed band [lo, hi), m/s.
    pub speed_mps: [f64; 2],
    /// Grade band lower edge, tan α (`None`: open).
    pub grade_lo: Option<f64>,
    /// Grade band upper edge, tan α (`None`: open).
    pub grade_hi: Option<f64>,
    /// Service brake or retarder active.
    pub braking: bool,
    /// Clutch actuated.
    pub clutch_actuated: bool,
    /// The cell in words.
    pub label: String,
    /// Rows that count.
    pub rows: usize,
    /// Their duration, s.
    pub duration_s: f64,
    /// Mean residual, unit.
    pub mean_residual: f64,
    /// RMS residual, unit.
    pub rms_residual: f64,
    /// Floor RMS, unit.
    pub floor_rms: f64,
    /// `rms_residual / floor_rms`.
    pub ratio: f64,
    /// Effective degrees of freedom.
    pub dof: f64,
    /// Unadjusted p-value (`None`: too little data to test).
    pub p_value: Option<f64>,
    /// Holm-adjusted over the signal's tested cells.
    pub p_holm: Option<f64>,
    /// Holm-adjusted p ≤ α and ratio ≥ the practical ratio.
    pub significant: bool,
}

/// A plain statement about the residual, derived from the data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Statement {
    /// Shape id: `constant`, `speed`, `speed_squared`, `acceleration`, `grade`,
    /// `engine_torque`, `gear_ratio`, `torque_sign_change`, `clutch_actuated`, `braking`,
    /// `gear_shift`.
    pub shape: String,
    /// In words, e.g. "grows with speed² (explains 64 % of the residual energy)".
    pub text: String,
    /// Share of the residual energy the shape explains together with the constant it is
    /// fitted with (the shape alone must add at least [`LocateConfig::min_share`]); for
    /// indicators the share of the excess energy `Σ(r² − σ²)` inside the indicator.
    pub share: f64,
    /// Fitted coefficient: signal unit per shape unit (per shape unit·s for integrated
    /// signals); NaN for indicators.
    pub coefficient: f64,
    /// p-value of the shape's test.
    pub p_value: f64,
    /// The statement with the largest share.
    pub best: bool,
}

/// Everything located for one signal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignalLocation {
    /// Compared signal.
    pub signal: String,
    /// SI unit.
    pub unit: String,
    /// Rows that count.
    pub rows: usize,
    /// RMS residual over them, unit.
    pub rms_residual: f64,
    /// Floor RMS over them, unit.
    pub floor_rms: f64,
    /// Window tests.
    pub windows: Vec<WindowTest>,
    /// Band powers of the whole drive.
    pub bands: Vec<BandPower>,
    /// Input coherence.
    pub coherence: Vec<InputCoherence>,
    /// Input lags.
    pub lags: Vec<InputLag>,
    /// Condition cells.
    pub conditions: Vec<ConditionCell>,
    /// Statements (only for a signal with a mismatch), best first.
    pub statements: Vec<Statement>,
    /// Verdict input: at least one significant window.
    pub significant: bool,
}

/// The result of [`locate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Location {
    /// Mismatch stretches of every signal (diagnosis.json `mismatch`).
    pub mismatch: Vec<Mismatch>,
    /// Per signal.
    pub signals: Vec<SignalLocation>,
    /// Verdict input: any significant mismatch in the drive.
    pub any_significant: bool,
    /// α used.
    pub alpha: f64,
    /// Windows tested in the Holm family.
    pub family_size: usize,
}

impl Location {
    /// Per-signal verdict input: `{signal: significant}`.
    pub fn verdict(&self) -> BTreeMap<String, bool> {
        self.signals
            .iter()
            .map(|s| (s.signal.clone(), s.significant))
            .collect()
    }
}

/// Holm step-down adjusted p-values (same order as `p`).
pub fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut idx: Vec<usize> = (0..m).collect();
    idx.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut out = vec![1.0; m];
    let mut run = 0.0f64;
    for (rank, &i) in idx.iter().enumerate() {
        let adj = ((m - rank) as f64 * p[i]).min(1.0);
        run = run.max(adj);
        out[i] = run;
    }
    out
}

/// Upper tail of `F(d1, d2)` at `x` (1 for x ≤ 0 or degenerate degrees of freedom).
fn f_sf(x: f64, d1: f64, d2: f64) -> f64 {
    if !(x.is_finite() && x > 0.0 && d1 > 0.0 && d2 > 0.0) {
        return if x == f64::INFINITY { 0.0 } else { 1.0 };
    }
    FisherSnedecor::new(d1, d2).map_or(1.0, |f| f.sf(x).clamp(0.0, 1.0))
}

/// Standard normal quantile.
fn z_quantile(p: f64) -> f64 {
    Normal::new(0.0, 1.0).map_or(f64::NAN, |n| n.inverse_cdf(p))
}

/// Σ_t a(t)·b(t+k) for k = −max_lag..=max_lag, by FFT (index k + max_lag).
fn xcorr_sums(a: &[f64], b: &[f64], max_lag: usize) -> Vec<f64> {
    let n = a.len();
    if n == 0 {
        return vec![0.0; 2 * max_lag + 1];
    }
    let m = (2 * n).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(m);
    let inv = planner.plan_fft_inverse(m);
    let spec = |x: &[f64]| {
        let mut buf = fwd.make_input_vec();
        buf[..n].copy_from_slice(x);
        let mut s = fwd.make_output_vec();
        fwd.process(&mut buf, &mut s).expect("plan sizes");
        s
    };
    let (sa, sb) = (spec(a), spec(b));
    let mut prod: Vec<num_complex::Complex64> =
        sa.iter().zip(&sb).map(|(x, y)| x.conj() * y).collect();
    let mut out = inv.make_output_vec();
    inv.process(&mut prod, &mut out).expect("plan sizes");
    let l = max_lag as i64;
    (-l..=l)
        .map(|k| {
            if k.unsigned_abs() as usize >= n {
                0.0
            } else if k >= 0 {
                out[k as usize] / m as f64
            } else {
                out[(m as i64 + k) as usize] / m as f64
            }
        })
        .collect()
}

/// A frequency band of the analysis.
#[derive(Debug, Clone)]
struct Band {
    name: &'static str,
    lo: f64,
    hi: f64,
}

fn bands(cfg: &LocateConfig, nyquist: f64) -> Vec<Band> {
    let qs = cfg.quasi_static_hz;
    let [hop_lo, hop_hi] = cfg.hop_band_hz;
    let mut b = vec![Band {
        name: "quasi_static",
        lo: 0.0,
        hi: qs,
    }];
    match cfg.shuffle_band_hz {
        Some([lo, hi]) => {
            let lo = lo.max(qs);
            if lo > qs {
                b.push(Band {
                    name: "transition",
                    lo: qs,
                    hi: lo,
                });
            }
            if hi > lo {
                b.push(Band {
                    name: "shuffle",
                    lo,
                    hi,
                });
            }
            if hop_lo > hi {
                b.push(Band {
                    name: "high",
                    lo: hi,
                    hi: hop_lo,
                });
            }
        }
        None => {
            if hop_lo > qs {
                b.push(Band {
                    name: "dynamic",
                    lo: qs,
                    hi: hop_lo,
                });
            }
        }
    }
    b.push(Band {
        name: "axle_hop",
        lo: hop_lo,
        hi: hop_hi,
    });
    b.into_iter()
        .filter(|x| x.lo < nyquist)
        .map(|mut x| {
            x.hi = x.hi.min(nyquist);
            x
        })
        .collect()
}

/// Band power by summing PSD bins with `lo ≤ f < hi` (bin 0, the mean, left out), and bins.
fn band_power(freq: &[f64], psd: &[f64], lo: f64, hi: f64) -> (f64, usize) {
    let df = if freq.len() > 1 {
        freq[1] - freq[0]
    } else {
        0.0
    };
    let mut s = 0.0;
    let mut k = 0;
    for (f, p) in freq.iter().zip(psd).skip(1) {
        if *f >= lo && *f < hi {
            s += p * df;
            k += 1;
        }
    }
    (s, k)
}

/// A condition column: `None` when empty (not recorded), else checked for length.
fn opt_col<'a, T>(v: &'a [T], n: usize, what: &str) -> Result<Option<&'a [T]>, LocateError> {
    if v.is_empty() {
        Ok(None)
    } else if v.len() != n {
        Err(LocateError::Length {
            what: format!("conditions.{what}"),
            expected: n,
            got: v.len(),
        })
    } else {
        Ok(Some(v))
    }
}

/// Borrowed condition columns.
struct Cond<'a> {
    t: &'a [f64],
    d: &'a [f64],
    gear: Option<&'a [f64]>,
    torque: Option<&'a [f64]>,
    speed: Option<&'a [f64]>,
    slope: Option<&'a [f64]>,
    accel: Option<&'a [f64]>,
    braking: Option<&'a [bool]>,
    clutch: Option<&'a [bool]>,
    dt: f64,
}

impl<'a> Cond<'a> {
    fn new(c: &'a Conditions, n: usize) -> Result<Self, LocateError> {
        let need = |v: &'a [f64], what: &str| {
            if v.len() != n {
                Err(LocateError::Length {
                    what: format!("conditions.{what}"),
                    expected: n,
                    got: v.len(),
                })
            } else {
                Ok(v)
            }
        };
        let t = need(&c.t_s, "t_s")?;
        let d = need(&c.distance_m, "distance_m")?;
        let mut dts: Vec<f64> = t
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect();
        dts.sort_by(f64::total_cmp);
        let dt = dts.get(dts.len() / 2).copied().unwrap_or(f64::NAN);
        Ok(Self {
            t,
            d,
            gear: opt_col(&c.gear, n, "gear")?,
            torque: opt_col(&c.engine_torque_nm, n, "engine_torque_nm")?,
            speed: opt_col(&c.speed_mps, n, "speed_mps")?,
            slope: opt_col(&c.slope, n, "slope")?,
            accel: opt_col(&c.accel_mps2, n, "accel_mps2")?,
            braking: opt_col(&c.braking, n, "braking")?,
            clutch: opt_col(&c.clutch_actuated, n, "clutch_actuated")?,
            dt,
        })
    }

    fn torque_sign(&self, i: usize, zero: f64) -> TorqueSign {
        match self.torque.map(|m| m[i]) {
            Some(m) if m > zero => TorqueSign::Drive,
            Some(m) if m < -zero => TorqueSign::Brake,
            Some(m) if m.is_finite() => TorqueSign::Zero,
            _ => TorqueSign::Unknown,
        }
    }
}

/// The operating condition of `rows` in words.
fn describe(c: &Cond<'_>, rows: &[usize], cfg: &LocateConfig) -> String {
    let mut parts = Vec::new();
    if rows.is_empty() {
        return "no rows".into();
    }
    let share = |f: &dyn Fn(usize) -> bool| {
        rows.iter().filter(|&&i| f(i)).count() as f64 / rows.len() as f64
    };
    if let Some(g) = c.gear {
        let gs: Vec<i64> = rows
            .iter()
            .filter(|&&i| g[i].is_finite())
            .map(|&i| g[i].round() as i64)
            .collect();
        if let (Some(lo), Some(hi)) = (gs.iter().min(), gs.iter().max()) {
            parts.push(if lo == hi {
                format!("gear {lo}")
            } else {
                format!("gears {lo}–{hi}")
            });
        }
    }
    if c.torque.is_some() {
        let drive = share(&|i| c.torque_sign(i, cfg.torque_zero_nm) == TorqueSign::Drive);
        let brake = share(&|i| c.torque_sign(i, cfg.torque_zero_nm) == TorqueSign::Brake);
        parts.push(if drive >= 0.8 {
            "drive torque".to_string()
        } else if brake >= 0.8 {
            "engine braking".to_string()
        } else {
            format!(
                "mixed torque ({:.0} % drive, {:.0} % engine braking)",
                100.0 * drive,
                100.0 * brake
            )
        });
    }
    let range = |v: &[f64]| {
        let xs: Vec<f64> = rows
            .iter()
            .map(|&i| v[i])
            .filter(|x| x.is_finite())
            .collect();
        let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo.is_finite()).then_some((lo, hi))
    };
    if let Some((lo, hi)) = c.speed.and_then(range) {
        parts.push(format!("speed {lo:.1}–{hi:.1} m/s"));
    }
    if let Some((lo, hi)) = c.slope.and_then(range) {
        parts.push(format!("grade {:+.1}…{:+.1} %", 100.0 * lo, 100.0 * hi));
    }
    if let Some(b) = c.braking {
        let s = share(&|i| b[i]);
        parts.push(if s == 0.0 {
            "not braking".into()
        } else {
            format!("braking {:.0} % of the time", 100.0 * s)
        });
    }
    if let Some(cl) = c.clutch {
        let s = share(&|i| cl[i]);
        if s > 0.0 {
            parts.push(format!("clutch actuated {:.0} % of the time", 100.0 * s));
        }
    }
    parts.join(", ")
}

/// Rows within ±`hw` rows of an event that `at(i)` marks between rows i−1 and i.
fn event_mask(n: usize, hw: usize, events: &[(usize, usize)]) -> Vec<bool> {
    let mut m = vec![false; n];
    for &(a, b) in events {
        let lo = a.saturating_sub(hw);
        let hi = (b + hw + 1).min(n);
        for x in &mut m[lo..hi] {
            *x = true;
        }
    }
    m
}

/// Everything about one signal that needs no cross-signal information.
struct Pending {
    loc: SignalLocation,
    usable: Vec<bool>,
    residual: Vec<f64>,
    window_rows: Vec<Vec<usize>>,
}

/// Locates the mismatch of `cmp` against `floors` (see the module documentation). `inputs`
/// are named input series on the comparison's rows for coherence and lags. A signal without a
/// floor in `floors` is skipped.
///
/// # Errors
/// [`LocateError::BadConfig`] for bad settings; [`LocateError::Length`] when a signal, a
/// condition column or an input does not have the comparison's rows.
pub fn locate(
    cmp: &Comparison,
    floors: &NoiseFloors,
    inputs: &[NamedSeries],
    cfg: &LocateConfig,
) -> Result<Location, LocateError> {
    cfg.validate()?;
    let n = cmp.conditions.t_s.len();
    let cond = Cond::new(&cmp.conditions, n)?;
    for s in &cmp.signals {
        for (what, len) in [
            ("measured", s.measured.len()),
            ("simulated", s.simulated.len()),
            ("valid", s.valid.len()),
        ] {
            if len != n {
                return Err(LocateError::Length {
                    what: format!("{}.{what}", s.name),
                    expected: n,
                    got: len,
                });
            }
        }
    }
    for x in inputs {
        if x.values.len() != n {
            return Err(LocateError::Length {
                what: format!("input {}", x.name),
                expected: n,
                got: x.values.len(),
            });
        }
    }
    let mut pending: Vec<Pending> = Vec::new();
    for s in &cmp.signals {
        let Some(floor) = floors.get(&s.name) else {
            continue;
        };
        if floor.null_variance.len() != n {
            return Err(LocateError::Length {
                what: format!("noise floor of {}", s.name),
                expected: n,
                got: floor.null_variance.len(),
            });
        }
        pending.push(windows_of(s, floor, &cond, cfg));
    }
    // Holm over every tested window of every signal
    let mut family: Vec<(usize, usize, f64)> = Vec::new();
    for (si, p) in pending.iter().enumerate() {
        for (wi, w) in p.loc.windows.iter().enumerate() {
            family.push((si, wi, w.p_value));
        }
    }
    let adj = holm(&family.iter().map(|f| f.2).collect::<Vec<_>>());
    for ((si, wi, _), a) in family.iter().zip(&adj) {
        let w = &mut pending[*si].loc.windows[*wi];
        w.p_holm = *a;
        w.significant = *a <= cfg.alpha && w.ratio >= cfg.practical_ratio;
    }
    let mut mismatch = Vec::new();
    let mut signals = Vec::new();
    for (p, s) in pending
        .into_iter()
        .zip(cmp.signals.iter().filter(|s| floors.get(&s.name).is_some()))
    {
        let floor = floors.get(&s.name).expect("filtered");
        let Pending {
            mut loc,
            usable,
            residual,
            window_rows,
        } = p;
        loc.significant = loc.windows.iter().any(|w| w.significant);
        // stretches
        let mut k = 0;
        while k < loc.windows.len() {
            if !loc.windows[k].significant {
                k += 1;
                continue;
            }
            let mut e = k;
            while e + 1 < loc.windows.len()
                && loc.windows[e + 1].significant
                && loc.windows[e + 1].index <= loc.windows[e].index + 2
            {
                e += 1;
            }
            let rows: Vec<usize> = window_rows[k..=e].iter().flatten().copied().collect();
            mismatch.push(stretch(
                &s.name,
                &loc.windows[k..=e],
                &rows,
                &residual,
                floor,
                &cond,
                cfg,
            ));
            k = e + 1;
        }
        loc.bands = band_powers(&residual, &usable, floor, cfg, cond.dt);
        loc.coherence = inputs
            .iter()
            .filter_map(|x| coherence(x, &residual, &usable, floor, cfg, cond.dt))
            .collect();
        loc.lags = inputs
            .iter()
            .filter_map(|x| lag(x, &residual, &usable, cfg, cond.dt))
            .collect();
        loc.conditions = cells(&residual, &usable, floor, &cond, cfg);
        if loc.significant {
            loc.statements = statements(&s.name, &residual, &usable, floor, &cond, cfg);
        }
        signals.push(loc);
    }
    let any_significant = signals.iter().any(|s| s.significant);
    Ok(Location {
        mismatch,
        signals,
        any_significant,
        alpha: cfg.alpha,
        family_size: family.len(),
    })
}

fn windows_of(s: &Compared, floor: &NoiseFloor, c: &Cond<'_>, cfg: &LocateConfig) -> Pending {
    let n = s.valid.len();
    let residual = s.residual();
    let usable: Vec<bool> = (0..n)
        .map(|i| {
            residual[i].is_finite()
                && floor.null_variance[i].is_finite()
                && floor.null_variance[i] > 0.0
                && c.t[i].is_finite()
        })
        .collect();
    let (mut q, mut e, mut cnt) = (0.0, 0.0, 0usize);
    for i in 0..n {
        if usable[i] {
            q += residual[i] * residual[i];
            e += floor.null_variance[i];
            cnt += 1;
        }
    }
    // window index of every row
    let key = |i: usize| -> Option<i64> {
        let (x, w) = match cfg.window {
            WindowAxis::Time { window_s } => (c.t[i], window_s),
            WindowAxis::Distance { window_m } => (c.d[i], window_m),
        };
        x.is_finite().then(|| (x / w).floor() as i64)
    };
    let mut groups: BTreeMap<i64, (Vec<usize>, usize)> = BTreeMap::new();
    for (i, &u) in usable.iter().enumerate() {
        if let Some(k) = key(i) {
            let g = groups.entry(k).or_default();
            g.1 += 1;
            if u {
                g.0.push(i);
            }
        }
    }
    let k_copies = floor.copies as f64;
    let mut windows = Vec::new();
    let mut window_rows = Vec::new();
    for (idx, (rows, total)) in groups {
        if rows.is_empty() || (rows.len() as f64) < cfg.min_valid_fraction * total as f64 {
            continue;
        }
        let qw: f64 = rows.iter().map(|&i| residual[i] * residual[i]).sum();
        let ew: f64 = rows.iter().map(|&i| floor.null_variance[i]).sum();
        let nu = floor.window_dof(&rows);
        let f = qw / ew;
        let (a, b) = (rows[0], rows[rows.len() - 1]);
        windows.push(WindowTest {
            index: idx,
            start_s: c.t[a],
            end_s: c.t[b],
            start_m: c.d[a],
            end_m: c.d[b],
            rows: rows.len(),
            rms_residual: (qw / rows.len() as f64).sqrt(),
            floor_rms: (ew / rows.len() as f64).sqrt(),
            ratio: f.sqrt(),
            dof: nu,
            p_value: f_sf(f, nu, k_copies * nu),
            p_holm: 1.0,
            significant: false,
        });
        window_rows.push(rows);
    }
    Pending {
        loc: SignalLocation {
            signal: s.name.clone(),
            unit: s.unit.clone(),
            rows: cnt,
            rms_residual: if cnt > 0 {
                (q / cnt as f64).sqrt()
            } else {
                f64::NAN
            },
            floor_rms: if cnt > 0 {
                (e / cnt as f64).sqrt()
            } else {
                f64::NAN
            },
            windows,
            bands: Vec::new(),
            coherence: Vec::new(),
            lags: Vec::new(),
            conditions: Vec::new(),
            statements: Vec::new(),
            significant: false,
        },
        usable,
        residual,
        window_rows,
    }
}

/// Native Nyquist frequency of a floor's signal (grid Nyquist when unknown), Hz.
fn native_nyquist(floor: &NoiseFloor, dt: f64) -> f64 {
    let grid = 0.5 / dt;
    floor
        .sensor
        .as_ref()
        .map_or(grid, |s| (0.5 * s.native_rate_hz).min(grid))
}

/// Welch PSD of `x` over its `usable` runs with `nperseg`-row segments: (freq, psd, dof, power
/// of the segment means).
fn psd_over(
    x: &[f64],
    usable: &[bool],
    nperseg: usize,
    dt: f64,
) -> Option<(Vec<f64>, Vec<f64>, f64, f64)> {
    let pieces: Vec<(&[f64], &[f64])> = runs(usable)
        .into_iter()
        .map(|(a, b)| (&x[a..b], &x[a..b]))
        .collect();
    let c = csd_pieces(
        &pieces,
        &WelchConfig {
            fs_hz: 1.0 / dt,
            nperseg: Some(nperseg),
            noverlap: None,
            confidence: 0.95,
        },
    )
    .ok()?;
    let dc = segment_mean_square(&pieces.iter().map(|p| p.0).collect::<Vec<_>>(), nperseg);
    Some((c.freq_hz, c.pxx, c.dof, dc))
}

fn band_powers(
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    cfg: &LocateConfig,
    dt: f64,
) -> Vec<BandPower> {
    if !(dt.is_finite() && dt > 0.0) {
        return Vec::new();
    }
    let Some(null) = &floor.null_psd else {
        return Vec::new();
    };
    let res = psd_over(r, usable, null.nperseg, dt);
    let nyq = native_nyquist(floor, dt);
    bands(cfg, 0.5 / dt)
        .into_iter()
        .map(|b| {
            let observable = b.lo < nyq;
            let hi = b.hi.min(nyq);
            let mut out = BandPower {
                band: b.name.into(),
                lo_hz: b.lo,
                hi_hz: b.hi,
                observable,
                residual_power: None,
                null_power: None,
                ratio: None,
                p_value: None,
            };
            if let (true, Some((f, p, dof, dc))) = (observable, &res) {
                // the lowest band also holds what is slower than a segment (a constant offset)
                let (dc_r, dc_n) = if b.lo == 0.0 {
                    (*dc, null.dc_power)
                } else {
                    (0.0, 0.0)
                };
                let (pr, k) = band_power(f, p, b.lo, hi);
                let (pn, _) = band_power(&null.freq_hz, &null.psd, b.lo, hi);
                let (pr, pn) = (pr + dc_r, pn + dc_n);
                if k > 0 {
                    out.residual_power = Some(pr);
                    out.null_power = Some(pn);
                    if pn > 0.0 {
                        let ratio = pr / pn;
                        // Hann-windowed neighbouring bins overlap: ~1.5 bins per independent one
                        let kb = (k as f64 / 1.5).max(1.0);
                        out.ratio = Some(ratio);
                        out.p_value = Some(f_sf(ratio, dof * kb, null.dof * kb));
                    }
                }
            }
            out
        })
        .collect()
}

fn coherence(
    x: &NamedSeries,
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    cfg: &LocateConfig,
    dt: f64,
) -> Option<InputCoherence> {
    if !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    let ok: Vec<bool> = (0..r.len())
        .map(|i| usable[i] && x.values[i].is_finite())
        .collect();
    let nperseg = floor
        .null_psd
        .as_ref()
        .map_or(((10.0 / dt).round() as usize).max(8), |p| p.nperseg);
    let pieces: Vec<(&[f64], &[f64])> = runs(&ok)
        .into_iter()
        .map(|(a, b)| (&x.values[a..b], &r[a..b]))
        .collect();
    let c = csd_pieces(
        &pieces,
        &WelchConfig {
            fs_hz: 1.0 / dt,
            nperseg: Some(nperseg),
            noverlap: None,
            confidence: 0.95,
        },
    )
    .ok()?;
    let coh = c.coherence();
    let nd = 0.5 * c.dof;
    let nyq = native_nyquist(floor, dt);
    let bands = bands(cfg, 0.5 / dt)
        .into_iter()
        .filter(|b| b.lo < nyq)
        .filter_map(|b| {
            let hi = b.hi.min(nyq);
            let bins: Vec<usize> = (1..coh.len())
                .filter(|&k| c.freq_hz[k] >= b.lo && c.freq_hz[k] < hi)
                .collect();
            if bins.is_empty() {
                return None;
            }
            let mean = bins.iter().map(|&k| coh[k]).sum::<f64>() / bins.len() as f64;
            let &kp = bins.iter().max_by(|&&a, &&b| coh[a].total_cmp(&coh[b]))?;
            let threshold = if nd > 1.0 {
                1.0 - (cfg.alpha / bins.len() as f64).powf(1.0 / (nd - 1.0))
            } else {
                1.0
            };
            Some(BandCoherence {
                band: b.name.into(),
                lo_hz: b.lo,
                hi_hz: hi,
                mean,
                peak: coh[kp],
                peak_hz: c.freq_hz[kp],
                threshold,
                significant: coh[kp] > threshold,
            })
        })
        .collect();
    Some(InputCoherence {
        input: x.name.clone(),
        segments: c.n_segments,
        bands,
    })
}

fn lag(
    x: &NamedSeries,
    r: &[f64],
    usable: &[bool],
    cfg: &LocateConfig,
    dt: f64,
) -> Option<InputLag> {
    if !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    let n = r.len();
    let ok: Vec<bool> = (0..n)
        .map(|i| {
            i > 0
                && usable[i]
                && usable[i - 1]
                && x.values[i].is_finite()
                && x.values[i - 1].is_finite()
        })
        .collect();
    let cnt = ok.iter().filter(|o| **o).count();
    let l = ((cfg.max_lag_s / dt).round() as usize).min(n / 4);
    if cnt < 4 * l.max(1) {
        return None;
    }
    let mut dx: Vec<f64> = (0..n)
        .map(|i| {
            if ok[i] {
                x.values[i] - x.values[i - 1]
            } else {
                0.0
            }
        })
        .collect();
    let mut dr: Vec<f64> = (0..n)
        .map(|i| if ok[i] { r[i] - r[i - 1] } else { 0.0 })
        .collect();
    for v in [&mut dx, &mut dr] {
        let m = v
            .iter()
            .zip(&ok)
            .filter(|(_, o)| **o)
            .map(|(x, _)| x)
            .sum::<f64>()
            / cnt as f64;
        for (x, o) in v.iter_mut().zip(&ok) {
            if *o {
                *x -= m;
            }
        }
    }
    let ex: f64 = dx.iter().map(|v| v * v).sum();
    let er: f64 = dr.iter().map(|v| v * v).sum();
    if !(ex > 0.0 && er > 0.0) {
        return None;
    }
    let norm = (ex * er).sqrt();
    let xc: Vec<f64> = xcorr_sums(&dx, &dr, l).iter().map(|v| v / norm).collect();
    let axx = xcorr_sums(&dx, &dx, l);
    let arr = xcorr_sums(&dr, &dr, l);
    // Bartlett: Var ρ̂_xr(k) ≈ Σ_j ρ_xx(j)·ρ_rr(j) / N for independent series
    let bartlett: f64 = axx
        .iter()
        .zip(&arr)
        .map(|(a, b)| (a / ex) * (b / er))
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let sd = (bartlett / cnt as f64).sqrt();
    let z = z_quantile(1.0 - cfg.alpha / (2.0 * (2 * l + 1) as f64));
    let threshold = z * sd;
    let (kp, &vp) = xc
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    Some(InputLag {
        input: x.name.clone(),
        lag_s: (kp as f64 - l as f64) * dt,
        value: vp,
        zero_lag_value: xc[l],
        threshold,
        significant: vp.abs() > threshold,
    })
}

/// Speed band index and edges.
fn speed_band(v: f64, w: f64) -> (i64, [f64; 2]) {
    let k = (v.max(0.0) / w).floor() as i64;
    (k, [k as f64 * w, (k + 1) as f64 * w])
}

fn cells(
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    c: &Cond<'_>,
    cfg: &LocateConfig,
) -> Vec<ConditionCell> {
    type Key = (Option<i64>, TorqueSign, i64, usize, bool, bool);
    let mut groups: BTreeMap<Key, Vec<usize>> = BTreeMap::new();
    let edges = &cfg.grade_edges;
    for i in 0..r.len() {
        if !usable[i] {
            continue;
        }
        let gear = c
            .gear
            .and_then(|g| g[i].is_finite().then(|| g[i].round() as i64));
        let sp = c.speed.map_or(-1, |v| {
            if v[i].is_finite() {
                speed_band(v[i], cfg.speed_band_mps).0
            } else {
                -1
            }
        });
        let gr = c.slope.map_or(usize::MAX, |s| {
            if s[i].is_finite() {
                edges.partition_point(|e| *e <= s[i])
            } else {
                usize::MAX
            }
        });
        let key = (
            gear,
            c.torque_sign(i, cfg.torque_zero_nm),
            sp,
            gr,
            c.braking.is_some_and(|b| b[i]),
            c.clutch.is_some_and(|b| b[i]),
        );
        groups.entry(key).or_default().push(i);
    }
    let k_copies = floor.copies as f64;
    let dt = if c.dt.is_finite() { c.dt } else { 0.0 };
    let mut out: Vec<ConditionCell> = groups
        .into_iter()
        .map(|((gear, torque, sp, gr, braking, clutch), rows)| {
            let m = rows.len() as f64;
            let q: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
            let e: f64 = rows.iter().map(|&i| floor.null_variance[i]).sum();
            let mean = rows.iter().map(|&i| r[i]).sum::<f64>() / m;
            let duration = m * dt;
            let nu = floor.effective_dof(&rows);
            let speed = if sp >= 0 {
                [
                    sp as f64 * cfg.speed_band_mps,
                    (sp + 1) as f64 * cfg.speed_band_mps,
                ]
            } else {
                [f64::NAN, f64::NAN]
            };
            let (glo, ghi) = if gr == usize::MAX {
                (None, None)
            } else {
                (gr.checked_sub(1).map(|k| edges[k]), edges.get(gr).copied())
            };
            let tested = duration >= cfg.min_cell_s && e > 0.0;
            let mut label = Vec::new();
            label.push(gear.map_or("gear unknown".into(), |g| format!("gear {g}")));
            label.push(
                match torque {
                    TorqueSign::Drive => "drive torque",
                    TorqueSign::Brake => "engine braking",
                    TorqueSign::Zero => "zero torque",
                    TorqueSign::Unknown => "torque unknown",
                }
                .into(),
            );
            if sp >= 0 {
                label.push(format!("{:.0}–{:.0} m/s", speed[0], speed[1]));
            }
            if gr != usize::MAX {
                label.push(match (glo, ghi) {
                    (None, Some(h)) => format!("grade < {:+.0} %", 100.0 * h),
                    (Some(l), None) => format!("grade ≥ {:+.0} %", 100.0 * l),
                    (Some(l), Some(h)) => format!("grade {:+.0}…{:+.0} %", 100.0 * l, 100.0 * h),
                    (None, None) => "grade any".into(),
                });
            }
            label.push(if braking { "braking" } else { "not braking" }.into());
            if clutch {
                label.push("clutch actuated".into());
            }
            ConditionCell {
                gear,
                torque,
                speed_mps: speed,
                grade_lo: glo,
                grade_hi: ghi,
                braking,
                clutch_actuated: clutch,
                label: label.join(", "),
                rows: rows.len(),
                duration_s: duration,
                mean_residual: mean,
                rms_residual: (q / m).sqrt(),
                floor_rms: (e / m).sqrt(),
                ratio: if e > 0.0 { (q / e).sqrt() } else { f64::NAN },
                dof: nu,
                p_value: tested.then(|| f_sf(q / e, nu, k_copies * nu)),
                p_holm: None,
                significant: false,
            }
        })
        .collect();
    let tested: Vec<usize> = (0..out.len())
        .filter(|&k| out[k].p_value.is_some())
        .collect();
    let adj = holm(
        &tested
            .iter()
            .map(|&k| out[k].p_value.unwrap_or(1.0))
            .collect::<Vec<_>>(),
    );
    for (&k, a) in tested.iter().zip(adj) {
        out[k].p_holm = Some(a);
        out[k].significant = a <= cfg.alpha && out[k].ratio >= cfg.practical_ratio;
    }
    out
}

/// One mismatch stretch.
fn stretch(
    signal: &str,
    w: &[WindowTest],
    rows: &[usize],
    r: &[f64],
    floor: &NoiseFloor,
    c: &Cond<'_>,
    cfg: &LocateConfig,
) -> Mismatch {
    let m = rows.len().max(1) as f64;
    let q: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    let e: f64 = rows.iter().map(|&i| floor.null_variance[i]).sum();
    let first = w.first().expect("a stretch has windows");
    let last = w.last().expect("a stretch has windows");
    let dt = c.dt;
    let nyq = if dt.is_finite() && dt > 0.0 {
        native_nyquist(floor, dt)
    } else {
        f64::NAN
    };
    let mut band_hz = [0.0, nyq];
    if let (Some(null), true) = (&floor.null_psd, dt.is_finite() && dt > 0.0) {
        let mut ok = vec![false; r.len()];
        for &i in rows {
            ok[i] = true;
        }
        let longest = runs(&ok).iter().map(|(a, b)| b - a).max().unwrap_or(0);
        let nperseg = null.nperseg.min(longest);
        let global_var = floor.floor * floor.floor;
        if nperseg >= 8 && global_var > 0.0 {
            if let Some((f, p, _, dc)) = psd_over(r, &ok, nperseg, dt) {
                let scale = (e / m) / global_var;
                let best = bands(cfg, 0.5 / dt)
                    .into_iter()
                    .filter(|b| b.lo < nyq)
                    .filter_map(|b| {
                        let hi = b.hi.min(nyq);
                        let (mut pr, k) = band_power(&f, &p, b.lo, hi);
                        let (mut pn, _) = band_power(&null.freq_hz, &null.psd, b.lo, hi);
                        if b.lo == 0.0 {
                            pr += dc;
                            pn += null.dc_power;
                        }
                        (k > 0 && pn > 0.0).then(|| (pr / (pn * scale), [b.lo, hi]))
                    })
                    .max_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((_, b)) = best {
                    band_hz = b;
                }
            }
        }
    }
    Mismatch {
        signal: signal.into(),
        start_s: first.start_s,
        end_s: last.end_s,
        start_m: first.start_m,
        end_m: last.end_m,
        band_hz,
        condition: describe(c, rows, cfg),
        rms_residual: (q / m).sqrt(),
        significance: w.iter().map(|x| x.p_holm).fold(1.0, f64::min),
        floor_rms: (e / m).sqrt(),
        windows: w.len(),
    }
}

/// A candidate shape of the residual: id, words, values per row.
struct Shape {
    id: &'static str,
    text: &'static str,
    values: Vec<f64>,
}

fn statements(
    signal: &str,
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    c: &Cond<'_>,
    cfg: &LocateConfig,
) -> Vec<Statement> {
    let n = r.len();
    let dt = c.dt;
    if !(dt.is_finite() && dt > 0.0) {
        return Vec::new();
    }
    let integrated = cfg.integrated_signals.iter().any(|s| s == signal);
    // continuous shapes
    let mut shapes: Vec<Shape> = Vec::new();
    if let Some(v) = c.speed {
        shapes.push(Shape {
            id: "speed",
            text: "grows with speed",
            values: v.to_vec(),
        });
        shapes.push(Shape {
            id: "speed_squared",
            text: "grows with speed²",
            values: v.iter().map(|x| x * x).collect(),
        });
    }
    if let Some(a) = c.accel {
        shapes.push(Shape {
            id: "acceleration",
            text: "proportional to acceleration",
            values: a.to_vec(),
        });
    }
    if let Some(s) = c.slope {
        shapes.push(Shape {
            id: "grade",
            text: "proportional to grade",
            values: s.to_vec(),
        });
    }
    if let Some(m) = c.torque {
        shapes.push(Shape {
            id: "engine_torque",
            text: "proportional to engine torque",
            values: m.to_vec(),
        });
    }
    if let (Some(g), false) = (c.gear, cfg.gear_ratios.is_empty()) {
        shapes.push(Shape {
            id: "gear_ratio",
            text: "proportional to the gear ratio",
            values: g
                .iter()
                .map(|&x| {
                    let k = x.round();
                    if k >= 1.0 && (k as usize) <= cfg.gear_ratios.len() {
                        cfg.gear_ratios[k as usize - 1]
                    } else {
                        0.0
                    }
                })
                .collect(),
        });
    }
    let integrate = |v: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; n];
        let mut acc = 0.0;
        let mut win = i64::MIN;
        for i in 0..n {
            let w = if !c.t[i].is_finite() {
                win
            } else if cfg.reinit_times_s.is_empty() {
                (c.t[i] / cfg.reinit_window_s).floor() as i64
            } else {
                cfg.reinit_times_s.partition_point(|&x| x <= c.t[i]) as i64
            };
            if w != win {
                acc = 0.0;
                win = w;
            } else if v[i].is_finite() && v[i - 1].is_finite() {
                acc += 0.5 * (v[i] + v[i - 1]) * (c.t[i] - c.t[i - 1]);
            }
            out[i] = acc;
        }
        out
    };
    let base: Vec<f64> = if integrated {
        integrate(&vec![1.0; n])
    } else {
        vec![1.0; n]
    };
    if integrated {
        for s in shapes.iter_mut() {
            s.values = integrate(&s.values);
        }
    }
    let rows: Vec<usize> = (0..n)
        .filter(|&i| usable[i] && base[i].is_finite())
        .collect();
    if rows.len() < 10 {
        return Vec::new();
    }
    let n_eff = floor.effective_dof(&rows).max(3.0);
    let sr2: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    if sr2 <= 0.0 {
        return Vec::new();
    }
    let n_masks = 4usize;
    let alpha_s = cfg.alpha / (shapes.len() + 1 + n_masks) as f64;
    let mut out = Vec::new();
    // the base (constant) alone
    let (sbb, sbr) = rows.iter().fold((0.0, 0.0), |(a, b), &i| {
        (a + base[i] * base[i], b + base[i] * r[i])
    });
    let ssr_base = if sbb > 0.0 {
        sr2 - sbr * sbr / sbb
    } else {
        sr2
    };
    let share_c = (sr2 - ssr_base) / sr2;
    let f_c = (sr2 - ssr_base) / (ssr_base / (n_eff - 1.0)).max(f64::MIN_POSITIVE);
    let p_c = f_sf(f_c, 1.0, n_eff - 1.0);
    if share_c >= cfg.min_share && p_c <= alpha_s {
        out.push(Statement {
            shape: "constant".into(),
            text: "constant offset".into(),
            share: share_c,
            coefficient: if sbb > 0.0 { sbr / sbb } else { f64::NAN },
            p_value: p_c,
            best: false,
        });
    }
    for s in &shapes {
        let x = &s.values;
        let rs: Vec<usize> = rows.iter().copied().filter(|&i| x[i].is_finite()).collect();
        if rs.len() < 10 {
            continue;
        }
        // OLS on [base, x]
        let (mut a11, mut a12, mut a22, mut b1, mut b2, mut rr) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for &i in &rs {
            a11 += base[i] * base[i];
            a12 += base[i] * x[i];
            a22 += x[i] * x[i];
            b1 += base[i] * r[i];
            b2 += x[i] * r[i];
            rr += r[i] * r[i];
        }
        let det = a11 * a22 - a12 * a12;
        if det.is_nan() || det <= 1e-12 * a11 * a22 || a11 <= 0.0 {
            continue;
        }
        let c1 = (a22 * b1 - a12 * b2) / det;
        let c2 = (a11 * b2 - a12 * b1) / det;
        let ssr_full = rr - c1 * b1 - c2 * b2;
        let ssr_b = rr - b1 * b1 / a11;
        let gain = (ssr_b - ssr_full).max(0.0);
        // gate on what the shape adds to the constant; report (and rank by) what the two
        // explain together, so that a residual ∝ v² (always positive) ranks v² above the
        // constant that is part of it
        let share = (rr - ssr_full).max(0.0) / sr2;
        let added = gain / sr2;
        let f = gain / (ssr_full.max(0.0) / (n_eff - 2.0)).max(f64::MIN_POSITIVE);
        let p = f_sf(f, 1.0, (n_eff - 2.0).max(1.0));
        if added >= cfg.min_share && p <= alpha_s {
            out.push(Statement {
                shape: s.id.into(),
                text: s.text.into(),
                share,
                coefficient: c2,
                p_value: p,
                best: false,
            });
        }
    }
    // indicator masks
    let hw = (cfg.event_halfwidth_s / dt).round() as usize;
    let mut masks: Vec<(&str, &str, Vec<bool>)> = Vec::new();
    if let Some(m) = c.torque {
        let mut events = Vec::new();
        let mut last: Option<(f64, usize)> = None;
        for (i, &x) in m.iter().enumerate() {
            if !x.is_finite() || x.abs() <= cfg.torque_zero_nm {
                continue;
            }
            let s = x.signum();
            if let Some((ls, li)) = last {
                if ls != s {
                    events.push((li, i));
                }
            }
            last = Some((s, i));
        }
        masks.push((
            "torque_sign_change",
            "only at torque sign changes",
            event_mask(n, hw, &events),
        ));
    }
    if let Some(cl) = c.clutch {
        masks.push((
            "clutch_actuated",
            "only while the clutch is actuated",
            cl.to_vec(),
        ));
    }
    if let Some(b) = c.braking {
        masks.push(("braking", "only while braking", b.to_vec()));
    }
    if let Some(g) = c.gear {
        let events: Vec<(usize, usize)> = (1..n)
            .filter(|&i| g[i].is_finite() && g[i - 1].is_finite() && g[i] != g[i - 1])
            .map(|i| (i - 1, i))
            .collect();
        masks.push((
            "gear_shift",
            "only at gear shifts",
            event_mask(n, hw, &events),
        ));
    }
    let k_copies = floor.copies as f64;
    for (id, text, m) in masks {
        let inside: Vec<usize> = rows.iter().copied().filter(|&i| m[i]).collect();
        let outside: Vec<usize> = rows.iter().copied().filter(|&i| !m[i]).collect();
        if inside.is_empty() || inside.len() * 2 > rows.len() {
            continue;
        }
        let sums = |rs: &[usize]| {
            rs.iter().fold((0.0, 0.0), |(q, e), &i| {
                (q + r[i] * r[i], e + floor.null_variance[i])
            })
        };
        let (qi, ei) = sums(&inside);
        let (qo, eo) = sums(&outside);
        let nu_i = floor.effective_dof(&inside);
        let p_in = f_sf(qi / ei, nu_i, k_copies * nu_i);
        let ratio_in = (qi / ei).sqrt();
        let ratio_out = if eo > 0.0 { (qo / eo).sqrt() } else { 0.0 };
        let (xi, xo) = ((qi - ei).max(0.0), (qo - eo).max(0.0));
        let share = if xi + xo > 0.0 { xi / (xi + xo) } else { 0.0 };
        if p_in <= alpha_s
            && ratio_in >= cfg.practical_ratio
            && (share >= 0.8 || ratio_out < cfg.practical_ratio)
            && share >= 0.5
        {
            out.push(Statement {
                shape: id.into(),
                text: text.into(),
                share,
                coefficient: f64::NAN,
                p_value: p_in,
                best: false,
            });
        }
    }
    out.sort_by(|a, b| b.share.total_cmp(&a.share));
    if let Some(s) = out.first_mut() {
        s.best = true;
    }
    for s in out.iter_mut() {
        let what = if s.coefficient.is_nan() {
            "of the excess residual energy"
        } else {
            "of the residual energy"
        };
        s.text = format!("{} (explains {:.0} % {what})", s.text, 100.0 * s.share);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holm_matches_the_step_down_rule() {
        let p = [0.01, 0.04, 0.03, 0.005];
        let a = holm(&p);
        // sorted: 0.005·4 = 0.02, 0.01·3 = 0.03, 0.03·2 = 0.06, 0.04·1 → max(0.06, 0.04)
        let want = [0.03, 0.06, 0.06, 0.02];
        for (x, y) in a.iter().zip(want) {
            assert!((x - y).abs() < 1e-12, "{a:?}");
        }
        assert!(holm(&[]).is_empty());
    }

    #[test]
    fn xcorr_finds_a_shift() {
        let a: Vec<f64> = (0..200).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let b: Vec<f64> = (0..200)
            .map(|i| if i >= 3 { a[i - 3] } else { 0.0 })
            .collect();
        let x = xcorr_sums(&a, &b, 5);
        let k = x
            .iter()
            .enumerate()
            .max_by(|p, q| p.1.total_cmp(q.1))
            .unwrap()
            .0;
        assert_eq!(k as i64 - 5, 3);
    }

    #[test]
    fn bad_config_is_an_error() {
        let c = LocateConfig {
            alpha: 0.0,
            ..LocateConfig::default()
        };
        assert!(c.validate().is_err());
        let c = LocateConfig {
            window: WindowAxis::Time { window_s: -1.0 },
            ..LocateConfig::default()
        };
        assert!(c.validate().is_err());
        assert!(LocateConfig::default().validate().is_ok());
    }
}
