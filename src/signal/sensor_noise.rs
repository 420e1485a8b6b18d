//! A recorded channel's sensor error model on the log's grid ([`SensorNoise`]): its native
//! samples, white noise σ, quantisation step and the persistent part of the quantisation error,
//! estimated blind from the recording ([`super::sensor_noise_estimate`]) or given directly
//! ([`SensorNoise::given`]); and the Monte-Carlo copies of that error ([`SensorNoise::draw`]).
//! The method and its measured accuracy are described in docs/diagnosis/method.md (noise floor,
//! part 1).
//!
//! Units: σ and steps in the channel's SI unit, periods in rows and s. Deterministic: every
//! random stream is seeded from a run seed, the copy and the column name ([`stream`]).

use super::stats::median;
use crate::rng::{splitmix64, Xoshiro256StarStar};
use crate::schema::{drive_log, Interpolation};
use crate::table::DriveLog;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a sensor's noise cannot be estimated.
#[derive(Debug, Error)]
pub enum SensorNoiseError {
    /// A series without any finite value, or no rows at all.
    #[error("{what}: no finite value")]
    Empty {
        /// The series.
        what: String,
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
}

/// How a channel was put on the log's grid (the schema's interpolation kind).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleKind {
    /// Linear between native samples.
    Linear,
    /// Each native sample held until the next (zero-order hold).
    Hold,
}

impl SampleKind {
    /// The kind of a canonical column (`Linear` for unknown columns).
    pub fn of_column(name: &str) -> SampleKind {
        match drive_log().column(name).map(|c| c.interpolation) {
            Some(Interpolation::Hold) => SampleKind::Hold,
            _ => SampleKind::Linear,
        }
    }
}

/// One channel's sensor error model, estimated blind from the recording
/// ([`super::sensor_noise_estimate`]) or given ([`SensorNoise::given`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorNoise {
    /// Column.
    pub column: String,
    /// SI unit of the column.
    pub unit: String,
    /// How the channel sits on the grid.
    pub kind: SampleKind,
    /// Grid step of the log, s.
    pub grid_dt_s: f64,
    /// Estimated native rate, Hz.
    pub native_rate_hz: f64,
    /// Native samples recovered (knots plus filled-in ones).
    pub n_native: usize,
    /// Robust spread of the native second differences / √6 (includes dithered quantisation),
    /// unit.
    pub sigma_raw: f64,
    /// Quantisation step found on the native values, unit (`None`: not quantised).
    pub quantization_step: Option<f64>,
    /// White part of the error, `√max(0, σ_raw² − q²/12)`, unit.
    pub sigma_white: f64,
    /// Half-width of the persistent quantisation error, unit.
    pub persistent_half_width: f64,
    /// Native sample positions, rows (fractional).
    #[serde(skip)]
    pub(super) positions: Vec<f64>,
    /// Run index (persistent error) of every native sample (32 bits: a long drive's record is
    /// one index per native sample).
    #[serde(skip)]
    pub(super) run: Vec<u32>,
    /// Recorded level of every run.
    #[serde(skip)]
    pub(super) run_level: Vec<f64>,
    /// Recorded value of every native sample.
    #[serde(skip)]
    pub(super) native_values: Vec<f64>,
}

/// FNV-1a hash of a name (seeds per column).
fn fnv1a64(name: &str) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for b in name.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}

/// The random stream of `column` in copy `copy` of a run seeded with `seed`.
pub fn stream(seed: u64, copy: u64, column: &str) -> Xoshiro256StarStar {
    let mut s = seed ^ fnv1a64(column);
    let a = splitmix64(&mut s);
    let mut c = copy.wrapping_add(0x5EED);
    Xoshiro256StarStar::seed_from_u64(a ^ splitmix64(&mut c))
}

impl SensorNoise {
    /// A sensor error model given directly (white σ, quantisation step, native rate), e.g. for
    /// tests or a channel whose data sheet is known: native samples every `period_rows` rows of
    /// an `n_rows` grid, runs of the persistent error every `run_rows` rows.
    ///
    /// # Errors
    /// [`SensorNoiseError::BadConfig`] for non-finite or non-positive steps and negative σ.
    #[allow(clippy::too_many_arguments)]
    pub fn given(
        column: &str,
        unit: &str,
        kind: SampleKind,
        n_rows: usize,
        dt_s: f64,
        period_rows: usize,
        sigma_white: f64,
        quantization_step: Option<f64>,
    ) -> Result<SensorNoise, SensorNoiseError> {
        let bad = |parameter, value| SensorNoiseError::BadConfig {
            parameter,
            value,
            requirement: "finite and > 0 (σ ≥ 0)",
        };
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(bad("dt_s", dt_s));
        }
        if period_rows == 0 {
            return Err(bad("period_rows", 0.0));
        }
        if !(sigma_white.is_finite() && sigma_white >= 0.0) {
            return Err(bad("sigma_white", sigma_white));
        }
        if let Some(q) = quantization_step {
            if !(q.is_finite() && q > 0.0) {
                return Err(bad("quantization_step", q));
            }
        }
        let positions: Vec<f64> = (0..n_rows).step_by(period_rows).map(|i| i as f64).collect();
        let half = quantization_step.map_or(0.0, |q| {
            0.5 * q * (-2.0 * std::f64::consts::PI.powi(2) * sigma_white.powi(2) / (q * q)).exp()
        });
        let rate = 1.0 / (period_rows as f64 * dt_s);
        let hw = ((0.5 * rate).round() as usize).max(1);
        let run: Vec<u32> = (0..positions.len())
            .map(|j| (j / (2 * hw + 1)) as u32)
            .collect();
        let run_level = vec![f64::NAN; run.last().map_or(0, |&r| r as usize + 1)];
        Ok(SensorNoise {
            column: column.into(),
            unit: unit.into(),
            kind,
            grid_dt_s: dt_s,
            native_rate_hz: rate,
            n_native: positions.len(),
            sigma_raw: (sigma_white.powi(2) + quantization_step.map_or(0.0, |q| q * q / 12.0))
                .sqrt(),
            quantization_step,
            sigma_white,
            persistent_half_width: half,
            native_values: vec![f64::NAN; positions.len()],
            positions,
            run,
            run_level,
        })
    }

    /// The estimate's figures without its record of native samples (their positions, runs,
    /// levels and values: 24 bytes or more per native sample): what a report or a floor reads,
    /// and what the estimate is after a round trip through its serialised form. Draws from it
    /// have no native samples ([`SensorNoise::draw`]).
    pub fn without_samples(&self) -> SensorNoise {
        SensorNoise {
            column: self.column.clone(),
            unit: self.unit.clone(),
            positions: Vec::new(),
            run: Vec::new(),
            run_level: Vec::new(),
            native_values: Vec::new(),
            ..*self
        }
    }

    /// One draw of the sensor error on an `n_rows` grid: `σ_w·N(0,1)` per native sample plus
    /// `U(−h, h)` per run of equal recorded level, interpolated or held onto the rows like the
    /// recording. Rows before the first native sample take its value, after the last the last's.
    /// Without native samples (a series never estimated) every row draws its own.
    pub fn draw(&self, n_rows: usize, rng: &mut Xoshiro256StarStar) -> Vec<f64> {
        self.draw_in(n_rows, rng, f64::NEG_INFINITY, f64::INFINITY)
            .0
    }

    /// [`SensorNoise::draw`] for a column whose physical range is `[lo, hi]`, with the rows at
    /// rest: a run whose recorded level lies at a bound (a brake, retarder or clutch that is off,
    /// a vehicle standing) gets no persistent error, and its rows are returned with that bound —
    /// `diagnose::noise::perturbed_log` sets them to it. The reading at rest is noise about the
    /// actuator's rest state, which a sensor clamping at the bound shows as a one-sided offset
    /// (the recorded brake force of a synthetic drive is |N(0, 200 N)| rounded to 0.1 kN while
    /// the brake is off, +85 N on average); a copy at the rest state differs from the recording
    /// by that offset, as the recording differs from the truth.
    pub fn draw_in(
        &self,
        n_rows: usize,
        rng: &mut Xoshiro256StarStar,
        lo: f64,
        hi: f64,
    ) -> (Vec<f64>, Vec<Option<f64>>) {
        if self.positions.is_empty() {
            return (
                (0..n_rows)
                    .map(|_| self.sigma_white * rng.standard_normal())
                    .collect(),
                vec![None; n_rows],
            );
        }
        let n_runs = self.run.last().map_or(0, |&r| r as usize + 1);
        let white: Vec<f64> = (0..self.positions.len())
            .map(|_| self.sigma_white * rng.standard_normal())
            .collect();
        let h = self.persistent_half_width;
        // a run is at a bound when its recorded level is within one step (or σ_w) of it: the
        // running median of clamped noise sits at the bound or one step off it
        let step = self.quantization_step.unwrap_or(0.0).max(self.sigma_white);
        let bound: Vec<Option<f64>> = (0..n_runs)
            .map(|r| {
                let level = self.run_level.get(r).copied().unwrap_or(f64::NAN);
                if level <= lo + step {
                    Some(lo)
                } else if level >= hi - step {
                    Some(hi)
                } else {
                    None
                }
            })
            .collect();
        let pers: Vec<f64> = (0..n_runs)
            .map(|r| {
                let u = if h > 0.0 { rng.uniform(-h, h) } else { 0.0 };
                if bound[r].is_some() {
                    0.0
                } else {
                    u
                }
            })
            .collect();
        let d: Vec<f64> = white
            .iter()
            .zip(&self.run)
            .map(|(w, &r)| w + pers[r as usize])
            .collect();
        // at rest: in a run at a bound and itself within the noise of it (3σ_w + q), so that the
        // first samples of an actuation, whose running median is still the rest level, stay
        let near = 3.0 * self.sigma_white + self.quantization_step.unwrap_or(0.0);
        let rest: Vec<Option<f64>> = self
            .run
            .iter()
            .zip(&self.native_values)
            .map(|(&r, v)| bound[r as usize].filter(|b| (v - b).abs() <= near))
            .collect();
        let p = &self.positions;
        let mut out = vec![0.0; n_rows];
        let mut at = vec![None; n_rows];
        let mut j = 0usize;
        for i in 0..n_rows {
            let x = i as f64;
            while j + 1 < p.len() && p[j + 1] <= x {
                j += 1;
            }
            (out[i], at[i]) = if x < p[0] {
                (d[0], rest[0])
            } else if j + 1 >= p.len() {
                (d[p.len() - 1], rest[p.len() - 1])
            } else {
                match self.kind {
                    SampleKind::Hold => (d[j], rest[j]),
                    SampleKind::Linear => {
                        let w = (x - p[j]) / (p[j + 1] - p[j]);
                        let r = if rest[j] == rest[j + 1] {
                            rest[j]
                        } else {
                            None
                        };
                        (d[j] + w * (d[j + 1] - d[j]), r)
                    }
                }
            };
        }
        (out, at)
    }
}

/// Grid step of a log, s (median of the row intervals).
///
/// # Errors
/// [`SensorNoiseError::Empty`] for fewer than 2 rows; [`SensorNoiseError::BadConfig`] for a
/// non-increasing time axis.
pub fn grid_step_s(log: &DriveLog) -> Result<f64, SensorNoiseError> {
    if log.len() < 2 {
        return Err(SensorNoiseError::Empty {
            what: "time axis (fewer than 2 rows)".into(),
        });
    }
    let mut d: Vec<f64> = log
        .timestamp_ns
        .windows(2)
        .map(|w| (w[1] - w[0]) as f64 * 1e-9)
        .collect();
    let dt = median(&mut d);
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SensorNoiseError::BadConfig {
            parameter: "grid step, s",
            value: dt,
            requirement: "finite and > 0 (increasing timestamps)",
        });
    }
    Ok(dt)
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn without_samples_is_the_serialised_estimate() {
        let s = SensorNoise::given("x", "1", SampleKind::Hold, 10_000, 0.02, 5, 0.2, Some(0.1))
            .unwrap();
        assert!(!s.positions.is_empty());
        let bare = s.without_samples();
        let json = serde_json::to_string(&s).unwrap();
        let back: SensorNoise = serde_json::from_str(&json).unwrap();
        assert_eq!(back, bare);
        assert_eq!(serde_json::to_string(&bare).unwrap(), json);
        assert!(bare.positions.is_empty() && bare.native_values.is_empty());
    }
}
