//! A parameter's per-drive estimates pooled into one ([`pool`]), and the random-effects fit of
//! one or more groups of them that pooling and the change test share ([`GroupFit`]).
//!
//! Drives of one truck scatter more than their own intervals say: each drive's estimate takes up
//! what else its residual holds (wind on that day, that road, that payload), a departure that is
//! the same size on a long drive as on a short one. The scatter is therefore modelled as
//! additive, `xᵢ = θ + uᵢ + eᵢ`, `var eᵢ = sᵢ²` (the drive's own interval), `var uᵢ = τ²` (the
//! between-drive variance), and fitted as a random-effects meta-analysis is: `τ²` by the
//! DerSimonian–Laird moment estimator, the means weighted by `1/(sᵢ² + τ²)`, their standard
//! errors scaled by the modified Hartung–Knapp factor `R = max(1, Q*/(n − g))` and read with
//! Student t on `n − g` degrees of freedom (DerSimonian & Laird, *Meta-analysis in clinical
//! trials*, Controlled Clinical Trials 7, 1986; Knapp & Hartung, *Improved tests for a random
//! effects meta-regression with a single covariate*, Statistics in Medicine 22, 2003). With few
//! drives a scale estimated from the drives themselves is uncertain, and the t quantile carries
//! that uncertainty; a normal quantile would not.

use super::series::Z_975;

/// A random-effects fit of `g` groups of per-drive estimates that share one between-drive
/// variance: each group's mean and its standard error.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupFit {
    /// Per group: the weighted mean and its standard error (scaled by `scale`).
    pub means: Vec<(f64, f64)>,
    /// Between-drive variance `τ²` (DerSimonian–Laird, pooled within the groups).
    pub tau2: f64,
    /// Modified Hartung–Knapp factor `R = max(1, Q*/(n − g))` (1 with no degree of freedom).
    pub scale: f64,
    /// Degrees of freedom of the scale, `n − g`.
    pub dof: usize,
}

/// Fits `groups` of `(value, standard error)` (each group's points already filtered, none
/// empty): the DerSimonian–Laird `τ² = max(0, (Q − (n − g)) / c)` from the fixed-weight
/// (`wᵢ = 1/sᵢ²`) within-group statistic `Q = Σ wᵢ (xᵢ − x̄_g)²` and
/// `c = Σ_g (Σ wᵢ − Σ wᵢ² / Σ wᵢ)`; then the means with `wᵢ* = 1/(sᵢ² + τ²)`, each with the
/// standard error `√(R / Σ wᵢ*)`.
pub fn fit_groups(groups: &[&[(f64, f64)]]) -> GroupFit {
    let n: usize = groups.iter().map(|g| g.len()).sum();
    let dof = n.saturating_sub(groups.len());
    let mean = |g: &[(f64, f64)], tau2: f64| {
        let sw: f64 = g.iter().map(|(_, s)| 1.0 / (s * s + tau2)).sum();
        let m = g.iter().map(|(x, s)| x / (s * s + tau2)).sum::<f64>() / sw;
        let q: f64 = g
            .iter()
            .map(|(x, s)| (x - m).powi(2) / (s * s + tau2))
            .sum();
        (m, sw, q)
    };
    let (mut q, mut c) = (0.0, 0.0);
    for g in groups {
        let (_, sw, qg) = mean(g, 0.0);
        q += qg;
        c += sw - g.iter().map(|(_, s)| s.powi(-4)).sum::<f64>() / sw;
    }
    let tau2 = if dof > 0 && c > 0.0 {
        ((q - dof as f64) / c).max(0.0)
    } else {
        0.0
    };
    let fits: Vec<(f64, f64, f64)> = groups.iter().map(|g| mean(g, tau2)).collect();
    let q_star: f64 = fits.iter().map(|f| f.2).sum();
    let scale = if dof > 0 {
        (q_star / dof as f64).max(1.0)
    } else {
        1.0
    };
    GroupFit {
        means: fits
            .iter()
            .map(|(m, sw, _)| (*m, (scale / sw).sqrt()))
            .collect(),
        tau2,
        scale,
        dof,
    }
}

/// Whether a point `(value, standard error)` can be pooled: a finite value with a finite,
/// positive standard error.
pub fn is_usable(&(x, s): &(f64, f64)) -> bool {
    x.is_finite() && s.is_finite() && s > 0.0
}

/// The points that can be pooled ([`is_usable`]).
pub fn usable(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points.iter().copied().filter(is_usable).collect()
}

/// A pooled estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pooled {
    /// The random-effects weighted mean.
    pub value: f64,
    /// Its standard error, scaled by the dispersion.
    pub se: f64,
    /// 95 % interval, lower end.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// Drives pooled.
    pub n: usize,
    /// Between-drive standard deviation `τ`, in the parameter's unit: how much the drives
    /// scatter beyond their own intervals (0 when they do not).
    pub between_drive_sd: f64,
    /// Modified Hartung–Knapp factor `R = max(1, Q*/(n − 1))` (1 for one drive): how much more
    /// the drives scatter than `τ` and their intervals say.
    pub dispersion: f64,
}

/// Pools per-drive estimates `(value, standard error)` ([`fit_groups`] with one group): the
/// mean weighted by `1/(sᵢ² + τ²)`, its standard error `√(R / Σ wᵢ*)`, and the 95 % interval
/// `x̄ ± q · se` with `q` the Student t quantile on `n − 1` degrees of freedom when a scale was
/// estimated from the drives (`τ > 0` or `R > 1`), else the normal one. Points with a non-finite
/// value or a standard error that is not positive are left out; `None` when none is left.
pub fn pool(points: &[(f64, f64)]) -> Option<Pooled> {
    let ok = usable(points);
    if ok.is_empty() {
        return None;
    }
    let fit = fit_groups(&[&ok]);
    let (value, se) = fit.means[0];
    let estimated = fit.tau2 > 0.0 || fit.scale > 1.0;
    let q = match crate::signal::stats::t_quantile(0.975, fit.dof as f64) {
        q if estimated && q.is_finite() => q,
        _ => Z_975,
    };
    Some(Pooled {
        value,
        se,
        ci_low: value - q * se,
        ci_high: value + q * se,
        n: ok.len(),
        between_drive_sd: fit.tau2.sqrt(),
        dispersion: fit.scale,
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
        assert_eq!(p.between_drive_sd, 0.0);
        assert!((p.ci_high - 1.0 - Z_975 * 0.25).abs() < 1e-12);
    }

    #[test]
    fn weights_follow_the_errors_and_scatter_widens_the_interval() {
        // drives within their intervals: fixed weights, a precise drive dominates
        let p = pool(&[(1.0, 0.1), (1.05, 1.0)]).unwrap();
        assert_eq!(p.between_drive_sd, 0.0);
        assert!((p.value - (100.0 + 1.05) / 101.0).abs() < 1e-12);
        // two drives 10 standard errors apart: fixed weights 100 each, Q = 2 · 100 · 1² = 200,
        // c = 200 − 2·10⁴/200 = 100, τ² = (200 − 1)/100 = 1.99; weights 1/(0.01 + 1.99) = 0.5,
        // mean 1, Q* = 1, R = 1, se = √(1/1) = 1; t₁ quantile 12.71
        let tight = pool(&[(0.0, 0.1), (2.0, 0.1)]).unwrap();
        assert!(
            (tight.between_drive_sd - 1.99f64.sqrt()).abs() < 1e-12,
            "{tight:?}"
        );
        assert!((tight.value - 1.0).abs() < 1e-12 && (tight.dispersion - 1.0).abs() < 1e-12);
        assert!((tight.se - 1.0).abs() < 1e-12, "{tight:?}");
        assert!(
            (tight.ci_high - 1.0 - 12.706_204_736).abs() < 1e-6,
            "{tight:?}"
        );
        assert!(pool(&[(f64::NAN, 1.0), (1.0, 0.0)]).is_none());
    }

    #[test]
    fn the_between_drive_variance_is_the_dersimonian_laird_estimate() {
        // equal errors s = 1, values 0, 2, 4: Q = 8, c = 3 − 3/3 = 2, τ² = (8 − 2)/2 = 3,
        // weights 1/4, mean 2, Q* = 8/4 = 2, R = max(1, 2/2) = 1, se = √(4/3)
        let p = pool(&[(0.0, 1.0), (2.0, 1.0), (4.0, 1.0)]).unwrap();
        assert!((p.between_drive_sd - 3f64.sqrt()).abs() < 1e-12, "{p:?}");
        assert!((p.value - 2.0).abs() < 1e-12 && p.dispersion == 1.0);
        assert!((p.se - (4.0f64 / 3.0).sqrt()).abs() < 1e-12, "{p:?}");
        // with equal errors the interval is the one-sample t interval of the values
        let t2 = crate::signal::stats::t_quantile(0.975, 2.0);
        assert!((p.ci_high - 2.0 - t2 * (4.0f64 / 3.0).sqrt()).abs() < 1e-12);
    }
}
