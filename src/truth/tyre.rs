//! Driven-axle tyres of the truth plant: longitudinal slip with a relaxation length, and the
//! tyres' temperature, which sets the rolling resistance.
//!
//! # Longitudinal force (one side, a twin-tyre group)
//! Slip velocity `v_sx = ω_w·r_w − v` (positive when driving). The tyre's longitudinal
//! deflection `u` (m) follows the relaxation-length equation (Pacejka, "Tire and Vehicle
//! Dynamics", Elsevier, §7.2, the "stretched string" first-order model):
//!
//! `u̇ = v_sx − |v|·u/σ`,
//!
//! so in steady rolling `u/σ = v_sx/|v| = κ` (the practical slip), and the transient slip is
//! `κ' = u/σ`. The force is a saturating function of it, linear with the slip stiffness C_κ at
//! small slip and limited by friction:
//!
//! `F_x = µ·F_z·tanh(C_κ·κ'/(µ·F_z)) + d(v)·v_sx`,
//!
//! where `d(v) = d_0·max(0, 1 − |v|/v_low)` is the low-speed damping Pacejka adds (§8.6) because
//! at |v| → 0 the relaxation equation becomes an undamped spring `C_κ/σ`.
//!
//! # Thermal model
//! Lumped temperature rise over ambient `ΔT` of all tyres:
//! `C·dΔT/dt = P_roll − (h0 + h1·|v|)·ΔT`, with the rolling-loss power `P_roll = F_r·|v|` (all
//! of it heats the tyres). The rolling-resistance coefficient falls as the tyres warm:
//! `c_r1(ΔT) = c_r1,warm·max(1 − β, 1 + β·(ΔT_w − ΔT)/ΔT_w)`: cold tyres (ΔT = 0) roll
//! `1 + β` times harder than warm ones (ΔT = ΔT_w). See [`super::params::ThermalParams`].

use super::params::{ThermalParams, TyreParams};

/// Longitudinal force of one side, N, from its deflection `u` (m), slip velocity `v_sx` (m/s)
/// and the vehicle speed `v` (m/s).
pub fn force(t: &TyreParams, u: f64, v_sx: f64, v: f64) -> f64 {
    let fmax = t.mu * t.fz_n;
    let kappa = u / t.relaxation_m;
    let d = t.low_speed_damping_n_s_per_m * (1.0 - v.abs() / t.low_speed_mps).max(0.0);
    fmax * (t.slip_stiffness_n * kappa / fmax).tanh() + d * v_sx
}

/// Rate of the deflection, m/s.
pub fn deflection_rate(t: &TyreParams, u: f64, v_sx: f64, v: f64) -> f64 {
    v_sx - v.abs() * u / t.relaxation_m
}

/// Thermal factor on the warm rolling-resistance coefficient at temperature rise `dt_k`.
pub fn rolling_factor(th: &ThermalParams, dt_k: f64) -> f64 {
    let b = th.cold_excess;
    (1.0 + b * (th.warm_rise_k - dt_k) / th.warm_rise_k).max(1.0 - b)
}

/// Rate of the temperature rise, K/s, for rolling-loss power `p_roll_w` at speed `v`.
pub fn temperature_rate(th: &ThermalParams, dt_k: f64, p_roll_w: f64, v: f64) -> f64 {
    (p_roll_w - (th.h0_w_per_k + th.h1_w_per_k_m_s * v.abs()) * dt_k) / th.heat_capacity_j_per_k
}

#[cfg(test)]
mod tests {
    use super::*;

    fn th() -> ThermalParams {
        ThermalParams {
            heat_capacity_j_per_k: 1.26e6,
            h0_w_per_k: 300.0,
            h1_w_per_k_m_s: 45.0,
            warm_rise_k: 40.0,
            cold_excess: 0.2,
        }
    }

    #[test]
    fn truth_tyre_cold_rolls_harder_and_steady_slip_is_kappa() {
        let th = th();
        assert!((rolling_factor(&th, 0.0) - 1.2).abs() < 1e-12);
        assert!((rolling_factor(&th, 40.0) - 1.0).abs() < 1e-12);
        let t = TyreParams {
            fz_n: 56_000.0,
            slip_stiffness_n: 560_000.0,
            relaxation_m: 0.6,
            mu: 0.8,
            low_speed_damping_n_s_per_m: 1.0e4,
            low_speed_mps: 3.0,
        };
        // steady state u̇ = 0 at v = 20 m/s, v_sx = 0.02 m/s: κ = 0.001, u = σκ
        let u = 0.6 * 0.001;
        assert!(deflection_rate(&t, u, 0.02, 20.0).abs() < 1e-15);
        // small slip: F ≈ C_κ·κ = 560 N (tanh(0.0125) differs by 5e-5 relative)
        assert!((force(&t, u, 0.02, 20.0) - 560.0).abs() < 0.1);
        // saturation at µF_z
        assert!(force(&t, 0.6, 0.0, 20.0) <= 0.8 * 56_000.0);
    }
}
