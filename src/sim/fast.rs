//! The fast path for long drives: exact discretisation of the linear driveline between input
//! samples (an exponential integrator), with the non-linear parts held over each step.
//!
//! Per gear, clutch mode (locked / slipping) and PI state (active / output clamped), the linear
//! part `ż = A z + B u` is discretised exactly for the step `dt`:
//! `Φ = e^{A dt}`, `Γ = ∫₀^dt e^{As} ds B` (one matrix exponential of the augmented
//! `[[A, B], [0, 0]]·dt`, cached). The inputs `u = (M_e, M_trans, F, ω_ref)` are held over the
//! step: the recorded/scripted inputs at the step's midpoint, the road force
//! `F = sign(v)(F_r + F_a + F_b) + F_g` (the only state non-linearity) at the step's start.
//! Because the stiff linear modes (the 9000 rad/s drive-shaft damping mode) are integrated
//! exactly, the step is limited only by how fast the inputs and the road force change — not by
//! stiffness: the method is stable for any dt (the road-force feedback is explicit, its rate
//! `r_w²·∂F/∂v / J4` is below 0.01 1/s, so dt = 0.01 s is 4 orders inside its limit).
//!
//! Mode switches are detected at step ends (to the step's resolution, not located): a locked
//! clutch unlocks when |M_trans| exceeds the static capacity; a slipping clutch locks when the
//! slip speed changes sign and the capacity holds (momentum-weighted merge, as the accurate path
//! does). The PI output is clamped to the engine's limits; the clamp is decided at each step's
//! start. With `standstill_events`, a vehicle whose speed changes sign in a step while brake and
//! static rolling resistance can hold it is stopped (ω_w set to 0, the ground reaction then
//! cancels the drive-shaft torque each step) until the drive force exceeds that capacity. Equations and state are those of [`super::hybrid`]; the accuracy against the accurate
//! integrator is pinned in the tests.
//!
//! # Drive-shaft lash (optional, [`FastDriveline::with_lash`])
//! With a total play `b > 0` in the drive shaft (the catalogue effect `driveline_backlash`,
//! docs/diagnosis/catalogue.md), the shaft torque is a dead-zone spring,
//! `M_d = k_d (φ_d − s b/2) + c_d (ω_d − ω_w)` in contact (`s = sign φ_d`, `|φ_d| ≥ b/2`) and
//! `M_d = 0` in the gap (`|φ_d| < b/2`), `φ_d` the total shaft twist including the play. The
//! contact side is decided from `φ_d` at each step's start (a position-based dead zone); in
//! contact the step integrates the shifted twist `φ_d − s b/2` with the nominal matrices, in the
//! gap it uses matrices without the shaft's spring and damper (cached per gear and mode like
//! the others). Entering contact is detected at step ends, so the shaft overshoots the contact
//! by at most `|ω_d − ω_w| dt`; callers that need impacts resolved use a smaller step.
//! `b = 0` (the default) is the nominal model, bit for bit.

use super::dopri::Stats;
use super::hybrid::{ClutchMode, EngineInput, Event, Scenario, SimError, Trajectory, N_STATES};
use crate::model::driveline::DrivelineParams;
use nalgebra::{DMatrix, SMatrix, SVector};

const N_IN: usize = 4;

type Phi = SMatrix<f64, N_STATES, N_STATES>;
type Gamma = SMatrix<f64, N_STATES, N_IN>;

#[derive(Clone, Copy, PartialEq, Eq)]
struct Key {
    gear: usize,
    locked: bool,
    /// PI output unclamped: M_e = K_P(ω_ref − ω_e) + K_I x_I in the matrix.
    pi: bool,
    /// The engine follows a speed reference, so x_I integrates (also while clamped).
    integrate: bool,
    /// Drive shaft in its lash gap: no shaft spring or damper.
    gap: bool,
}

impl Key {
    /// Slot of this configuration in [`FastDriveline`]'s cache: 16 per gear.
    fn slot(self) -> usize {
        (self.gear - 1) * 16
            + usize::from(self.locked)
            + 2 * usize::from(self.pi)
            + 4 * usize::from(self.integrate)
            + 8 * usize::from(self.gap)
    }
}

/// Search cursors of the scenario's inputs for one simulation: the steps move forward in
/// time, so each lookup scans on from the last ([`super::inputs::Piecewise::piece_index_from`],
/// the same pieces as a binary search; a span that starts part-way into a long input finds its
/// first piece by the binary search).
#[derive(Default)]
struct Cursors {
    engine: std::cell::Cell<usize>,
    gear: std::cell::Cell<usize>,
    slope: std::cell::Cell<usize>,
    brake: std::cell::Cell<usize>,
    clutch: std::cell::Cell<usize>,
}

/// The exponential integrator bound to one vehicle and step.
pub struct FastDriveline<'a> {
    p: &'a DrivelineParams,
    ratios: &'a [f64],
    dt: f64,
    /// Total drive-shaft play b, rad (0: none).
    lash: f64,
    /// Discretised matrices per configuration, at [`Key::slot`].
    cache: Vec<Option<Box<(Phi, Gamma)>>>,
}

impl<'a> FastDriveline<'a> {
    /// Binds parameters and gearbox; `dt_s` is both the step and the output period.
    pub fn new(p: &'a DrivelineParams, ratios: &'a [f64], dt_s: f64) -> Self {
        Self {
            p,
            ratios,
            dt: dt_s,
            lash: 0.0,
            cache: vec![None; 16 * ratios.len()],
        }
    }

    /// The same integrator with a total drive-shaft play of `lash_rad` (rad, ≥ 0; see the
    /// module documentation). Negative or non-finite values are taken as 0.
    pub fn with_lash(mut self, lash_rad: f64) -> Self {
        self.lash = if lash_rad.is_finite() && lash_rad > 0.0 {
            lash_rad
        } else {
            0.0
        };
        self.cache.iter_mut().for_each(|c| *c = None);
        self
    }

    /// Contact side of the drive shaft at twist `phi_d`: `+1`/`−1` in contact, `0` in the gap
    /// (always `+1` without lash, where the offset is 0).
    fn lash_side(&self, phi_d: f64) -> f64 {
        if self.lash == 0.0 || phi_d >= 0.5 * self.lash {
            1.0
        } else if phi_d <= -0.5 * self.lash {
            -1.0
        } else {
            0.0
        }
    }

    /// Continuous-time (A, B) of one configuration; inputs `(M_e, M_trans, F, ω_ref)`.
    fn continuous(&self, k: Key) -> (DMatrix<f64>, DMatrix<f64>) {
        let p = self.p;
        let it = self.ratios[k.gear - 1];
        let fi = p.final_drive_ratio;
        let (je, jc) = (p.j_e_kg_m2, p.j_c_kg_m2);
        let j1 = je + jc;
        let j2 = p.j_t_kg_m2[k.gear - 1] + p.j_p_kg_m2;
        let j3 = p.j_f_kg_m2 + p.j_d_kg_m2;
        let j4 = p.j4();
        let (kc, cc) = (p.k_c_nm_per_rad, p.c_c_nm_s_per_rad);
        let (kp, cp) = (p.k_p_nm_per_rad, p.c_p_nm_s_per_rad);
        let (kd, cd) = if k.gap {
            (0.0, 0.0)
        } else {
            (p.k_d_nm_per_rad, p.c_d_nm_s_per_rad)
        };
        let (kpi, kii) = (p.pi_kp_nm_s_per_rad, p.pi_ki_nm_per_rad);
        let mut a = DMatrix::zeros(N_STATES, N_STATES);
        let mut b = DMatrix::zeros(N_STATES, N_IN);
        // index of the speed that drives the clutch spring: ω_e when locked, ω_c when slipping
        let wc = if k.locked { 0 } else { 1 };
        // M_c = cc (ω_c − i_t ω_p) + kc φ_c as a row over the state
        let mut mc = [0.0; N_STATES];
        mc[wc] = cc;
        mc[3] = -cc * it;
        mc[2] = kc;
        // M_e as a row over state and inputs
        let mut me_state = [0.0; N_STATES];
        let mut me_in = [0.0; N_IN];
        if k.pi {
            me_state[0] = -kpi;
            me_state[8] = kii;
            me_in[3] = kpi;
        } else {
            me_in[0] = 1.0;
        }
        if k.locked {
            for j in 0..N_STATES {
                a[(0, j)] = (me_state[j] - mc[j]) / j1;
                a[(1, j)] = a[(0, j)];
            }
            for j in 0..N_IN {
                b[(0, j)] = me_in[j] / j1;
                b[(1, j)] = b[(0, j)];
            }
        } else {
            for j in 0..N_STATES {
                a[(0, j)] = me_state[j] / je;
                a[(1, j)] = -mc[j] / jc;
            }
            for j in 0..N_IN {
                b[(0, j)] = me_in[j] / je;
            }
            b[(0, 1)] -= 1.0 / je;
            b[(1, 1)] = 1.0 / jc;
        }
        // φ̇_c = ω_c − i_t ω_p
        a[(2, wc)] += 1.0;
        a[(2, 3)] = -it;
        // ω̇_p = (i_t M_c − b_t ω_p − M_p)/J2
        for j in 0..N_STATES {
            a[(3, j)] = it * mc[j] / j2;
        }
        a[(3, 3)] += -(p.b_t_nm_s_per_rad + cp) / j2;
        a[(3, 4)] = -kp / j2;
        a[(3, 5)] = cp * fi / j2;
        // φ̇_p = ω_p − i_f ω_d
        a[(4, 3)] = 1.0;
        a[(4, 5)] = -fi;
        // ω̇_d = (i_f M_p − b_f ω_d − M_d)/J3
        a[(5, 3)] = fi * cp / j3;
        a[(5, 4)] = fi * kp / j3;
        a[(5, 5)] = -(cp * fi * fi + p.b_f_nm_s_per_rad + cd) / j3;
        a[(5, 6)] = -kd / j3;
        a[(5, 7)] = cd / j3;
        // φ̇_d = ω_d − ω_w
        a[(6, 5)] = 1.0;
        a[(6, 7)] = -1.0;
        // ω̇_w = (M_d − r_w F)/J4
        a[(7, 5)] = cd / j4;
        a[(7, 6)] = kd / j4;
        a[(7, 7)] = -cd / j4;
        b[(7, 2)] = -p.wheel_radius_m / j4;
        // ẋ_I = ω_ref − ω_e whenever the engine follows a speed reference (no anti-windup)
        if k.integrate {
            a[(8, 0)] = -1.0;
            b[(8, 3)] = 1.0;
        }
        (a, b)
    }

    fn discrete(&mut self, k: Key) -> &(Phi, Gamma) {
        let dt = self.dt;
        let slot = k.slot();
        if self.cache[slot].is_none() {
            let (a, b) = self.continuous(k);
            let n = N_STATES + N_IN;
            let mut m = DMatrix::zeros(n, n);
            m.view_mut((0, 0), (N_STATES, N_STATES))
                .copy_from(&(a * dt));
            m.view_mut((0, N_STATES), (N_STATES, N_IN))
                .copy_from(&(b * dt));
            let e = m.exp();
            let phi = Phi::from_fn(|i, j| e[(i, j)]);
            let gamma = Gamma::from_fn(|i, j| e[(i, N_STATES + j)]);
            self.cache[slot] = Some(Box::new((phi, gamma)));
        }
        self.cache[slot].as_deref().expect("filled above")
    }

    fn clutch_capacity(&self, x: f64) -> f64 {
        self.p.clutch_capacity(x)
    }

    fn road_force(&self, sc: &Scenario, cur: &Cursors, t: f64, v: f64) -> f64 {
        self.p.road_force(
            v,
            sc.slope.eval_from(&cur.slope, t),
            sc.brake_n.eval_from(&cur.brake, t),
            sc.smoothing,
        )
    }

    /// (M_e, M_c, M_p, M_d) for state `y`; `me` is the engine torque in use.
    fn torques(&self, gear: usize, mode: ClutchMode, y: &[f64; N_STATES], me: f64) -> [f64; 4] {
        let p = self.p;
        let it = self.ratios[gear - 1];
        let w_c = if mode == ClutchMode::Locked {
            y[0]
        } else {
            y[1]
        };
        let side = self.lash_side(y[6]);
        let m_d = if side == 0.0 {
            0.0
        } else {
            p.c_d_nm_s_per_rad * (y[5] - y[7]) + p.k_d_nm_per_rad * (y[6] - side * 0.5 * self.lash)
        };
        [
            me,
            p.c_c_nm_s_per_rad * (w_c - it * y[3]) + p.k_c_nm_per_rad * y[2],
            p.c_p_nm_s_per_rad * (y[3] - p.final_drive_ratio * y[5]) + p.k_p_nm_per_rad * y[4],
            m_d,
        ]
    }

    fn m_trans_locked(&self, me: f64, mc: f64) -> f64 {
        self.p.locked_clutch_torque(me, mc)
    }

    /// Simulates the scenario from `y0` in `mode0` with the fixed step, one output sample per step.
    ///
    /// # Errors
    /// [`SimError::Gear`] for gears outside the gearbox.
    pub fn simulate(
        &mut self,
        sc: &Scenario,
        y0: [f64; N_STATES],
        mode0: ClutchMode,
    ) -> Result<Trajectory, SimError> {
        self.simulate_span(sc, 0.0, sc.t_end_s, y0, mode0)
    }

    /// Simulates `[t_start, t_end]` of the scenario from `y0` in `mode0` (the state at
    /// `t_start`), one output sample per step, the first at `t_start`.
    ///
    /// # Errors
    /// [`SimError::Gear`] for gears outside the gearbox.
    pub fn simulate_span(
        &mut self,
        sc: &Scenario,
        t_start: f64,
        t_end: f64,
        y0: [f64; N_STATES],
        mode0: ClutchMode,
    ) -> Result<Trajectory, SimError> {
        let n = ((t_end - t_start) / self.dt).round() as usize;
        let mut traj = Trajectory {
            t: Vec::with_capacity(n + 1),
            y: Vec::with_capacity(n + 1),
            mode: Vec::with_capacity(n + 1),
            torques: Vec::with_capacity(n + 1),
            gear: Vec::with_capacity(n + 1),
            events: Vec::new(),
            stats: Stats::default(),
        };
        self.run_span(sc, t_start, t_end, y0, mode0, &mut traj)?;
        Ok(traj)
    }

    /// [`FastDriveline::simulate_span`] with each sample's time and state handed to `out`
    /// instead of a [`Trajectory`] (nothing else is computed for it: no torques, modes, gears
    /// or events), the last sample only when `last` is set; returns the state and clutch mode
    /// at `t_end` and whether the clutch was locked at every sample. The states are those of
    /// [`FastDriveline::simulate_span`], bit for bit.
    ///
    /// A span whose clutch stays locked reads the clutch capacity only in the test that would
    /// unlock it (`|M_trans| > (M_s/M_k)·M_k(x)`), so the same span with a larger capacity gives
    /// the same states, bit for bit: what the diagnosis's fits of the capacity rest on
    /// ([`crate::diagnose::capacity_reach`]).
    ///
    /// # Errors
    /// As [`FastDriveline::simulate_span`].
    pub fn simulate_span_states(
        &mut self,
        sc: &Scenario,
        (t_start, t_end): (f64, f64),
        y0: [f64; N_STATES],
        mode0: ClutchMode,
        last: bool,
        out: &mut dyn FnMut(f64, &[f64; N_STATES]),
    ) -> Result<SpanEnd, SimError> {
        let mut sink = StateSink {
            out,
            last,
            end: (y0, mode0),
            locked: true,
        };
        self.run_span(sc, t_start, t_end, y0, mode0, &mut sink)?;
        Ok(SpanEnd {
            y: sink.end.0,
            mode: sink.end.1,
            locked_throughout: sink.locked,
        })
    }

    /// The integration loop of [`FastDriveline::simulate_span`], its samples into `sink`.
    fn run_span<S: Sink>(
        &mut self,
        sc: &Scenario,
        t_start: f64,
        t_end: f64,
        y0: [f64; N_STATES],
        mode0: ClutchMode,
        sink: &mut S,
    ) -> Result<(), SimError> {
        let p = self.p;
        let dt = self.dt;
        let n = ((t_end - t_start) / dt).round() as usize;
        let cur = Cursors::default();
        let mut y = y0;
        let mut mode = mode0;
        // vehicle held at standstill (only with `standstill_events`)
        let mut stuck = sc.standstill_events && y0[7] == 0.0;
        if mode == ClutchMode::Locked {
            y[1] = y[0];
        }
        let gear_at = |t: f64| -> Result<usize, SimError> {
            let g = round_to_i64(sc.gear.eval_from(&cur.gear, t));
            if g < 1 || g as usize > self.ratios.len() {
                return Err(SimError::Gear {
                    gear: g,
                    t,
                    max: self.ratios.len(),
                });
            }
            Ok(g as usize)
        };
        let mut gear = gear_at(t_start + 0.5 * dt)?;
        let (je, jc) = (p.j_e_kg_m2, p.j_c_kg_m2);
        let engine_torque = |t: f64, y: &[f64; N_STATES]| -> (f64, bool, f64) {
            // (M_e in use, PI active in the matrices, ω_ref)
            match &sc.engine {
                EngineInput::Torque(m) => (m.eval_from(&cur.engine, t), false, 0.0),
                EngineInput::SpeedReference(r) => {
                    let w_ref = r.eval_from(&cur.engine, t);
                    let raw = p.pi_kp_nm_s_per_rad * (w_ref - y[0]) + p.pi_ki_nm_per_rad * y[8];
                    let lim = raw
                        .max(p.engine_min_torque_nm)
                        .min(p.engine_max_torque(y[0]));
                    (lim, lim == raw, w_ref)
                }
            }
        };
        for k in 0..=n {
            let t = t_start + k as f64 * dt;
            let (me, pi_active, _) = engine_torque(t, &y);
            if S::TORQUES {
                let [_, mc, mp, md] = self.torques(gear, mode, &y, me);
                let mtr = match mode {
                    ClutchMode::Locked => self.m_trans_locked(me, mc),
                    ClutchMode::Slipping(s) => {
                        s * self.clutch_capacity(sc.clutch_x.eval_from(&cur.clutch, t))
                    }
                };
                sink.sample(t, &y, mode, gear, [me, mc, mp, md, mtr], k == n);
            } else {
                sink.sample(t, &y, mode, gear, [0.0; 5], k == n);
            }
            if k == n {
                break;
            }
            let tm = t + 0.5 * dt;
            let g = gear_at(tm)?;
            if g != gear {
                sink.event(Event {
                    t,
                    kind: format!("gear_{gear}_to_{g}"),
                });
                gear = g;
            }
            // the engine torque at the step's start, as recorded above (same t, same state)
            let me_start = me;
            let (me_mid, _, w_ref) = match &sc.engine {
                EngineInput::Torque(m) => (m.eval_from(&cur.engine, tm), false, 0.0),
                EngineInput::SpeedReference(r) => {
                    (me_start, pi_active, r.eval_from(&cur.engine, tm))
                }
            };
            let m_trans_in = match mode {
                ClutchMode::Locked => 0.0,
                ClutchMode::Slipping(s) => {
                    s * self.clutch_capacity(sc.clutch_x.eval_from(&cur.clutch, tm))
                }
            };
            let v_start = p.wheel_radius_m * y[7];
            let force = if stuck {
                // held: the ground reaction cancels the drive-shaft torque
                let [_, _, _, md0] = self.torques(gear, mode, &y, me_start);
                md0 / p.wheel_radius_m
            } else {
                self.road_force(sc, &cur, tm, v_start)
            };
            let side = self.lash_side(y[6]);
            let key = Key {
                gear,
                locked: mode == ClutchMode::Locked,
                pi: pi_active,
                integrate: matches!(sc.engine, EngineInput::SpeedReference(_)),
                gap: side == 0.0,
            };
            // in contact the nominal matrices act on the twist beyond the play
            let offset = side * 0.5 * self.lash;
            let (phi, gamma) = self.discrete(key);
            let u = SVector::<f64, N_IN>::new(me_mid, m_trans_in, force, w_ref);
            let mut z = SVector::<f64, N_STATES>::from_column_slice(&y);
            z[6] -= offset;
            let mut z1 = phi * z + gamma * u;
            z1[6] += offset;
            y.copy_from_slice(z1.as_slice());
            sink.step();
            // mode switches at the step end
            let t1 = t + dt;
            if sc.standstill_events {
                let v_end = p.wheel_radius_m * y[7];
                let crossing = v_start != 0.0 && v_start * v_end <= 0.0;
                // the forces at the step end matter only when held or when the speed crosses 0
                if stuck || crossing {
                    let (me1, _, _) = engine_torque(t1, &y);
                    let [_, _, _, md1] = self.torques(gear, mode, &y, me1);
                    let mg = p.mass_kg * p.gravity_m_per_s2;
                    let drive = md1 / p.wheel_radius_m
                        - mg * crate::model::driveline::grade_sine(
                            sc.slope.eval_from(&cur.slope, t1),
                        );
                    let f0 = if sc.smoothing { 0.0 } else { 1.0 };
                    let cap = f0 * p.c_r1 * mg + sc.brake_n.eval_from(&cur.brake, t1);
                    if stuck {
                        if drive.abs() > cap {
                            stuck = false;
                            sink.event(Event {
                                t: t1,
                                kind: "breakaway".into(),
                            });
                        } else {
                            y[7] = 0.0;
                        }
                    } else if drive.abs() <= cap {
                        stuck = true;
                        y[7] = 0.0;
                        sink.event(Event {
                            t: t1,
                            kind: "stop".into(),
                        });
                    }
                }
            }
            match mode {
                ClutchMode::Locked => {
                    y[1] = y[0];
                    let (me1, _, _) = engine_torque(t1, &y);
                    let [_, mc1, _, _] = self.torques(gear, mode, &y, me1);
                    let mt = self.m_trans_locked(me1, mc1);
                    if mt.abs()
                        > p.clutch_static_to_kinetic
                            * self.clutch_capacity(sc.clutch_x.eval_from(&cur.clutch, t1))
                    {
                        mode = ClutchMode::Slipping(if mt > 0.0 { 1.0 } else { -1.0 });
                        sink.event(Event {
                            t: t1,
                            kind: "unlock".into(),
                        });
                    }
                }
                ClutchMode::Slipping(s) => {
                    if s * (y[0] - y[1]) <= 0.0 {
                        let w = (je * y[0] + jc * y[1]) / (je + jc);
                        let mut yt = y;
                        yt[0] = w;
                        yt[1] = w;
                        let (me1, _, _) = engine_torque(t1, &yt);
                        let [_, mc1, _, _] = self.torques(gear, ClutchMode::Locked, &yt, me1);
                        let mt = self.m_trans_locked(me1, mc1);
                        if mt.abs()
                            <= p.clutch_static_to_kinetic
                                * self.clutch_capacity(sc.clutch_x.eval_from(&cur.clutch, t1))
                        {
                            mode = ClutchMode::Locked;
                            y = yt;
                            sink.event(Event {
                                t: t1,
                                kind: "lock".into(),
                            });
                        } else {
                            mode = ClutchMode::Slipping(if mt > 0.0 { 1.0 } else { -1.0 });
                            sink.event(Event {
                                t: t1,
                                kind: "slip_reversal".into(),
                            });
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// `x.round() as i64`, without the libm call for a value that is already whole (a recorded
/// gear, every step): the conversion truncates toward zero, which for a whole `x` in `i64`'s
/// range is `x` itself, the same as rounding; any other value (NaN, out of range, fractional)
/// takes `round`. The x86-64 baseline has no rounding instruction, so `f64::round` is a call.
fn round_to_i64(x: f64) -> i64 {
    let t = x as i64;
    if t as f64 == x {
        t
    } else {
        x.round() as i64
    }
}

/// Where [`FastDriveline::run_span`] puts its samples.
trait Sink {
    /// The sink reads the torques: they are computed for every sample.
    const TORQUES: bool;
    /// Sample at `t` (the last of the span when `last`); `torques` is (M_e, M_c, M_p, M_d,
    /// M_trans) in N·m when [`Sink::TORQUES`], else zeros.
    fn sample(
        &mut self,
        t: f64,
        y: &[f64; N_STATES],
        mode: ClutchMode,
        gear: usize,
        torques: [f64; 5],
        last: bool,
    );
    /// A mode switch or gear change.
    fn event(&mut self, e: Event);
    /// One accepted step.
    fn step(&mut self);
}

impl Sink for Trajectory {
    const TORQUES: bool = true;
    fn sample(
        &mut self,
        t: f64,
        y: &[f64; N_STATES],
        mode: ClutchMode,
        gear: usize,
        torques: [f64; 5],
        _last: bool,
    ) {
        self.t.push(t);
        self.y.push(*y);
        self.mode.push(mode);
        self.torques.push(torques);
        self.gear.push(gear);
    }
    fn event(&mut self, e: Event) {
        self.events.push(e);
    }
    fn step(&mut self) {
        self.stats.accepted += 1;
    }
}

/// Where a span of [`FastDriveline::simulate_span_states`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpanEnd {
    /// State at the span's end.
    pub y: [f64; N_STATES],
    /// Clutch mode at the span's end.
    pub mode: ClutchMode,
    /// The clutch was locked at every sample of the span, the first and the last included.
    pub locked_throughout: bool,
}

/// The states alone, to a caller's closure ([`FastDriveline::simulate_span_states`]).
struct StateSink<'o> {
    out: &'o mut dyn FnMut(f64, &[f64; N_STATES]),
    /// Hand over the span's last sample too.
    last: bool,
    /// The last sample's state and mode.
    end: ([f64; N_STATES], ClutchMode),
    /// Every sample so far had the clutch locked.
    locked: bool,
}

impl Sink for StateSink<'_> {
    const TORQUES: bool = false;
    fn sample(
        &mut self,
        t: f64,
        y: &[f64; N_STATES],
        mode: ClutchMode,
        _gear: usize,
        _torques: [f64; 5],
        last: bool,
    ) {
        self.end = (*y, mode);
        self.locked &= mode == ClutchMode::Locked;
        if !last || self.last {
            (self.out)(t, y);
        }
    }
    fn event(&mut self, _e: Event) {}
    fn step(&mut self) {}
}

#[cfg(test)]
mod tests {
    #[test]
    fn whole_values_round_to_themselves_and_the_others_as_round_does() {
        for x in [
            0.0,
            -0.0,
            1.0,
            12.0,
            -3.0,
            0.5,
            1.5,
            2.5,
            -2.5,
            3.4999999999999996,
            1e300,
            -1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            9.2e18,
            -9.3e18,
        ] {
            assert_eq!(super::round_to_i64(x), x.round() as i64, "{x}");
        }
    }
}
