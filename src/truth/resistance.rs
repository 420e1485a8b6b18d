//! Driving resistances of the truth plant and the wind process.
//!
//! # Conventions
//! Forces in N, positive **against** forward motion; speeds in m/s, forward positive; slope
//! angle α positive uphill. For a moving truck (v > 0, the plant stops it at v = 0):
//!
//! - aerodynamic drag through the **air speed** `v_a = v + w` (w > 0 a headwind):
//!   `F_a = ½·ρ·c_w·A_f·v_a·|v_a|`;
//! - rolling resistance `F_r = (c_r1·φ_T(ΔT)·φ_s(x) + c_r2·v)·m·g·cos α`, with the tyre thermal
//!   factor φ_T ([`super::tyre::rolling_factor`]) and a surface factor φ_s (1, or more on a wet
//!   or broken stretch);
//! - grade `F_g = m·g·sin α`.
//!
//! # Wind
//! `w(t) = w̄ + w_g(t)`: a mean head/tail wind w̄ drawn per drive, uniform on ±4 m/s (the
//! along-road component of a 3–5 m/s mean wind at 2 m height, typical of Sweden), plus gusts as
//! first-order-filtered white noise (an Ornstein–Uhlenbeck process) of standard deviation
//! σ_g = 1.0 m/s and time constant τ_g = 5 s (turbulence intensity ≈ 20–30 % of the mean wind;
//! the time scale of gusts seen by a truck at road speed). Sampled exactly on a grid of `dt`:
//! `w_g[k+1] = a·w_g[k] + σ_g·√(1 − a²)·N(0,1)`, `a = exp(−dt/τ_g)`; held between samples.

use crate::rng::Xoshiro256StarStar;

/// Aerodynamic drag at vehicle speed `v` and headwind `w`, N.
pub fn aero(rho: f64, cwa: f64, v: f64, w: f64) -> f64 {
    let va = v + w;
    0.5 * rho * cwa * va * va.abs()
}

/// Rolling resistance, N: `(c_r1_eff + c_r2·v)·m·g·cos α`.
pub fn rolling(c_r1_eff: f64, c_r2: f64, v: f64, m: f64, g: f64, cos_a: f64) -> f64 {
    (c_r1_eff + c_r2 * v.abs()) * m * g * cos_a
}

/// Wind parameters (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindParams {
    /// Mean headwind w̄, m/s (negative: tailwind).
    pub mean_mps: f64,
    /// Gust standard deviation σ_g, m/s.
    pub gust_sigma_mps: f64,
    /// Gust time constant τ_g, s.
    pub gust_tau_s: f64,
}

impl WindParams {
    /// Bound of the mean wind draw, m/s.
    pub const MEAN_BOUND_MPS: f64 = 4.0;

    /// Draws a drive's wind: mean uniform on ±4 m/s, σ_g = 1 m/s, τ_g = 5 s.
    pub fn draw(rng: &mut Xoshiro256StarStar) -> Self {
        Self {
            mean_mps: rng.uniform(-Self::MEAN_BOUND_MPS, Self::MEAN_BOUND_MPS),
            gust_sigma_mps: 1.0,
            gust_tau_s: 5.0,
        }
    }

    /// No wind at all.
    pub fn calm() -> Self {
        Self {
            mean_mps: 0.0,
            gust_sigma_mps: 0.0,
            gust_tau_s: 5.0,
        }
    }
}

/// The wind process sampled on a grid.
#[derive(Debug, Clone)]
pub struct Wind {
    p: WindParams,
    a: f64,
    gust: f64,
    rng: Xoshiro256StarStar,
}

impl Wind {
    /// A wind process stepped every `dt_s`, starting from a stationary gust draw.
    pub fn new(p: WindParams, dt_s: f64, mut rng: Xoshiro256StarStar) -> Self {
        let gust = p.gust_sigma_mps * rng.standard_normal();
        Self {
            p,
            a: (-dt_s / p.gust_tau_s).exp(),
            gust,
            rng,
        }
    }

    /// Current headwind, m/s.
    pub fn now(&self) -> f64 {
        self.p.mean_mps + self.gust
    }

    /// Advances the gust by one grid step.
    pub fn step(&mut self) {
        let n = self.rng.standard_normal();
        self.gust = self.a * self.gust + self.p.gust_sigma_mps * (1.0 - self.a * self.a).sqrt() * n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_wind_gusts_have_the_stated_variance() {
        let p = WindParams {
            mean_mps: 2.0,
            gust_sigma_mps: 1.0,
            gust_tau_s: 5.0,
        };
        let mut w = Wind::new(p, 0.1, Xoshiro256StarStar::seed_from_u64(7));
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            w.step();
            let g = w.now() - 2.0;
            s += g;
            s2 += g * g;
        }
        let var = s2 / n as f64 - (s / n as f64).powi(2);
        // 20 000 s of a 5 s process: ~2000 independent samples, so the variance estimate has a
        // relative standard error ≈ √(2/2000) ≈ 3 %; 15 % is five of them
        assert!((var - 1.0).abs() < 0.15, "gust variance {var}");
        // headwind drag: 20 m/s + 5 m/s headwind = 25 m/s air speed
        assert!((aero(1.2, 5.0, 20.0, 5.0) - 0.5 * 1.2 * 5.0 * 625.0).abs() < 1e-9);
        assert!(aero(1.2, 5.0, 2.0, -5.0) < 0.0, "a strong tailwind pushes");
    }
}
