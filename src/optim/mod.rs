//! The optimiser every fit of the crate uses: a weighted nonlinear least-squares problem
//! ([`LeastSquares`]: normal equations at a point, the cost at a trial point), one
//! Levenberg–Marquardt executor ([`minimise`]) with its damping policy and stopping rules
//! ([`Settings`]), an observer hook called after every trial ([`Observer`]), a scalar
//! problem with central-difference derivatives ([`ScalarResiduals`]) and a golden-section
//! search for the bounded scalar refinements ([`golden_section`]).
//!
//! Conventions: the residual is `r = y − f(p)` (measured minus modelled), `J = ∂f/∂p`, the cost
//! is the (weighted) sum or mean of squares, and the Gauss–Newton step is
//! `δ = (JᵀWJ)⁻¹ JᵀW r`. Written here rather than taken from a crate because the fits need what
//! the general solvers do not offer together: a Jacobian that is a secant of re-simulations
//! (each costs a whole drive's simulation, so the executor never evaluates more than the step
//! it tries), trial points the model may refuse (a value that unloads an axle), a bound per
//! parameter and an evaluation budget.

mod golden;
mod least_squares;
mod levenberg_marquardt;
mod scalar;

pub use golden::golden_section;
pub use least_squares::{LeastSquares, NormalEquations};
pub use levenberg_marquardt::{
    minimise, Damping, Iteration, Observer, Outcome, Report, Scaling, Settings, Silent, Stop,
};
pub use scalar::ScalarResiduals;

#[cfg(test)]
mod tests;
