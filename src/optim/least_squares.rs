//! The problem the Levenberg–Marquardt executor ([`super::minimise`]) minimises.

use nalgebra::{DMatrix, DVector};

/// Normal equations of a weighted least-squares problem at a point `p`: `JᵀWJ` and `JᵀW r`,
/// with `r = y − f(p)` the residual and `J = ∂f/∂p`, so that the Gauss–Newton step is
/// `δ = (JᵀWJ)⁻¹ JᵀW r`. Both in the cost's units per parameter unit (squared for `JᵀWJ`).
#[derive(Debug, Clone, PartialEq)]
pub struct NormalEquations {
    /// `JᵀWJ` (n × n, symmetric).
    pub jtj: DMatrix<f64>,
    /// `JᵀW r` (n).
    pub jtr: DVector<f64>,
}

impl NormalEquations {
    /// The one-parameter normal equations `⟨a, a⟩`, `⟨a, r⟩`.
    pub fn scalar(jtj: f64, jtr: f64) -> Self {
        Self {
            jtj: DMatrix::from_element(1, 1, jtj),
            jtr: DVector::from_element(1, jtr),
        }
    }

    /// Whether every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.jtj
            .iter()
            .chain(self.jtr.iter())
            .all(|v| v.is_finite())
    }
}

/// A weighted nonlinear least-squares problem. The executor holds the current point and its
/// cost; the problem forms the normal equations there and evaluates trial points, and is told
/// whether the last trial was kept ([`LeastSquares::accept`]) or discarded
/// ([`LeastSquares::reject`]), so that a problem whose Jacobian is a secant of its evaluations
/// can learn from both.
pub trait LeastSquares {
    /// The normal equations at the current point `p` (the start, or the last accepted trial);
    /// `None` when they cannot be formed (the executor stops).
    fn normal_equations(&mut self, p: &[f64]) -> Option<NormalEquations>;

    /// The cost at the trial point `p`; `None` (or a non-finite cost) when the model does not
    /// accept `p`. The problem keeps what it needs of the trial until the executor accepts or
    /// rejects it.
    fn trial(&mut self, p: &[f64]) -> Option<f64>;

    /// The last trial lowered the cost and becomes the current point.
    fn accept(&mut self) {}

    /// The last trial was evaluated but did not lower the cost.
    fn reject(&mut self) {}
}
