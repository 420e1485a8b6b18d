//! The road-slope filter (Myklebust & Eriksson (2012), §5): a Butterworth low-pass in the *spatial*
//! domain that removes the slope content that excites driveline shuffle while keeping the road's
//! own grades.
//!
//! Design (docs/models/road.md): order 3, cut-off f_co = 4·10⁻³ 1/m (a decade above the
//! city-road knee), required attenuation −30 dB at f_lo = 2·10⁻² 1/m (a 3rd-order filter gives
//! ≈ −42 dB there). Two variants on the same distance grid:
//! - **off-line, zero phase**: forward-backward filtering (`sosfiltfilt`); its magnitude is
//!   |H|², so −84 dB at f_lo. Edges use [`EdgeMode::Matched`] by default — the filter's
//!   ~400-sample transient is longer than scipy's 12-sample default padding (see
//!   [`crate::signal::EdgeMode`] for the measured edge errors); `edge = "scipy"` reproduces
//!   `scipy.signal.sosfiltfilt` exactly.
//! - **on-line, causal**: a single forward pass of the *lowest* order that meets the −30 dB
//!   requirement (3 for the default design), started from the steady state of the first sample
//!   (`sosfilt_zi`·s₀), so a drive starting on a grade shows no start-up transient.
//!
//! Conventions: slope s = tan α (1), distance in m, spatial frequency in 1/m; the grid step
//! `step_m` sets the spatial sampling rate fs = 1/step_m (1/m). Missing slope samples on the grid
//! (short sensor dropouts that ingest allowed) are held from the previous sample — the slope
//! sensor is state-like in the schema — and leading ones take the first valid value.

use crate::schema::Interpolation;
use crate::signal::distance::{fill_gaps, DistanceLog};
use crate::signal::quantization::{estimate_quantization, Quantization};
use crate::signal::{
    butter, sosfilt, sosfilt_zi, sosfiltfilt, try_lowest_order_meeting, BandType, EdgeMode,
    SignalError, MAX_SEARCH_ORDER,
};
use serde::Deserialize;
use thiserror::Error;

/// Which edge treatment the zero-phase variant uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SlopeEdge {
    /// fleetdyn's matched edge treatment (default).
    #[default]
    Matched,
    /// `scipy.signal.sosfiltfilt` defaults (odd padding of 3·(2·sections+1) samples).
    Scipy,
}

impl SlopeEdge {
    /// The treatment's name as configuration files write it: `matched`, `scipy`.
    pub fn name(self) -> &'static str {
        match self {
            SlopeEdge::Matched => "matched",
            SlopeEdge::Scipy => "scipy",
        }
    }
}

/// `[slope]` settings; units in the key names.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlopeFilterConfig {
    /// Cut-off spatial frequency, 1/m.
    pub cutoff_per_m: f64,
    /// Order of the zero-phase filter.
    pub order: usize,
    /// Frequency where the attenuation requirement applies, 1/m.
    pub stop_per_m: f64,
    /// Required attenuation at `stop_per_m`, dB (positive number).
    pub required_attenuation_db: f64,
    /// Edge treatment of the zero-phase variant.
    pub edge: SlopeEdge,
}

impl Default for SlopeFilterConfig {
    fn default() -> Self {
        Self {
            cutoff_per_m: 4e-3,
            order: 3,
            stop_per_m: 2e-2,
            required_attenuation_db: 30.0,
            edge: SlopeEdge::Matched,
        }
    }
}

/// Why the slope could not be filtered.
#[derive(Debug, Error)]
pub enum SlopeError {
    /// The drive has no `road_slope` column or no valid slope sample.
    #[error("{file}: no road_slope samples to filter")]
    NoSlope {
        /// Source file.
        file: String,
    },
    /// Filter design or filtering failed (e.g. cut-off above the grid's Nyquist frequency).
    #[error("{file}: slope filter: {source}")]
    Filter {
        /// Source file.
        file: String,
        /// Cause.
        #[source]
        source: SignalError,
    },
    /// No Butterworth order up to the search limit meets the requirement.
    #[error("no causal Butterworth order up to {max_order} attenuates {required_db} dB at {stop_per_m} 1/m with cut-off {cutoff_per_m} 1/m")]
    Unreachable {
        /// Requirement.
        required_db: f64,
        /// Stop frequency.
        stop_per_m: f64,
        /// Cut-off.
        cutoff_per_m: f64,
        /// Highest order searched.
        max_order: usize,
    },
}

/// The filtered slope of one drive, on its distance grid and on its time axis.
#[derive(Debug, Clone)]
pub struct SlopeFiltered {
    /// Slope on the distance grid as resampled (held), gaps filled.
    pub raw: Vec<f64>,
    /// Zero-phase (forward-backward) low-pass on the grid.
    pub zero_phase: Vec<f64>,
    /// Causal low-pass on the grid.
    pub causal: Vec<f64>,
    /// Zero-phase result at each drive sample time (via the time → distance map).
    pub zero_phase_time: Vec<f64>,
    /// Causal result at each drive sample time.
    pub causal_time: Vec<f64>,
    /// Order of the causal filter (lowest meeting the requirement).
    pub causal_order: usize,
    /// Gain of the zero-phase filter at `stop_per_m`, dB (|H|²).
    pub zero_phase_gain_at_stop_db: f64,
    /// Gain of the causal filter at `stop_per_m`, dB.
    pub causal_gain_at_stop_db: f64,
    /// Gain of the single-pass zero-phase design (order `order`) at `stop_per_m`, dB — the
    /// figure the design requirement is checked against (≈ −42 dB for order 3; Myklebust &
    /// Eriksson (2012), §5, round it to −40 dB).
    pub design_gain_at_stop_db: f64,
    /// Estimated slope-sensor quantisation, tan α.
    pub quantization: Option<Quantization>,
}

/// Filters the drive's slope per the module doc.
///
/// # Errors
/// [`SlopeError`] when there is no slope, the design is invalid for the grid, or the
/// attenuation requirement cannot be met.
pub fn filter_slope(d: &DistanceLog, cfg: &SlopeFilterConfig) -> Result<SlopeFiltered, SlopeError> {
    let file = d.meta.source_file.clone();
    let raw = d
        .signal("road_slope")
        .and_then(|v| fill_gaps(v, Interpolation::Hold))
        .ok_or_else(|| SlopeError::NoSlope { file: file.clone() })?;
    let fs = 1.0 / d.step_m;
    let err = |source| SlopeError::Filter {
        file: file.clone(),
        source,
    };
    let sos = butter(cfg.order, cfg.cutoff_per_m, fs, BandType::Lowpass).map_err(err)?;
    let edge = match cfg.edge {
        SlopeEdge::Matched => EdgeMode::Matched {
            padlen: None,
            fit_len: None,
        },
        SlopeEdge::Scipy => EdgeMode::Scipy { padlen: None },
    };
    let zero_phase = sosfiltfilt(&sos, &raw, &edge).map_err(err)?;

    let causal_order = try_lowest_order_meeting(
        cfg.cutoff_per_m,
        cfg.stop_per_m,
        cfg.required_attenuation_db,
        fs,
        false,
    )
    .map_err(err)?
    .ok_or(SlopeError::Unreachable {
        required_db: cfg.required_attenuation_db,
        stop_per_m: cfg.stop_per_m,
        cutoff_per_m: cfg.cutoff_per_m,
        max_order: MAX_SEARCH_ORDER,
    })?;
    let causal_sos = butter(causal_order, cfg.cutoff_per_m, fs, BandType::Lowpass).map_err(err)?;
    let zi: Vec<[f64; 2]> = sosfilt_zi(&causal_sos)
        .iter()
        .map(|z| [z[0] * raw[0], z[1] * raw[0]])
        .collect();
    let (causal, _) = sosfilt(&causal_sos, &raw, Some(&zi));

    let design_gain_at_stop_db = sos.gain_db(cfg.stop_per_m, fs);
    Ok(SlopeFiltered {
        zero_phase_time: d.map.to_time_axis(&zero_phase, d.step_m),
        causal_time: d.map.to_time_axis(&causal, d.step_m),
        quantization: estimate_quantization(&raw),
        zero_phase_gain_at_stop_db: 2.0 * design_gain_at_stop_db,
        causal_gain_at_stop_db: causal_sos.gain_db(cfg.stop_per_m, fs),
        design_gain_at_stop_db,
        causal_order,
        raw,
        zero_phase,
        causal,
    })
}
