//! The records of step 2 of the diagnosis, locate (docs/diagnosis/method.md): each window's test
//! ([`WindowTest`]); each stretch of significant windows as a [`Mismatch`], one record of
//! diagnosis.json's `mismatch` list; the residual power by band ([`BandPower`]); the input
//! coherence and lags ([`InputCoherence`], [`InputLag`]); the operating-condition cells
//! ([`ConditionCell`]) and plain statements ([`Statement`]); gathered per signal
//! ([`SignalLocation`]) and for the drive ([`Location`]).
//!
//! Units: times in s from the first row, distances in m of travelled distance, residuals and
//! floors in the signal's SI unit, powers in its square, frequencies in Hz, grades as tan α.
//! How each figure is computed: [`super::locate`] (windows, stretches),
//! [`super::locate_frequency`] (bands, coherence, lags), [`super::locate_conditions`] (cells),
//! [`super::locate_statements`] (statements).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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
    /// Share of the residual energy the shape explains together with the constant it is
    /// fitted with (the shape alone must add at least
    /// [`LocateConfig::min_share`](super::locate_config::LocateConfig::min_share)); for
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

/// The result of [`locate`](super::locate::locate).
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
