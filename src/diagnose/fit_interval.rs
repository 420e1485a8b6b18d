//! The 95 % confidence interval of a fitted parameter in step 3 of the diagnosis, explain
//! (docs/diagnosis/method.md): profile likelihood with an effective sample count
//! ([`profile_interval`]). The interval is in the parameter's SI unit.
//!
//! # Confidence interval: profile likelihood with an effective sample count
//! With Gaussian residuals of unknown variance, the deviance of a parameter value `p` is
//! `D(p) = N_eff ln(J(p) / J(p̂))` (`J` the weighted train mean square, the variance profiled
//! out). `N_eff` accounts for the residual's autocorrelation twice over and takes the smaller:
//! - from the autocorrelation time: the fewest `N / τ` over the fitted channels
//!   ([`effective_samples`](super::whiteness::effective_samples), `τ` the integrated
//!   autocorrelation time of the residual at `p̂`, Sokal's window) — the fewest, because the
//!   channels are largely redundant (engine and vehicle speed, three bellows of one truck);
//! - from the blocks (cluster-robust, a block bootstrap's variance without resampling): the
//!   score `Σ a r` of each train block of the split at `p̂` gives the sandwich variance
//!   `V = B/(B−1) Σ_b g_b² / H²` (`H = ⟨a, a⟩`), and `N_cl = J(p̂) / (H V)` is the sample count
//!   for which the likelihood's curvature matches it. This catches correlation longer than a
//!   window (a road stretch's slope bias) that the autocorrelation misses.
//!
//! The 95 % interval is `{p : D(p) ≤ c}` with `c = χ²₁(0.95) = 3.841`, or `t²_{B−1}(0.975)` when
//! `N_cl` binds (its `B − 1` degrees of freedom, as a cluster-robust t test); its ends are
//! found by bracketing outwards from the Gauss–Newton estimate `√(J(p̂)(e^{c/N_eff} − 1)/H)` and
//! the Illinois false-position method on `ln J`, each end at most [`MAX_CI_EVALUATIONS`]
//! simulations (the two ends in parallel), or the domain's bound when the deviance stays below
//! `c` up to it. The other parameters are held at their values: in one dimension the profile is
//! the likelihood itself.

use super::evaluator::{Eval, Evaluator};
use super::fit_spec::fit_spec;
use super::problem::Part;
use crate::model::catalogue::Effect;

/// Most simulations per end of a profile-likelihood interval.
pub const MAX_CI_EVALUATIONS: usize = 8;

/// A 95 % profile-likelihood interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// Simulations used.
    pub evaluations: usize,
}

/// The 95 % profile-likelihood interval of `e`'s parameter around the fit `best` on the models
/// of `active` (cost relative to `base`'s outputs for the others), with `n_eff` effective
/// samples, deviance threshold `threshold` and Gauss–Newton curvature `curvature` (module
/// documentation). Both ends are searched in parallel.
#[allow(clippy::too_many_arguments)]
pub fn profile_interval(
    ev: &Evaluator<'_, '_>,
    e: Effect,
    active: &[bool],
    base: &Eval,
    best: &Eval,
    curvature: f64,
    n_eff: f64,
    threshold: f64,
) -> Interval {
    let spec = fit_spec(e, ev.problem.nominal().get(e), ev.problem.slope_step());
    if spec.switch {
        return Interval {
            lo: 0.99 * best.value,
            hi: 1.01 * best.value,
            evaluations: 0,
        };
    }
    let n_eff = if n_eff.is_finite() {
        n_eff.max(1.0)
    } else {
        1.0
    };
    let j_best = ev.cost(best, active, Part::Train);
    let d0 = if curvature > 0.0 {
        (j_best * ((threshold / n_eff).exp() - 1.0) / curvature).sqrt()
    } else {
        spec.step.abs()
    };
    let d0 = if d0.is_finite() && d0 > 0.0 {
        d0
    } else {
        spec.step.abs()
    };
    let tol_f = 0.02 * threshold / n_eff;
    let side = |s: f64| -> (f64, usize) {
        let bound = if s > 0.0 { spec.hi } else { spec.lo };
        let f = |p: f64| -> f64 {
            // the deviance above the threshold, on the scale of ln J
            match ev.eval_train(base, active, e, p) {
                Ok(x) => {
                    let d = ev.deviance(&x, best, active, n_eff, Part::Train);
                    if d.is_finite() {
                        (d - threshold) / n_eff
                    } else {
                        f64::INFINITY
                    }
                }
                Err(_) => f64::INFINITY,
            }
        };
        let mut n = 0;
        // bracket: inner end (f < 0) from the estimate outwards, outer end where f ≥ 0
        let (mut pin, mut fin) = (best.value, -threshold / n_eff);
        let mut d = d0;
        let (mut pout, mut fout);
        loop {
            let p = (best.value + s * d).clamp(spec.lo, spec.hi);
            n += 1;
            let fp = f(p);
            if fp >= 0.0 {
                pout = p;
                fout = fp;
                break;
            }
            pin = p;
            fin = fp;
            if p == bound || n >= MAX_CI_EVALUATIONS {
                return (p, n);
            }
            d *= 2.0;
        }
        // Illinois false position on f (an infinite f bisects)
        let mut last = 0;
        while n < MAX_CI_EVALUATIONS {
            if (pout - pin).abs() <= 1e-3 * d0 {
                break;
            }
            let p = if fout.is_finite() {
                pin - fin * (pout - pin) / (fout - fin)
            } else {
                0.5 * (pin + pout)
            };
            n += 1;
            let fp = f(p);
            if fp.abs() < tol_f {
                return (p, n);
            }
            if fp >= 0.0 {
                pout = p;
                fout = fp;
                if last == 1 {
                    fin *= 0.5;
                }
                last = 1;
            } else {
                pin = p;
                fin = fp;
                if last == -1 && fout.is_finite() {
                    fout *= 0.5;
                }
                last = -1;
            }
        }
        (0.5 * (pin + pout), n)
    };
    let ((lo, n1), (hi, n2)) = rayon::join(|| side(-1.0), || side(1.0));
    Interval {
        lo,
        hi,
        evaluations: n1 + n2,
    }
}
