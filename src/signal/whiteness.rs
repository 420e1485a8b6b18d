//! Whiteness and effective sample size of a residual sampled in contiguous runs (a recording's
//! valid stretches between gaps): the mean squared autocorrelation at chosen lags
//! ([`mean_squared_autocorrelation`], the Ljung–Box statistic per sample) and the number of
//! independent samples from the integrated autocorrelation time ([`effective_samples`]).
//!
//! Lags in samples; a run is a range of positions in the residual vector, and lagged pairs are
//! only formed within a run (the samples on either side of a gap are not neighbours);
//! [`super::stats::run_positions`] finds the runs of a set of row indices.

use std::ops::Range;

/// Mean over the lags `k · lag_step`, `k = 1 … lags`, of the squared *non-centred*
/// autocorrelation `ρ(k) = Σ r_i r_{i+k} / Σ r_i²`, pairs within `runs`: the Ljung–Box
/// statistic per sample `Q/n`, 0 for white noise and 1 for a constant (a bias counts as
/// structure). A lag longer than a run adds nothing from it. `None` when `Σ r_i² = 0` or
/// `lags = 0`.
///
/// Reference: Ljung & Box, "On a measure of lack of fit in time series models", Biometrika 65
/// (1978).
pub fn mean_squared_autocorrelation(
    r: &[f64],
    runs: &[Range<usize>],
    lag_step: usize,
    lags: usize,
) -> Option<f64> {
    let e0: f64 = r.iter().map(|x| x * x).sum();
    if e0 <= 0.0 || lags == 0 {
        return None;
    }
    let mut q = 0.0;
    for k in 1..=lags {
        let lag = k * lag_step;
        let mut s = 0.0;
        for run in runs {
            let (a, b) = (run.start, run.end);
            if b - a > lag {
                s += r[a..b - lag]
                    .iter()
                    .zip(&r[a + lag..b])
                    .map(|(x, y)| x * y)
                    .sum::<f64>();
            }
        }
        q += (s / e0).powi(2);
    }
    Some(q / lags as f64)
}

/// Effective number of independent samples `N / τ` of `r`: `τ = 1 + 2 Σ_{k=1}^{M} ρ(k)` the
/// integrated autocorrelation time of the *centred* residual (the mean over all runs removed),
/// `ρ` the autocovariance pooled over `runs` (each run's by FFT, zero-padded so that no pair
/// wraps) over its lag-0 value, `M` Sokal's automatic window (the smallest `M ≥ 5 τ(M)`),
/// and `τ ≥ 1`. `N` for fewer than 2 samples or a constant residual.
///
/// Reference: Sokal, "Monte Carlo methods in statistical mechanics: foundations and new
/// algorithms", in *Functional Integration*, NATO ASI Series B 361 (1997).
pub fn effective_samples(r: &[f64], runs: &[Range<usize>]) -> f64 {
    let n = r.len();
    if n < 2 {
        return n as f64;
    }
    let mean = r.iter().sum::<f64>() / n as f64;
    let mut acov: Vec<f64> = Vec::new();
    for run in runs {
        let len = run.len();
        let x: Vec<f64> = r[run.clone()].iter().map(|v| v - mean).collect();
        let m = (2 * len).next_power_of_two();
        let fwd = super::fft_plans::forward(m);
        let inv = super::fft_plans::inverse(m);
        let mut buf = vec![0.0; m];
        buf[..len].copy_from_slice(&x);
        let mut spec = fwd.make_output_vec();
        if fwd.process(&mut buf, &mut spec).is_err() {
            continue;
        }
        for c in spec.iter_mut() {
            *c = num_complex::Complex::new(c.norm_sqr(), 0.0);
        }
        let mut out = inv.make_output_vec();
        if inv.process(&mut spec, &mut out).is_err() {
            continue;
        }
        if acov.len() < len {
            acov.resize(len, 0.0);
        }
        for k in 0..len {
            acov[k] += out[k] / m as f64;
        }
    }
    if acov.is_empty() || acov[0] <= 0.0 {
        return n as f64;
    }
    let mut tau = 1.0;
    for (m, a) in acov.iter().enumerate().skip(1) {
        tau += 2.0 * a / acov[0];
        if m as f64 >= 5.0 * tau {
            break;
        }
    }
    n as f64 / tau.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;
    use crate::signal::stats::run_positions;

    /// One run over all `n` samples.
    fn whole(n: usize) -> Vec<Range<usize>> {
        std::iter::once(0..n).collect()
    }

    fn gauss(rng: &mut Xoshiro256StarStar) -> f64 {
        // Box–Muller
        let (u, v) = (rng.next_f64().max(1e-300), rng.next_f64());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    #[test]
    fn white_noise_scores_zero_and_a_constant_one() {
        let mut rng = Xoshiro256StarStar::seed_from_u64(1);
        let noise: Vec<f64> = (0..20_000).map(|_| gauss(&mut rng)).collect();
        let all = whole(noise.len());
        // the sampling noise of ρ(k)² is 1/n = 5·10⁻⁵
        let q = mean_squared_autocorrelation(&noise, &all, 5, 20).unwrap();
        assert!(q < 1e-3, "{q}");
        // a constant: ρ(k) = (n − k)/n, lags up to 100 of 20 000 samples
        let q = mean_squared_autocorrelation(&[0.5; 20_000], &all, 5, 20).unwrap();
        assert!((q - 1.0).abs() < 0.01, "{q}");
        assert_eq!(
            mean_squared_autocorrelation(&[0.0; 10], &whole(10), 1, 3),
            None
        );
        assert_eq!(
            mean_squared_autocorrelation(&[1.0; 10], &whole(10), 1, 0),
            None
        );
    }

    #[test]
    fn lagged_pairs_stay_within_runs() {
        // two runs of three ones: lag 1 has 2 + 2 pairs, lag 2 has 1 + 1, lag 3 none
        let r = [1.0; 6];
        let runs = run_positions(&[0, 1, 2, 10, 11, 12]);
        assert_eq!(runs, vec![0..3, 3..6]);
        let q = mean_squared_autocorrelation(&r, &runs, 1, 3).unwrap();
        let expect = ((4.0f64 / 6.0).powi(2) + (2.0f64 / 6.0).powi(2)) / 3.0;
        assert!((q - expect).abs() < 1e-15, "{q} vs {expect}");
    }

    #[test]
    fn effective_samples_of_ar1_noise() {
        // AR(1), φ = 0.9: τ = (1 + φ)/(1 − φ) = 19; Sokal's window leaves a bias of a few per
        // cent and the estimate's sampling error at 200 000 samples is about 5 %
        let mut rng = Xoshiro256StarStar::seed_from_u64(2);
        let mut x = 0.0;
        let v: Vec<f64> = (0..200_000)
            .map(|_| {
                x = 0.9 * x + gauss(&mut rng);
                x
            })
            .collect();
        let n = v.len() as f64;
        let ne = effective_samples(&v, &whole(v.len()));
        assert!((n / ne / 19.0 - 1.0).abs() < 0.2, "τ = {}", n / ne);
        // white noise: τ = 1
        let w: Vec<f64> = (0..50_000).map(|_| gauss(&mut rng)).collect();
        let ne = effective_samples(&w, &whole(w.len()));
        assert!((ne / w.len() as f64 - 1.0).abs() < 0.1, "{ne}");
        assert_eq!(effective_samples(&[1.0; 8], &whole(8)), 8.0);
    }
}
