//! A driveline retarder for synthetic drives: a hydrodynamic auxiliary brake on the propeller
//! shaft (gearbox output), as a ZF Intarder or a Voith retarder.
//!
//! # Model
//! - **Torque** `T_r` ≥ 0 brakes, N·m at the propeller shaft (the canonical `retarder_torque`
//!   column; J1939 ERC1 reports it in % of the retarder reference torque, SPN 556).
//! - **Available torque** at propeller-shaft speed `ω_p = i_f ω_w` (rad/s):
//!   `T_avail = T_max · min(1, (ω_p / ω_full)²)` — a hydrodynamic brake's torque grows with the
//!   square of the rotor speed until the control valve limits it at `T_max`
//!   ([`RetarderConfig::max_torque_nm`]); `ω_full` is [`RetarderConfig::full_torque_speed_rpm`].
//!   At standstill it is zero: a retarder cannot hold a truck.
//! - **Response.** The torque follows the command at most at the rate `T_max /`
//!   [`RetarderConfig::response_s`] (filling and emptying of the working chamber), and never
//!   above `T_avail`.
//! - **Where it acts** in the closed loop ([`super::drive`]): its wheel-equivalent force
//!   `T_r i_f / r_w` is added to the service-brake force input of the driveline step (the
//!   simplest honest option: the fast driveline model has no retarder, and a brake at the
//!   propeller shaft seen through the stiff final drive is, for the vehicle's motion, a brake
//!   at the wheels; the shaft torsion it would add is not simulated). The axle model gets
//!   `T_r i_f` as the auxiliary brake torque at the driven wheels.

/// Retarder settings. SI units except the speed, given in rpm as datasheets give it.
#[derive(Debug, Clone, PartialEq)]
pub struct RetarderConfig {
    /// Largest braking torque at the propeller shaft, N·m (> 0).
    pub max_torque_nm: f64,
    /// Propeller-shaft speed from which the full torque is available, rpm (> 0).
    pub full_torque_speed_rpm: f64,
    /// Time to go from zero to full torque (and back), s (> 0).
    pub response_s: f64,
}

impl Default for RetarderConfig {
    /// 3500 N·m (the ERC1 reference torque of the bundled `j1939-json-mcap` mapping, the order
    /// of a ZF Intarder's maximum), full from 600 rpm at the propeller shaft (37 km/h for a
    /// 3.08 final drive and 0.5 m wheels), 0.5 s response.
    fn default() -> Self {
        Self {
            max_torque_nm: 3500.0,
            full_torque_speed_rpm: 600.0,
            response_s: 0.5,
        }
    }
}

impl RetarderConfig {
    /// `T_avail(ω_p)`, N·m, at propeller-shaft speed `w_p_rad_s` (rad/s; the magnitude counts).
    pub fn available_torque_nm(&self, w_p_rad_s: f64) -> f64 {
        let w_full = self.full_torque_speed_rpm * std::f64::consts::PI / 30.0;
        self.max_torque_nm * (w_p_rad_s.abs() / w_full).powi(2).min(1.0)
    }

    /// The torque after one step of `dt_s` from `current_nm` towards `command_nm`: rate-limited
    /// to `T_max/response_s` and limited to `[0, T_avail(ω_p)]`, N·m.
    pub fn follow(&self, current_nm: f64, command_nm: f64, w_p_rad_s: f64, dt_s: f64) -> f64 {
        let max_step = self.max_torque_nm / self.response_s * dt_s.max(0.0);
        let target = command_nm.clamp(0.0, self.available_torque_nm(w_p_rad_s));
        let next = current_nm + (target - current_nm).clamp(-max_step, max_step);
        next.clamp(0.0, self.available_torque_nm(w_p_rad_s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn torque_grows_with_the_square_of_the_speed_up_to_the_maximum() {
        let r = RetarderConfig::default();
        let w_full = 600.0 * std::f64::consts::PI / 30.0;
        assert_eq!(r.available_torque_nm(0.0), 0.0);
        assert!((r.available_torque_nm(0.5 * w_full) - 875.0).abs() < 1e-9);
        assert_eq!(r.available_torque_nm(2.0 * w_full), 3500.0);
        assert_eq!(r.available_torque_nm(-2.0 * w_full), 3500.0);
    }

    #[test]
    fn follow_is_rate_limited_and_never_above_the_available_torque() {
        let r = RetarderConfig::default();
        let fast = 1000.0;
        // 0.1 s at 3500 N·m / 0.5 s: 700 N·m per step
        assert!((r.follow(0.0, 3500.0, fast, 0.1) - 700.0).abs() < 1e-9);
        assert!((r.follow(3500.0, 0.0, fast, 0.1) - 2800.0).abs() < 1e-9);
        assert!((r.follow(1000.0, 1200.0, fast, 0.1) - 1200.0).abs() < 1e-9);
        // slowing down: the available torque caps the held torque at once
        assert_eq!(r.follow(3500.0, 3500.0, 0.0, 0.1), 0.0);
        assert_eq!(r.follow(0.0, -100.0, fast, 0.1), 0.0);
    }
}
