//! Settings of the modal comparison ([`super::modal`], docs/diagnosis/method.md, steps 2 and 3
//! for the driveline effects): what counts as a closed clutch, the analysis window after a
//! closing, the frequency band and acceptance rules of a fitted mode, and the false-alarm rate
//! and practical margin of the drive-level test.
//!
//! Units in the names: s, m/s, Hz, 1/s, rad/s (the engine speed's unit); fractions where none.

use serde::Serialize;

/// Settings of the modal comparison.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModalConfig {
    /// Clutch position at or below which the clutch counts as closed, fraction of travel
    /// (0.02: the 2 % the comparison uses for a clutch transition,
    /// [`super::rows::longitudinal_rows`]).
    pub clutch_closed_max: f64,
    /// Start of the analysis window after the first closed clutch sample, s. 0.2 s: the clutch
    /// position comes at 10 Hz, so the closing is known to 0.1 s; one more sample makes sure
    /// the clutch has locked and the window holds the free ringing, not the engagement.
    pub window_start_s: f64,
    /// End of the analysis window after the closing, s. 2.5 s: at the measured decay rates
    /// (4–6 1/s in gears 7–12, ~1 1/s in gear 1) the ringing has died into the noise well before,
    /// and a longer window lets the next torque change into the fit.
    pub window_end_s: f64,
    /// Lowest measured vehicle speed at the window start, m/s (the model has no creep mode,
    /// [`super::setup::MIN_SPEED_MPS`]).
    pub min_speed_mps: f64,
    /// Frequency band searched, Hz: 0.8–12 Hz holds the shuffle of every gear of a heavy
    /// truck (measured 1.3–8.3 Hz on the proof drives, gear 1 with a 38 % softer shaft to
    /// gear 12) and stays below the 25 Hz Nyquist frequency of a 50 Hz engine speed.
    pub band_hz: (f64, f64),
    /// Largest decay rate accepted, 1/s: above it the window holds less than a cycle of
    /// ringing at 4 Hz and the frequency is not determined.
    pub max_decay_per_s: f64,
    /// Smallest share of the detrended variance the oscillation must explain (R²). 0.6: the
    /// proof drives' engagements reach 0.8–0.99; a window with no ringing explains noise only
    /// (R² ≈ 4/n ≈ 0.05 for a 115-sample window).
    pub min_r2: f64,
    /// Smallest amplitude at the window start, rad/s (the engine speed's unit; a signal in
    /// another unit needs its own value). 0.3 rad/s: 3× the 1 rpm (0.105 rad/s) noise σ of a J1939 EEC1 engine speed; the
    /// proof drives' engagements ring at 0.46–1.9 rad/s.
    pub min_amplitude_rad_s: f64,
    /// False-alarm rate of the drive-level test (and family-wise rate of the per-gear tests).
    pub alpha: f64,
    /// Smallest mean relative frequency shift the drive-level test reports, fraction: 0.03,
    /// about 3× the per-gear repeatability (0.05 Hz at 4–8 Hz) measured within a drive, and a
    /// third of the shift a 25 % shaft-stiffness change gives (`f ∝ √k_d` at most: 12 %).
    pub min_relative_shift: f64,
    /// Fewest engagements with both fits accepted for a drive-level test.
    pub min_engagements: usize,
    /// Largest ratio (either way) of a measured mode's frequency to its reference for the
    /// two to be the same mode. 1.6: the catalogue's shaft-stiffness changes (±25–50 %) move
    /// the shuffle by a factor of at most √1.5 ≈ 1.22 (or 1/√0.5 ≈ 1.41); a mode further off
    /// is another motion — measured on a proof drive with a slipping clutch, a 0.95 Hz drift
    /// fitted in gear 12, whose shuffle is at 8.3 Hz.
    pub max_mode_ratio: f64,
}

impl Default for ModalConfig {
    fn default() -> Self {
        Self {
            clutch_closed_max: 0.02,
            window_start_s: 0.2,
            window_end_s: 2.5,
            min_speed_mps: 1.0,
            band_hz: (0.8, 12.0),
            max_decay_per_s: 20.0,
            min_r2: 0.6,
            min_amplitude_rad_s: 0.3,
            alpha: 0.01,
            min_relative_shift: 0.03,
            min_engagements: 3,
            max_mode_ratio: 1.6,
        }
    }
}
