//! The hybrid driveline model of docs/models/driveline.md (A. Myklebust, L. Eriksson, "Road Slope
//! Analysis and Filtering for Driveline Shuffle Simulation", IFAC E-COSM'12, 2012, §2; cited in
//! this crate as "Myklebust & Eriksson (2012)"), simulated with the accurate adaptive integrator
//! ([`super::dopri`]) and located mode switches.
//!
//! # State and conventions
//! `y = (ω_e, ω_c, φ_c, ω_p, φ_p, ω_d, φ_d, ω_w, x_I)`, SI: engine and clutch-disc speeds, clutch
//! spring torsion φ_c = θ_c − θ_t, gearbox-output (propeller) speed, propeller torsion
//! φ_p = θ_p − θ_f, final-drive speed, drive-shaft torsion φ_d = θ_d − θ_w, wheel speed, and the
//! PI integrator state x_I = ∫(ω_ref − ω_e)dt. In the locked mode ω_c ≡ ω_e.
//! Torques: `M_c = c_c(ω_c − i_t ω_p) + k_c φ_c`, `M_p = c_p(ω_p − i_f ω_d) + k_p φ_p`,
//! `M_d = c_d(ω_d − ω_w) + k_d φ_d`. Vehicle: `J4 ω̇_w = M_d − r_w·F`,
//! `F = sign(v)(F_r + F_a + F_b) + F_g`, `F_r = f(v)(c_r1 + c_r2|v|) m g`,
//! `f(v) = 1 − exp(−c_sr v²)` (or 1 without smoothing), `F_a = ½ρ c_wA_f v²`,
//! `F_g = m g sin(atan s)` for the slope s = tan α.
//!
//! # Clutch modes (events, not smoothing)
//! - locked: `J1 ω̇_e = M_e − M_c`; it unlocks when `|M_trans| = (|M_e J_c + M_c J_e|)/(J_e + J_c)`
//!   rises through the static capacity `M_s = k_µ M_k(x)`; the slip direction σ is the sign of
//!   M_trans;
//! - slipping: `J_e ω̇_e = M_e − σM_k`, `J_c ω̇_c = σM_k − M_c`; when σ(ω_e − ω_c) falls through
//!   0 the two bodies are merged at their momentum-weighted speed and lock if the static capacity
//!   holds, else slip on in the other direction.
//!
//! # Vehicle standstill (optional, `Scenario::standstill_events`)
//! Rolling in direction sv = ±1, the road force uses sv instead of sign(v); when sv·v falls
//! through 0 the vehicle stops if the drive force `M_d/r_w − m g sin α` is within the holding
//! capacity `f(0)·c_r1·m·g + F_b` (ω̇_w = 0 while held), else it reverses; it breaks away when
//! the drive force rises through the capacity. Without it, sign(v) is taken from the state.
//!
//! Inputs are piecewise linear ([`Piecewise`]); the integration restarts at every breakpoint, where
//! discrete inputs (gear) change. A gear change is an instantaneous change of i_t and J_t with the
//! state carried over. The engine is an ideal torque source, or the PI controller
//! `M_e = clamp(K_P(ω_ref − ω_e) + K_I x_I, M_min, M_max(ω_e))` (no anti-windup, as in
//! Myklebust & Eriksson (2012), eqs. (31)–(33)).

use super::dopri::{hermite, integrate, DopriError, EventFn, Knot, Stats, Tolerances};
use super::inputs::{Piece, Piecewise};
use crate::model::driveline::DrivelineParams;
use thiserror::Error;

/// Number of states.
pub const N_STATES: usize = 9;

/// Characteristic size of each state: `atol_i = tol · STATE_SCALE[i]` with `rtol = tol`.
pub const STATE_SCALE: [f64; N_STATES] = [100.0, 100.0, 0.01, 10.0, 0.01, 10.0, 0.01, 10.0, 10.0];

/// Engine input.
#[derive(Debug, Clone, PartialEq)]
pub enum EngineInput {
    /// Prescribed engine torque, N·m.
    Torque(Piecewise),
    /// Engine-speed reference for the PI controller, rad/s.
    SpeedReference(Piecewise),
}

/// A simulation scenario: all inputs over `[0, t_end_s]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Duration, s.
    pub t_end_s: f64,
    /// Gear (rounded to the nearest integer; 1 = lowest).
    pub gear: Piecewise,
    /// Clutch position, 0 = engaged … 1.
    pub clutch_x: Piecewise,
    /// Road slope tan α.
    pub slope: Piecewise,
    /// Service-brake force at the ground, N (≥ 0).
    pub brake_n: Piecewise,
    /// Engine torque or speed reference.
    pub engine: EngineInput,
    /// Rolling-resistance smoothing f(v) = 1 − exp(−c_sr v²) on (true) or off.
    pub smoothing: bool,
    /// Locate the vehicle's stops and breakaways as events (a standstill mode that holds the
    /// wheels while brake and static rolling resistance can), instead of taking sign(v) from
    /// the state. Meant for unsmoothed rolling resistance; the accurate integrator only.
    pub standstill_events: bool,
}

/// Wheel (vehicle) discrete state.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Wheel {
    /// No standstill events: sign(v) from the state.
    Free,
    /// Rolling in direction ±1 (fixed between events).
    Rolling(f64),
    /// Held at standstill.
    Stuck,
}

/// Clutch mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ClutchMode {
    /// Engine and clutch disc rotate together.
    Locked,
    /// Slipping with direction σ = sign(ω_e − ω_c) ∈ {−1, +1}.
    Slipping(f64),
}

/// A located discrete event.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// Time, s.
    pub t: f64,
    /// `unlock`, `lock`, `slip_reversal` or `gear_<a>_to_<b>`.
    pub kind: String,
}

/// Output trajectory sampled on a uniform grid.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trajectory {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// States per sample.
    pub y: Vec<[f64; N_STATES]>,
    /// Clutch mode per sample.
    pub mode: Vec<ClutchMode>,
    /// (M_e, M_c, M_p, M_d, M_trans) per sample, N·m.
    pub torques: Vec<[f64; 5]>,
    /// Gear per sample.
    pub gear: Vec<usize>,
    /// Mode switches and gear changes.
    pub events: Vec<Event>,
    /// Integrator work.
    pub stats: Stats,
}

impl Trajectory {
    /// Vehicle speed per sample, m/s.
    pub fn speed(&self, r_w: f64) -> Vec<f64> {
        self.y.iter().map(|y| r_w * y[7]).collect()
    }
}

/// Why a simulation failed.
#[derive(Debug, Error, PartialEq)]
pub enum SimError {
    /// The scenario asks for a gear the gearbox lacks.
    #[error("gear {gear} at t = {t} s is not a forward gear of this gearbox (1..={max})")]
    Gear {
        /// Gear.
        gear: i64,
        /// Time.
        t: f64,
        /// Highest gear.
        max: usize,
    },
    /// Integration failed.
    #[error(transparent)]
    Integrator(#[from] DopriError),
    /// Too many mode switches in one interval (chattering).
    #[error("more than {limit} clutch mode switches before t = {t} s (chattering)")]
    Chattering {
        /// Time.
        t: f64,
        /// Limit.
        limit: usize,
    },
}

/// Inputs frozen on one integration interval (piece indices fixed, so values are smooth).
struct Frozen {
    gear: usize,
    x: Piece,
    s: Piece,
    fb: Piece,
    e: Piece,
}

/// The hybrid model bound to one vehicle.
pub struct HybridDriveline<'a> {
    p: &'a DrivelineParams,
    ratios: &'a [f64],
    sc: &'a Scenario,
}

impl<'a> HybridDriveline<'a> {
    /// Binds parameters, gearbox and scenario.
    pub fn new(p: &'a DrivelineParams, ratios: &'a [f64], sc: &'a Scenario) -> Self {
        Self { p, ratios, sc }
    }

    fn freeze(&self, ta: f64, tb: f64) -> Result<Frozen, SimError> {
        let tm = 0.5 * (ta + tb);
        let sc = self.sc;
        let g = sc.gear.eval(tm).round() as i64;
        if g < 1 || g as usize > self.ratios.len() {
            return Err(SimError::Gear {
                gear: g,
                t: tm,
                max: self.ratios.len(),
            });
        }
        let e = match &sc.engine {
            EngineInput::Torque(p) | EngineInput::SpeedReference(p) => {
                p.frozen_piece(p.piece_index(tm))
            }
        };
        let at = |p: &Piecewise| p.frozen_piece(p.piece_index(tm));
        Ok(Frozen {
            gear: g as usize,
            x: at(&sc.clutch_x),
            s: at(&sc.slope),
            fb: at(&sc.brake_n),
            e,
        })
    }

    /// Kinetic clutch capacity M_k at clutch position x, N·m (docs/models/driveline.md actuator
    /// law).
    pub fn clutch_capacity(&self, x: f64) -> f64 {
        self.p.clutch_capacity(x)
    }

    fn engine_torque(&self, fr: &Frozen, t: f64, w_e: f64, x_i: f64) -> f64 {
        let p = self.p;
        match &self.sc.engine {
            EngineInput::Torque(_) => fr.e.eval(t),
            EngineInput::SpeedReference(_) => {
                let raw = p.pi_kp_nm_s_per_rad * (fr.e.eval(t) - w_e) + p.pi_ki_nm_per_rad * x_i;
                raw.max(p.engine_min_torque_nm)
                    .min(p.engine_max_torque(w_e))
            }
        }
    }

    /// (M_e, M_c, M_p, M_d) at t for state y in `mode`.
    fn torques(&self, fr: &Frozen, mode: ClutchMode, t: f64, y: &[f64]) -> [f64; 4] {
        let p = self.p;
        let it = self.ratios[fr.gear - 1];
        let w_c = if mode == ClutchMode::Locked {
            y[0]
        } else {
            y[1]
        };
        let m_e = self.engine_torque(fr, t, y[0], y[8]);
        let m_c = p.c_c_nm_s_per_rad * (w_c - it * y[3]) + p.k_c_nm_per_rad * y[2];
        let m_p =
            p.c_p_nm_s_per_rad * (y[3] - p.final_drive_ratio * y[5]) + p.k_p_nm_per_rad * y[4];
        let m_d = p.c_d_nm_s_per_rad * (y[5] - y[7]) + p.k_d_nm_per_rad * y[6];
        [m_e, m_c, m_p, m_d]
    }

    fn m_trans_locked(&self, m_e: f64, m_c: f64) -> f64 {
        self.p.locked_clutch_torque(m_e, m_c)
    }

    /// Road force F = sign(v)(F_r + F_a + F_b) + F_g, N (positive resists forward motion); while
    /// rolling between standstill events the direction of motion replaces sign(v).
    fn road_force(&self, fr: &Frozen, t: f64, v: f64, wheel: Wheel) -> f64 {
        let s = fr.s.eval(t);
        let fb = fr.fb.eval(t);
        match wheel {
            Wheel::Rolling(sv) => {
                let grade = self.p.road_force(0.0, s, 0.0, self.sc.smoothing);
                let resist = self.p.road_force(v.abs(), 0.0, fb, self.sc.smoothing);
                sv * resist + grade
            }
            _ => self.p.road_force(v, s, fb, self.sc.smoothing),
        }
    }

    /// At standstill: (drive force the shafts and the grade put on the held vehicle, holding
    /// capacity of static rolling resistance f(0)·c_r1·m·g plus the brake), N.
    fn static_balance(&self, fr: &Frozen, t: f64, y: &[f64]) -> (f64, f64) {
        let p = self.p;
        let [_, _, _, m_d] = self.torques(fr, ClutchMode::Slipping(1.0), t, y);
        let s = fr.s.eval(t);
        let mg = p.mass_kg * p.gravity_m_per_s2;
        let drive = m_d / p.wheel_radius_m - mg * crate::model::driveline::grade_sine(s);
        let f0 = if self.sc.smoothing { 0.0 } else { 1.0 };
        (drive, f0 * p.c_r1 * mg + fr.fb.eval(t))
    }

    fn rhs(&self, fr: &Frozen, mode: ClutchMode, wheel: Wheel, t: f64, y: &[f64], dy: &mut [f64]) {
        let p = self.p;
        let it = self.ratios[fr.gear - 1];
        let j2 = p.j_t_kg_m2[fr.gear - 1] + p.j_p_kg_m2;
        let j3 = p.j_f_kg_m2 + p.j_d_kg_m2;
        let [m_e, m_c, m_p, m_d] = self.torques(fr, mode, t, y);
        let w_c = if mode == ClutchMode::Locked {
            y[0]
        } else {
            y[1]
        };
        let v = p.wheel_radius_m * y[7];
        let f = self.road_force(fr, t, v, wheel);
        match mode {
            ClutchMode::Locked => {
                dy[0] = (m_e - m_c) / (p.j_e_kg_m2 + p.j_c_kg_m2);
                dy[1] = dy[0];
            }
            ClutchMode::Slipping(sigma) => {
                let m_tr = sigma * self.clutch_capacity(fr.x.eval(t));
                dy[0] = (m_e - m_tr) / p.j_e_kg_m2;
                dy[1] = (m_tr - m_c) / p.j_c_kg_m2;
            }
        }
        dy[2] = w_c - it * y[3];
        dy[3] = (it * m_c - p.b_t_nm_s_per_rad * y[3] - m_p) / j2;
        dy[4] = y[3] - p.final_drive_ratio * y[5];
        dy[5] = (p.final_drive_ratio * m_p - p.b_f_nm_s_per_rad * y[5] - m_d) / j3;
        dy[6] = y[5] - y[7];
        dy[7] = if wheel == Wheel::Stuck {
            0.0
        } else {
            (m_d - p.wheel_radius_m * f) / p.j4()
        };
        dy[8] = match &self.sc.engine {
            EngineInput::SpeedReference(_) => fr.e.eval(t) - y[0],
            EngineInput::Torque(_) => 0.0,
        };
    }

    fn unlock_margin(&self, fr: &Frozen, t: f64, y: &[f64]) -> f64 {
        let [m_e, m_c, _, _] = self.torques(fr, ClutchMode::Locked, t, y);
        self.m_trans_locked(m_e, m_c).abs()
            - self.p.clutch_static_to_kinetic * self.clutch_capacity(fr.x.eval(t))
    }

    /// Unlocks the clutch at `t`: slip direction from the sign of the locked-clutch torque, the
    /// disc starting at the engine speed; records the event and returns the new mode.
    fn unlock(&self, fr: &Frozen, t: f64, y: &mut [f64], events: &mut Vec<Event>) -> ClutchMode {
        let [m_e, m_c, _, _] = self.torques(fr, ClutchMode::Locked, t, y);
        y[1] = y[0];
        events.push(Event {
            t,
            kind: "unlock".into(),
        });
        ClutchMode::Slipping(if self.m_trans_locked(m_e, m_c) > 0.0 {
            1.0
        } else {
            -1.0
        })
    }

    fn breakpoints(&self) -> Vec<f64> {
        let sc = self.sc;
        let p = self.p;
        let mut b: Vec<f64> = Vec::new();
        let engine = match &sc.engine {
            EngineInput::Torque(x) | EngineInput::SpeedReference(x) => x,
        };
        for pw in [&sc.gear, &sc.clutch_x, &sc.slope, &sc.brake_n, engine] {
            b.extend(pw.breakpoints());
        }
        // kinks of M_k(t) where a clutch ramp crosses the ends of the effective range
        for (t0, t1, v0, v1) in sc.clutch_x.pieces() {
            if v1 != v0 {
                for lim in [
                    p.clutch_l_lower * p.clutch_x_max,
                    p.clutch_l_upper * p.clutch_x_max,
                ] {
                    let tc = t0 + (lim - v0) / (v1 - v0) * (t1 - t0);
                    if t0 < tc && tc < t1 {
                        b.push(tc);
                    }
                }
            }
        }
        b.retain(|&x| x > 0.0 && x < sc.t_end_s);
        b.sort_by(f64::total_cmp);
        // breakpoints closer than 1 ns (a clutch-range kink next to an input sample) are one
        b.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        b.push(sc.t_end_s);
        b
    }

    /// Simulates the scenario from `y0` in `mode0` with relative tolerance `tol`
    /// (`atol_i = tol·STATE_SCALE[i]`), sampling the output at `fs_hz`.
    ///
    /// # Errors
    /// [`SimError`] for gears outside the gearbox, integrator failure or chattering.
    pub fn simulate(
        &self,
        y0: [f64; N_STATES],
        mode0: ClutchMode,
        tol: f64,
        fs_hz: f64,
    ) -> Result<Trajectory, SimError> {
        let p = self.p;
        let tols = Tolerances {
            rtol: tol,
            atol: STATE_SCALE.iter().map(|s| s * tol).collect(),
        };
        let mut y = y0.to_vec();
        let mut mode = mode0;
        if mode == ClutchMode::Locked {
            y[1] = y[0];
        }
        let mut wheel = if self.sc.standstill_events {
            if y[7] > 0.0 {
                Wheel::Rolling(1.0)
            } else if y[7] < 0.0 {
                Wheel::Rolling(-1.0)
            } else {
                Wheel::Stuck
            }
        } else {
            Wheel::Free
        };
        let mut traj = Trajectory::default();
        let n_out = (self.sc.t_end_s * fs_hz).round() as usize;
        let mut next_out = 0usize;
        let mut t = 0.0;
        let mut h = 1e-4;
        let mut prev_gear = self.freeze(0.0, self.breakpoints()[0])?.gear;
        let je = p.j_e_kg_m2;
        let jc = p.j_c_kg_m2;
        for tb in self.breakpoints() {
            let fr = self.freeze(t, tb)?;
            if fr.gear != prev_gear {
                traj.events.push(Event {
                    t,
                    kind: format!("gear_{prev_gear}_to_{}", fr.gear),
                });
                prev_gear = fr.gear;
            }
            let mut switches = 0usize;
            while t < tb {
                if mode == ClutchMode::Locked && self.unlock_margin(&fr, t, &y) > 0.0 {
                    mode = self.unlock(&fr, t, &mut y, &mut traj.events);
                }
                if wheel == Wheel::Stuck {
                    let (drive, cap) = self.static_balance(&fr, t, &y);
                    if drive.abs() > cap {
                        wheel = Wheel::Rolling(drive.signum());
                        traj.events.push(Event {
                            t,
                            kind: "breakaway".into(),
                        });
                    }
                }
                let m = mode;
                let wm = wheel;
                let mut f = |tt: f64, yy: &[f64], dd: &mut [f64]| self.rhs(&fr, m, wm, tt, yy, dd);
                let unlock = |tt: f64, yy: &[f64]| self.unlock_margin(&fr, tt, yy);
                let lock = |_tt: f64, yy: &[f64]| match m {
                    ClutchMode::Slipping(s) => s * (yy[0] - yy[1]),
                    ClutchMode::Locked => 1.0,
                };
                let v_zero = |_tt: f64, yy: &[f64]| match wm {
                    Wheel::Rolling(sv) => sv * yy[7],
                    _ => 1.0,
                };
                let breakaway = |tt: f64, yy: &[f64]| {
                    let (drive, cap) = self.static_balance(&fr, tt, yy);
                    drive.abs() - cap
                };
                let mut events: Vec<(EventFn, f64)> = vec![match m {
                    ClutchMode::Locked => (&unlock, 1.0),
                    ClutchMode::Slipping(_) => (&lock, -1.0),
                }];
                match wm {
                    Wheel::Rolling(_) => events.push((&v_zero, -1.0)),
                    Wheel::Stuck => events.push((&breakaway, 1.0)),
                    Wheel::Free => {}
                }
                let mut sample = |ka: &Knot, kb: &Knot| {
                    let (ta, ya, tbb) = (ka.t, ka.y, kb.t);
                    while next_out <= n_out {
                        let to = next_out as f64 / fs_hz;
                        if to > tbb || (to < ta && next_out > 0) {
                            break;
                        }
                        let mut yo = [0.0; N_STATES];
                        if to <= ta {
                            yo.copy_from_slice(ya);
                        } else {
                            hermite(ka, kb, to, &mut yo);
                        }
                        if m == ClutchMode::Locked {
                            yo[1] = yo[0];
                        }
                        let [m_e, m_c, m_p, m_d] = self.torques(&fr, m, to, &yo);
                        let m_tr = match m {
                            ClutchMode::Locked => self.m_trans_locked(m_e, m_c),
                            ClutchMode::Slipping(s) => s * self.clutch_capacity(fr.x.eval(to)),
                        };
                        traj.t.push(to);
                        traj.y.push(yo);
                        traj.mode.push(m);
                        traj.torques.push([m_e, m_c, m_p, m_d, m_tr]);
                        traj.gear.push(fr.gear);
                        next_out += 1;
                    }
                };
                let out = integrate(&mut f, t, &y, tb, h, &tols, &events, &mut sample)?;
                traj.stats += out.stats;
                h = out.h_last;
                y = out.y;
                t = if out.event.is_some() && tb - out.t < 1e-12 {
                    tb
                } else {
                    out.t
                };
                if let Some(k) = out.event {
                    switches += 1;
                    if switches > 1000 {
                        return Err(SimError::Chattering { t, limit: 1000 });
                    }
                    if k == 1 {
                        // wheel event
                        match wheel {
                            Wheel::Rolling(_) => {
                                y[7] = 0.0;
                                let (drive, cap) = self.static_balance(&fr, t, &y);
                                if drive.abs() <= cap {
                                    wheel = Wheel::Stuck;
                                    traj.events.push(Event {
                                        t,
                                        kind: "stop".into(),
                                    });
                                } else {
                                    wheel = Wheel::Rolling(drive.signum());
                                    traj.events.push(Event {
                                        t,
                                        kind: "v_reversal".into(),
                                    });
                                }
                            }
                            _ => {
                                let (drive, _) = self.static_balance(&fr, t, &y);
                                wheel = Wheel::Rolling(drive.signum());
                                traj.events.push(Event {
                                    t,
                                    kind: "breakaway".into(),
                                });
                            }
                        }
                        continue;
                    }
                    match mode {
                        ClutchMode::Locked => {
                            mode = self.unlock(&fr, t, &mut y, &mut traj.events);
                        }
                        ClutchMode::Slipping(_) => {
                            let w = (je * y[0] + jc * y[1]) / (je + jc);
                            let mut ytest = y.clone();
                            ytest[0] = w;
                            ytest[1] = w;
                            if self.unlock_margin(&fr, t, &ytest) <= 0.0 {
                                mode = ClutchMode::Locked;
                                y = ytest;
                                traj.events.push(Event {
                                    t,
                                    kind: "lock".into(),
                                });
                            } else {
                                let [m_e, m_c, _, _] =
                                    self.torques(&fr, ClutchMode::Locked, t, &ytest);
                                mode =
                                    ClutchMode::Slipping(if self.m_trans_locked(m_e, m_c) > 0.0 {
                                        1.0
                                    } else {
                                        -1.0
                                    });
                                traj.events.push(Event {
                                    t,
                                    kind: "slip_reversal".into(),
                                });
                            }
                        }
                    }
                }
            }
        }
        Ok(traj)
    }
}

/// Steady state with the clutch locked at vehicle speed `v_mps > 0` on slope `slope` in `gear`:
/// every acceleration zero, shaft torsions carrying the road load, PI integrator preloaded so
/// that its output equals the engine torque. Returns the state and that engine torque, N·m.
pub fn steady_state_locked(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v_mps: f64,
    slope: f64,
    smoothing: bool,
) -> ([f64; N_STATES], f64) {
    let it = ratios[gear - 1];
    let fi = p.final_drive_ratio;
    let w_w = v_mps / p.wheel_radius_m;
    let w_d = w_w;
    let w_p = fi * w_d;
    let w_e = it * w_p;
    let f = if smoothing {
        p.rolling_smoothing(v_mps)
    } else {
        1.0
    };
    let mg = p.mass_kg * p.gravity_m_per_s2;
    let force = f * (p.c_r1 + p.c_r2_s_per_m * v_mps) * mg
        + 0.5 * p.rho_air_kg_per_m3 * p.c_w_a_f_m2 * v_mps * v_mps
        + mg * crate::model::driveline::grade_sine(slope);
    let m_d = p.wheel_radius_m * force;
    let m_p = (p.b_f_nm_s_per_rad * w_d + m_d) / fi;
    let m_c = (p.b_t_nm_s_per_rad * w_p + m_p) / it;
    let x_i = if p.pi_ki_nm_per_rad > 0.0 {
        m_c / p.pi_ki_nm_per_rad
    } else {
        0.0
    };
    (
        [
            w_e,
            w_e,
            m_c / p.k_c_nm_per_rad,
            w_p,
            m_p / p.k_p_nm_per_rad,
            w_d,
            m_d / p.k_d_nm_per_rad,
            w_w,
            x_i,
        ],
        m_c,
    )
}
