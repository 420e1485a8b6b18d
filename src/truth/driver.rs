//! The truth plant's driver: follows a speed profile with stops, and commands engine torque
//! (through the AMT) and service brake.
//!
//! # Conventions
//! Speeds m/s, forces N (brake force ≥ 0 against motion), distances m from the road start,
//! torques net engine N·m.
//!
//! # Speed profile
//! Cruise speed `v_c` (the road's design speed, at most 85 km/h — the EU truck speed limiter
//! is set to ≤ 90 km/h and drivers keep below it), lowered before each stop so the truck can stop
//! at a comfortable deceleration `a_b = 0.8 m/s²`: `v_ref(x) = min(v_c, √(2·a_b·(x_s − x)))`,
//! x_s the next stop. Stops are drawn per drive (uniform positions, at least 300 m apart): one
//! per 6 km on rural roads, one per 1 km on city roads (design speed ≤ 60 km/h), plus the stop
//! at the road end. The driver dwells 8–25 s (uniform) at each stop, holding the brake.
//!
//! # Control
//! Desired acceleration `a = clamp(a_ff + 0.8 1/s·(v_ref − v) + I, −2, 1) m/s²` (a_ff = −a_b
//! on the braking curve, −2 m/s² within 0.5 m of the stop point, else 0) with a slow integral
//! `İ = 0.02 1/s²·(v_ref − v)` (|I| ≤ 0.3 m/s²) for the bias of the driver's force estimate;
//! force `F = m_n·a + F_res(v, slope)` from the nominal truck (the driver knows the nominal
//! resistances and sees the grade); engine net torque `F·r_w/(i_t·i_f)` in the current gear
//! (the start gear at standstill); service brake `−F − F_eb` when F is below the engine-brake
//! force `F_eb = −M_fr·i_t·i_f/r_w` (fuel cut), else 0.

use super::engine::{friction, full_load};
use super::params::TruckParams;
use crate::rng::Xoshiro256StarStar;

/// Comfortable braking deceleration, m/s².
pub const A_BRAKE: f64 = 0.8;

/// What the driver commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverCommand {
    /// Net engine torque demand, N·m.
    pub demand_nm: f64,
    /// Demand as a fraction of full load, 0..1.
    pub pedal: f64,
    /// Service brake force, N.
    pub brake_n: f64,
    /// The reference speed, m/s.
    pub v_ref: f64,
}

/// The driver.
#[derive(Debug, Clone)]
pub struct Driver {
    p: TruckParams,
    cruise: f64,
    /// Stop positions, m, increasing; the last is the road end.
    pub stops: Vec<f64>,
    dwell: Vec<f64>,
    next: usize,
    stand_since: Option<f64>,
    integ: f64,
    /// The drive is over (stood at the road end for its dwell).
    pub finished: bool,
}

impl Driver {
    /// A driver for the nominal truck `nominal` on a road of `length_m` with cruise speed
    /// `cruise_mps`; `city` selects the stop density; stops and dwells from `rng`.
    pub fn new(
        nominal: &TruckParams,
        length_m: f64,
        cruise_mps: f64,
        city: bool,
        rng: &mut Xoshiro256StarStar,
    ) -> Self {
        let per_m = if city { 1.0 / 1000.0 } else { 1.0 / 6000.0 };
        let n = (length_m * per_m).floor() as usize;
        let mut stops: Vec<f64> = Vec::new();
        for _ in 0..n {
            let x = rng.uniform(0.1 * length_m, 0.9 * length_m);
            if stops.iter().all(|s| (s - x).abs() > 300.0) {
                stops.push(x);
            }
        }
        stops.sort_by(f64::total_cmp);
        stops.push(length_m - 5.0);
        let dwell = stops.iter().map(|_| rng.uniform(8.0, 25.0)).collect();
        Self {
            p: nominal.clone(),
            cruise: cruise_mps.min(85.0 / 3.6),
            stops,
            dwell,
            next: 0,
            stand_since: None,
            integ: 0.0,
            finished: false,
        }
    }

    /// The reference speed at `x`, m/s.
    pub fn v_ref(&self, x: f64) -> f64 {
        match self.stops.get(self.next) {
            Some(&xs) => self.cruise.min((2.0 * A_BRAKE * (xs - x).max(0.0)).sqrt()),
            None => 0.0,
        }
    }

    /// One control step: at time `t`, position `x`, speed `v`, slope `slope`, engine speed
    /// `w_e`, in gear index `gear` (None: neutral, the start gear `start` is assumed),
    /// standing `stopped`.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        t: f64,
        x: f64,
        v: f64,
        slope: f64,
        w_e: f64,
        gear: Option<usize>,
        start: usize,
        stopped: bool,
        dt: f64,
    ) -> DriverCommand {
        let p = &self.p;
        let mg = p.mass_kg * p.gravity;
        let cos_a = 1.0 / (1.0 + slope * slope).sqrt();
        // at a stop: stand and dwell
        if let Some(&xs) = self.stops.get(self.next) {
            if stopped && x > xs - 15.0 {
                let since = *self.stand_since.get_or_insert(t);
                let hold = 0.3 * mg;
                if t - since >= self.dwell[self.next] {
                    self.next += 1;
                    self.stand_since = None;
                    self.integ = 0.0;
                    if self.next >= self.stops.len() {
                        self.finished = true;
                    }
                } else {
                    return DriverCommand {
                        demand_nm: 0.0,
                        pedal: 0.0,
                        brake_n: hold,
                        v_ref: 0.0,
                    };
                }
            }
        }
        let v_ref = self.v_ref(x);
        let e = v_ref - v;
        self.integ = (self.integ + 0.02 * e * dt).clamp(-0.3, 0.3);
        // on the braking curve the reference decelerates at A_BRAKE: feed it forward; past the
        // stop point stop firmly
        let next = self.stops.get(self.next).copied().unwrap_or(f64::INFINITY);
        let a_ff = if x >= next - 0.5 {
            -2.0
        } else if v_ref < self.cruise - 1e-9 {
            -A_BRAKE
        } else {
            0.0
        };
        let a = (a_ff + 0.8 * e + self.integ).clamp(-2.0, 1.0);
        let f_res = 0.5 * p.rho_air * p.c_w_a_f_m2 * v * v
            + (p.c_r1 + p.c_r2_s_per_m * v) * mg * cos_a
            + mg * slope * cos_a;
        let f = p.body_mass() * a + f_res;
        let g = gear.unwrap_or(start);
        let ratio = p.total_ratio(g);
        let r = p.wheel_radius_m;
        let w = w_e.max(p.engine.idle_rad_s);
        let f_eb = -friction(&p.engine, w) * ratio / r;
        let (demand_nm, brake_n) = if v_ref < 0.3 && v < 0.5 {
            // arrived early: stand on the brake
            (0.0, 0.3 * mg)
        } else if f >= f_eb {
            (f * r / ratio, 0.0)
        } else {
            (f_eb * r / ratio, f_eb - f)
        };
        let fl = full_load(&p.engine, w);
        DriverCommand {
            demand_nm,
            pedal: (demand_nm / fl).clamp(0.0, 1.0),
            brake_n,
            v_ref,
        }
    }
}
