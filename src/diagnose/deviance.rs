//! Deviance thresholds and the deviance of an events view in step 3 of the diagnosis, explain
//! (docs/diagnosis/method.md): the threshold of a 95 % interval and of the likelihood-ratio
//! test, `χ²₁(0.95)` ([`CHI2_1_95`]) or `t²_{B−1}(0.975)` when the between-block sample count
//! binds ([`deviance_threshold`]), and the quasi-likelihood deviance of samples with known
//! variances ([`events_deviance`]). How the deviance and the interval are defined:
//! [`super::fit_interval`]. Deviances are dimensionless.

/// χ²₁ 95 % quantile: the deviance threshold of the 95 % interval and the likelihood-ratio test.
pub const CHI2_1_95: f64 = 3.841_458_820_694_124;

/// Deviance threshold of a 95 % interval with `n_eff` effective samples of which the
/// cluster-robust count `cluster` (`(N_cl, B)`) may be the binding one: `χ²₁(0.95)` when the
/// autocorrelation count `n_acf` binds, `t²_{B−1}(0.975)` when the between-block count does (its
/// `B − 1` degrees of freedom, as a cluster-robust t test).
pub fn deviance_threshold(n_acf: f64, cluster: Option<(f64, usize)>) -> (f64, f64) {
    match cluster {
        Some((n_cl, b)) if n_cl < n_acf && b >= 2 => {
            let t = crate::signal::stats::t_quantile(0.975, (b - 1) as f64);
            let t = if t.is_nan() { f64::INFINITY } else { t };
            (n_cl, t * t)
        }
        _ => (n_acf, CHI2_1_95),
    }
}

/// Deviance of an events view ([`Evaluator::deviance`](super::evaluator::Evaluator::deviance)):
/// `n (j_x − j_r) / max(1, j_r)` for `n` events whose standardised mean square (each residual
/// over its own known standard deviation) is `j_x` at the tested parameters and `j_r` at the
/// reference — the χ² difference of known-variance samples, scaled by the reference's
/// overdispersion when its residual exceeds the known variances (a quasi-likelihood).
pub fn events_deviance(n: f64, j_x: f64, j_r: f64) -> f64 {
    n * (j_x - j_r) / j_r.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_events_view_fitted_exactly_keeps_a_finite_interval() {
        // one event fitted to a near-zero residual: a value one standard deviation off scores
        // a deviance of 1 (inside the 95 % interval's 3.84), where the profiled form
        // 1 · ln(1 / 1e-6) = 13.8 would exclude it
        let d = events_deviance(1.0, 1.0, 1e-6);
        assert!((d - 1.0).abs() < 1e-5, "{d}");
        assert!(d < CHI2_1_95);
        assert!((1.0f64 / 1e-6).ln() > CHI2_1_95);
        // 2 σ off: excluded
        assert!(events_deviance(1.0, 4.0, 0.0) > CHI2_1_95);
        // zero at the reference; grows with the events' count
        assert_eq!(events_deviance(7.0, 0.8, 0.8), 0.0);
        assert_eq!(events_deviance(10.0, 1.5, 0.5), 10.0);
        // a reference residual four times the known variance: the evidence counts a quarter
        assert_eq!(events_deviance(10.0, 8.0, 4.0), 10.0);
        // and near a good reference it agrees with the profiled form to first order
        let (jr, jx): (f64, f64) = (1.0, 1.01);
        assert!((events_deviance(20.0, jx, jr) - 20.0 * (jx / jr).ln()).abs() < 1e-3);
    }
}
