//! The Levenberg–Marquardt executor ([`minimise`]): damped Gauss–Newton steps
//! `(JᵀWJ + λ D) δ = JᵀW r`, `D` the diagonal scaling of [`Scaling`], each step clamped to the
//! parameters' bounds and kept only when it lowers the cost; the damping `λ` falls after a kept
//! step and rises after a refused one ([`Damping`]).

use super::least_squares::{LeastSquares, NormalEquations};
use nalgebra::DVector;

/// How the damping enters the normal equations' diagonal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scaling {
    /// Marquardt's form `A_dd = (1 + λ) (JᵀWJ)_dd`; a diagonal entry that is not positive stops
    /// the executor (no curvature along that parameter).
    Marquardt,
    /// `A_dd = (JᵀWJ)_dd + λ max((JᵀWJ)_dd, floor)`: a parameter with no curvature is still
    /// damped by `λ · floor`.
    Floored(f64),
}

/// The damping policy. After a kept step `λ ← 0` when `λ < zero_below`, else
/// `λ ← max(λ / decrease, min)`; after a refused step (worse, refused by the model, or a
/// damped system that is not positive definite) `λ ← max(λ · increase, increase_floor)`, and
/// the executor stops once `λ ≥ max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damping {
    /// `λ` of the first step (0: a plain Gauss–Newton step).
    pub initial: f64,
    /// Factor after a refused step.
    pub increase: f64,
    /// Least `λ` after a refused step (so that a refusal at `λ = 0` damps).
    pub increase_floor: f64,
    /// Divisor after a kept step.
    pub decrease: f64,
    /// Below this a kept step returns to `λ = 0`.
    pub zero_below: f64,
    /// Least `λ` after a kept step.
    pub min: f64,
    /// The executor stops when `λ` reaches this.
    pub max: f64,
}

impl Damping {
    /// Gauss–Newton first: `λ = 0` until a step is refused, ×4 up (at least to ½), ÷4 down and
    /// back to 0 below 10⁻³, stop at 10⁶. For fits that pay a simulation per evaluation.
    pub const GAUSS_NEWTON_FIRST: Damping = Damping {
        initial: 0.0,
        increase: 4.0,
        increase_floor: 0.5,
        decrease: 4.0,
        zero_below: 1e-3,
        min: 0.0,
        max: 1e6,
    };

    /// The classical policy: `λ = 10⁻³` at the start, ×10 up, ÷10 down (not below 10⁻¹²), stop
    /// at 10¹².
    pub const CLASSICAL: Damping = Damping {
        initial: 1e-3,
        increase: 10.0,
        increase_floor: 0.0,
        decrease: 10.0,
        zero_below: 0.0,
        min: 1e-12,
        max: 1e12,
    };

    fn after_kept(&self, lambda: f64) -> f64 {
        if lambda < self.zero_below {
            0.0
        } else {
            (lambda / self.decrease).max(self.min)
        }
    }

    fn after_refused(&self, lambda: f64) -> f64 {
        (lambda * self.increase).max(self.increase_floor)
    }
}

/// Settings of one minimisation.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Damping policy.
    pub damping: Damping,
    /// Diagonal scaling.
    pub scaling: Scaling,
    /// Per-parameter bounds `(lo, hi)` every trial point is clamped to; empty: unbounded.
    pub bounds: Vec<(f64, f64)>,
    /// Stop before evaluating a (clamped) step whose largest component is below this, in the
    /// parameters' units.
    pub step_tolerance: f64,
    /// Stop after a kept step that lowers the cost by less than this, relative.
    pub gain_tolerance: f64,
    /// Most kept steps.
    pub max_iterations: usize,
    /// Most cost evaluations (trials).
    pub max_evaluations: usize,
}

impl Settings {
    /// Unbounded, no tolerances, no limits but `max_iterations` kept steps.
    pub fn new(damping: Damping, scaling: Scaling, max_iterations: usize) -> Self {
        Self {
            damping,
            scaling,
            bounds: Vec::new(),
            step_tolerance: 0.0,
            gain_tolerance: 0.0,
            max_iterations,
            max_evaluations: usize::MAX,
        }
    }
}

/// What became of a trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// It lowered the cost and is the current point.
    Kept,
    /// It was evaluated and did not lower the cost.
    Worse,
    /// The model refused it (no cost or a non-finite one).
    Refused,
}

/// One trial, as the observer sees it.
#[derive(Debug, Clone, Copy)]
pub struct Iteration<'a> {
    /// Evaluations so far, this one included.
    pub evaluations: usize,
    /// The trial point.
    pub params: &'a [f64],
    /// Its cost (NaN when refused).
    pub cost: f64,
    /// The damping it was computed with.
    pub lambda: f64,
    /// What became of it.
    pub outcome: Outcome,
}

/// Called after every trial.
pub trait Observer {
    /// One trial.
    fn observe(&mut self, it: &Iteration<'_>);
}

/// The observer that does nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Observer for Silent {
    fn observe(&mut self, _: &Iteration<'_>) {}
}

impl<F: FnMut(&Iteration<'_>)> Observer for F {
    fn observe(&mut self, it: &Iteration<'_>) {
        self(it)
    }
}

/// Why the executor stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// A kept step gained less than [`Settings::gain_tolerance`].
    Converged,
    /// The next step was below [`Settings::step_tolerance`].
    SmallStep,
    /// The normal equations could not be formed, were not finite, or (with
    /// [`Scaling::Marquardt`]) had no curvature along a parameter.
    NoCurvature,
    /// The damping reached [`Damping::max`].
    Damping,
    /// [`Settings::max_iterations`] kept steps.
    Iterations,
    /// [`Settings::max_evaluations`] trials.
    Evaluations,
}

/// Result of [`minimise`].
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The last kept point (the start when no step was kept).
    pub params: Vec<f64>,
    /// Its cost.
    pub cost: f64,
    /// Trials evaluated.
    pub evaluations: usize,
    /// Steps kept.
    pub iterations: usize,
    /// The damping at the end.
    pub lambda: f64,
    /// Why it stopped.
    pub stop: Stop,
}

/// The damped step, or `None` when the damped system is not positive definite.
fn damped_step(ne: &NormalEquations, lambda: f64, scaling: Scaling) -> Option<DVector<f64>> {
    let mut a = ne.jtj.clone();
    for d in 0..a.nrows() {
        let j = ne.jtj[(d, d)];
        a[(d, d)] = match scaling {
            Scaling::Marquardt => j * (1.0 + lambda),
            Scaling::Floored(floor) => j + lambda * j.max(floor),
        };
    }
    if a.nrows() == 1 {
        let h = a[(0, 0)];
        return (h > 0.0).then(|| DVector::from_element(1, ne.jtr[0] / h));
    }
    a.cholesky().map(|c| c.solve(&ne.jtr))
}

/// Minimises `problem` from `start` (cost `start_cost`) by Levenberg–Marquardt (module
/// documentation): each iteration forms the normal equations at the current point, solves the
/// damped system, clamps the point to [`Settings::bounds`], and evaluates it; a trial that
/// lowers the cost is kept. `observer` sees every trial. Deterministic: the only arithmetic is
/// the problem's and the damped solve.
pub fn minimise<P, O>(
    problem: &mut P,
    start: &[f64],
    start_cost: f64,
    s: &Settings,
    observer: &mut O,
) -> Report
where
    P: LeastSquares + ?Sized,
    O: Observer + ?Sized,
{
    let mut p = start.to_vec();
    let mut cost = start_cost;
    let mut lambda = s.damping.initial;
    let (mut evaluations, mut iterations) = (0, 0);
    let stop = loop {
        if evaluations >= s.max_evaluations {
            break Stop::Evaluations;
        }
        if iterations >= s.max_iterations {
            break Stop::Iterations;
        }
        let Some(ne) = problem.normal_equations(&p) else {
            break Stop::NoCurvature;
        };
        let flat = matches!(s.scaling, Scaling::Marquardt)
            && (0..ne.jtj.nrows()).any(|d| ne.jtj[(d, d)] <= 0.0);
        if !ne.is_finite() || flat {
            break Stop::NoCurvature;
        }
        let Some(delta) = damped_step(&ne, lambda, s.scaling) else {
            lambda = s.damping.after_refused(lambda);
            if lambda >= s.damping.max {
                break Stop::Damping;
            }
            continue;
        };
        let q: Vec<f64> = p
            .iter()
            .zip(delta.iter())
            .enumerate()
            .map(|(i, (x, d))| {
                let v = x + d;
                s.bounds.get(i).map_or(v, |&(lo, hi)| v.clamp(lo, hi))
            })
            .collect();
        let largest = p
            .iter()
            .zip(&q)
            .map(|(a, b)| (b - a).abs())
            .fold(0.0, f64::max);
        if largest < s.step_tolerance {
            break Stop::SmallStep;
        }
        evaluations += 1;
        let tried = problem.trial(&q).filter(|c| c.is_finite());
        let outcome = match tried {
            Some(c) if c < cost => Outcome::Kept,
            Some(_) => Outcome::Worse,
            None => Outcome::Refused,
        };
        observer.observe(&Iteration {
            evaluations,
            params: &q,
            cost: tried.unwrap_or(f64::NAN),
            lambda,
            outcome,
        });
        match (outcome, tried) {
            (Outcome::Kept, Some(c)) => {
                let gain = (cost - c) / cost.max(1e-300);
                problem.accept();
                p = q;
                cost = c;
                iterations += 1;
                lambda = s.damping.after_kept(lambda);
                if gain < s.gain_tolerance {
                    break Stop::Converged;
                }
            }
            _ => {
                if outcome == Outcome::Worse {
                    problem.reject();
                }
                lambda = s.damping.after_refused(lambda);
                if lambda >= s.damping.max {
                    break Stop::Damping;
                }
            }
        }
    };
    Report {
        params: p,
        cost,
        evaluations,
        iterations,
        lambda,
        stop,
    }
}
