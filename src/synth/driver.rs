//! A simple driver for synthetic drives: a target-speed profile along the road and a speed
//! controller that turns it into an engine-torque demand and a service-brake force.
//!
//! # Target speed
//! The cruise speed is the speed limit ([`DriverConfig::speed_limit_mps`]) or, when that is
//! `None`, the rule set's design speed. The driver stops at every multiple of
//! [`DriverConfig::stop_every_m`] (if any) and at the end of the road. Approaching a stop at
//! `x_s`, the target is `min(v_cruise, √(2 b (x_s − x)))` with `b = 0.8 ·`
//! [`DriverConfig::decel_mps2`] (a braking curve with 20 % margin), and the braking curve's own
//! deceleration `−b` is fed forward.
//!
//! # Controller
//! Desired acceleration `a = clamp(a_ff + k_v (v_target − v), −decel, accel)` (`k_v` =
//! [`DriverConfig::speed_gain_per_s`]). Required wheel force `F = m_eff a + F_road(v, slope)`,
//! `m_eff = m + J_w/r_w²`, `F_road` the driveline's road force without brake. `F > 0` becomes an
//! engine torque `F r_w / (i_t i_f)` expressed as a fraction of the full-load torque at the
//! current engine speed (clamped to 0…1) and multiplied by the tip-in/tip-out factor; `F < 0`
//! becomes a service-brake force `−F` when the driver wants to slow down (`a < −0.05 m/s²`),
//! otherwise the truck coasts. At standstill the driver holds the brake with
//! [`DriverConfig::hold_brake_n`]. The drive starts with the truck standing for one dwell time;
//! a stop counts as made once the speed is below 0.05 m/s within 25 m before (or beyond) its
//! position.
//!
//! # Tip-in / tip-out
//! Every `U(3, 8)` s the torque demand's factor is redrawn as `1 + U(−tip, tip)`
//! (`tip` = [`DriverConfig::tip_fraction`]), from a PRNG seeded with the drive's seed: the same
//! seed gives the same variations.

use crate::model::driveline::DrivelineParams;
use crate::road::rng::Xoshiro256StarStar;

/// Driver settings. SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct DriverConfig {
    /// Cruise speed, m/s; `None`: the road rules' design speed.
    pub speed_limit_mps: Option<f64>,
    /// Distance between planned stops, m; `None`: only the stop at the end of the road.
    pub stop_every_m: Option<f64>,
    /// Standstill time at each planned stop, s.
    pub stop_dwell_s: f64,
    /// Comfortable acceleration limit, m/s² (> 0).
    pub accel_mps2: f64,
    /// Comfortable deceleration limit, m/s² (> 0).
    pub decel_mps2: f64,
    /// Speed-error gain k_v, 1/s.
    pub speed_gain_per_s: f64,
    /// Amplitude of the tip-in/tip-out factor on the torque demand (fraction, ≥ 0).
    pub tip_fraction: f64,
    /// Brake force held at standstill, N.
    pub hold_brake_n: f64,
}

impl Default for DriverConfig {
    /// No speed limit override, a stop every 1 km held 8 s, 0.8 m/s² up, 1.2 m/s² down,
    /// k_v = 0.5 1/s, ±5 % tip variations, a 30 kN holding brake.
    fn default() -> Self {
        Self {
            speed_limit_mps: None,
            stop_every_m: Some(1000.0),
            stop_dwell_s: 8.0,
            accel_mps2: 0.8,
            decel_mps2: 1.2,
            speed_gain_per_s: 0.5,
            tip_fraction: 0.05,
            hold_brake_n: 30_000.0,
        }
    }
}

/// What the driver asks for in one control step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverCommand {
    /// Engine torque demand as a fraction of the full-load torque at the current engine speed, 0…1.
    pub torque_fraction: f64,
    /// Service-brake force at the ground, N (≥ 0).
    pub brake_n: f64,
    /// Desired acceleration, m/s².
    pub accel_mps2: f64,
    /// Target speed, m/s.
    pub target_mps: f64,
}

/// The driver's state along one drive.
#[derive(Debug, Clone)]
pub struct Driver {
    cfg: DriverConfig,
    cruise_mps: f64,
    stops_m: Vec<f64>,
    next_stop: usize,
    /// Time until which the driver stands at the current stop, s.
    dwell_until_s: Option<f64>,
    rng: Xoshiro256StarStar,
    tip: f64,
    next_tip_s: f64,
}

impl Driver {
    /// A driver for a road of `length_m` at cruise speed `cruise_mps` (already resolved from
    /// the limit or the design speed), with seed `seed`.
    pub fn new(cfg: DriverConfig, cruise_mps: f64, length_m: f64, seed: u64) -> Self {
        let mut stops_m = Vec::new();
        if let Some(e) = cfg.stop_every_m.filter(|e| e.is_finite() && *e > 0.0) {
            let mut x = e;
            while x < length_m - 0.5 * e.min(200.0) {
                stops_m.push(x);
                x += e;
            }
        }
        stops_m.push(length_m);
        Self {
            cfg,
            cruise_mps,
            stops_m,
            next_stop: 0,
            dwell_until_s: None,
            rng: Xoshiro256StarStar::seed_from_u64(seed ^ 0x6472_6976_6572),
            tip: 1.0,
            next_tip_s: 0.0,
        }
    }

    /// The planned stop positions, m (the last is the road end).
    pub fn stops_m(&self) -> &[f64] {
        &self.stops_m
    }

    /// True once the truck stands at the road end.
    pub fn finished(&self) -> bool {
        self.next_stop >= self.stops_m.len()
            || (self.next_stop + 1 == self.stops_m.len() && self.dwell_until_s.is_some())
    }

    /// The driver's command at time `t_s`, position `x_m`, speed `v_mps` on `slope` (tan α),
    /// with engine speed `w_e` (rad/s) and overall ratio `i_t i_f` of the engaged gear.
    #[allow(clippy::too_many_arguments)]
    pub fn command(
        &mut self,
        p: &DrivelineParams,
        t_s: f64,
        x_m: f64,
        v_mps: f64,
        slope: f64,
        w_e_rad_s: f64,
        overall_ratio: f64,
    ) -> DriverCommand {
        let c = &self.cfg;
        if t_s >= self.next_tip_s {
            self.tip = 1.0 + self.rng.uniform(-c.tip_fraction, c.tip_fraction);
            self.next_tip_s = t_s + self.rng.uniform(3.0, 8.0);
        }
        let hold = DriverCommand {
            torque_fraction: 0.0,
            brake_n: c.hold_brake_n,
            accel_mps2: 0.0,
            target_mps: 0.0,
        };
        if t_s < c.stop_dwell_s {
            // standing at the start for one dwell time
            return hold;
        }
        if let Some(until) = self.dwell_until_s {
            if t_s < until {
                return hold;
            }
            self.dwell_until_s = None;
            self.next_stop += 1;
        }
        let Some(&x_s) = self.stops_m.get(self.next_stop) else {
            return hold;
        };
        if v_mps.abs() < 0.05 && x_m > x_s - 25.0 {
            // arrived: stand for the dwell time (for ever at the road end)
            self.dwell_until_s = Some(if self.next_stop + 1 == self.stops_m.len() {
                f64::INFINITY
            } else {
                t_s + c.stop_dwell_s
            });
            return hold;
        }
        let b = 0.8 * c.decel_mps2;
        let curve = (2.0 * b * (x_s - x_m).max(0.0)).sqrt();
        let (target, a_ff) = if curve < self.cruise_mps {
            (curve, -b)
        } else {
            (self.cruise_mps, 0.0)
        };
        let a = (a_ff + c.speed_gain_per_s * (target - v_mps)).clamp(-c.decel_mps2, c.accel_mps2);
        let m_eff = p.mass_kg + p.j_w_kg_m2 / p.wheel_radius_m.powi(2);
        let f = m_eff * a + p.road_force(v_mps, slope, 0.0, false);
        let (frac, brake) = if f > 0.0 {
            let m = f * p.wheel_radius_m / overall_ratio.max(1e-9);
            let full = p.engine_max_torque(w_e_rad_s).max(1.0);
            ((m / full * self.tip).clamp(0.0, 1.0), 0.0)
        } else if a < -0.05 {
            (0.0, -f)
        } else {
            (0.0, 0.0)
        };
        // creeping to the stop point at near-zero target: hold the brake once slow enough
        let brake = if target < 0.3 && v_mps < 0.5 {
            brake.max(c.hold_brake_n)
        } else {
            brake
        };
        DriverCommand {
            torque_fraction: frac,
            brake_n: brake,
            accel_mps2: a,
            target_mps: target,
        }
    }
}
