//! Consistent reconstruction of a quantised, slowly varying signal: alternate a zero-phase
//! low-pass with the projection onto the quantisation cells of the recorded samples.
//!
//! # Problem
//! A sensor of resolution `Δ` reports `q_k = Δ·round(s_k/Δ)` (plus a lattice offset): every
//! recorded sample says only that the true value lies in its cell `[q_k − Δ/2, q_k + Δ/2]`.
//! Rounding leaves an error of rms `Δ/√12` whose steps (a staircase where the signal ramps)
//! are broadband. A linear low-pass alone removes the steps only by also removing the signal's
//! own fast content; for a road slope that is the grade change of a city hill (seed 000's
//! 4·10⁻³ 1/m slope filter removed 0.013–0.019 rms of real grade on the proof's 12 % city
//! drives, three to four times the quantisation error it was meant to remove).
//!
//! # Method
//! A *consistent* estimate stays inside every sample's cell. Thao & Vetterli (1994,
//! "Deterministic analysis of oversampled A/D conversion and decoding improvement based on
//! consistent estimates", IEEE Trans. Signal Process. 42(3):519–531) showed that for an
//! oversampled band-limited signal consistent estimates have an error falling as 1/r² with the
//! oversampling ratio `r`, against 1/r for linear reconstruction, and computed them by
//! alternating projections onto the convex sets "band-limited" and "in every cell" (POCS, Youla
//! & Webb 1982, "Image restoration by the method of convex projections: part 1", IEEE Trans.
//! Med. Imaging 1(2):81–94). Here, starting from the recorded levels, each of
//! [`DequantiseConfig::iterations`] rounds applies
//! 1. a zero-phase low-pass (Butterworth of order [`DequantiseConfig::order`], cut-off
//!    [`DequantiseConfig::cutoff_per_sample`], forward-backward with the matched edges of
//!    [`crate::signal::sosfiltfilt`]) — not an exact projection (a Butterworth filter is not
//!    idempotent), the practical stand-in Thao & Vetterli also discuss;
//! 2. the projection onto the cells: each sample clamped to `[q_k − Δ/2, q_k + Δ/2]`.
//!
//! The result is the last projection: no output sample leaves its cell, so the reconstruction
//! never moves a sample more than `Δ/2` from the recording and cannot flatten a real hill
//! however low the cut-off. Where the signal is held on one level for longer than the filter's
//! reach the low-pass leaves the level as it is (the cells cannot say where in the cell it
//! lies); where it ramps through a staircase the low-pass turns the steps into the ramp.
//!
//! # Sensor noise
//! Noise before the quantiser flips a sample into a neighbouring cell now and then, and a hard
//! cell around a flipped sample pulls the estimate to the cell boundary there. The recorded
//! levels are therefore first passed through a running median of `2 w + 1` samples
//! ([`DequantiseConfig::median_half_width`]): a median leaves every monotone run (the staircase
//! of a ramp) and every level held longer than `w` samples unchanged and removes shorter
//! excursions (Gallagher & Wise 1981, "A theoretical analysis of the properties of median
//! filters", IEEE Trans. Acoust., Speech, Signal Process. 29(6):1136–1141).
//!
//! # Conventions
//! Samples uniformly spaced; the cut-off is in cycles per sample (a distance grid of 1 m: 1/m);
//! values and `Δ` in the signal's unit.

use super::{butter, sosfiltfilt, BandType, EdgeMode, SignalError};
use thiserror::Error;

/// Why a signal cannot be dequantised.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DequantiseError {
    /// The resolution must be finite and positive.
    #[error("dequantise: resolution {step} must be finite and > 0")]
    BadStep {
        /// The resolution given.
        step: f64,
    },
    /// Every sample must be finite (fill gaps first).
    #[error("dequantise: sample {index} is {value}; every sample must be finite")]
    NotFinite {
        /// Index of the first bad sample.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The low-pass could not be designed or run (a cut-off at or above Nyquist, a signal
    /// shorter than the filter's edge padding).
    #[error("dequantise: low-pass: {0}")]
    Filter(#[from] SignalError),
}

/// Settings of [`dequantise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DequantiseConfig {
    /// Half width `w` of the running median applied to the recorded levels, samples (0: none).
    pub median_half_width: usize,
    /// Cut-off of the low-pass, cycles per sample (below 0.5).
    pub cutoff_per_sample: f64,
    /// Butterworth order of the low-pass (applied forward and backward).
    pub order: usize,
    /// Rounds of low-pass and projection.
    pub iterations: usize,
}

impl Default for DequantiseConfig {
    /// For a road slope on the 1 m distance grid:
    /// - `w = 3` (a 7 m median): removes level excursions of at most 3 m — one or two 10 Hz
    ///   slope messages at 50–90 km/h, the flips of 0.2 % sensor noise against a 1 % step —
    ///   and keeps every level held for more than 3 m;
    /// - cut-off 0.02 1/m (50 m wavelength), order 2: the scale of the shortest vertical curves
    ///   road design builds (a city crest of R = 300 m takes 36 m per 12 % of grade change,
    ///   Trafikverket 2004 via seed 000 §3; a freeway's 1 % grade change takes 75 m at R =
    ///   7.5 km, AASHTO), so a curve's ramp passes while the staircase of a finer one (city:
    ///   a 1.5 % step every 4.5 m of a curve) does not; whatever the filter takes from a real
    ///   curve the projection puts back to within `Δ/2`;
    /// - 3 rounds: iterating a filter that is not a projection lowers its effective cut-off, so
    ///   more rounds spread a level change further. Measured on the model profiles of the
    ///   tests (1 m grid, rms error against the truth, rounding alone in brackets): a 1 km sine
    ///   of 5 % with a 1 % sensor 0.00116 / 0.00081 / 0.00048 after 1 / 3 / 20 rounds
    ///   (0.00273); a city hill (±12 %, R = 300 m, 150 m tangents, 1.5 % sensor) 0.00420 /
    ///   0.00469 / 0.00658 (0.00431); a freeway (R = 8 km, 600 m tangents, 1.07 % sensor)
    ///   0.00321 / 0.00313 / 0.00300 (0.00340).
    fn default() -> Self {
        Self {
            median_half_width: 3,
            cutoff_per_sample: 0.02,
            order: 2,
            iterations: 3,
        }
    }
}

/// The consistent reconstruction of `recorded` (quantised with resolution `step`, uniformly
/// spaced samples; see the module documentation). The output has the input's length; every
/// output sample lies within `step/2` of the median-filtered recorded level.
///
/// # Errors
/// [`DequantiseError`] for a bad `step`, a non-finite sample, or a low-pass that cannot run on
/// this input.
pub fn dequantise(
    recorded: &[f64],
    step: f64,
    cfg: &DequantiseConfig,
) -> Result<Vec<f64>, DequantiseError> {
    if !(step.is_finite() && step > 0.0) {
        return Err(DequantiseError::BadStep { step });
    }
    if let Some((index, &value)) = recorded.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(DequantiseError::NotFinite { index, value });
    }
    if recorded.len() < 2 {
        return Ok(recorded.to_vec());
    }
    let levels = running_median(recorded, cfg.median_half_width);
    let sos = butter(cfg.order, cfg.cutoff_per_sample, 1.0, BandType::Lowpass)?;
    let edge = EdgeMode::Matched {
        padlen: None,
        fit_len: None,
    };
    let half = 0.5 * step;
    let mut x = levels.clone();
    for _ in 0..cfg.iterations {
        let y = sosfiltfilt(&sos, &x, &edge)?;
        for ((xi, yi), q) in x.iter_mut().zip(y).zip(&levels) {
            *xi = yi.clamp(q - half, q + half);
        }
    }
    Ok(x)
}

/// Running median over `2 w + 1` samples, the window shrunk symmetrically at the ends.
fn running_median(x: &[f64], w: usize) -> Vec<f64> {
    if w == 0 {
        return x.to_vec();
    }
    let n = x.len();
    let mut buf = Vec::with_capacity(2 * w + 1);
    (0..n)
        .map(|i| {
            let h = w.min(i).min(n - 1 - i);
            buf.clear();
            buf.extend_from_slice(&x[i - h..=i + h]);
            buf.sort_by(f64::total_cmp);
            buf[h]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rms(a: &[f64], b: &[f64]) -> f64 {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    }

    fn quantise(x: &[f64], step: f64) -> Vec<f64> {
        x.iter().map(|v| (v / step).round() * step).collect()
    }

    /// Grade of a road on a 1 m grid: tangents of `grades` each `tangent_m` long, joined by
    /// parabolic vertical curves of radius `radius_m` (grade linear in distance at 1/R).
    fn road(grades: &[f64], tangent_m: f64, radius_m: f64) -> Vec<f64> {
        let mut g = vec![grades[0]; tangent_m as usize];
        for w in grades.windows(2) {
            let mut s = w[0];
            let dir = (w[1] - w[0]).signum();
            while (w[1] - s) * dir > 0.0 {
                s += dir / radius_m;
                g.push(if (w[1] - s) * dir > 0.0 { s } else { w[1] });
            }
            g.extend(std::iter::repeat_n(w[1], tangent_m as usize));
        }
        g
    }

    #[test]
    fn staircase_of_a_smooth_grade_is_reconstructed_well_below_rounding_error() {
        // a grade that keeps changing (a 1 km sine of 5 % amplitude, 1 m grid), 1 % sensor:
        // rounding leaves Δ/√12 = 0.0029; the string through the staircase must do at least
        // three times better (the tolerance of "well below"; only the extremes, where the
        // string cuts the top cell, are left).
        let step = 0.01;
        let truth: Vec<f64> = (0..5000)
            .map(|i| 0.05 * (2.0 * std::f64::consts::PI * i as f64 / 1000.0).sin())
            .collect();
        let q = quantise(&truth, step);
        let rounding = rms(&q, &truth);
        assert!((rounding - step / 12f64.sqrt()).abs() < 0.1 * rounding);
        let g = dequantise(&q, step, &DequantiseConfig::default()).unwrap();
        let e = rms(&g, &truth);
        assert!(e < rounding / 3.0, "rms error {e} vs rounding {rounding}");
        // consistent: every sample in its cell
        for (gi, qi) in g.iter().zip(&q) {
            assert!((gi - qi).abs() <= 0.5 * step + 1e-12);
        }
    }

    #[test]
    fn a_grade_already_on_the_lattice_stays_unchanged() {
        // a constant grade exactly on a lattice level stays exactly itself (the low-pass keeps
        // a constant, tolerance: rounding of the filter's arithmetic)
        let step = 0.01;
        let flat = vec![0.03; 400];
        let g = dequantise(&flat, step, &DequantiseConfig::default()).unwrap();
        assert!(g.iter().all(|v| (v - 0.03).abs() < 1e-12));
        // two long tangents one step apart: all the cells can say is "a level, then the
        // next"; 150 m from the change nothing moves by more than 10⁻³ of a step (far below
        // any slope sensor's resolution; the filter's tail reaches further, at 10⁻⁶), and
        // across the change the estimate rises monotonically through the cells' boundary
        let mut steps = vec![0.02; 600];
        steps.extend(vec![0.03; 600]);
        let g = dequantise(&steps, step, &DequantiseConfig::default()).unwrap();
        for i in (0..450).chain(750..1200) {
            assert!(
                (g[i] - steps[i]).abs() < 1e-3 * step,
                "sample {i}: {} vs {}",
                g[i],
                steps[i]
            );
        }
        assert!(g[599] <= 0.025 + 1e-12 && g[600] >= 0.025 - 1e-12);
        // monotone but for the Butterworth ringing (an order-2 step response overshoots by
        // 4 %; bound 5 % of the step)
        let dip = g.windows(2).map(|w| w[0] - w[1]).fold(0.0, f64::max);
        assert!(dip < 0.05 * step, "largest fall {dip}");
        for (gi, qi) in g.iter().zip(&steps) {
            assert!((gi - qi).abs() <= 0.5 * step + 1e-12);
        }
    }

    #[test]
    fn a_twelve_percent_city_hill_is_not_flattened() {
        // city-se design: tangents of +11.7 % and −11.3 % (off the lattice), 150 m each,
        // vertical curves R = 300 m (70 m from one to the other), 1.5 % sensor (the coarse end
        // of the proof's range)
        let step = 0.015;
        let truth = road(&[0.0, 0.117, -0.113, 0.004], 150.0, 300.0);
        let q = quantise(&truth, step);
        let g = dequantise(&q, step, &DequantiseConfig::default()).unwrap();
        let peak = |v: &[f64]| v.iter().fold(f64::NEG_INFINITY, |m, &x| m.max(x));
        let trough = |v: &[f64]| v.iter().fold(f64::INFINITY, |m, &x| m.min(x));
        // the hill keeps its grades: no sample further than half a step from its recorded
        // level (the construction's guarantee), so none further than a whole step from the
        // road (half a step of rounding on top), and the crest and the sag within a step
        let worst = g
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst <= step + 1e-12, "worst error {worst}");
        assert!((peak(&g) - 0.117).abs() <= step && (trough(&g) + 0.113).abs() <= step);
        // while seed 000's low-pass (4e-3 1/m) takes the hill down by far more than a step
        let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).unwrap();
        let edge = EdgeMode::Matched {
            padlen: None,
            fit_len: None,
        };
        let lp = sosfiltfilt(&sos, &q, &edge).unwrap();
        // (measured: 0.018 rms against 0.0047 for the reconstruction and 0.0043 for rounding:
        // the reconstruction does not beat rounding on a profile of tangents, whose rounding
        // bias no slope-only method can see, but it never takes the hill down)
        assert!(
            rms(&lp, &truth) > step,
            "low-pass error {}",
            rms(&lp, &truth)
        );
    }

    #[test]
    fn isolated_noise_flips_do_not_pull_the_string() {
        // a level held in the middle of its cell with single-sample flips to the next level
        // (0.2 % noise against a 1 % step): the median removes them, the output is the level
        let step = 0.01;
        let mut q = vec![0.02; 500];
        for i in [40, 130, 131, 260, 410] {
            q[i] = 0.03;
        }
        let g = dequantise(&q, step, &DequantiseConfig::default()).unwrap();
        assert!(g.iter().all(|v| (v - 0.02).abs() < 1e-12));
    }

    #[test]
    fn bad_input_is_an_error() {
        let cfg = DequantiseConfig::default();
        assert_eq!(
            dequantise(&[0.0, 1.0], 0.0, &cfg),
            Err(DequantiseError::BadStep { step: 0.0 })
        );
        assert!(matches!(
            dequantise(&[0.0, f64::NAN, 1.0], 0.01, &cfg),
            Err(DequantiseError::NotFinite { index: 1, .. })
        ));
        assert_eq!(dequantise(&[0.02], 0.01, &cfg), Ok(vec![0.02]));
    }
}
