//! Signal processing for fleet logs: resampling to distance ([`distance`]), reading a series
//! between its samples ([`interp_linear`]), a first-order lag ([`first_order_lag`]), sensor
//! quantisation ([`quantization`]) and its consistent reconstruction ([`dequantise`]), Butterworth design in second-order
//! sections, causal and zero-phase filtering, Welch spectra, cross-spectra and coherence.
//!
//! The functions mirror scipy.signal (`butter(..., output='sos')`,
//! `sosfilt`, `sosfilt_zi`, `sosfiltfilt`, `welch`, `sosfreqz`) and are
//! tested against scipy reference vectors; [`EdgeMode::Matched`] is our own
//! edge treatment for zero-phase filtering of slowly varying signals such as
//! road slope (Myklebust & Eriksson (2012), §5: 3rd-order Butterworth
//! low-pass in distance, cut-off 4e-3 1/m).
//!
//! Conventions: frequencies and sampling rates share one unit (Hz for time
//! series, 1/m for distance-sampled series); sections are scipy rows
//! `[b0, b1, b2, a0, a1, a2]` with `a0 = 1`; PSDs are one-sided densities
//! (unit² per frequency unit).

mod butterworth;
pub mod dequantise;
pub mod distance;
mod error;
pub mod fft_plans;
mod filtfilt;
mod first_order_lag;
mod interp;
pub mod quantization;
pub mod sensor_noise;
pub mod sensor_noise_estimate;
mod sos;
mod spectrum;
pub mod stats;
mod welch;
pub mod whiteness;

pub use butterworth::{
    butter, lowest_order_meeting, try_lowest_order_meeting, BandType, Sos, MAX_SEARCH_ORDER,
};
pub use error::SignalError;
pub use filtfilt::{
    impulse_decay_len, matched_default_fit_len, ramp_zi, scipy_default_padlen, sosfiltfilt,
    EdgeMode, MATCHED_DECAY_THRESHOLD,
};
pub use first_order_lag::first_order_lag;
pub use interp::{interp_linear, interp_linear_at, LinearResampler};
pub use sos::{
    sosfilt, sosfilt_in_place, sosfilt_in_place_rev, sosfilt_zi, FREE_RESPONSE_FLOOR,
    FUSED_SECTIONS, LANES, LOCKSTEP_MIN, SOSFILT_BLOCK,
};
pub use spectrum::{cumulative_power, knee_frequency, share_below};
pub use welch::{
    chi2_ppf, csd, csd_piece_stream, csd_pieces, equivalent_dof, hann_periodic, welch, WelchConfig,
    WelchCsd, WelchPsd,
};
