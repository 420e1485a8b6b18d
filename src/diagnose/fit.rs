//! The full fit of step 3 of the diagnosis, explain (docs/diagnosis/method.md; [`super::explain`]
//! runs it): one catalogue effect's parameter fitted by Levenberg–Marquardt on the re-simulated
//! extended model ([`fit_effect`]).
//!
//! # The parts
//! The screen that picks the candidates: [`super::screen`]. Steps, domains and start grids:
//! [`super::fit_spec`]. The models at a round's parameters, the cost and the deviance:
//! [`super::evaluator`]. The 95 % interval: [`super::fit_interval`], its thresholds
//! [`super::deviance`].
//!
//! # Full fit
//! Levenberg–Marquardt on the one scalar parameter (accepted ones held), minimising the
//! weighted train mean square by re-simulating the extended model — so the hybrid simulation
//! switches clutch modes and gears itself (mode-aware for `clutch_slip`). The Jacobian is the
//! secant of the last two simulated points (in one dimension Broyden's update is exact; the
//! first secant is the screen's finite difference, or in later rounds a simulation at the
//! screen's estimate), the step `δ = ⟨a, r⟩ / (⟨a, a⟩ (1 + λ))` is clamped to the physical
//! domain, λ falls ×¼ on success and rises ×4 (at least to ½) on failure; at most
//! [`MAX_FIT_EVALUATIONS`] simulations, stopping when a step is below 10⁻³ of `h_e` or
//! improves the cost by less than 10⁻⁶ relative. A value the model rejects (a CG shift that
//! unloads an axle) counts as a failed step.
//!
//! `signal_delay` and `clutch_slip` start from the best point of a grid ([`DELAY_GRID_S`](crate::model::catalogue::DELAY_GRID_S):
//! 0 … 0.6 s in 25 ms steps; [`CLUTCH_GRID`](crate::model::catalogue::CLUTCH_GRID): 50 … 100 % of the nominal capacity in 1.5 %
//! steps; the costs in parallel) when that beats the base and the screen's probe: their costs
//! have side basins (a delay's about 0.05 s wide, a clutch's about 3 % of its capacity), in
//! which the secant from the probe stops.
//!
//! The cost reads the train part alone, so the start grid's points, the trials and the
//! interval's probes simulate the longitudinal model on the train windows only
//! ([`Evaluator::eval_train`]: the same train outputs, bit for bit, for about half the
//! simulation); the fitted point is simulated once more on every row, as the acceptance rule
//! reads its held-out part, and that simulation is counted in `FitResult::evaluations`.
//!
//! Values in the parameter's SI unit; the cost is the weighted train mean square
//! (dimensionless).

use super::problem::Part;
use crate::model::catalogue::Effect;
use crate::optim::{minimise, Damping, LeastSquares, NormalEquations, Scaling, Settings, Silent};

pub use super::deviance::{deviance_threshold, events_deviance, CHI2_1_95};
pub use super::evaluator::{Active, Eval, Evaluator, ModelView, MATERIAL_CHANGE_MS};
pub use super::fit_interval::{profile_interval, Interval, MAX_CI_EVALUATIONS};
pub use super::fit_spec::{applicable, fit_spec, FitSpec};
pub use super::screen::{screen, Probe, Screen, ScreenEntry, MAX_FULL_FITS, SCREEN_MIN_REDUCTION};

/// Most simulations of one Levenberg–Marquardt fit.
pub const MAX_FIT_EVALUATIONS: usize = 8;

/// Result of one full fit.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// Fitted simulation.
    pub best: Eval,
    /// Simulations used.
    pub evaluations: usize,
    /// Gauss–Newton curvature `⟨a, a⟩` at the end (cost units per parameter unit²).
    pub curvature: f64,
    /// Cluster-robust effective sample count and the number of train blocks, when defined.
    pub cluster: Option<(f64, usize)>,
}

/// Levenberg–Marquardt fit of `e`'s parameter (module documentation) on the models of
/// `active`, from the round's value (`base`, its `value` set), the first secant through the
/// screen's probe when it was taken this round, else through a simulation at the screen's
/// single-effect estimate `start` (the physical step when that is no change); with a start
/// grid ([`FitSpec::grid`]) from its best point when that is lower, the secant through its
/// better neighbour. `FitResult::evaluations` counts the grid's simulations too.
pub fn fit_effect(
    ev: &Evaluator<'_, '_>,
    e: Effect,
    base: &Eval,
    entry: &ScreenEntry,
) -> FitResult {
    let spec = fit_spec(e, ev.problem.nominal().get(e), ev.problem.slope_step());
    let active = entry.active();
    let cost = |x: &Eval| ev.cost(x, active, Part::Train);
    let mut evaluations = 0;
    let first = match entry.probe.as_ref() {
        Some(p) if p.fresh => Some(ev.eval_outputs(base.value + p.h, p.outputs.clone())),
        _ => {
            let c = if entry.single_change != 0.0 {
                entry.single_change
            } else {
                entry.step
            };
            let v = (base.value + c).clamp(spec.lo, spec.hi);
            evaluations += 1;
            ev.eval_train(base, active, e, v)
                .ok()
                .filter(|x| cost(x).is_finite())
        }
    };
    let Some(probe) = first else {
        return FitResult {
            best: base.clone(),
            evaluations,
            curvature: 0.0,
            cluster: None,
        };
    };
    let probe = &probe;
    if spec.switch {
        let best = if cost(probe) < cost(base) {
            evaluations += usize::from(probe.train_only);
            whole(ev, base, active, e, probe.clone()).unwrap_or_else(|| base.clone())
        } else {
            base.clone()
        };
        return FitResult {
            best,
            evaluations,
            curvature: 0.0,
            cluster: None,
        };
    }
    let (mut cur, mut other) = if cost(probe) < cost(base) {
        (probe.clone(), base.clone())
    } else {
        (base.clone(), probe.clone())
    };
    // a start grid: the best grid point becomes the start when it beats the base and the
    // probe, its better neighbour the other end of the first secant (the grid's costs are
    // computed in parallel and only the two kept points simulated again, so no grid of outputs
    // is held; ties go to the lower value)
    let mut grid_evaluations = 0;
    if let Some([grid_lo, grid_hi, grid_step]) = spec.grid {
        use rayon::prelude::*;
        let grid_lo = grid_lo.max(spec.lo);
        // the end included (0.6 / 0.025 is 23.999… in binary)
        let n = ((grid_hi.min(spec.hi) - grid_lo) / grid_step + 1e-9).floor() as usize + 1;
        let costs: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|k| {
                ev.eval_train(base, active, e, grid_lo + k as f64 * grid_step)
                    .map_or(f64::INFINITY, |x| cost(&x))
            })
            .collect();
        grid_evaluations = n;
        let best = (0..n)
            .filter(|&k| costs[k].is_finite())
            .min_by(|&a, &b| costs[a].total_cmp(&costs[b]).then(a.cmp(&b)));
        if let Some(k) = best.filter(|&k| costs[k] < cost(&cur)) {
            let neighbour = match (k.checked_sub(1), (k + 1 < n).then_some(k + 1)) {
                (Some(a), Some(b)) => Some(if costs[a] <= costs[b] { a } else { b }),
                (a, b) => a.or(b),
            };
            let at = |j: usize| {
                ev.eval_train(base, active, e, grid_lo + j as f64 * grid_step)
                    .ok()
            };
            if let Some(x) = at(k) {
                grid_evaluations += 1;
                if let Some(y) = neighbour.and_then(at) {
                    grid_evaluations += 1;
                    other = y;
                }
                cur = x;
            }
        }
    }
    let settings = Settings {
        bounds: vec![(spec.lo, spec.hi)],
        step_tolerance: 1e-3 * spec.step.abs(),
        gain_tolerance: 1e-6,
        max_evaluations: MAX_FIT_EVALUATIONS.saturating_sub(evaluations),
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, usize::MAX)
    };
    let start_cost = cost(&cur);
    let start = [cur.value];
    let mut secant = SecantFit {
        ev,
        base,
        active,
        effect: e,
        cur,
        other,
        trial: None,
        curvature: 0.0,
    };
    let report = minimise(&mut secant, &start, start_cost, &settings, &mut Silent);
    evaluations += report.evaluations;
    let SecantFit {
        cur,
        other,
        curvature,
        ..
    } = secant;
    // the cluster-robust sample count with the last secant
    let dp = cur.value - other.value;
    let cluster = if dp != 0.0 {
        let a = |m: usize, k: usize, i: usize| (cur.outputs[m][k][i] - other.outputs[m][k][i]) / dp;
        ev.cluster_n_eff(&cur, active, a)
    } else {
        None
    };
    let evaluations = evaluations + grid_evaluations + usize::from(cur.train_only);
    match whole(ev, base, active, e, cur) {
        Some(best) => FitResult {
            best,
            evaluations,
            curvature,
            cluster,
        },
        None => FitResult {
            best: base.clone(),
            evaluations,
            curvature: 0.0,
            cluster: None,
        },
    }
}

/// `x` on every row: a train-only evaluation ([`Evaluator::eval_train`]) simulated once more
/// whole, as the acceptance rule reads its held-out part (the train part comes out the same,
/// bit for bit); `None` when a window the train part does not read fails, and the fit then
/// stays at the base.
fn whole(ev: &Evaluator<'_, '_>, base: &Eval, active: &[bool], e: Effect, x: Eval) -> Option<Eval> {
    if x.train_only {
        ev.eval(base, active, e, x.value).ok()
    } else {
        Some(x)
    }
}

/// The one-parameter fit as a least-squares problem: the Jacobian is the secant through the
/// current point and the last other simulated one (a trial that does not lower the cost
/// replaces the other end, so the next secant is shorter), the cost the weighted train mean
/// square.
struct SecantFit<'a, 'p, 'b> {
    ev: &'a Evaluator<'p, 'b>,
    base: &'a Eval,
    active: &'a [bool],
    effect: Effect,
    cur: Eval,
    other: Eval,
    trial: Option<Eval>,
    /// `⟨a, a⟩` of the last secant.
    curvature: f64,
}

impl LeastSquares for SecantFit<'_, '_, '_> {
    fn normal_equations(&mut self, _: &[f64]) -> Option<NormalEquations> {
        let (cur, other) = (&self.cur, &self.other);
        let dp = cur.value - other.value;
        if dp == 0.0 {
            return None;
        }
        let a = |m: usize, k: usize, i: usize| (cur.outputs[m][k][i] - other.outputs[m][k][i]) / dp;
        let r = self.ev.resid(cur);
        let (h, g) = (
            self.ev.inner(self.active, a, a),
            self.ev.inner(self.active, a, r),
        );
        self.curvature = h;
        Some(NormalEquations::scalar(h, g))
    }

    fn trial(&mut self, p: &[f64]) -> Option<f64> {
        self.trial = None;
        let t = self
            .ev
            .eval_train(self.base, self.active, self.effect, p[0])
            .ok()?;
        let c = self.ev.cost(&t, self.active, Part::Train);
        self.trial = Some(t);
        Some(c)
    }

    fn accept(&mut self) {
        if let Some(t) = self.trial.take() {
            self.other = std::mem::replace(&mut self.cur, t);
        }
    }

    fn reject(&mut self) {
        if let Some(t) = self.trial.take() {
            self.other = t;
        }
    }
}
