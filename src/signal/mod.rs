//! Signal processing (temporary module root; merged with the filter work).
pub mod distance;
pub mod quantization;
