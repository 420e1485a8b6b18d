//! A one-parameter least-squares problem given by its residuals, with the derivative by
//! central differences ([`ScalarResiduals`]).

use super::least_squares::{LeastSquares, NormalEquations};

/// The problem `min_x Σ r_i(x)²` for residuals `r(x)` (`None`: the model refuses `x`), its
/// derivative `dr/dx` by central differences of half-width `h`. The residuals are
/// `y − f(x)` (module conventions of [`super`]), so `J = −dr/dx`.
pub struct ScalarResiduals<F> {
    residuals: F,
    h: f64,
    current: Option<Vec<f64>>,
    trial: Option<Vec<f64>>,
}

impl<F: Fn(f64) -> Option<Vec<f64>>> ScalarResiduals<F> {
    /// The problem of `residuals`, differences of half-width `h` (in `x`'s unit).
    pub fn new(residuals: F, h: f64) -> Self {
        Self {
            residuals,
            h,
            current: None,
            trial: None,
        }
    }

    /// Sets the current point `x`; its sum of squares, `None` when the model refuses it.
    pub fn start(&mut self, x: f64) -> Option<f64> {
        let r = (self.residuals)(x)?;
        let ss = sum_of_squares(&r);
        self.current = Some(r);
        Some(ss)
    }

    /// The residuals at `x`.
    pub fn residuals(&self, x: f64) -> Option<Vec<f64>> {
        (self.residuals)(x)
    }

    /// `dr/dx` at `x` by central differences.
    pub fn derivative(&self, x: f64) -> Option<Vec<f64>> {
        let (rp, rm) = ((self.residuals)(x + self.h)?, (self.residuals)(x - self.h)?);
        Some(
            rp.iter()
                .zip(&rm)
                .map(|(a, b)| (a - b) / (2.0 * self.h))
                .collect(),
        )
    }
}

/// `Σ r_i²`.
pub fn sum_of_squares(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

impl<F: Fn(f64) -> Option<Vec<f64>>> LeastSquares for ScalarResiduals<F> {
    fn normal_equations(&mut self, p: &[f64]) -> Option<NormalEquations> {
        let x = p[0];
        if self.current.is_none() {
            self.current = Some((self.residuals)(x)?);
        }
        let slope = self.derivative(x)?;
        let r = self.current.as_ref()?;
        let jtj: f64 = slope.iter().map(|j| j * j).sum();
        let jtr: f64 = -slope.iter().zip(r).map(|(j, r)| j * r).sum::<f64>();
        Some(NormalEquations::scalar(jtj, jtr))
    }

    fn trial(&mut self, p: &[f64]) -> Option<f64> {
        let r = (self.residuals)(p[0])?;
        let ss = sum_of_squares(&r);
        self.trial = Some(r);
        Some(ss)
    }

    fn accept(&mut self) {
        self.current = self.trial.take();
    }

    fn reject(&mut self) {
        self.trial = None;
    }
}
