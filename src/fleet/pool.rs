//! A parameter's per-drive estimates pooled into one ([`pool`]).

use super::series::Z_975;

/// A pooled estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pooled {
    /// The inverse-variance weighted mean.
    pub value: f64,
    /// Its standard error, scaled by the dispersion.
    pub se: f64,
    /// 95 % interval, lower end.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// Drives pooled.
    pub n: usize,
    /// Birge ratio `R = max(1, χ² / (n − 1))` (1 for one drive): how much more the drives
    /// scatter than their own intervals say.
    pub dispersion: f64,
}

/// Pools per-drive estimates `(value, standard error)`: the inverse-variance weighted mean
/// `x̄ = Σ wᵢ xᵢ / Σ wᵢ`, `wᵢ = 1/sᵢ²`, with the standard error `√(R / Σ wᵢ)` scaled by the Birge
/// ratio `R = max(1, Σ wᵢ (xᵢ − x̄)² / (n − 1))`, so that drives scattering more than their
/// intervals say (a city drive's estimate biased by what else its residual holds) widen the
/// interval instead of being trusted; the 95 % interval `x̄ ± q · se` with `q` the Student t
/// quantile with `n − 1` degrees of freedom when `R > 1` (the scale was estimated), else the
/// normal one. Points with a non-finite value or a standard error that is not positive are
/// left out; `None` when none is left.
pub fn pool(points: &[(f64, f64)]) -> Option<Pooled> {
    let ok: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, s)| x.is_finite() && s.is_finite() && *s > 0.0)
        .collect();
    let n = ok.len();
    if n == 0 {
        return None;
    }
    let sw: f64 = ok.iter().map(|(_, s)| 1.0 / (s * s)).sum();
    let value = ok.iter().map(|(x, s)| x / (s * s)).sum::<f64>() / sw;
    let chi2: f64 = ok.iter().map(|(x, s)| ((x - value) / s).powi(2)).sum();
    let dispersion = if n > 1 {
        (chi2 / (n - 1) as f64).max(1.0)
    } else {
        1.0
    };
    let se = (dispersion / sw).sqrt();
    let q = if dispersion > 1.0 {
        match crate::signal::stats::t_quantile(0.975, (n - 1) as f64) {
            q if q.is_nan() => Z_975,
            q => q,
        }
    } else {
        Z_975
    };
    Some(Pooled {
        value,
        se,
        ci_low: value - q * se,
        ci_high: value + q * se,
        n,
        dispersion,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_errors_give_the_mean_and_its_standard_error() {
        let p = pool(&[(1.0, 0.5), (1.0, 0.5), (1.0, 0.5), (1.0, 0.5)]).unwrap();
        assert_eq!(p.value, 1.0);
        assert!((p.se - 0.25).abs() < 1e-15 && p.dispersion == 1.0);
        assert!((p.ci_high - 1.0 - Z_975 * 0.25).abs() < 1e-12);
    }

    #[test]
    fn weights_follow_the_errors_and_scatter_widens_the_interval() {
        // a precise drive dominates
        let p = pool(&[(1.0, 0.1), (2.0, 1.0)]).unwrap();
        assert!((p.value - (100.0 + 2.0) / 101.0).abs() < 1e-12);
        // drives 10 standard errors apart: R = χ² = 2 · 10² / 2 … the interval widens by √R
        let tight = pool(&[(0.0, 0.1), (2.0, 0.1)]).unwrap();
        assert!((tight.dispersion - 200.0).abs() < 1e-9, "{tight:?}");
        assert!(tight.ci_low < 0.0 && tight.ci_high > 2.0, "{tight:?}");
        assert!(pool(&[(f64::NAN, 1.0), (1.0, 0.0)]).is_none());
    }
}
