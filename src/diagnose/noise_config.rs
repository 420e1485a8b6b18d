//! Settings of the noise-floor estimate (docs/diagnosis/method.md, step 2; [`super::noise`]):
//! the Monte-Carlo copies and their seed, the columns perturbed with their physical ranges, the
//! smoothing, lags and PSD segment of the floor's statistics, and the event channels whose
//! sample phase each copy jitters.
//!
//! Times in s; ranges in each column's SI unit.

use super::noise_error::NoiseError;
use serde::{Deserialize, Serialize};

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
    pub(super) fn validate(&self) -> Result<(), NoiseError> {
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
