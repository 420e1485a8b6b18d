//! Real FFT plans kept per thread: planning a length (choosing the algorithm, computing its
//! twiddle factors) costs as much as several transforms of it, and the diagnosis transforms
//! the same few lengths many times per drive (every null copy's autocovariance, every
//! residual's whiteness and cross-correlation). A plan depends only on the length and the
//! processor's features, so a kept plan gives the same bits as a fresh one.
//!
//! Per thread because `realfft`'s planner is not `Sync`; each rayon worker keeps its own. The
//! lengths asked for are powers of two (zero-padded correlations) and Welch segment lengths,
//! so a thread holds a handful of plans whatever the number of drives it serves.

use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::cell::RefCell;
use std::sync::Arc;

thread_local! {
    static PLANNER: RefCell<RealFftPlanner<f64>> = RefCell::new(RealFftPlanner::new());
}

/// The forward real-to-complex plan of length `len`, planned once per thread.
pub fn forward(len: usize) -> Arc<dyn RealToComplex<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft_forward(len))
}

/// The inverse complex-to-real plan of length `len`, planned once per thread.
pub fn inverse(len: usize) -> Arc<dyn ComplexToReal<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft_inverse(len))
}
