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
//! by at most `|ω_d − ω_w| dt`; callers that need impacts resolved use a smaller step, or
//! substeps near the gap ([`FastDriveline::with_gap_substeps`]): a step that starts and ends in
//! contact on one side with the twist beyond the play at least what the twist rate covers in
//! the step (`s φ_d − b/2 ≥ |ω_d − ω_w| dt` at both ends) is taken whole, every other step as
//! `m` substeps of `dt/m` (the whole step is tried first and dropped when its end fails the
//! test). Away from the gap the shaft is a linear spring and the step is the nominal model's;
//! where the play is taken up or opened, the step is the fine one.
//! `b = 0` (the default) is the nominal model, bit for bit.

use super::dopri::Stats;
use super::fast_inputs::{held_value, Cursors};
pub use super::fast_span::{Resume, SpanEnd};
use super::fast_span::{Sink, StateSink};
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
    /// One of the lash's substeps ([`FastDriveline::with_gap_substeps`]), not a whole step.
    sub: bool,
}

impl Key {
    /// Slot of this configuration in [`FastDriveline`]'s cache: 32 per gear.
    fn slot(self) -> usize {
        (self.gear - 1) * 32
            + usize::from(self.locked)
            + 2 * usize::from(self.pi)
            + 4 * usize::from(self.integrate)
            + 8 * usize::from(self.gap)
            + 16 * usize::from(self.sub)
    }
}

/// The exponential integrator bound to one vehicle and step.
pub struct FastDriveline<'a> {
    p: &'a DrivelineParams,
    ratios: &'a [f64],
    dt: f64,
    /// Total drive-shaft play b, rad (0: none).
    lash: f64,
    /// Substeps per step near and in the lash gap (1: whole steps throughout).
    gap_substeps: usize,
    /// Keep the state at each whole step's start until the clutch first unlocks
    /// ([`SpanEnd::first_unlock`]).
    track_unlock: bool,
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
            gap_substeps: 1,
            track_unlock: false,
            cache: vec![None; 32 * ratios.len()],
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

    /// The same integrator taking `m` substeps of `dt / m` wherever the drive shaft is in its
    /// lash gap or near it, whole steps elsewhere (see the module documentation; `m` ≤ 1 or
    /// a zero lash: whole steps throughout, bit for bit [`FastDriveline::with_lash`]). A step
    /// whose shaft stays in contact on one side and clear of the gap is the whole step; each
    /// substep hands over a sample, so the samples are `dt / m` apart there.
    pub fn with_gap_substeps(mut self, m: usize) -> Self {
        self.gap_substeps = m.max(1);
        self.cache.iter_mut().for_each(|c| *c = None);
        self
    }

    /// The same integrator keeping, when `on`, the state at each whole step's start until the
    /// clutch first unlocks, for [`SpanEnd::first_unlock`] (off: `None` there, and no state is
    /// copied per step). The samples are the same either way.
    pub fn tracking_first_unlock(mut self, on: bool) -> Self {
        self.track_unlock = on;
        self
    }

    /// The step, s (also the output period outside the lash's substeps).
    pub fn step_s(&self) -> f64 {
        self.dt
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
        let dt = if k.sub {
            self.dt / self.gap_substeps as f64
        } else {
            self.dt
        };
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

    #[inline(always)]
    fn road_force(&self, sc: &Scenario, cur: &Cursors, t: f64, v: f64) -> f64 {
        self.p.road_force(
            v,
            sc.slope.eval_from(&cur.slope, t),
            held_value(&sc.brake_n, &cur.brake, &cur.held_brake, t, |b| b),
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
        self.run_span(sc, (t_start, t_end), Start::At(y0, mode0), &mut traj)?;
        Ok(traj)
    }

    /// [`FastDriveline::simulate_span`] with each sample's time and state handed to `out`
    /// instead of a [`Trajectory`] (nothing else is computed for it: no torques, modes, gears
    /// or events), the last sample only when `last` is set; returns the state and clutch mode
    /// at `t_end`, whether the clutch was locked at every sample, and (with
    /// [`FastDriveline::tracking_first_unlock`]) the whole step a larger capacity can take the
    /// span up at ([`SpanEnd::first_unlock`]). The states are those of
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
        self.span_states(sc, (t_start, t_end), Start::At(y0, mode0), last, out)
    }

    /// [`FastDriveline::simulate_span_states`] of `[t_start, t_end]` taken up at the whole
    /// step `from` of an earlier simulation of the same span
    /// ([`SpanEnd::first_unlock`]), clutch locked: the samples from that step's start on. With
    /// every parameter the same except a clutch capacity at least the earlier one's, the
    /// samples are those of simulating the whole span, bit for bit: up to that step the clutch
    /// stayed locked, where a larger capacity changes nothing (see
    /// [`FastDriveline::simulate_span_states`]), and the steps keep their times on the span's
    /// grid.
    ///
    /// # Errors
    /// As [`FastDriveline::simulate_span`].
    pub fn resume_span_states(
        &mut self,
        sc: &Scenario,
        span: (f64, f64),
        from: &Resume,
        last: bool,
        out: &mut dyn FnMut(f64, &[f64; N_STATES]),
    ) -> Result<SpanEnd, SimError> {
        self.span_states(sc, span, Start::Resume(*from), last, out)
    }

    fn span_states(
        &mut self,
        sc: &Scenario,
        span: (f64, f64),
        start: Start,
        last: bool,
        out: &mut dyn FnMut(f64, &[f64; N_STATES]),
    ) -> Result<SpanEnd, SimError> {
        let (y0, mode0) = match start {
            Start::At(y, m) => (y, m),
            Start::Resume(r) => (r.y, ClutchMode::Locked),
        };
        let mut sink = StateSink {
            out,
            last,
            end: (y0, mode0),
            locked: true,
        };
        let first_unlock = self.run_span(sc, span, start, &mut sink)?;
        Ok(SpanEnd {
            y: sink.end.0,
            mode: sink.end.1,
            locked_throughout: sink.locked,
            first_unlock,
        })
    }

    /// The integration loop of [`FastDriveline::simulate_span`], its samples into `sink`, from
    /// `start`; returns the span's [`SpanEnd::first_unlock`].
    ///
    /// On x86-64 CPUs with AVX (checked at run time) the loop is compiled with 256-bit
    /// registers; the operations and their order are the same (no fused multiply-adds), so
    /// every CPU gives the same bits.
    fn run_span<S: Sink>(
        &mut self,
        sc: &Scenario,
        span: (f64, f64),
        start: Start,
        sink: &mut S,
    ) -> Result<Option<Resume>, SimError> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: `run_span_avx` only requires AVX, which the CPU was just found to have.
            return unsafe { self.run_span_avx(sc, span, start, sink) };
        }
        self.run_span_on(sc, span, start, sink)
    }

    /// [`FastDriveline::run_span_on`] compiled with AVX enabled.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn run_span_avx<S: Sink>(
        &mut self,
        sc: &Scenario,
        span: (f64, f64),
        start: Start,
        sink: &mut S,
    ) -> Result<Option<Resume>, SimError> {
        self.run_span_on(sc, span, start, sink)
    }

    /// The loop of [`FastDriveline::run_span`].
    #[inline(always)]
    fn run_span_on<S: Sink>(
        &mut self,
        sc: &Scenario,
        (t_start, t_end): (f64, f64),
        start: Start,
        sink: &mut S,
    ) -> Result<Option<Resume>, SimError> {
        let dt = self.dt;
        let n = ((t_end - t_start) / dt).round() as usize;
        let cur = Cursors::default();
        let (k0, mut w) = match start {
            Start::At(y0, mode0) => (
                0,
                Walk {
                    y: y0,
                    mode: mode0,
                    // vehicle held at standstill (only with `standstill_events`)
                    stuck: sc.standstill_events && y0[7] == 0.0,
                    gear: self.gear_at(sc, &cur, t_start + 0.5 * dt)?,
                },
            ),
            Start::Resume(r) => {
                let t = t_start + r.k as f64 * dt;
                let walk = Walk {
                    y: r.y,
                    mode: ClutchMode::Locked,
                    stuck: r.stuck,
                    gear: self.gear_at(sc, &cur, t + 0.5 * dt)?,
                };
                (r.k, walk)
            }
        };
        if w.mode == ClutchMode::Locked {
            w.y[1] = w.y[0];
        }
        let split = self.lash > 0.0 && self.gap_substeps > 1;
        let mut trial_events = Vec::new();
        // the last whole step begun with the clutch locked, until it first unlocks
        let (mut resume, mut unlocked) = (None, false);
        for k in k0..=n {
            let t = t_start + k as f64 * dt;
            unlocked |= w.mode != ClutchMode::Locked;
            if self.track_unlock && !unlocked {
                resume = Some(Resume {
                    k,
                    y: w.y,
                    stuck: w.stuck,
                });
            }
            let (me, pi_active, _) = self.engine_torque(sc, &cur, t, &w.y);
            self.sample(sc, &cur, &w, t, me, k == n, sink);
            if k == n {
                break;
            }
            if !split {
                self.advance(sc, &cur, &mut w, t, false, (me, pi_active), &mut |e| {
                    sink.event(e)
                })?;
                sink.step();
                continue;
            }
            // with the lash's substeps: the whole step where the shaft stays in contact on
            // one side, clear of the gap, at both its ends; the substeps elsewhere
            let side = self.lash_side(w.y[6]);
            if side != 0.0 && self.clear_of_gap(&w.y, side) {
                let mut trial = w;
                trial_events.clear();
                self.advance(sc, &cur, &mut trial, t, false, (me, pi_active), &mut |e| {
                    trial_events.push(e)
                })?;
                if self.lash_side(trial.y[6]) == side && self.clear_of_gap(&trial.y, side) {
                    w = trial;
                    trial_events.drain(..).for_each(|e| sink.event(e));
                    sink.step();
                    continue;
                }
            }
            let h = dt / self.gap_substeps as f64;
            for j in 0..self.gap_substeps {
                let ts = t + j as f64 * h;
                let (me_j, pi_j) = if j == 0 {
                    (me, pi_active)
                } else {
                    let (m, pi, _) = self.engine_torque(sc, &cur, ts, &w.y);
                    self.sample(sc, &cur, &w, ts, m, false, sink);
                    (m, pi)
                };
                self.advance(sc, &cur, &mut w, ts, true, (me_j, pi_j), &mut |e| {
                    sink.event(e)
                })?;
                sink.step();
            }
        }
        Ok(if unlocked { resume } else { None })
    }

    /// The drive shaft in contact on `side` (±1) is clear of the lash gap: its twist beyond the
    /// play is at least what its twist rate covers in one whole step, `s·φ_d − b/2 ≥ |ω_d − ω_w| dt`.
    fn clear_of_gap(&self, y: &[f64; N_STATES], side: f64) -> bool {
        side * y[6] - 0.5 * self.lash >= (y[5] - y[7]).abs() * self.dt
    }

    /// Kinetic clutch capacity at `t` from the scenario's clutch position, N·m.
    #[inline]
    fn capacity_at(&self, sc: &Scenario, cur: &Cursors, t: f64) -> f64 {
        held_value(&sc.clutch_x, &cur.clutch, &cur.held_capacity, t, |x| {
            self.clutch_capacity(x)
        })
    }

    /// Gear at `t` from the scenario, checked against the gearbox.
    fn gear_at(&self, sc: &Scenario, cur: &Cursors, t: f64) -> Result<usize, SimError> {
        let g = round_to_i64(held_value(&sc.gear, &cur.gear, &cur.held_gear, t, |g| g));
        if g < 1 || g as usize > self.ratios.len() {
            return Err(SimError::Gear {
                gear: g,
                t,
                max: self.ratios.len(),
            });
        }
        Ok(g as usize)
    }

    /// (M_e in use, PI active in the matrices, ω_ref) at `t` in state `y`.
    #[inline(always)]
    fn engine_torque(
        &self,
        sc: &Scenario,
        cur: &Cursors,
        t: f64,
        y: &[f64; N_STATES],
    ) -> (f64, bool, f64) {
        let p = self.p;
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
    }

    /// Hands the sample at `t` (engine torque `me` in use) to `sink`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn sample<S: Sink>(
        &self,
        sc: &Scenario,
        cur: &Cursors,
        w: &Walk,
        t: f64,
        me: f64,
        last: bool,
        sink: &mut S,
    ) {
        if S::TORQUES {
            let [_, mc, mp, md] = self.torques(w.gear, w.mode, &w.y, me);
            let mtr = match w.mode {
                ClutchMode::Locked => self.m_trans_locked(me, mc),
                ClutchMode::Slipping(s) => s * self.capacity_at(sc, cur, t),
            };
            sink.sample(t, &w.y, w.mode, w.gear, [me, mc, mp, md, mtr], last);
        } else {
            sink.sample(t, &w.y, w.mode, w.gear, [0.0; 5], last);
        }
    }

    /// One step from `t` (the whole step, or with `sub` one of the lash's substeps), `w` moved
    /// to its end; `(me_start, pi_active)` is the engine torque at `t` as sampled. Gear changes
    /// and mode switches go to `event`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn advance(
        &mut self,
        sc: &Scenario,
        cur: &Cursors,
        w: &mut Walk,
        t: f64,
        sub: bool,
        (me_start, pi_active): (f64, bool),
        event: &mut dyn FnMut(Event),
    ) -> Result<(), SimError> {
        let p = self.p;
        let dt = if sub {
            self.dt / self.gap_substeps as f64
        } else {
            self.dt
        };
        let (je, jc) = (p.j_e_kg_m2, p.j_c_kg_m2);
        let tm = t + 0.5 * dt;
        let g = self.gear_at(sc, cur, tm)?;
        if g != w.gear {
            event(Event {
                t,
                kind: format!("gear_{}_to_{g}", w.gear),
            });
            w.gear = g;
        }
        let gear = w.gear;
        let (me_mid, _, w_ref) = match &sc.engine {
            EngineInput::Torque(m) => (m.eval_from(&cur.engine, tm), false, 0.0),
            EngineInput::SpeedReference(r) => (me_start, pi_active, r.eval_from(&cur.engine, tm)),
        };
        let m_trans_in = match w.mode {
            ClutchMode::Locked => 0.0,
            ClutchMode::Slipping(s) => s * self.capacity_at(sc, cur, tm),
        };
        let v_start = p.wheel_radius_m * w.y[7];
        let force = if w.stuck {
            // held: the ground reaction cancels the drive-shaft torque
            let [_, _, _, md0] = self.torques(gear, w.mode, &w.y, me_start);
            md0 / p.wheel_radius_m
        } else {
            self.road_force(sc, cur, tm, v_start)
        };
        let side = self.lash_side(w.y[6]);
        let key = Key {
            gear,
            locked: w.mode == ClutchMode::Locked,
            pi: pi_active,
            integrate: matches!(sc.engine, EngineInput::SpeedReference(_)),
            gap: side == 0.0,
            sub,
        };
        // in contact the nominal matrices act on the twist beyond the play
        let offset = side * 0.5 * self.lash;
        let (phi, gamma) = self.discrete(key);
        let u = SVector::<f64, N_IN>::new(me_mid, m_trans_in, force, w_ref);
        let mut z = SVector::<f64, N_STATES>::from_column_slice(&w.y);
        z[6] -= offset;
        let mut z1 = phi * z + gamma * u;
        z1[6] += offset;
        w.y.copy_from_slice(z1.as_slice());
        // mode switches at the step end
        let t1 = t + dt;
        if sc.standstill_events {
            let v_end = p.wheel_radius_m * w.y[7];
            let crossing = v_start != 0.0 && v_start * v_end <= 0.0;
            // the forces at the step end matter only when held or when the speed crosses 0
            if w.stuck || crossing {
                let (me1, _, _) = self.engine_torque(sc, cur, t1, &w.y);
                let [_, _, _, md1] = self.torques(gear, w.mode, &w.y, me1);
                let mg = p.mass_kg * p.gravity_m_per_s2;
                let drive = md1 / p.wheel_radius_m
                    - mg * crate::model::driveline::grade_sine(sc.slope.eval_from(&cur.slope, t1));
                let f0 = if sc.smoothing { 0.0 } else { 1.0 };
                let cap = f0 * p.c_r1 * mg + sc.brake_n.eval_from(&cur.brake, t1);
                if w.stuck {
                    if drive.abs() > cap {
                        w.stuck = false;
                        event(Event {
                            t: t1,
                            kind: "breakaway".into(),
                        });
                    } else {
                        w.y[7] = 0.0;
                    }
                } else if drive.abs() <= cap {
                    w.stuck = true;
                    w.y[7] = 0.0;
                    event(Event {
                        t: t1,
                        kind: "stop".into(),
                    });
                }
            }
        }
        match w.mode {
            ClutchMode::Locked => {
                w.y[1] = w.y[0];
                let (me1, _, _) = self.engine_torque(sc, cur, t1, &w.y);
                let [_, mc1, _, _] = self.torques(gear, w.mode, &w.y, me1);
                let mt = self.m_trans_locked(me1, mc1);
                if mt.abs() > p.clutch_static_to_kinetic * self.capacity_at(sc, cur, t1) {
                    w.mode = ClutchMode::Slipping(if mt > 0.0 { 1.0 } else { -1.0 });
                    event(Event {
                        t: t1,
                        kind: "unlock".into(),
                    });
                }
            }
            ClutchMode::Slipping(s) => {
                if s * (w.y[0] - w.y[1]) <= 0.0 {
                    let wm = (je * w.y[0] + jc * w.y[1]) / (je + jc);
                    let mut yt = w.y;
                    yt[0] = wm;
                    yt[1] = wm;
                    let (me1, _, _) = self.engine_torque(sc, cur, t1, &yt);
                    let [_, mc1, _, _] = self.torques(gear, ClutchMode::Locked, &yt, me1);
                    let mt = self.m_trans_locked(me1, mc1);
                    if mt.abs() <= p.clutch_static_to_kinetic * self.capacity_at(sc, cur, t1) {
                        w.mode = ClutchMode::Locked;
                        w.y = yt;
                        event(Event {
                            t: t1,
                            kind: "lock".into(),
                        });
                    } else {
                        w.mode = ClutchMode::Slipping(if mt > 0.0 { 1.0 } else { -1.0 });
                        event(Event {
                            t: t1,
                            kind: "slip_reversal".into(),
                        });
                    }
                }
            }
        }
        Ok(())
    }
}

/// Where [`FastDriveline::run_span`] starts: a state and clutch mode at the span's start, or a
/// whole step of an earlier simulation of the span.
#[derive(Clone, Copy)]
enum Start {
    At([f64; N_STATES], ClutchMode),
    Resume(Resume),
}

/// Where a simulation stands between steps ([`FastDriveline::run_span`]).
#[derive(Clone, Copy)]
struct Walk {
    y: [f64; N_STATES],
    mode: ClutchMode,
    /// Vehicle held at standstill (only with `standstill_events`).
    stuck: bool,
    /// Gear of the last step.
    gear: usize,
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

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_loop_compiled_with_avx_gives_the_bits_of_the_plain_one() {
        // a mixed-gear drive (every gear up and down, clutch launches and shifts) of the 40 t
        // truck, with and without lash (the lash's substeps); both loops must give every
        // sample's state and torques, the modes, gears and events, to the bit
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        use super::*;
        let veh = crate::model::vehicle::VehicleFile::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures/vehicles/truck-40t.toml"),
        )
        .unwrap();
        let p = veh.driveline.as_ref().unwrap();
        let r = &veh.gearbox.ratios;
        let (sc, y0, mode0) = crate::sim::scenarios::mixed_gear_drive(p, r, 240.0);
        for lash in [0.0, 0.05] {
            let run = |avx: bool| {
                let mut fast = FastDriveline::new(p, r, 0.01)
                    .with_lash(lash)
                    .with_gap_substeps(4);
                let mut traj = Trajectory::default();
                let span = (0.0, sc.t_end_s);
                let start = Start::At(y0, mode0);
                if avx {
                    // SAFETY: the CPU was found to have AVX above.
                    unsafe { fast.run_span_avx(&sc, span, start, &mut traj) }.unwrap();
                } else {
                    fast.run_span_on(&sc, span, start, &mut traj).unwrap();
                }
                traj
            };
            let (plain, avx) = (run(false), run(true));
            let bits = |t: &Trajectory| {
                let mut v: Vec<u64> = t.t.iter().map(|x| x.to_bits()).collect();
                v.extend(t.y.iter().flatten().map(|x| x.to_bits()));
                v.extend(t.torques.iter().flatten().map(|x| x.to_bits()));
                v
            };
            assert!(plain.t.len() > 20_000, "{}", plain.t.len());
            assert!(bits(&plain) == bits(&avx), "lash {lash}");
            assert_eq!(plain.mode, avx.mode);
            assert_eq!(plain.gear, avx.gear);
            assert_eq!(
                format!("{:?}", plain.events),
                format!("{:?}", avx.events),
                "lash {lash}"
            );
        }
    }

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
