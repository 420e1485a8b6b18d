use super::*;
use nalgebra::{DMatrix, DVector};

/// Rosenbrock's function as least squares: `r = (10 (x₂ − x₁²), 1 − x₁)`, minimum 0 at (1, 1).
struct Rosenbrock {
    trial: Option<Vec<f64>>,
}

fn rosenbrock_residuals(p: &[f64]) -> [f64; 2] {
    [10.0 * (p[1] - p[0] * p[0]), 1.0 - p[0]]
}

impl LeastSquares for Rosenbrock {
    fn normal_equations(&mut self, p: &[f64]) -> Option<NormalEquations> {
        // J = ∂f/∂p = −∂r/∂p
        let j = DMatrix::from_row_slice(2, 2, &[20.0 * p[0], -10.0, 1.0, 0.0]);
        let r = DVector::from_row_slice(&rosenbrock_residuals(p));
        Some(NormalEquations {
            jtj: j.transpose() * &j,
            jtr: j.transpose() * r,
        })
    }

    fn trial(&mut self, p: &[f64]) -> Option<f64> {
        self.trial = Some(p.to_vec());
        Some(rosenbrock_residuals(p).iter().map(|v| v * v).sum())
    }
}

#[test]
fn rosenbrock_converges_and_every_kept_step_lowers_the_cost() {
    let start = [-1.2, 1.0];
    let c0: f64 = rosenbrock_residuals(&start).iter().map(|v| v * v).sum();
    let mut kept = vec![c0];
    let mut observer = |it: &Iteration<'_>| {
        if it.outcome == Outcome::Kept {
            kept.push(it.cost);
        }
    };
    let s = Settings {
        gain_tolerance: 1e-14,
        ..Settings::new(Damping::CLASSICAL, Scaling::Floored(1e-12), 200)
    };
    let r = minimise(
        &mut Rosenbrock { trial: None },
        &start,
        c0,
        &s,
        &mut observer,
    );
    assert!(
        (r.params[0] - 1.0).abs() < 1e-6 && (r.params[1] - 1.0).abs() < 1e-6,
        "{r:?}"
    );
    assert!(r.cost < 1e-12, "{r:?}");
    assert_eq!(kept.len(), r.iterations + 1);
    assert!(kept.windows(2).all(|w| w[1] < w[0]));
}

/// A linear model `f = X p`: normal equations exact, so the first undamped step solves it.
struct Linear {
    x: DMatrix<f64>,
    y: DVector<f64>,
}

impl LeastSquares for Linear {
    fn normal_equations(&mut self, p: &[f64]) -> Option<NormalEquations> {
        let r = &self.y - &self.x * DVector::from_column_slice(p);
        Some(NormalEquations {
            jtj: self.x.transpose() * &self.x,
            jtr: self.x.transpose() * r,
        })
    }

    fn trial(&mut self, p: &[f64]) -> Option<f64> {
        Some((&self.y - &self.x * DVector::from_column_slice(p)).norm_squared())
    }
}

#[test]
fn an_undamped_first_step_solves_a_linear_problem() {
    let x = DMatrix::from_fn(30, 3, |i, j| (i as f64 * 0.1).powi(j as i32));
    let y = DVector::from_fn(30, |i, _| {
        2.0 - 0.5 * (i as f64 * 0.1) + ((i * 7) % 5) as f64 * 0.01
    });
    let mut lin = Linear {
        x: x.clone(),
        y: y.clone(),
    };
    let c0 = y.norm_squared();
    let s = Settings {
        gain_tolerance: 1e-9,
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, 10)
    };
    let r = minimise(&mut lin, &[0.0; 3], c0, &s, &mut Silent);
    let exact = (x.transpose() * &x)
        .cholesky()
        .unwrap()
        .solve(&(x.transpose() * &y));
    for (a, b) in r.params.iter().zip(exact.iter()) {
        assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
    }
    // the second step gains nothing: the first one was exact
    assert!(r.iterations <= 2, "{r:?}");
}

#[test]
fn bounds_hold_and_refused_points_are_never_kept() {
    // min (x − 3)², trial points above 2.5 refused, bounds [0, 10]
    let mut seen_refused = 0;
    let mut problem = ScalarResiduals::new(|x: f64| (x <= 2.5).then(|| vec![3.0 - x]), 1e-4);
    let c0 = problem.start(0.0).unwrap();
    let s = Settings {
        bounds: vec![(0.0, 10.0)],
        step_tolerance: 1e-9,
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, 100)
    };
    let mut observer = |it: &Iteration<'_>| {
        if it.outcome == Outcome::Refused {
            seen_refused += 1;
            assert!(it.params[0] > 2.5);
        }
    };
    let r = minimise(&mut problem, &[0.0], c0, &s, &mut observer);
    assert!(seen_refused > 0);
    assert!(r.params[0] <= 2.5 && r.params[0] > 2.4, "{r:?}");

    // a bound below the minimum: the fit ends on it
    let mut problem = ScalarResiduals::new(|x: f64| Some(vec![3.0 - x]), 1e-4);
    let c0 = problem.start(0.0).unwrap();
    let s = Settings {
        bounds: vec![(0.0, 2.0)],
        step_tolerance: 1e-9,
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, 100)
    };
    let r = minimise(&mut problem, &[0.0], c0, &s, &mut Silent);
    assert_eq!(r.params[0], 2.0);
}

#[test]
fn the_evaluation_budget_is_kept() {
    let mut problem = ScalarResiduals::new(|x: f64| Some(vec![(3.0 - x).powi(3)]), 1e-4);
    let c0 = problem.start(0.0).unwrap();
    let s = Settings {
        max_evaluations: 3,
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, 100)
    };
    let r = minimise(&mut problem, &[0.0], c0, &s, &mut Silent);
    assert_eq!((r.evaluations, r.stop), (3, Stop::Evaluations));
}

#[test]
fn scalar_residuals_recover_an_exponential_rate() {
    let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
    let y: Vec<f64> = t.iter().map(|t| (-0.7 * t).exp()).collect();
    let mut problem = ScalarResiduals::new(
        |k: f64| Some(t.iter().zip(&y).map(|(t, y)| y - (k * t).exp()).collect()),
        1e-6,
    );
    let c0 = problem.start(0.0).unwrap();
    let s = Settings {
        step_tolerance: 1e-12,
        ..Settings::new(Damping::GAUSS_NEWTON_FIRST, Scaling::Marquardt, 50)
    };
    let r = minimise(&mut problem, &[0.0], c0, &s, &mut Silent);
    assert!((r.params[0] + 0.7).abs() < 1e-8, "{r:?}");
}

#[test]
fn golden_section_brackets_the_minimum() {
    // 60 reductions leave a bracket of 0.618⁶⁰ ≈ 3·10⁻¹³, but near a quadratic minimum f is
    // flat to rounding within ≈ √ε ≈ 1.5·10⁻⁸ of it, so the point is only that good
    let (x, fx) = golden_section(|x| (x - 0.3).powi(2) + 1.0, 0.0, 1.0, 60);
    assert!(
        (x - 0.3).abs() < 1e-7 && (fx - 1.0).abs() < 1e-15,
        "{x} {fx}"
    );
    // at the edge of the interval
    // a linear f has no flat part: the bracket's width
    let (x, _) = golden_section(|x| x, 0.0, 1.0, 60);
    assert!(x < 1e-12, "{x}");
}
