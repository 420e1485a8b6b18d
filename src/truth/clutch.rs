//! Dry clutch and clutch-disc torsional damper of the truth plant.
//!
//! # Friction clutch
//! Actuator travel `x` (0 = engaged, 1 = open; the CAN `clutch_position`) saturated to the
//! effective range: `x_eff = clamp(x, L_l, L_u)`; kinetic capacity
//! `M_k = M_k,max·(L_u − x_eff)/(L_u − L_l)`, static capacity `M_s = k_µ·M_k` (the actuator law of
//! docs/models/driveline.md; M_k,max is the plant's own capacity, so a worn clutch has a smaller
//! one than the AMT believes). Modes (switches are located events of the integrator, never
//! smoothed):
//! - **locked**: engine and disc turn together; the friction interface carries
//!   `M_tr = (M_e·J_c + M_d·J_e)/(J_e + J_c)` (M_d the damper torque); it breaks away when
//!   `|M_tr| > M_s` (guards `M_s ∓ M_tr`), into slip with direction `sign(M_tr)`;
//! - **slipping** with direction `s = ±1`: the interface carries `s·M_k`; when the slip speed
//!   `s·(ω_e − ω_c)` reaches 0 the clutch locks if `|M_tr| ≤ M_s`, else the slip reverses.
//!
//! # Damper (two-stage spring with friction hysteresis)
//! Twist `φ = θ_c − θ_in` (disc hub ahead of the input shaft: positive when driving). Spring:
//! stage 1 `M = k1·φ` for `|φ| ≤ θ1`; stage 2 `M = sign(φ)·(k1·θ1 + k2·(|φ| − θ1))`. The stage
//! is a mode with its own guard (the stiffness jump is located, not smoothed). Hysteresis:
//! Coulomb friction of the friction washers `T_h·tanh(φ̇/ω_h)` (regularised by a stiff tanh of
//! documented width ω_h, see [`super::params::DamperParams`]), plus a small viscous part `c·φ̇`.
//! Damper torque `M_d = spring(φ) + c·φ̇ + T_h·tanh(φ̇/ω_h)`.

use super::params::{DamperParams, TruckParams};

/// Clutch interface mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ClutchMode {
    /// Engine and disc locked together.
    Locked,
    /// Slipping; the value is the slip direction `s = sign(ω_e − ω_c)` (±1).
    Slipping(f64),
}

/// Damper spring stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DamperStage {
    /// `|φ| ≤ θ1`.
    First,
    /// `|φ| > θ1`; the value is `sign(φ)` (±1).
    Second(f64),
}

/// Kinetic capacity at actuator travel `x`, N·m.
pub fn kinetic_capacity(p: &TruckParams, x: f64) -> f64 {
    let xe = x.clamp(p.clutch_l_lower, p.clutch_l_upper);
    p.clutch_kinetic_nm * (p.clutch_l_upper - xe) / (p.clutch_l_upper - p.clutch_l_lower)
}

/// Actuator travel at which a clutch of capacity `max_nm` transmits `m_nm` kinetically (the
/// inverse of [`kinetic_capacity`], clamped to `[L_l, L_u]`).
pub fn travel_for(p: &TruckParams, max_nm: f64, m_nm: f64) -> f64 {
    let frac = (m_nm / max_nm).clamp(0.0, 1.0);
    p.clutch_l_upper - frac * (p.clutch_l_upper - p.clutch_l_lower)
}

/// Spring torque of the damper at twist `phi` in `stage`, N·m.
pub fn damper_spring(d: &DamperParams, stage: DamperStage, phi: f64) -> f64 {
    match stage {
        DamperStage::First => d.k1_nm_per_rad * phi,
        DamperStage::Second(s) => {
            s * (d.k1_nm_per_rad * d.theta1_rad) + d.k2_nm_per_rad * (phi - s * d.theta1_rad)
        }
    }
}

/// Damper torque at twist `phi`, twist rate `dphi`, N·m.
pub fn damper_torque(d: &DamperParams, stage: DamperStage, phi: f64, dphi: f64) -> f64 {
    damper_spring(d, stage, phi)
        + d.c_nm_s_per_rad * dphi
        + d.hysteresis_nm * (dphi / d.hysteresis_width_rad_s).tanh()
}

/// The stage a twist `phi` belongs to.
pub fn stage_of(d: &DamperParams, phi: f64) -> DamperStage {
    if phi.abs() <= d.theta1_rad {
        DamperStage::First
    } else {
        DamperStage::Second(phi.signum())
    }
}

/// Torque through the locked friction interface, `(M_e·J_c + M_d·J_e)/(J_e + J_c)`, N·m.
pub fn locked_transmitted(p: &TruckParams, m_e: f64, m_d: f64) -> f64 {
    (m_e * p.j_c + m_d * p.j_e) / (p.j_e + p.j_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d() -> DamperParams {
        DamperParams {
            k1_nm_per_rad: 100.0,
            k2_nm_per_rad: 300.0,
            theta1_rad: 0.1,
            c_nm_s_per_rad: 0.0,
            hysteresis_nm: 0.0,
            hysteresis_width_rad_s: 0.5,
        }
    }

    #[test]
    fn truth_damper_spring_is_continuous_at_the_stage_change() {
        let d = d();
        let at = |phi: f64| damper_spring(&d, stage_of(&d, phi), phi);
        // continuity at θ1 = 0.1: k1·θ1 = 10 N·m from both sides
        assert!((at(0.1) - 10.0).abs() < 1e-12);
        assert!((at(0.1 + 1e-9) - 10.0).abs() < 1e-6);
        // stage 2 slope k2 = 300: 0.2 rad → 10 + 300·0.1 = 40 N·m; odd symmetry
        assert!((at(0.2) - 40.0).abs() < 1e-12);
        assert!((at(-0.2) + 40.0).abs() < 1e-12);
    }
}
