//! Consistent reconstruction of a quantised, slowly varying signal: alternate a zero-phase
//! low-pass with the projection onto the quantisation cells of the recorded samples.
//!
//! # Problem
//! A sensor of resolution `Δ` reports `q_k = Δ·round(s_k/Δ)` (plus a lattice offset): every
//! recorded sample says only that the true value lies in its cell `[q_k − Δ/2, q_k + Δ/2]`.
//! Rounding leaves an error of rms `Δ/√12` whose steps (a staircase where the signal ramps)
//! are broadband. A linear low-pass alone removes the steps only by also removing the signal's
//! own fast content; for a road slope that is the grade change of a city hill (the
//! 4·10⁻³ 1/m slope filter of Myklebust & Eriksson (2012) removes 0.013–0.019 rms of real
//! grade on the proof's 12 % city drives, three to four times the quantisation error it is
//! meant to remove).
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
//! 2. the projection onto the cells: each sample clamped to `[q_k − Δ/2 − m, q_k + Δ/2 + m]`,
//!    `m` the margin for the sensor's noise ([`DequantiseConfig::cell_margin`], below).
//!
//! The result is the last projection: no output sample leaves its (widened) cell, so the
//! reconstruction never moves a sample more than `Δ/2 + m` from the recording and cannot
//! flatten a real hill however low the cut-off. Where the signal is held on one level, unflipped,
//! for longer than the filter's reach the low-pass leaves the level as it is (the cells cannot
//! say where in the cell it lies); where it ramps through a staircase the low-pass turns the
//! steps into the ramp.
//!
//! # Sensor noise
//! Noise before the quantiser flips a reading into a neighbouring cell now and then, the more
//! often the nearer the true value lies to the cells' boundary: the share of flipped readings
//! says where in the cell the value lies (dither). The low-pass averages the flips into that
//! share. A flipped reading does not bound the value by its own cell, though, but by that cell
//! widened by about the noise σ; with hard cells every flipped reading pins the estimate to
//! the boundary, and under many rounds the boundary becomes the fixed point of a grade held
//! anywhere near it (the unit test: grades held 0.01–0.45 % below a 1 % sensor's boundary, σ
//! = 0.2 %, mean error up to 0.0017 with hard cells, 0.0013 for the readings' own average and
//! 0.0003 with cells widened by σ). So every cell is widened by
//! [`DequantiseConfig::cell_margin`] (the caller's estimate of σ; 0 for a noise-free sensor).
//!
//! Nothing is removed before the low-pass. A running median of the recorded levels
//! ([`DequantiseConfig::median_half_width`], off by default) removes short flips and, with
//! them, that information: on the roads of `research/studies/dequantise_design.rs` (σ = 0.2 %
//! before 1–2 % sensors) a 7 m median with 3 rounds at 0.02 1/m and hard cells leaves the
//! 200 m means of the slope *further* from the road than the recording itself (RMS 0.00253
//! against 0.00229, pooled), and on the proof's three `slope_quantization` drives of seed 1 it
//! does the same (20 s means 0.00131, 0.00213, 0.00296 against the recording's 0.00093,
//! 0.00170, 0.00199; `research/studies/slope_cure.rs`).
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
    /// Half width `w` of the running median applied to the recorded levels, samples (0: none;
    /// a median keeps monotone runs and levels held longer than `w` and removes shorter
    /// excursions, Gallagher & Wise 1981, IEEE Trans. ASSP 29(6):1136–1141).
    pub median_half_width: usize,
    /// Cut-off of the low-pass, cycles per sample (below 0.5).
    pub cutoff_per_sample: f64,
    /// Butterworth order of the low-pass (applied forward and backward).
    pub order: usize,
    /// Rounds of low-pass and projection.
    pub iterations: usize,
    /// Widening of every cell on either side, in the signal's unit (0: the cells as recorded).
    pub cell_margin: f64,
}

impl Default for DequantiseConfig {
    /// For a road slope on the 1 m distance grid: no median (the module's "Sensor noise"),
    /// cut-off 0.05 1/m (20 m wavelength), order 2, 100 rounds, hard cells (set the margin to
    /// the sensor's noise). Iterating a filter that is not a projection lowers its effective
    /// cut-off, so the rounds spread a level change further and average more flips, while
    /// the cells keep every real curve (a city crest of R = 300 m takes 36 m per 12 % of grade
    /// change, Trafikverket 2004 as cited by Myklebust & Eriksson (2012), §4) to within `Δ/2`
    /// plus the margin.
    ///
    /// Chosen with `research/studies/dequantise_design.rs`: 80 generated roads (20 of each bundled
    /// rule set, seeds 9001–9020, 5 km — none of them a proof road — each read by 1, 1.5 and 2 %
    /// sensors with 0.2 % noise, one reading per 2 m), a grid of cut-offs (0.02–0.05 1/m), rounds
    /// (20, 50, 100) and margins (0, σ, 2σ), and a rule fixed before that grid ran: within 5 % of
    /// the best RMS error of 200 m means of the slope (what a 20 s speed window integrates), the
    /// lowest RMS error per metre. Pooled, per metre / of 200 m means: recording 0.00473 / 0.00229;
    /// chosen (margin σ) 0.00229 / 0.00155; the same without margin 0.00246 / 0.00160, with 2σ
    /// 0.00250 / 0.00184; every setting with margin σ and at least 50 rounds within 0.00229–0.00297
    /// / 0.00148–0.00162.
    fn default() -> Self {
        Self {
            median_half_width: 0,
            cutoff_per_sample: 0.05,
            order: 2,
            iterations: 100,
            cell_margin: 0.0,
        }
    }
}

/// The consistent reconstruction of `recorded` (quantised with resolution `step`, uniformly
/// spaced samples; see the module documentation). The output has the input's length; every
/// output sample lies within `step/2` plus [`DequantiseConfig::cell_margin`] of its recorded
/// level (of the median-filtered level with [`DequantiseConfig::median_half_width`] above 0).
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
    let half = 0.5 * step + cfg.cell_margin;
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
        // any slope sensor's resolution; measured 1.3·10⁻⁷ there, the rounds' tail), and
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
        // while the road-slope low-pass (4e-3 1/m) takes the hill down by far more than a step
        let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).unwrap();
        let edge = EdgeMode::Matched {
            padlen: None,
            fit_len: None,
        };
        let lp = sosfiltfilt(&sos, &q, &edge).unwrap();
        // (measured: 0.018 rms against 0.0049 for the reconstruction and 0.0043 for rounding:
        // the reconstruction does not beat rounding on a profile of tangents, whose rounding
        // bias no slope-only method can see, but it never takes the hill down)
        assert!(
            rms(&lp, &truth) > step,
            "low-pass error {}",
            rms(&lp, &truth)
        );
    }

    #[test]
    fn noise_flips_place_a_held_grade_inside_its_cell() {
        // grades held between 2 % and the 2.5 % boundary, read by a 1 % sensor with 0.2 %
        // Gaussian noise before the quantiser (the proof's bus), one reading per 2 samples:
        // the nearer the boundary, the more readings flip to 3 %. Rounding puts every grade at
        // 2 % (up to half a step off); the share of flips says where in the cell it lies.
        use crate::rng::Xoshiro256StarStar;
        let (step, sigma) = (0.01, 0.002);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let with_margin = DequantiseConfig {
            cell_margin: sigma,
            ..DequantiseConfig::default()
        };
        let (mut worst, mut worst_hard, mut worst_rec) = (0.0f64, 0.0f64, 0.0f64);
        for grade in [0.0205, 0.021, 0.022, 0.023, 0.0243, 0.0249] {
            let mut rng = Xoshiro256StarStar::seed_from_u64(7);
            let mut q = vec![0.0; 2000];
            for k in (0..q.len()).step_by(2) {
                let v = ((grade + sigma * rng.standard_normal()) / step).round() * step;
                q[k] = v;
                q[k + 1] = v;
            }
            let g = dequantise(&q, step, &with_margin).unwrap();
            let hard = dequantise(&q, step, &DequantiseConfig::default()).unwrap();
            let (e, eh, er) = (mean(&g) - grade, mean(&hard) - grade, mean(&q) - grade);
            println!("grade {grade}: mean error {e:+.5} (hard cells {eh:+.5}, recorded {er:+.5})");
            worst = worst.max(e.abs());
            worst_hard = worst_hard.max(eh.abs());
            worst_rec = worst_rec.max(er.abs());
            // consistent within the margin: every sample within Δ/2 + σ of its reading
            for (gi, qi) in g.iter().zip(&q) {
                assert!((gi - qi).abs() <= 0.5 * step + sigma + 1e-12);
            }
        }
        // measured: 0.0003 with the margin against 0.0013 for the recorded readings' own mean
        // (the dithered average) and 0.0017 with hard cells, whose fixed point, under many
        // rounds, is the boundary itself (a flipped reading's cell ends there). Bound: half of
        // the readings' own worst error (the margin measured at 0.23 of it), so a cure that
        // only kept the readings' average would fail
        println!("worst: {worst:.5}, hard cells {worst_hard:.5}, recorded {worst_rec:.5}");
        assert!(
            worst < 0.5 * worst_rec,
            "worst {worst} vs recorded {worst_rec}"
        );
        assert!(worst_hard > worst, "hard {worst_hard} vs margin {worst}");
    }

    #[test]
    fn the_optional_median_removes_isolated_flips() {
        // a level held in the middle of its cell with single-sample flips to the next level:
        // with a 7-sample median the output is the level (the median's property; off by
        // default, see the module's "Sensor noise")
        let step = 0.01;
        let mut q = vec![0.02; 500];
        for i in [40, 130, 131, 260, 410] {
            q[i] = 0.03;
        }
        let cfg = DequantiseConfig {
            median_half_width: 3,
            ..DequantiseConfig::default()
        };
        let g = dequantise(&q, step, &cfg).unwrap();
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
