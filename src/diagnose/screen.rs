//! The screen of step 3 of the diagnosis, explain (docs/diagnosis/method.md; [`super::explain`]
//! runs it): which catalogue effects are worth a full fit in a greedy round.
//!
//! # Screen (fast)
//! For every applicable catalogue effect, the sensitivity of the simulated outputs to its
//! parameter is a finite difference of the extended model, `S_e = (y(θ + h_e) − y(θ)) / h_e`,
//! with a physically sized step `h_e` ([`fit_spec`]; about the middle of the magnitudes a fleet
//! meets, docs/validation/proof.md) — large enough to cross thresholds (the clutch only slips
//! below its load, lash only shows beyond it). For the three effects whose outputs respond by
//! a threshold or a shift (`clutch_slip`, `driveline_backlash`, `signal_delay`) one step reads
//! a curved response at one arbitrary point, so the screen also probes ½ and 1½ times the
//! step and judges the effect by the rung whose sensitivity removes the most train SSE
//! ([`SCREEN_LADDER`](crate::model::catalogue::SCREEN_LADDER)), each rung's change projected
//! on the domain (a lash cannot fall below 0, so a rung whose fit asks for less lash removes
//! nothing); its full fit starts from the step's probe as every other's does
//! (or from a start grid's best point where that is lower: `signal_delay`, `clutch_slip`).
//! Steps and domains are the catalogue's ([`crate::model::catalogue::FitRule`], the "fit step"
//! and "fit domain" columns of docs/diagnosis/catalogue.md; θ₀ the vehicle file's value)
//! (the step's sign flips where the domain ends). The probe simulates the effect's own model
//! and, for longitudinal effects, the axle model too; the models whose outputs change are the
//! ones the effect is fitted and scored on. Probes are taken once, in the first greedy round,
//! and reused by later rounds ([`Probe`]). The train residual `r = y_meas − y(θ)` is
//! least-squares fitted on each sensitivity alone (`β_e = ⟨S_e, r⟩ / ⟨S_e, S_e⟩`; the fraction
//! of the weighted train SSE removed is the squared weighted correlation of `S_e` and `r`), and
//! on all sensitivities jointly (reported). A coefficient pointing out of the physical domain
//! is clamped to it, and its reduction is that of the clamped change. Candidates are the
//! effects whose single-effect fit removes more than [`SCREEN_MIN_REDUCTION`] of the weighted
//! train SSE of their models, ranked by the share of every model's SSE they remove, at most
//! [`MAX_FULL_FITS`]. A switch (`slope_quantization`'s cure, nothing fitted) is screened on
//! every row, train and held-out (each part's inner products as the cost weights them,
//! summed), as the acceptance rule tests it ([`super::explain`], rule 3), and is a candidate
//! whenever it removes any of that SSE: the threshold rations full fits, and a switch needs
//! none (its probe is its one simulation). With a threshold, a quantised-slope drive of the
//! proof whose rounding shows mostly in its held-out blocks would leave its cure out (it
//! removes 9.5 % of the train SSE with the fixed driver, 9.7 % with the drawn one), and on
//! every row another such drive falls below it.
//!
//! Steps in the parameter's SI unit; reductions are fractions of a weighted train SSE.

use super::evaluator::{Active, Eval, Evaluator};
use super::fit_spec::fit_spec;
use super::long_drive::{is_long, map_in_order};
use super::problem::Part;
use super::row_column::RowColumn;
use crate::model::catalogue::{Domain, Effect};
use serde::Serialize;
use std::sync::Arc;

/// Fraction of the weighted train SSE of its models a single-effect screen fit must remove to
/// make the effect a candidate: 10 %. Rule 1 of the acceptance needs a 25 % fall of the
/// held-out RMSE, 44 % of the mean square; the linearised screen underestimates nonlinear
/// effects (the true clutch slip screened at 11–39 % and passed at 39 %, lash at 7–13 % and did
/// not pass), so the bar is well below 44 % but above what clean drives' weak candidates reach
/// (2–5 % for lash and shaft stiffness, whose 1 ms / many-step simulations dominated the time).
pub const SCREEN_MIN_REDUCTION: f64 = 0.10;
/// Most candidates fully fitted per greedy round (bounds the time per drive).
pub const MAX_FULL_FITS: usize = 6;

/// A finite-difference probe of one effect: the simulation at `base + h` next to the base it
/// was taken from. Probes are taken once, in the first greedy round, and reused by the later
/// rounds' screens (the sensitivities of the other effects change little when one accepted
/// parameter moves, and the screen only ranks; the full fit re-simulates).
#[derive(Debug, Clone)]
pub struct Probe {
    /// Step, parameter unit.
    pub h: f64,
    /// Models whose outputs the effect changes.
    pub active: Active,
    /// Outputs at the base.
    pub base: Vec<Arc<Vec<RowColumn>>>,
    /// Outputs at the base plus `h`, each column stored over the base's where it departs
    /// from it on few rows ([`RowColumn::over`]; every row reads the simulated value).
    pub outputs: Vec<Arc<Vec<RowColumn>>>,
    /// Taken in the current round (then `outputs` is a simulation of the current round's
    /// parameters and starts the full fit).
    pub fresh: bool,
    /// The largest single-effect reduction (the change projected on the domain) over the
    /// rungs of the effect's [`FitSpec::ladder`](super::fit_spec::FitSpec::ladder) (0 without
    /// a ladder): what makes it a candidate when larger than this probe's own. Measured against
    /// the train residual of the round that took the probe (the first) and, like the probe,
    /// reused by later rounds — which recompute the step's own reduction against their residual
    /// but not the rungs' (their probes are not kept), so after an accepted finding a ladder
    /// effect may be fitted once more than a fresh screen would ask; the acceptance rule still
    /// decides.
    pub ladder_reduction: f64,
}

impl Probe {
    /// Sensitivity at (model, channel slot, row).
    fn s(&self, m: usize, k: usize, i: usize) -> f64 {
        (self.outputs[m][k][i] - self.base[m][k][i]) / self.h
    }
}

/// One effect in the screen.
#[derive(Debug, Clone, Serialize)]
pub struct ScreenEntry {
    /// Catalogue id.
    pub effect: &'static str,
    /// Models whose outputs the effect changes (its fit and score use them).
    pub models: Vec<Domain>,
    /// Finite-difference step, parameter unit.
    pub step: f64,
    /// Parameter change of the single-effect least-squares fit (projected on the domain).
    pub single_change: f64,
    /// Fraction of the weighted train SSE of its models the single-effect fit removes (of
    /// the SSE of every row for a switch).
    pub single_reduction: f64,
    /// The most any rung of the effect's
    /// [`FitSpec::ladder`](super::fit_spec::FitSpec::ladder) removes (0 without one); the
    /// candidate test and the ranking take the larger of this and `single_reduction`.
    pub ladder_reduction: f64,
    /// The same reduction as a fraction of all models' weighted train SSE (the ranking).
    pub overall_reduction: f64,
    /// Parameter change in the joint fit of all screened effects.
    pub joint_change: f64,
    /// Above the candidate threshold.
    pub candidate: bool,
    /// The finite-difference probe (none in a decided round's screen,
    /// [`Screen::without_probes`]).
    #[serde(skip)]
    pub probe: Option<Arc<Probe>>,
    /// The single-effect least-squares sums on the screened rows.
    #[serde(skip)]
    pub sums: ScreenSums,
}

/// The weighted inner products of one effect's single-effect screen fit (`Evaluator::inner`
/// on the screened rows, in the cost's units): `⟨S, S⟩`, `⟨S, r⟩`, `⟨r, r⟩` for the sensitivity
/// `S` (per parameter unit) and the round's residual `r`. The cost along the effect's
/// parameter is, linearised, `J(θ + δ) = ⟨r, r⟩ − 2δ⟨S, r⟩ + δ²⟨S, S⟩`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ScreenSums {
    /// `⟨S, S⟩`, cost units per parameter unit².
    pub ss: f64,
    /// `⟨S, r⟩`, cost units per parameter unit.
    pub sr: f64,
    /// `⟨r, r⟩`, cost units.
    pub rr: f64,
}

impl ScreenEntry {
    /// Which models the effect changes (empty without a probe).
    pub fn active(&self) -> &[bool] {
        self.probe.as_ref().map_or(&[], |p| &p.active)
    }
}

/// The screen of one greedy round.
#[derive(Debug, Clone, Serialize)]
pub struct Screen {
    /// One entry per screened effect.
    pub entries: Vec<ScreenEntry>,
    /// Fraction of all models' weighted train SSE the joint fit of every screened sensitivity
    /// removes (unconstrained: what the catalogue explains linearly at most).
    pub joint_reduction: f64,
}

impl Screen {
    /// The screen as a decided round keeps it: its figures without the entries' probes (each
    /// holds every changed model's outputs on every row; the explain step keeps its own map of
    /// the probes for the rounds that reuse them, and nothing reads a decided round's), after
    /// which [`ScreenEntry::active`] is empty.
    pub fn without_probes(mut self) -> Screen {
        for e in &mut self.entries {
            e.probe = None;
        }
        self
    }
}

/// `outputs` with each dense column stored over the base's where it differs from it on few
/// rows ([`RowColumn::over`]): a probe is kept for the later rounds, and an effect that acts
/// now and then leaves most rows as the base's. Every row reads the same value.
fn patched_over(
    outputs: &[Arc<Vec<RowColumn>>],
    base: &[Arc<Vec<RowColumn>>],
) -> Vec<Arc<Vec<RowColumn>>> {
    outputs
        .iter()
        .zip(base)
        .map(|(o, b)| {
            if Arc::ptr_eq(o, b) {
                return Arc::clone(o);
            }
            Arc::new(
                o.iter()
                    .zip(b.iter())
                    .map(|(c, bc)| match bc.dense_storage() {
                        Some(bs) => RowColumn::over(c, bs),
                        None => c.clone(),
                    })
                    .collect(),
            )
        })
        .collect()
}

/// Models `e` may change: its own, and for a longitudinal effect also the axle model (which
/// takes the engine torque, slope and mass as inputs).
fn may_change(ev: &Evaluator<'_, '_>, e: Effect) -> Active {
    ev.models
        .iter()
        .map(|v| (v.domain == e.domain() || e.domain() == Domain::Longitudinal) && v.serves(e))
        .collect()
}

/// Screens `effects` (applicable, not yet accepted) around `base` (the round's simulation).
/// Probes missing from `probes` are simulated (in parallel; one at a time on a long drive,
/// [`super::long_drive`]) and added; the others are reused
/// ([`Probe`]). An effect whose probes fail on both sides of the current value is left out (it
/// cannot be fitted).
pub fn screen(
    ev: &Evaluator<'_, '_>,
    base: &Eval,
    effects: &[Effect],
    probes: &mut std::collections::BTreeMap<Effect, Arc<Probe>>,
) -> Screen {
    let nominal = *ev.problem.nominal();
    for p in probes.values_mut() {
        if p.fresh {
            let mut q = p.as_ref().clone();
            q.fresh = false;
            *p = Arc::new(q);
        }
    }
    let missing: Vec<Effect> = effects
        .iter()
        .copied()
        .filter(|e| !probes.contains_key(e))
        .collect();
    let r = ev.resid(base);
    // the effects' probes in parallel, one effect at a time on a long drive (super::long_drive)
    let fresh: Vec<(Effect, Option<Probe>)> =
        map_in_order(is_long(ev.problem.times().len()), &missing, |&e| {
            let spec = fit_spec(e, nominal.get(e), ev.problem.slope_step());
            let cur = ev.theta.get(e);
            let in_domain = |p: &f64| *p >= spec.lo && *p <= spec.hi;
            let may = may_change(ev, e);
            // the probe at `p`, when the models run there and some output changes
            let probe_at = |p: f64| -> Option<Probe> {
                let x = ev.eval(base, &may, e, p).ok()?;
                if !x.train.iter().all(|j| j.is_finite()) {
                    return None;
                }
                // the models whose outputs actually changed
                let active: Active = (0..ev.models.len())
                    .map(|m| may[m] && ev.changed(m, &x, base))
                    .collect();
                active.iter().any(|a| *a).then(|| Probe {
                    h: p - cur,
                    outputs: patched_over(&x.outputs, &base.outputs),
                    active,
                    base: base.outputs.clone(),
                    fresh: true,
                    ladder_reduction: 0.0,
                })
            };
            if spec.switch {
                return (e, probe_at(spec.lo));
            }
            // the step, or against it where the domain ends there
            let step = [cur + spec.step, cur - spec.step]
                .into_iter()
                .filter(in_domain)
                .find_map(probe_at);
            if spec.ladder.len() < 2 {
                return (e, step);
            }
            // the other rungs in the step's direction: the most any of them explains
            let rungs: Vec<Probe> = spec
                .ladder
                .iter()
                .filter(|k| **k != 1.0)
                .map(|k| cur + k * spec.step)
                .filter(in_domain)
                .filter_map(probe_at)
                .collect();
            let ladder_reduction = rungs
                .iter()
                .chain(step.as_ref())
                .map(|p| single_reduction(ev, p, &r, cur, &spec))
                .fold(0.0, f64::max);
            // the fit and the linearised estimate start from the step's probe as for every
            // effect (from a rung only where the step itself does not run): a rung far beyond
            // a threshold sees a steep local response, and its linearised estimate would claim
            // a precision the parameter does not have near its current value
            let p = step.or_else(|| rungs.into_iter().next());
            (
                e,
                p.map(|p| Probe {
                    ladder_reduction,
                    ..p
                }),
            )
        });
    for (e, p) in fresh {
        if let Some(p) = p {
            probes.insert(e, Arc::new(p));
        }
    }
    let all: Active = vec![true; ev.models.len()];
    let n_models = ev.models.len() as f64;
    let rr_all = ev.inner(&all, &r, &r);
    let mut entries = Vec::new();
    // ⟨r, r⟩ depends on the active models and the parts alone: formed once per pair of them
    let mut rr_of: Vec<(Active, bool, f64)> = Vec::new();
    let mut rr_on = |active: &Active, switch: bool, parts: &[Part]| -> f64 {
        if let Some(&(_, _, v)) = rr_of.iter().find(|(a, sw, _)| a == active && *sw == switch) {
            return v;
        }
        let v = ev.inner_on(active, &r, &r, parts);
        rr_of.push((active.clone(), switch, v));
        v
    };
    for &e in effects {
        let Some(probe) = probes.get(&e) else {
            continue;
        };
        let spec = fit_spec(e, nominal.get(e), ev.problem.slope_step());
        let active = &probe.active;
        let s = |m: usize, k: usize, i: usize| probe.s(m, k, i);
        // a switch (nothing fitted) is screened on every row, as the acceptance rule tests it
        // (`super::explain`, rule 3)
        let parts: &[Part] = if spec.switch {
            &[Part::Train, Part::Heldout]
        } else {
            &[Part::Train]
        };
        let ss = ev.inner_on(active, s, s, parts);
        let sr = ev.inner_on(active, s, &r, parts);
        let rr = rr_on(active, spec.switch, parts);
        let rr_all = if spec.switch {
            rr_on(&all, true, parts)
        } else {
            rr_all
        };
        let cur = ev.theta.get(e);
        let (mut change, mut red) = projected_fit(ScreenSums { ss, sr, rr }, cur, &spec);
        if spec.switch {
            // only "on" is a value: a negative coefficient means the filter makes it worse
            if change <= 0.0 {
                red = 0.0;
            }
            change = if change > 0.0 { probe.h } else { 0.0 };
        }
        // a threshold or shift effect that a rung of its ladder shows more clearly
        let red_screen = red.max(probe.ladder_reduction);
        let n_act = active.iter().filter(|a| **a).count() as f64;
        // the same reduction over every model's SSE (each model's cost counts 1/n_models)
        let overall = if rr_all > 0.0 {
            red_screen * rr * n_act / n_models / rr_all
        } else {
            0.0
        };
        entries.push(ScreenEntry {
            effect: e.id(),
            models: (0..ev.models.len())
                .filter(|&m| active[m])
                .map(|m| ev.models[m].domain)
                .collect(),
            step: probe.h,
            single_change: change,
            single_reduction: red,
            ladder_reduction: probe.ladder_reduction,
            overall_reduction: overall,
            joint_change: f64::NAN,
            // the threshold rations full fits; a switch needs none (its probe is its one
            // simulation), so any reduction makes it a candidate
            candidate: if spec.switch {
                red > 0.0
            } else {
                red_screen > SCREEN_MIN_REDUCTION
            },
            probe: Some(probe.clone()),
            sums: ScreenSums { ss, sr, rr },
        });
    }
    // joint least squares over every model (normal equations, small ridge for collinear
    // fingerprints)
    let n = entries.len();
    let mut joint_reduction = 0.0;
    if n > 0 && rr_all > 0.0 {
        let sens: Vec<_> = entries
            .iter()
            .map(|en| {
                let p = en.probe.as_ref().expect("entries have probes");
                move |m: usize, k: usize, i: usize| p.s(m, k, i)
            })
            .collect();
        let fs: Vec<&dyn Fn(usize, usize, usize) -> f64> = sens
            .iter()
            .map(|f| f as &dyn Fn(usize, usize, usize) -> f64)
            .collect();
        let (gram, gr) = ev.gram(&all, &fs, &r);
        let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
        let mut g = nalgebra::DVector::<f64>::zeros(n);
        for p in 0..n {
            g[p] = gr[p];
            for q in p..n {
                let v = gram[p][q - p];
                a[(p, q)] = v;
                a[(q, p)] = v;
            }
        }
        let ridge = 1e-9 * (0..n).map(|p| a[(p, p)]).fold(0.0, f64::max);
        for p in 0..n {
            a[(p, p)] += ridge.max(1e-300);
        }
        if let Some(sol) = a.cholesky().map(|c| c.solve(&g)) {
            for (j, en) in entries.iter_mut().enumerate() {
                en.joint_change = sol[j];
            }
            joint_reduction = (sol.dot(&g) / rr_all).clamp(0.0, 1.0);
        }
    }
    Screen {
        entries,
        joint_reduction,
    }
}

/// The single-effect least-squares change `δ = ⟨S, r⟩ / ⟨S, S⟩` from `cur` and the share of
/// the SSE `⟨r, r⟩` it removes, `⟨S, r⟩² / (⟨S, S⟩ ⟨r, r⟩)`; a change that leaves the
/// physical domain `[lo, hi]` of `spec` is projected on it and removes
/// `(2δ⟨S, r⟩ − δ²⟨S, S⟩) / ⟨r, r⟩` (at least 0). `(0, 0)` for a zero sensitivity or residual.
/// For a switch the change is not projected (its sign says "on" or "off").
fn projected_fit(sums: ScreenSums, cur: f64, spec: &super::fit_spec::FitSpec) -> (f64, f64) {
    let ScreenSums { ss, sr, rr } = sums;
    if !(ss > 0.0 && rr > 0.0) {
        return (0.0, 0.0);
    }
    let (change, red) = (sr / ss, sr * sr / (ss * rr));
    let target = cur + change;
    if spec.switch || (target >= spec.lo && target <= spec.hi) {
        return (change, red);
    }
    let c = target.clamp(spec.lo, spec.hi) - cur;
    (c, ((2.0 * c * sr - c * c * ss) / rr).max(0.0))
}

/// The share of the weighted train SSE of `p`'s models that the single-effect fit on its
/// sensitivity removes from `cur`, the change projected on the domain of `spec`
/// ([`projected_fit`]): the reduction a rung of the ladder is judged by.
fn single_reduction(
    ev: &Evaluator<'_, '_>,
    p: &Probe,
    r: &impl Fn(usize, usize, usize) -> f64,
    cur: f64,
    spec: &super::fit_spec::FitSpec,
) -> f64 {
    let s = |m: usize, k: usize, i: usize| p.s(m, k, i);
    let sums = ScreenSums {
        ss: ev.inner(&p.active, s, s),
        sr: ev.inner(&p.active, s, r),
        rr: ev.inner(&p.active, r, r),
    };
    projected_fit(sums, cur, spec).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::fit_spec::FitSpec;

    fn spec(lo: f64, hi: f64, switch: bool) -> FitSpec {
        FitSpec {
            step: 1.0,
            lo,
            hi,
            switch,
            grid: None,
            ladder: &[1.0],
        }
    }

    /// The projected single-effect fit: inside the domain the least-squares change and the
    /// squared correlation; at a bound the clamped change and the cost it removes,
    /// `(2δ⟨S, r⟩ − δ²⟨S, S⟩) / ⟨r, r⟩` (exact for a quadratic cost); nothing when the fit
    /// asks to leave the domain from its bound.
    #[test]
    fn the_projected_fit_keeps_the_change_in_the_domain() {
        let sums = ScreenSums {
            ss: 4.0,
            sr: 2.0,
            rr: 2.0,
        };
        // δ = 0.5 inside [0, 1]: reduction ⟨S,r⟩²/(⟨S,S⟩⟨r,r⟩) = 4/8
        assert_eq!(projected_fit(sums, 0.0, &spec(0.0, 1.0, false)), (0.5, 0.5));
        // the domain ends at 0.2: δ = 0.2 removes (2·0.2·2 − 0.04·4)/2 = 0.32
        let (c, red) = projected_fit(sums, 0.0, &spec(0.0, 0.2, false));
        assert_eq!(c, 0.2);
        assert!((red - 0.32).abs() < 1e-15, "{red}");
        // a fit toward less lash from a lash of 0 removes nothing, however well it correlates
        let against = ScreenSums { sr: -2.0, ..sums };
        assert_eq!(
            projected_fit(against, 0.0, &spec(0.0, 1.0, false)),
            (0.0, 0.0)
        );
        // a switch keeps the sign of its coefficient (it says whether the cure helps)
        assert_eq!(
            projected_fit(against, 0.0, &spec(0.0, 1.0, true)),
            (-0.5, 0.5)
        );
        // no sensitivity or no residual: no change
        let flat = ScreenSums { ss: 0.0, ..sums };
        assert_eq!(projected_fit(flat, 0.0, &spec(0.0, 1.0, false)), (0.0, 0.0));
    }
}
