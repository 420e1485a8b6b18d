//! The truck's GNSS receiver, as far as the truth logs it: the altitude.
//!
//! # Error model
//! The receiver reads the road's elevation `z(x)` at the truck's travelled distance `x` plus a
//! vertical error that is the sum of two first-order Gauss–Markov processes in time,
//! `e_{k+1} = φ e_k + σ √(1 − φ²) ξ_k`, `φ = exp(−Δt/τ)`, `ξ_k ~ N(0, 1)`, each stationary from
//! the start (`e_0 = σ ξ`):
//! - a slow one ([`ReceiverParams::slow_sigma_m`], [`ReceiverParams::slow_tau_s`]: 2.5 m over
//!   10 min), the satellite geometry and the atmosphere drifting;
//! - a fast one ([`ReceiverParams::fast_sigma_m`], [`ReceiverParams::fast_tau_s`]: 1.0 m over
//!   20 s), multipath near the road.
//!
//! Together 2.7 m, the vertical accuracy a single-frequency automotive receiver without
//! corrections reports in the open (the car drive of the bundled fixtures reads 1–4 m). The bus
//! then adds white noise and quantises ([`altitude_message`]). Horizontal position is not
//! simulated: nothing in the truth depends on it.
//!
//! The slow error is what limits a slope-sensor offset measured against the altitude: over a
//! drive of length `S` a drift `Δe` reads as an offset `Δe / S` (2.5 m over 10 km: 2.5·10⁻⁴ rad).
//!
//! The process and its constants are the truth's own; the synthetic-log generator's receiver
//! ([`crate::synth`]) is a different one (a single process) and is not used here.

use crate::rng::Xoshiro256StarStar;
use crate::synth::can::{CanChannel, CanMessage, Dropouts, TorqueReference};

/// The receiver's vertical error processes (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReceiverParams {
    /// Slow error, σ in m.
    pub slow_sigma_m: f64,
    /// Slow error's time constant, s.
    pub slow_tau_s: f64,
    /// Fast error, σ in m.
    pub fast_sigma_m: f64,
    /// Fast error's time constant, s.
    pub fast_tau_s: f64,
}

impl Default for ReceiverParams {
    /// 2.5 m over 600 s plus 1.0 m over 20 s.
    fn default() -> Self {
        Self {
            slow_sigma_m: 2.5,
            slow_tau_s: 600.0,
            fast_sigma_m: 1.0,
            fast_tau_s: 20.0,
        }
    }
}

/// The receiver's altitude at the truth samples (times `t_s`, travelled distance `x_m`) on the
/// road of elevation `elevation_m` on the grid `k·step_m` (linear between grid points, held
/// beyond the ends), with the errors of `p` drawn from `rng`, m.
pub fn receiver_altitude(
    p: &ReceiverParams,
    step_m: f64,
    elevation_m: &[f64],
    t_s: &[f64],
    x_m: &[f64],
    rng: &mut Xoshiro256StarStar,
) -> Vec<f64> {
    let mut slow = p.slow_sigma_m * rng.standard_normal();
    let mut fast = p.fast_sigma_m * rng.standard_normal();
    let gm = |e: &mut f64, sigma: f64, tau: f64, dt: f64, n: f64| {
        let phi = (-dt / tau).exp();
        *e = phi * *e + sigma * (1.0 - phi * phi).max(0.0).sqrt() * n;
    };
    let mut out = Vec::with_capacity(t_s.len());
    for (i, (&t, &x)) in t_s.iter().zip(x_m).enumerate() {
        if i > 0 {
            let dt = t - t_s[i - 1];
            let (a, b) = (rng.standard_normal(), rng.standard_normal());
            gm(&mut slow, p.slow_sigma_m, p.slow_tau_s, dt, a);
            gm(&mut fast, p.fast_sigma_m, p.fast_tau_s, dt, b);
        }
        out.push(elevation_at(step_m, elevation_m, x) + slow + fast);
    }
    out
}

/// The elevation at `x` on the grid `k·step_m`: linear between points, held beyond the ends.
fn elevation_at(step_m: f64, z: &[f64], x: f64) -> f64 {
    if z.is_empty() {
        return 0.0;
    }
    let f = (x / step_m).max(0.0);
    let k = f.floor() as usize;
    if k + 1 >= z.len() {
        return z[z.len() - 1];
    }
    z[k] + (f - k as f64) * (z[k + 1] - z[k])
}

/// The altitude on the bus: J1939 Vehicle Direction/Speed (VDS, PGN 65256) field `Altitude`
/// (SPN 580: 0.125 m per bit, −2500 … 5531.875 m) at 1 Hz, phase 18 ms, with 0.2 m of white
/// noise on top of the receiver's errors; column `altitude`.
pub fn altitude_message() -> CanMessage {
    CanMessage {
        name: "VDS".into(),
        topic: "/can/vds".into(),
        rate_hz: 1.0,
        phase_s: 0.018,
        dropouts: Dropouts::NONE,
        channels: vec![CanChannel {
            column: "altitude".into(),
            field: "Altitude".into(),
            wire_unit: "m".into(),
            torque_reference: TorqueReference::None,
            resolution: 0.125,
            noise_sigma: 0.2,
            delay_s: 0.0,
            wire_min: -2500.0,
            wire_max: 5531.875,
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_has_the_two_processes_variance_and_follows_the_road() {
        // a flat road at 100 m: the readings are 100 m plus the error
        let p = ReceiverParams::default();
        let n = 200_000;
        let t: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let x = vec![0.0; n];
        let mut rng = Xoshiro256StarStar::seed_from_u64(7);
        let h = receiver_altitude(&p, 1.0, &[100.0, 100.0], &t, &x, &mut rng);
        let e: Vec<f64> = h.iter().map(|v| v - 100.0).collect();
        let var = e.iter().map(|v| v * v).sum::<f64>() / n as f64;
        let want = p.slow_sigma_m.powi(2) + p.fast_sigma_m.powi(2);
        // 200 000 s is 333 slow time constants: the sample variance of a Gauss–Markov process
        // has a relative standard error of about √(2τ/T) = 0.08; 4 of them
        assert!((var / want - 1.0).abs() < 0.32, "{var} vs {want}");
        // the lag-1 s autocorrelation is the variance-weighted mean of exp(−1/τ)
        let c1 = e.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (n - 1) as f64 / var;
        let want1 = (p.slow_sigma_m.powi(2) * (-1.0 / p.slow_tau_s).exp()
            + p.fast_sigma_m.powi(2) * (-1.0 / p.fast_tau_s).exp())
            / want;
        assert!((c1 - want1).abs() < 0.01, "{c1} vs {want1}");
        // without errors the readings are the road's elevation, linear between grid points
        let none = ReceiverParams {
            slow_sigma_m: 0.0,
            fast_sigma_m: 0.0,
            ..p
        };
        let z = [0.0, 2.0, 6.0];
        let h = receiver_altitude(
            &none,
            10.0,
            &z,
            &[0.0, 1.0, 2.0],
            &[5.0, 15.0, 40.0],
            &mut rng,
        );
        assert_eq!(h, vec![1.0, 4.0, 6.0]);
    }
}
