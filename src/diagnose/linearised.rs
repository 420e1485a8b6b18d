//! What a drive says about every catalogue parameter it informs, named or not: the first
//! greedy round's screen ([`super::screen`]) linearised into an estimate with a 95 % interval
//! ([`linearised_estimates`]). A fleet pools these across a vehicle's drives; a single drive
//! rarely pins a parameter down, many together do.
//!
//! # Method
//! Round 0 screens every applicable effect at the vehicle file's parameters θ₀ with a
//! finite-difference sensitivity `S` and the nominal train residual `r`. Along the effect's
//! parameter the cost is, linearised, `J(θ₀ + δ) = ⟨r, r⟩ − 2δ⟨S, r⟩ + δ²⟨S, S⟩`
//! ([`super::screen::ScreenSums`]), least at `δ* = ⟨S, r⟩ / ⟨S, S⟩` with
//! `J* = ⟨r, r⟩ − ⟨S, r⟩² / ⟨S, S⟩`. The 95 % interval is the deviance interval of the full fit
//! ([`super::fit_interval`]) on this quadratic: `{δ : N_eff ln(J(δ) / J*) ≤ χ²₁(0.95)}`, i.e.
//! `δ* ± √(J* (e^{c/N_eff} − 1) / ⟨S, S⟩)`, with the full fit's sample count and threshold
//! ([`super::deviance::deviance_threshold`]): `N_eff` the smaller of the fewest effective
//! samples over the effect's pooled views and the cluster-robust count of the train blocks, both
//! at the estimate (the outputs extrapolated along `S`), and `c = χ²₁(0.95)` or `t²_{B−1}(0.975)`
//! when the blocks bind. Estimate and interval are clipped to the parameter's physical domain.
//!
//! The estimate is the screen's: one finite difference, so exact for a parameter the outputs
//! follow linearly (drag area, rolling resistance, torque offsets, mass, grade offset) and
//! only indicative for threshold and shift effects (clutch capacity, lash, delays), whose
//! response curves. Switches (nothing fitted) have no estimate. Values in the parameter's SI
//! unit.

use super::deviance::deviance_threshold;
use super::evaluator::{Eval, Evaluator};
use super::fit_spec::fit_spec;
use super::problem::Part;
use super::row_column::RowColumn;
use super::screen::Screen;
use crate::model::catalogue::Effect;
use serde::Serialize;
use std::sync::Arc;

/// A linearised estimate of one catalogue parameter from the first round's screen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LinearisedEstimate {
    /// Catalogue id.
    pub effect: &'static str,
    /// The vehicle file's value, parameter unit.
    pub nominal: f64,
    /// The estimate `θ₀ + δ*` (clipped to the domain), parameter unit.
    pub value: f64,
    /// Lower end of the 95 % interval (clipped to the domain), parameter unit.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// Effective samples of the nominal residual behind the interval.
    pub n_eff: f64,
    /// Share of the weighted train SSE of the effect's views the estimate removes.
    pub reduction: f64,
}

/// The linearised estimate of every effect of `scr` (the first round's screen at the
/// parameters of `ev`, residual of `base`) that has a fitted parameter and a sensitivity
/// (module documentation). Effects whose probe changed no output, or whose residual is zero,
/// are left out: the drive does not inform them.
pub fn linearised_estimates(
    ev: &Evaluator<'_, '_>,
    base: &Eval,
    scr: &Screen,
) -> Vec<LinearisedEstimate> {
    let mut out = Vec::new();
    for en in &scr.entries {
        let Ok(e) = Effect::from_id(en.effect) else {
            continue;
        };
        let nominal = ev.theta.get(e);
        let spec = fit_spec(e, nominal, ev.problem.slope_step());
        let s = en.sums;
        let Some(probe) = en.probe.as_ref() else {
            continue;
        };
        if spec.switch || s.ss <= 0.0 || s.rr <= 0.0 || !(s.ss.is_finite() && s.sr.is_finite()) {
            continue;
        }
        let centre = nominal + s.sr / s.ss;
        let value = centre.clamp(spec.lo, spec.hi);
        // the outputs at the estimate, extrapolated along the sensitivity
        let delta = value - nominal;
        let outputs: Vec<Arc<Vec<RowColumn>>> = (0..ev.models.len())
            .map(|m| {
                if !probe.active[m] {
                    return base.outputs[m].clone();
                }
                let y: Vec<RowColumn> = (0..base.outputs[m].len())
                    .map(|k| {
                        RowColumn::map3(
                            &base.outputs[m][k],
                            &probe.outputs[m][k],
                            &probe.base[m][k],
                            |b0, p, pb| b0 + delta * (p - pb) / probe.h,
                        )
                    })
                    .collect();
                Arc::new(y)
            })
            .collect();
        let at = ev.eval_outputs(value, outputs);
        let active = &probe.active;
        let n_acf = ev.n_eff(&at, active, Part::Train);
        let sens =
            |m: usize, k: usize, i: usize| (probe.outputs[m][k][i] - probe.base[m][k][i]) / probe.h;
        let (n_eff, threshold) = deviance_threshold(n_acf, ev.cluster_n_eff(&at, active, sens));
        if !(n_eff.is_finite() && n_eff > 0.0) {
            continue;
        }
        let j_min = (s.rr - s.sr * s.sr / s.ss).max(0.0);
        let half = (j_min * (threshold / n_eff).exp_m1() / s.ss).sqrt();
        if !half.is_finite() {
            continue;
        }
        out.push(LinearisedEstimate {
            effect: en.effect,
            nominal,
            value,
            ci_low: (centre - half).clamp(spec.lo, spec.hi).min(value),
            ci_high: (centre + half).clamp(spec.lo, spec.hi).max(value),
            n_eff,
            reduction: en.single_reduction,
        });
    }
    out
}
