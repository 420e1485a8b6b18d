//! A simple driver for synthetic drives: a target-speed profile along the road and a speed
//! controller that turns it into an engine-torque demand (negative: engine brake), a retarder
//! torque and a service-brake force.
//!
//! # Target speed
//! The cruise speed is the speed limit ([`DriverConfig::speed_limit_mps`]) or, when that is
//! `None`, the rule set's design speed. The driver stops at every multiple of
//! [`DriverConfig::stop_every_m`] (if any) and at the end of the road. Approaching a stop at
//! `x_s`, the target is `min(v_cruise, √(2 b (x_s − x)))` with `b = 0.8 ·`
//! [`DriverConfig::decel_mps2`] (a braking curve with 20 % margin), and the braking curve's own
//! deceleration `−b` is fed forward.
//!
//! # Speed limits along the road
//! With [`DriverConfig::speed_limits`] (e.g. a VECTO cycle's target speed, see
//! [`super::road_source`]) the cruise speed becomes `min(v_cruise, v_lim(x))`, where the limit
//! `v_lim` holds on each step of its grid. Lower limits ahead are anticipated on the same
//! braking curve as stops: the envelope `v_env` on the grid is `min(v_cruise, v_lim)` lowered
//! backwards to `v_env,k = min(v_env,k, √(v_env,k+1² + 2 b Δx))` (linear between grid points),
//! so the truck reaches each lower limit where it starts; where `v_env` is below the limit in
//! force the driver is on that curve and `−b` is fed forward. Higher limits are taken up at
//! the comfortable acceleration.
//!
//! # Controller
//! Desired acceleration `a = clamp(a_ff + k_v (v_target − v), −decel, accel)` (`k_v` =
//! [`DriverConfig::speed_gain_per_s`]). Required wheel force `F = m_eff a + F_road(v, slope)`,
//! `m_eff = m + J_w/r_w²`, `F_road` the driveline's road force without brake. `F > 0` becomes an
//! engine torque `F r_w / (i_t i_f)` expressed as a fraction of the full-load torque at the
//! current engine speed (clamped to 0…1) and multiplied by the tip-in/tip-out factor.
//!
//! # Brake blending
//! `F < 0` asks for a braking force `B = −F` at the wheels, whether the driver slows down
//! (for a stop, or after overshooting the target) or holds the target speed downhill (a cruise
//! control whose downhill speed control is set to the cruise speed). It is shared out in the
//! order a truck's brake management uses — wear-free brakes first:
//! 1. **engine brake**, when the engine is coupled (the AMT drives in a gear with the clutch
//!    closed): `E = min(B, |M_min| i_t i_f / r_w)`, commanded as the negative torque fraction
//!    `−E r_w / (i_t i_f |M_min|)` of the engine's minimum torque `M_min`
//!    (`engine_min_torque_nm`);
//! 2. **retarder** ([`DriverConfig::retarder`], [`super::retarder`]): the command
//!    `(B − E) r_w / i_f` at the propeller shaft; the torque it delivers, `T_r`, is limited by
//!    its speed-dependent capacity and its response rate;
//! 3. **service brake**: the rest, `B − E − T_r i_f / r_w`, only when the driver wants to slow
//!    down (`a < −0.05 m/s²`); otherwise the truck runs on with what engine brake and retarder
//!    give (on a downhill steeper than they can hold, its speed creeps above the target until
//!    the speed error asks for `a < −0.05 m/s²`, and the service brake takes the rest).
//!
//! At standstill the driver holds the brake with [`DriverConfig::hold_brake_n`]. The drive
//! starts with the truck standing for one dwell time; a stop counts as made once the speed is
//! below 0.05 m/s within 25 m before (or beyond) its position.
//!
//! # Tip-in / tip-out
//! Every `U(3, 8)` s the torque demand's factor is redrawn as `1 + U(−tip, tip)`
//! (`tip` = [`DriverConfig::tip_fraction`]), from a PRNG seeded with the drive's seed: the same
//! seed gives the same variations.
//!
//! # Lift-offs
//! With [`DriverConfig::lift_offs`] the driver now and then takes the foot off the pedal while
//! driving on (anticipating traffic, cresting a hill): a lift-off starts
//! [`LiftOffs::interval_s`] after the previous one's start (drawn `U(lo, hi)`), lasts
//! [`LiftOffs::duration_s`] (drawn `U(lo, hi)`), and commands the torque fraction −1 — the
//! engine's motoring drag `engine_min_torque_nm` when coupled — with no brake, in place of a
//! positive torque demand. It is skipped (and the next one drawn) below
//! [`LiftOffs::min_speed_mps`], on a braking curve, or when the driver would not ask for torque.
//! Its end is a tip-in from drag: a torque reversal, as traffic makes them. The draws come from
//! their own PRNG stream (`seed ^ LIFT_STREAM`), so a driver without lift-offs draws exactly
//! the tip factors it drew before they existed.

use super::retarder::RetarderConfig;
use crate::model::driveline::DrivelineParams;
use crate::rng::Xoshiro256StarStar;

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
    /// The truck's driveline retarder; `None`: none fitted.
    pub retarder: Option<RetarderConfig>,
    /// Speed limits along the road (module doc); `None`: the cruise speed everywhere.
    pub speed_limits: Option<SpeedLimits>,
    /// Lift-offs while driving on (module doc); `None`: none.
    pub lift_offs: Option<LiftOffs>,
}

/// A driver's lift-offs (module doc). Times in s, each range `(lo, hi)` with `0 < lo ≤ hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftOffs {
    /// Time from one lift-off's start to the next one's, s, drawn `U(lo, hi)`.
    pub interval_s: (f64, f64),
    /// Length of a lift-off, s, drawn `U(lo, hi)`.
    pub duration_s: (f64, f64),
    /// No lift-off below this speed, m/s.
    pub min_speed_mps: f64,
}

/// PRNG stream of the lift-off draws (xored into the drive's seed).
const LIFT_STREAM: u64 = 0x6C69_6674_6F66_6673;

/// Speed limits along a drive's travelled distance: `limit_mps[k]` (m/s, finite and > 0)
/// holds on `[k·step_m, (k+1)·step_m)`, the last one beyond the grid's end.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedLimits {
    /// Grid step, m (finite and > 0).
    pub step_m: f64,
    /// Limit on each step, m/s.
    pub limit_mps: Vec<f64>,
}

impl SpeedLimits {
    /// The limit in force at `x_m` (the first one before the grid).
    pub fn at(&self, x_m: f64) -> f64 {
        let n = self.limit_mps.len();
        let k = (x_m / self.step_m).floor();
        if k.is_nan() || k < 0.0 {
            return self.limit_mps[0];
        }
        self.limit_mps[(k as usize).min(n - 1)]
    }
}

impl Default for DriverConfig {
    /// No speed limit override, a stop every 1 km held 8 s, 0.8 m/s² up, 1.2 m/s² down,
    /// k_v = 0.5 1/s, ±5 % tip variations, a 30 kN holding brake, the default retarder, no
    /// speed limits along the road, no lift-offs.
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
            retarder: Some(RetarderConfig::default()),
            speed_limits: None,
            lift_offs: None,
        }
    }
}

/// What the driver asks for in one control step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverCommand {
    /// Engine torque demand, −1…1: ≥ 0 a fraction of the full-load torque at the current
    /// engine speed, < 0 a fraction of the minimum torque's magnitude (engine brake).
    pub torque_fraction: f64,
    /// Service-brake force at the ground, N (≥ 0).
    pub brake_n: f64,
    /// Retarder torque at the propeller shaft over the step, N·m (≥ 0 brakes).
    pub retarder_nm: f64,
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
    /// Retarder torque of the previous step, N·m, and that step's time, s.
    retarder_nm: f64,
    last_t_s: Option<f64>,
    /// Speed envelope on the speed-limit grid, m/s (module doc), if limits are set.
    envelope: Option<Vec<f64>>,
    /// The lift-offs' own PRNG stream.
    lift_rng: Xoshiro256StarStar,
    /// The current or next lift-off, `[start, end)`, s.
    lift: Option<(f64, f64)>,
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
        let envelope = cfg.speed_limits.as_ref().and_then(|l| {
            let n = l.limit_mps.len();
            if n == 0 {
                return None;
            }
            let b = 0.8 * cfg.decel_mps2;
            let mut env: Vec<f64> = l.limit_mps.iter().map(|&v| v.min(cruise_mps)).collect();
            for k in (0..n - 1).rev() {
                env[k] = env[k].min((env[k + 1].powi(2) + 2.0 * b * l.step_m).sqrt());
            }
            Some(env)
        });
        Self {
            cfg,
            cruise_mps,
            stops_m,
            next_stop: 0,
            dwell_until_s: None,
            rng: Xoshiro256StarStar::seed_from_u64(seed ^ 0x6472_6976_6572),
            tip: 1.0,
            next_tip_s: 0.0,
            retarder_nm: 0.0,
            last_t_s: None,
            envelope,
            lift_rng: Xoshiro256StarStar::seed_from_u64(seed ^ LIFT_STREAM),
            lift: None,
        }
    }

    /// Whether a lift-off holds at `t_s` (module doc), drawing the next one as time passes.
    fn lifting_off(&mut self, t_s: f64) -> bool {
        let Some(l) = self.cfg.lift_offs else {
            return false;
        };
        let draw = |rng: &mut Xoshiro256StarStar, from: f64| {
            let start = from + rng.uniform(l.interval_s.0, l.interval_s.1);
            (start, start + rng.uniform(l.duration_s.0, l.duration_s.1))
        };
        let mut lift = match self.lift {
            Some(w) => w,
            None => draw(&mut self.lift_rng, t_s),
        };
        while t_s >= lift.1 {
            lift = draw(&mut self.lift_rng, lift.0);
        }
        self.lift = Some(lift);
        t_s >= lift.0
    }

    /// Skips the lift-off holding now (it could not be made); the next is drawn from its start.
    fn skip_lift_off(&mut self, t_s: f64) {
        if let Some((start, end)) = self.lift {
            if t_s >= start && t_s < end {
                self.lift = Some((start, t_s));
            }
        }
    }

    /// The speed envelope at `x_m` (m/s) and whether it lies below the limit in force there
    /// (the driver is braking toward a lower limit ahead), if speed limits are set.
    fn envelope_at(&self, x_m: f64) -> Option<(f64, bool)> {
        let (env, limits) = (self.envelope.as_ref()?, self.cfg.speed_limits.as_ref()?);
        let n = env.len();
        let f = (x_m / limits.step_m).max(0.0);
        let k = (f.floor() as usize).min(n - 1);
        let v = if k + 1 < n {
            let w = f - k as f64;
            env[k] + w * (env[k + 1] - env[k])
        } else {
            env[n - 1]
        };
        let cap = limits.at(x_m).min(self.cruise_mps);
        Some((v.min(cap), v < cap - 1e-9))
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
    /// with engine speed `w_e` (rad/s), overall ratio `i_t i_f` of the engaged gear, and whether
    /// the engine is coupled to the wheels (clutch closed in a gear: the engine brake works).
    /// Call once per control step, in time order (the retarder's response integrates over the
    /// time between calls).
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
        engine_coupled: bool,
    ) -> DriverCommand {
        let (mut cmd, wanted) = self.demand(
            p,
            t_s,
            x_m,
            v_mps,
            slope,
            w_e_rad_s,
            overall_ratio,
            engine_coupled,
        );
        let dt = self.last_t_s.map_or(0.0, |t0| t_s - t0);
        self.last_t_s = Some(t_s);
        if let Some(r) = &self.cfg.retarder {
            let w_p = v_mps / p.wheel_radius_m * p.final_drive_ratio;
            let command_nm = wanted.retarder_force_n * p.wheel_radius_m / p.final_drive_ratio;
            self.retarder_nm = r.follow(self.retarder_nm, command_nm, w_p, dt);
        } else {
            self.retarder_nm = 0.0;
        }
        cmd.retarder_nm = self.retarder_nm;
        if wanted.service_takes_rest {
            let delivered = self.retarder_nm * p.final_drive_ratio / p.wheel_radius_m;
            cmd.brake_n = (wanted.retarder_force_n - delivered).max(0.0);
        }
        cmd
    }

    /// The command before the retarder's response: the command with `retarder_nm = 0`, and the
    /// braking force wanted from the retarder (the service brake takes what the retarder does
    /// not deliver when `service_takes_rest`).
    #[allow(clippy::too_many_arguments)]
    fn demand(
        &mut self,
        p: &DrivelineParams,
        t_s: f64,
        x_m: f64,
        v_mps: f64,
        slope: f64,
        w_e_rad_s: f64,
        overall_ratio: f64,
        engine_coupled: bool,
    ) -> (DriverCommand, WantedBrake) {
        let c = &self.cfg;
        let none = WantedBrake {
            retarder_force_n: 0.0,
            service_takes_rest: false,
        };
        if t_s >= self.next_tip_s {
            self.tip = 1.0 + self.rng.uniform(-c.tip_fraction, c.tip_fraction);
            self.next_tip_s = t_s + self.rng.uniform(3.0, 8.0);
        }
        let hold = DriverCommand {
            torque_fraction: 0.0,
            brake_n: c.hold_brake_n,
            retarder_nm: 0.0,
            accel_mps2: 0.0,
            target_mps: 0.0,
        };
        if t_s < c.stop_dwell_s {
            // standing at the start for one dwell time
            return (hold, none);
        }
        if let Some(until) = self.dwell_until_s {
            if t_s < until {
                return (hold, none);
            }
            self.dwell_until_s = None;
            self.next_stop += 1;
        }
        let Some(&x_s) = self.stops_m.get(self.next_stop) else {
            return (hold, none);
        };
        if v_mps.abs() < 0.05 && x_m > x_s - 25.0 {
            // arrived: stand for the dwell time (for ever at the road end)
            self.dwell_until_s = Some(if self.next_stop + 1 == self.stops_m.len() {
                f64::INFINITY
            } else {
                t_s + c.stop_dwell_s
            });
            return (hold, none);
        }
        let b = 0.8 * c.decel_mps2;
        let curve = (2.0 * b * (x_s - x_m).max(0.0)).sqrt();
        let (mut target, mut a_ff) = if curve < self.cruise_mps {
            (curve, -b)
        } else {
            (self.cruise_mps, 0.0)
        };
        if let Some((v_env, braking)) = self.envelope_at(x_m) {
            if v_env < target {
                target = v_env;
                a_ff = if braking { -b } else { 0.0 };
            }
        }
        let a = (a_ff + c.speed_gain_per_s * (target - v_mps)).clamp(-c.decel_mps2, c.accel_mps2);
        let m_eff = p.mass_kg + p.j_w_kg_m2 / p.wheel_radius_m.powi(2);
        let f = m_eff * a + p.road_force(v_mps, slope, 0.0, false);
        let ratio = overall_ratio.max(1e-9);
        let mut wanted = none;
        let lifting = self.lifting_off(t_s);
        let lift_ok = lifting
            && f > 0.0
            && a_ff == 0.0
            && self.cfg.lift_offs.is_some_and(|l| v_mps >= l.min_speed_mps);
        if lifting && !lift_ok {
            self.skip_lift_off(t_s);
        }
        // bound again: the lift-off draws above needed `self` mutably
        let c = &self.cfg;
        let (frac, brake) = if lift_ok {
            // foot off the pedal: the engine's motoring drag, no brake
            (-1.0, 0.0)
        } else if f > 0.0 {
            let m = f * p.wheel_radius_m / ratio;
            let full = p.engine_max_torque(w_e_rad_s).max(1.0);
            ((m / full * self.tip).clamp(0.0, 1.0), 0.0)
        } else {
            // brake blending (module doc): engine brake, retarder, service brake
            let need = -f;
            let drag = (-p.engine_min_torque_nm).max(0.0);
            let engine = if engine_coupled && drag > 0.0 {
                need.min(drag * ratio / p.wheel_radius_m)
            } else {
                0.0
            };
            let frac = -(engine * p.wheel_radius_m / ratio / drag.max(1e-9)).min(1.0);
            let rest = need - engine;
            let slowing = a < -0.05;
            if c.retarder.is_some() {
                wanted = WantedBrake {
                    retarder_force_n: rest,
                    service_takes_rest: slowing,
                };
                (frac, 0.0)
            } else {
                (frac, if slowing { rest } else { 0.0 })
            }
        };
        // creeping to the stop point at near-zero target: hold the brake once slow enough
        if target < 0.3 && v_mps < 0.5 {
            wanted.service_takes_rest = false;
        }
        let brake = if target < 0.3 && v_mps < 0.5 {
            brake.max(c.hold_brake_n)
        } else {
            brake
        };
        (
            DriverCommand {
                torque_fraction: frac,
                brake_n: brake,
                retarder_nm: 0.0,
                accel_mps2: a,
                target_mps: target,
            },
            wanted,
        )
    }
}

/// What the blending wants from the retarder (see [`Driver::demand`]).
#[derive(Debug, Clone, Copy)]
struct WantedBrake {
    /// Braking force wanted from the retarder at the wheels, N.
    retarder_force_n: f64,
    /// The service brake takes what the retarder does not deliver.
    service_takes_rest: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::vehicle::VehicleFile;

    fn truck() -> DrivelineParams {
        VehicleFile::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/seed002-6x2-diesel.toml"
        )))
        .unwrap()
        .driveline
        .unwrap()
    }

    /// The lift-off windows of a driver asking for torque at a steady `v_mps` on a 2 % climb
    /// in a high gear (ratio 3, 1200 rpm), over 0.1 s steps from 10 s to 2000 s: each window's
    /// (start, end) in s, where the command is the drag fraction −1.
    fn windows(lift: Option<LiftOffs>, v_mps: f64) -> (Vec<(f64, f64)>, Vec<DriverCommand>) {
        let p = truck();
        let cfg = DriverConfig {
            stop_every_m: None,
            lift_offs: lift,
            ..DriverConfig::default()
        };
        let mut d = Driver::new(cfg, v_mps, 1.0e7, 7);
        let (mut out, mut cmds, mut open) = (Vec::new(), Vec::new(), None);
        for k in 100..20_000 {
            let t = k as f64 * 0.1;
            let c = d.command(&p, t, v_mps * t, v_mps, 0.02, 125.7, 3.0, true);
            match (c.torque_fraction == -1.0, open) {
                (true, None) => open = Some(t),
                (false, Some(t0)) => {
                    out.push((t0, t));
                    open = None;
                }
                _ => {}
            }
            cmds.push(c);
        }
        (out, cmds)
    }

    const LIFTS: LiftOffs = LiftOffs {
        interval_s: (20.0, 60.0),
        duration_s: (1.0, 4.0),
        min_speed_mps: 5.0,
    };

    #[test]
    fn lift_offs_release_the_pedal_for_their_drawn_lengths_and_intervals() {
        let (w, cmds) = windows(Some(LIFTS), 20.0);
        // ~2000 s / 40 s mean interval: tens of lift-offs, none of them braking
        assert!(w.len() >= 30 && w.len() <= 100, "{}", w.len());
        for &(t0, t1) in &w {
            // a window is whole 0.1 s steps: 1–4 s drawn, rounded up to the next step
            assert!((0.99..=4.11).contains(&(t1 - t0)), "{t0}…{t1}");
        }
        for pair in w.windows(2) {
            let gap = pair[1].0 - pair[0].0;
            assert!((19.9..=60.1).contains(&gap), "{pair:?}");
        }
        assert!(cmds
            .iter()
            .all(|c| c.brake_n == 0.0 && c.retarder_nm == 0.0));
        // between lift-offs the driver asks for torque as before
        assert!(cmds.iter().filter(|c| c.torque_fraction > 0.0).count() > 15_000);
    }

    #[test]
    fn no_lift_off_below_its_speed_or_without_lift_offs() {
        assert!(windows(Some(LIFTS), 4.0).0.is_empty());
        assert!(windows(None, 20.0).0.is_empty());
    }

    #[test]
    fn lift_offs_leave_the_tip_draws_alone() {
        // the torque demand outside the lift-offs is the same with and without them: the
        // lift-offs draw from their own stream
        let (w, with) = windows(Some(LIFTS), 20.0);
        let (_, without) = windows(None, 20.0);
        let lifted = |t: f64| w.iter().any(|&(t0, t1)| t >= t0 - 1e-9 && t < t1 - 1e-9);
        let mut compared = 0;
        for (k, (a, b)) in with.iter().zip(&without).enumerate() {
            let t = (k + 100) as f64 * 0.1;
            if !lifted(t) {
                assert_eq!(a.torque_fraction, b.torque_fraction, "t = {t}");
                compared += 1;
            }
        }
        assert!(compared > 15_000);
    }
}
