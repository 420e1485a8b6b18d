//! Numerical linearisation of the truth plant and mode extraction — the tools its verification
//! uses (an independent check of the simulated dynamics).
//!
//! - [`jacobian`]: `A = ∂f/∂x` of the plant in its current modes by central differences,
//!   `A[:, j] = (f(x + h_j e_j) − f(x − h_j e_j))/(2 h_j)`, `h_j = 1e-6·max(1, |x_j|)`
//!   (truncation O(h²), round-off O(ε/h) ≈ 1e-10 relative).
//! - [`oscillatory_modes`]: eigenvalues λ = σ ± iω_d of A (nalgebra's real Schur form); each
//!   complex pair gives the natural frequency `f_n = |λ|/2π` (Hz) and damping ratio
//!   `ζ = −σ/|λ|`.
//! - [`fit_damped`] / [`fit_modes`]: the same numbers from a sampled free response, by a Prony
//!   fit of order n with offset (Prony 1795; Hildebrand, "Introduction to Numerical Analysis",
//!   McGraw-Hill, §9.4): least squares on `y_k = a1·y_{k−1} + … + an·y_{k−n} + c`; the roots z
//!   of `zⁿ − a1 zⁿ⁻¹ − … − an` (companion-matrix eigenvalues) give `λ = ln(z)/Δt`. Order 2
//!   fits one damped oscillation; a higher order also absorbs slow real modes (e.g. the tyre
//!   relaxation, rate |v|/σ) that would otherwise bias it.

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
    fit_modes(y, dt, 2).into_iter().next()
}

/// Prony fit of order `order` of samples `y` spaced `dt` (module doc): the oscillatory modes
/// found (one per complex root pair), by increasing frequency; empty if singular or too short.
pub fn fit_modes(y: &[f64], dt: f64, order: usize) -> Vec<Mode> {
    if order == 0 || y.len() < 3 * order + 2 {
        return Vec::new();
    }
    let n = y.len() - order;
    let mut m = DMatrix::zeros(n, order + 1);
    let mut b = DVector::zeros(n);
    for k in 0..n {
        for i in 0..order {
            m[(k, i)] = y[k + order - 1 - i];
        }
        m[(k, order)] = 1.0;
        b[k] = y[k + order];
    }
    let Ok(sol) = m.svd(true, true).solve(&b, 1e-14) else {
        return Vec::new();
    };
    // companion matrix of z^n − a1 z^(n−1) − … − an
    let mut c = DMatrix::zeros(order, order);
    for i in 0..order {
        c[(0, i)] = sol[i];
        if i + 1 < order {
            c[(i + 1, i)] = 1.0;
        }
    }
    let mut out: Vec<Mode> = c
        .complex_eigenvalues()
        .iter()
        .filter(|z| z.im > 1e-12)
        .map(|z| {
            let r = (z.re * z.re + z.im * z.im).sqrt();
            let sigma = r.ln() / dt;
            let wd = z.im.atan2(z.re) / dt;
            let w = (sigma * sigma + wd * wd).sqrt();
            Mode {
                freq_hz: w / std::f64::consts::TAU,
                damping: -sigma / w,
            }
        })
        .collect();
    out.sort_by(|p, q| p.freq_hz.total_cmp(&q.freq_hz));
    out
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
        assert!(
            (m.freq_hz - f).abs() < 1e-8 && (m.damping - z).abs() < 1e-8,
            "{m:?}"
        );
    }
}
