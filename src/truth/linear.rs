//! Numerical linearisation of the truth plant and mode extraction — the tools its verification
//! uses (an independent check of the simulated dynamics).
//!
//! - [`jacobian`]: `A = ∂f/∂x` of the plant in its current modes by central differences,
//!   `A[:, j] = (f(x + h_j e_j) − f(x − h_j e_j))/(2 h_j)`, `h_j = 1e-6·max(1, |x_j|)`
//!   (truncation O(h²), round-off O(ε/h) ≈ 1e-10 relative).
//! - [`oscillatory_modes`]: eigenvalues λ = σ ± iω_d of A (nalgebra's real Schur form); each
//!   complex pair gives the natural frequency `f_n = |λ|/2π` (Hz) and damping ratio
//!   `ζ = −σ/|λ|`.
//! - [`fit_damped`]: the same two numbers from a sampled free response, by a second-order
//!   Prony fit with offset: least squares on `y_k = a1·y_{k−1} + a2·y_{k−2} + c`; the roots z of
//!   `z² − a1 z − a2` give `λ = ln(z)/Δt`.

use super::integrator::HybridSystem;
use super::plant::{Plant, State, N};
use nalgebra::{DMatrix, DVector};

/// A mode: natural frequency and damping ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Natural frequency |λ|/2π, Hz.
    pub freq_hz: f64,
    /// Damping ratio −Re λ/|λ|.
    pub damping: f64,
}

/// `∂f/∂x` at `x` in the plant's current modes (module doc).
pub fn jacobian(plant: &Plant, x: &State) -> DMatrix<f64> {
    let mut a = DMatrix::zeros(N, N);
    for j in 0..N {
        let h = 1e-6 * x[j].abs().max(1.0);
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += h;
        xm[j] -= h;
        let fp = plant.derivative(0.0, &xp);
        let fm = plant.derivative(0.0, &xm);
        for i in 0..N {
            a[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    a
}

/// The oscillatory modes of `a` (one per complex pair), by increasing frequency.
pub fn oscillatory_modes(a: &DMatrix<f64>) -> Vec<Mode> {
    let ev = a.clone().complex_eigenvalues();
    let mut out: Vec<Mode> = ev
        .iter()
        .filter(|l| l.im > 1e-6)
        .map(|l| {
            let w = (l.re * l.re + l.im * l.im).sqrt();
            Mode {
                freq_hz: w / std::f64::consts::TAU,
                damping: -l.re / w,
            }
        })
        .collect();
    out.sort_by(|p, q| p.freq_hz.total_cmp(&q.freq_hz));
    out
}

/// Second-order Prony fit of samples `y` spaced `dt` (module doc); `None` if the fit has no
/// complex root pair or is singular.
pub fn fit_damped(y: &[f64], dt: f64) -> Option<Mode> {
    if y.len() < 5 {
        return None;
    }
    let n = y.len() - 2;
    let mut m = DMatrix::zeros(n, 3);
    let mut b = DVector::zeros(n);
    for k in 0..n {
        m[(k, 0)] = y[k + 1];
        m[(k, 1)] = y[k];
        m[(k, 2)] = 1.0;
        b[k] = y[k + 2];
    }
    let sol = m.svd(true, true).solve(&b, 1e-14).ok()?;
    let (a1, a2) = (sol[0], sol[1]);
    let disc = a1 * a1 + 4.0 * a2;
    if disc >= 0.0 {
        return None;
    }
    let re = a1 / 2.0;
    let im = (-disc).sqrt() / 2.0;
    let r = (re * re + im * im).sqrt();
    let sigma = r.ln() / dt;
    let wd = im.atan2(re) / dt;
    let w = (sigma * sigma + wd * wd).sqrt();
    Some(Mode {
        freq_hz: w / std::f64::consts::TAU,
        damping: -sigma / w,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_prony_recovers_a_known_damped_sinusoid() {
        // y = 3 + e^{−ζωt}cos(ω_d t), f_n = 2 Hz, ζ = 0.1, sampled at 20 ms
        let (f, z, dt) = (2.0, 0.1, 0.02);
        let w = std::f64::consts::TAU * f;
        let wd = w * (1.0f64 - z * z).sqrt();
        let y: Vec<f64> = (0..200)
            .map(|k| {
                let t = k as f64 * dt;
                3.0 + (-z * w * t).exp() * (wd * t).cos()
            })
            .collect();
        let m = fit_damped(&y, dt).unwrap();
        // noise-free samples of an exact second-order response: the fit is exact to round-off
        assert!((m.freq_hz - f).abs() < 1e-8 && (m.damping - z).abs() < 1e-8, "{m:?}");
    }
}
