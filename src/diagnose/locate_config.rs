//! Settings, errors and input series of step 2 of the diagnosis, locate
//! (docs/diagnosis/method.md): how the drive is cut into windows ([`WindowAxis`]), the
//! thresholds of every test ([`LocateConfig`]; each is explained where its test is:
//! [`super::locate`] for the windows, [`super::locate_frequency`] for the bands, coherence and
//! lags, [`super::locate_conditions`] for the condition cells, [`super::locate_statements`] for
//! the plain statements), the driveline shuffle band of a vehicle ([`shuffle_band_hz`]), and the
//! recorded inputs the coherence and lags are computed against ([`inputs_from_log`]).
//!
//! All quantities SI (s, m, m/s, N·m); grades as tan α; frequencies in Hz. A setting outside its
//! domain is a [`LocateError::BadConfig`].

use crate::model::driveline::DrivelineParams;
use crate::model::resonance::{resonance, Path};
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
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

/// Settings of [`locate`](super::locate::locate) (every threshold is stated in the module
/// documentation of its test: [`super::locate`] and the modules it names).
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
    pub(super) fn validate(&self) -> Result<(), LocateError> {
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

/// The recorded inputs the location reads: engine torque, road slope, vehicle speed, brake
/// force, retarder torque, clutch position, each with the interpolation that fills its gaps
/// (the schema's kind).
const RECORDED_INPUTS: [(&str, Interpolation); 6] = [
    ("engine_torque", Interpolation::Linear),
    ("road_slope", Interpolation::Hold),
    ("vehicle_speed", Interpolation::Linear),
    ("brake_force", Interpolation::Linear),
    ("retarder_torque", Interpolation::Linear),
    ("clutch_position", Interpolation::Linear),
];

/// An input series of the location's coherence and lag tests
/// ([`super::locate::locate`]), made when the tests read it: one at a time, so a long drive
/// never holds every input's copy at once.
pub trait InputSeries {
    /// Canonical column.
    fn name(&self) -> &str;
    /// Rows.
    fn len(&self) -> usize;
    /// Whether it has no rows.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The series (`None`: it holds no value, and is left out of the tests).
    fn series(&self) -> Option<Cow<'_, NamedSeries>>;
}

impl InputSeries for NamedSeries {
    fn name(&self) -> &str {
        &self.name
    }
    fn len(&self) -> usize {
        self.values.len()
    }
    fn series(&self) -> Option<Cow<'_, NamedSeries>> {
        Some(Cow::Borrowed(self))
    }
}

/// A recorded input column of a log, its gaps filled when read ([`InputSeries::series`]).
#[derive(Debug, Clone, Copy)]
pub struct RecordedInput<'a> {
    name: &'a str,
    unit: &'a str,
    raw: &'a [f64],
    fill: Interpolation,
}

impl InputSeries for RecordedInput<'_> {
    fn name(&self) -> &str {
        self.name
    }
    fn len(&self) -> usize {
        self.raw.len()
    }
    fn series(&self) -> Option<Cow<'_, NamedSeries>> {
        Some(Cow::Owned(NamedSeries {
            name: self.name.to_string(),
            unit: self.unit.to_string(),
            values: fill_gaps(self.raw, self.fill)?,
        }))
    }
}

/// The recorded inputs of `log` the location reads, those present, in a fixed order, read
/// lazily ([`RecordedInput`]).
pub fn recorded_inputs(log: &DriveLog) -> Vec<RecordedInput<'_>> {
    RECORDED_INPUTS
        .iter()
        .filter_map(|&(c, fill)| {
            let s = log.signals.iter().find(|s| s.name == c)?;
            Some(RecordedInput {
                name: &s.name,
                unit: &s.unit,
                raw: &s.values,
                fill,
            })
        })
        .collect()
}

/// The recorded inputs of a log as named series, filled at once: those of
/// [`recorded_inputs`] that hold a value.
pub fn inputs_from_log(log: &DriveLog) -> Vec<NamedSeries> {
    recorded_inputs(log)
        .iter()
        .filter_map(|x| x.series().map(Cow::into_owned))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
