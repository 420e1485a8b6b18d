//! Engine and engine control unit (ECU) torque of the truth plant.
//!
//! # Conventions
//! Torques in N·m, positive driving; speeds in rad/s.
//!
//! - **Full-load curve** `M_fl(ω)`: the vehicle file's net (flywheel) curve, linear between its
//!   points, held beyond its ends.
//! - **Friction** `M_fr(ω) = f0 + f1·ω` (ω ≥ 0), the motoring torque the engine needs to turn.
//! - **Command**: the ECU turns a net torque demand `M_dem` into a combustion (indicated) torque
//!   command `M_cmd = clamp(M_dem + M_fr(ω), 0, M_fl(ω) + M_fr(ω))`; `M_cmd = 0` is fuel cut (net
//!   torque −M_fr, engine braking by friction).
//! - **Produced torque** lags the command by a first-order lag: `Ṁ_c = (M_cmd − M_c)/τ_e`; the
//!   net flywheel torque is `M_e = M_c − M_fr(ω)`.
//! - **Reported torque** (EEC1 actual engine torque) is the ECU's estimate from its command,
//!   with a map error: `M_rep = (1 + ε_g)·(M_cmd − M_fr(ω)) + ε_o`. In steady state
//!   (`M_c = M_cmd`) this is `(1 + ε_g)·M_e + ε_o`: the reported torque is the produced one with
//!   the map error, and during transients it leads the produced torque by τ_e.

use super::params::EngineParams;

/// Net full-load torque at `w`, N·m (linear interpolation, held beyond the ends).
pub fn full_load(e: &EngineParams, w: f64) -> f64 {
    let (s, t) = (&e.full_load_speed_rad_s, &e.full_load_nm);
    let k = s.partition_point(|&x| x <= w);
    if k == 0 {
        return t[0];
    }
    if k == s.len() {
        return t[t.len() - 1];
    }
    let u = (w - s[k - 1]) / (s[k] - s[k - 1]);
    t[k - 1] + u * (t[k] - t[k - 1])
}

/// Friction (motoring) torque at `w`, N·m, ≥ 0.
pub fn friction(e: &EngineParams, w: f64) -> f64 {
    e.friction0_nm + e.friction1_nm_s_per_rad * w.max(0.0)
}

/// Combustion torque command for a net demand `m_dem` at speed `w`, N·m.
pub fn command(e: &EngineParams, m_dem: f64, w: f64) -> f64 {
    let fr = friction(e, w);
    (m_dem + fr).clamp(0.0, full_load(e, w) + fr)
}

/// Net torque the ECU reports for the command `m_cmd` at speed `w`, N·m.
pub fn reported(e: &EngineParams, m_cmd: f64, w: f64) -> f64 {
    (1.0 + e.map_gain) * (m_cmd - friction(e, w)) + e.map_offset_nm
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eng() -> EngineParams {
        EngineParams {
            lag_s: 0.1,
            friction0_nm: 60.0,
            friction1_nm_s_per_rad: 0.9,
            full_load_speed_rad_s: vec![60.0, 100.0, 200.0],
            full_load_nm: vec![1000.0, 2600.0, 1800.0],
            idle_rad_s: 62.8,
            gov_kp: 40.0,
            gov_ki: 200.0,
            map_gain: 0.02,
            map_offset_nm: -10.0,
        }
    }

    #[test]
    fn truth_engine_command_is_clamped_to_fuel_cut_and_full_load() {
        let e = eng();
        // friction at 100 rad/s: 60 + 90 = 150 N·m
        assert!((command(&e, 5000.0, 100.0) - (2600.0 + 150.0)).abs() < 1e-9);
        assert_eq!(command(&e, -1000.0, 100.0), 0.0);
        assert!((full_load(&e, 150.0) - 2200.0).abs() < 1e-9);
        // steady state: reported = (1 + ε_g)·net + ε_o
        let cmd = command(&e, 1000.0, 100.0);
        assert!((reported(&e, cmd, 100.0) - (1.02 * 1000.0 - 10.0)).abs() < 1e-9);
    }
}
