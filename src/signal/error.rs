//! Error type of the [`crate::signal`] module.
//!
//! Every variant carries the numbers that explain it, so that a message such
//! as "input length 10 must be greater than padlen 12" can be acted upon
//! without re-running anything.

/// Errors raised by filter design, filtering and spectral estimation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignalError {
    /// Filter order must be at least 1.
    #[error("invalid filter order {order}: must be at least 1")]
    InvalidOrder {
        /// The order that was asked for.
        order: usize,
    },
    /// Cut-off frequency must satisfy 0 < cutoff < fs/2 (Nyquist).
    #[error("invalid cut-off {cutoff_hz} Hz for sampling rate {fs_hz} Hz: must satisfy 0 < cutoff < fs/2")]
    InvalidCutoff {
        /// Requested cut-off frequency (same unit as `fs_hz`).
        cutoff_hz: f64,
        /// Sampling rate.
        fs_hz: f64,
    },
    /// Sampling rate must be finite and strictly positive.
    #[error("invalid sampling rate {fs_hz}: must be finite and > 0")]
    InvalidSampleRate {
        /// The sampling rate given.
        fs_hz: f64,
    },
    /// A second-order section does not have `a0 == 1` or has a non-finite
    /// coefficient (scipy's `_validate_sos` rejects the same).
    #[error("invalid second-order section {section}: a0 = {a0} (must be exactly 1) or a non-finite coefficient")]
    InvalidSos {
        /// Index of the offending section.
        section: usize,
        /// Its `a0` coefficient.
        a0: f64,
    },
    /// The input is too short for the requested edge padding
    /// (scipy: "The length of the input vector x must be greater than padlen").
    #[error(
        "the length of the input vector x ({len}) must be greater than padlen, which is {padlen}"
    )]
    InputTooShort {
        /// Length of the input.
        len: usize,
        /// Padding length that was required.
        padlen: usize,
    },
    /// Welch segment parameters are inconsistent with each other or with
    /// the input (needs `nperseg >= 1`, `noverlap < nperseg`, `len >= 1`).
    #[error("invalid segmentation: nperseg = {nperseg}, noverlap = {noverlap}, input length = {len} (need nperseg >= 1, noverlap < nperseg, len >= 1)")]
    InvalidSegment {
        /// Samples per segment.
        nperseg: usize,
        /// Overlapping samples between consecutive segments.
        noverlap: usize,
        /// Input length.
        len: usize,
    },
    /// Confidence level must lie strictly between 0 and 1.
    #[error("invalid confidence level {confidence}: must satisfy 0 < confidence < 1")]
    InvalidConfidence {
        /// The level given.
        confidence: f64,
    },
    /// The input holds a NaN or infinity; `index` is the first offending
    /// sample.
    #[error("non-finite input value {value} at index {index}")]
    NonFinite {
        /// Index of the first non-finite sample.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// Returns `Err(NonFinite)` for the first NaN/inf sample of `x`.
pub(crate) fn check_finite(x: &[f64]) -> Result<(), SignalError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SignalError::NonFinite {
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}
