//! The half-truck axle-load model (axle-load thesis, §3.6): five second-order equations — chassis
//! bounce `z` and pitch `θ`, front axle `z_f`, rear and tag trailing arms `φ_r`, `φ_t` — assembled
//! by virtual work from the point Jacobians of docs/models/axle.md, where the sign convention, the
//! diagram and the derivation are written down.
//!
//! Conventions: q are small deviations from the static equilibrium on a level road (`z` up, `θ`
//! nose up, `z_f` up, `φ` arm's rear end up); positions `x` rearwards from the front axle,
//! heights above the ground; longitudinal forces + forward at the contact patches; torques at
//! the driven wheels, + driving; the auxiliary brake torque + braking; slope `s = tan α`, + uphill;
//! acceleration along the road, + forward. Outputs: normal forces (N), bellow gauge pressures
//! `p = F/A_eff` (Pa), suspension travel at each axle (chassis-to-axle distance change, m,
//! + extension), pitch (rad, + nose up) and pitch rate (rad/s).
//!
//! Integration: classical fixed-step Runge–Kutta 4. The model is linear but for the damper
//! tables, its fastest mode is the wheel hop (~10 Hz), and recorded inputs are sampled at 10–100
//! Hz, so a fixed step of at most 2 ms and at most 0.5/ρ (ρ the spectral radius of the
//! linearised system with the dampers' steepest slopes) is accurate and stable; the reference
//! test compares it with an independent derivation integrated by scipy (tests/it/axle_reference.rs).
//! [`HalfTruck::with_max_step`] trades accuracy for speed up to the bound 0.5/ρ.
//! [`HalfTruck::with_segment_steps`] steps the model exactly over each output interval in which
//! no damper changes segment, and by RK4 over the others.
//!
//! Extensions ([`AxleExtensions`], [`HalfTruck::with_extensions`]) add physics the nominal model
//! leaves out — the axle-load effects of the diagnosis catalogue (docs/diagnosis/catalogue.md).
//! All zero is the nominal model, bit for bit.
//!
//! # Reference
//!
//! The axle-load thesis: a Master's thesis written with Scania on estimating the dynamic axle
//! loads (normal forces) of a 6x2 electrified truck — front, driven rear and tag axle — with
//! quarter-car, bounce-pitch and half-truck models, validated against CAN-bus bellow pressures
//! and scale weights. The copy the model was built from names no author; it is cited in this
//! crate as "the axle-load thesis" with its section and equation numbers (docs/models/axle.md).

mod segment_steps;

use super::inputs::Piecewise;
pub use crate::model::axle::AxleExtensions;
use crate::model::axle::{Axle, AxleParams, DamperTable, StaticState};
use nalgebra::{SMatrix, SVector};

type V5 = SVector<f64, 5>;
type M5 = SMatrix<f64, 5, 5>;

const Z: usize = 0;
const TH: usize = 1;
const ZF: usize = 2;

/// Inputs of the axle model, functions of time (s from the start).
#[derive(Debug, Clone, PartialEq)]
pub struct AxleInputs {
    /// Longitudinal acceleration along the road, m/s² (+ forward), from speed or an IMU.
    pub accel_mps2: Piecewise,
    /// Road slope tan α (+ uphill).
    pub slope: Piecewise,
    /// Drive torque at the driven wheels, N·m (engine torque × gear ratio × final drive, or a
    /// motor torque signal × its ratio). `None` with `aux_brake_torque_wheel_nm` also `None`:
    /// the whole longitudinal force is taken at the driven axle.
    pub drive_torque_wheel_nm: Option<Piecewise>,
    /// Auxiliary brake torque at the driven wheels, N·m (+ braking).
    pub aux_brake_torque_wheel_nm: Option<Piecewise>,
    /// Total service-brake force at the ground, N (+ braking), shared by the vehicle file.
    pub service_brake_n: Option<Piecewise>,
}

/// Longitudinal forces at one instant, N (+ forward): at the three contact patches and the
/// unexplained remainder acting at `resistance_height_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Longitudinal {
    /// Front, rear, tag contact-patch forces.
    pub contact_n: [f64; 3],
    /// Remainder `m(a + g sin α) − Σ contact` at the resistance height.
    pub resistance_n: f64,
    /// Acceleration, m/s².
    pub accel_mps2: f64,
    /// `sin α` of the grade angle α.
    pub sin_alpha: f64,
    /// `cos α` of the grade angle α.
    pub cos_alpha: f64,
}

/// Piece indices of the five inputs, moved forward as time increases (so a long recorded drive
/// costs no binary search per evaluation).
#[derive(Debug, Clone, Copy, Default)]
struct Cursor([usize; 5]);

impl Cursor {
    #[inline]
    fn eval(&mut self, i: usize, s: &Piecewise, t: f64) -> f64 {
        let n = s.piece_count();
        let mut k = self.0[i].min(n - 1);
        if s.piece_start(k) > t {
            k = s.piece_index(t); // time went back: search again
        }
        while k + 1 < n && s.piece_start(k + 1) <= t {
            k += 1;
        }
        self.0[i] = k;
        s.eval_piece(k, t)
    }
}

/// Where a simulation starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    /// The static state on a level road (q = 0, at rest).
    Static,
    /// The steady state of the inputs at the first time (a recording that starts on a grade or
    /// moving).
    Steady,
    /// A given state `[z, θ, z_f, φ_r, φ_t, ż, θ̇, ż_f, φ̇_r, φ̇_t]`.
    State([f64; 10]),
}

/// Outputs sampled at the requested times.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AxleTrajectory {
    /// Times, s.
    pub t_s: Vec<f64>,
    /// Normal forces front, rear, tag, N.
    pub normal_n: [Vec<f64>; 3],
    /// Bellow gauge pressures, Pa.
    pub pressure_pa: [Vec<f64>; 3],
    /// Suspension travel at each axle, m (+ extension, 0 at the static state).
    pub travel_m: [Vec<f64>; 3],
    /// Chassis pitch, rad (+ nose up).
    pub pitch_rad: Vec<f64>,
    /// Chassis pitch rate, rad/s.
    pub pitch_rate_rad_per_s: Vec<f64>,
    /// Chassis CG vertical displacement, m (+ up).
    pub bounce_m: Vec<f64>,
    /// Largest auxiliary brake torque at the driven wheels keeping the slip ratio under the
    /// limit, from the simulated driven-axle load (axle-load thesis, eq. 1.1.1), N·m.
    pub aux_brake_limit_wheel_nm: Vec<f64>,
}

/// The assembled model.
#[derive(Debug, Clone)]
pub struct HalfTruck<'a> {
    p: &'a AxleParams,
    st: StaticState,
    m_inv: M5,
    k: M5,
    /// `M⁻¹ K`, and `M⁻¹ d` of the damper and bellow compression directions: the accelerations
    /// per unit state and per unit force (the step's products, formed once).
    m_inv_k: M5,
    m_inv_damper_d: [V5; 3],
    m_inv_bellow_d: [V5; 3],
    /// Constant generalised forces of the preloads (tyres, bellows) at q = 0.
    q_pre: V5,
    /// Σ m J_w (gravity normal to the road), Σ m J_u (along the road).
    g_w: V5,
    g_u: V5,
    /// J_u of the three contact patches and of the resistance point.
    contact: [V5; 3],
    resist: V5,
    /// J_w of the axle centres and of the chassis points above them.
    axle_w: [V5; 3],
    chassis_above: [V5; 3],
    /// Bellow and damper compression directions.
    bellow_d: [V5; 3],
    damper_d: [V5; 3],
    dampers: [DamperTable; 3],
    h_max: f64,
    /// Bound of the step from the fastest mode, 0.5/ρ, s.
    h_mode: f64,
    ext: AxleExtensions,
    /// Index of the rear arm's coordinate.
    rear_arm: usize,
    /// Step exactly where the dampers stay on one segment ([`HalfTruck::with_segment_steps`]).
    segment_steps: bool,
}

fn e(i: usize) -> V5 {
    let mut v = V5::zeros();
    v[i] = 1.0;
    v
}

impl<'a> HalfTruck<'a> {
    /// Assembles the model for checked parameters (`AxleParams::from_table`).
    pub fn new(p: &'a AxleParams) -> Self {
        let st = p.static_state();
        let (xc, hc, rw) = (st.chassis_x_cg_m, p.chassis_cg_height_m, p.wheel_radius_m);
        // point Jacobians (docs/models/axle.md): rows of ∂δu/∂q and ∂δw/∂q
        let chassis = |x: f64, h: f64| -> (V5, V5) { (-(h - hc) * e(TH), e(Z) + (xc - x) * e(TH)) };
        let front = |x: f64, h: f64| -> (V5, V5) { (-(h - hc) * e(TH), e(ZF) - x * e(TH)) };
        let arm = |a: Axle, x: f64, h: f64| -> (V5, V5) {
            let idx = if a == Axle::Rear { 3 } else { 4 };
            let (hp, la, ..) = p.arm(a).expect("rear and tag have arms");
            let xp = p.axle_x(a) - la;
            (
                -(hp - hc) * e(TH) + (h - hp) * e(idx),
                e(Z) + (xc - xp) * e(TH) + (x - xp) * e(idx),
            )
        };
        let mut m = M5::zeros();
        let (mut g_w, mut g_u) = (V5::zeros(), V5::zeros());
        let mut masses = vec![
            (p.chassis_mass_kg, chassis(xc, hc)),
            (p.axle_mass_front_kg, front(0.0, rw)),
        ];
        for a in [Axle::Rear, Axle::Tag] {
            masses.push((p.axle_mass(a), arm(a, p.axle_x(a), rw)));
        }
        for (mass, (ju, jw)) in masses {
            m += mass * (ju * ju.transpose() + jw * jw.transpose());
            g_w += mass * jw;
            g_u += mass * ju;
        }
        m[(TH, TH)] += p.chassis_pitch_inertia_kg_m2;
        for (a, idx) in [(Axle::Rear, 3), (Axle::Tag, 4)] {
            let (hp, la, _, _, i_pivot) = p.arm(a).expect("arm");
            m[(idx, idx)] += i_pivot - p.axle_mass(a) * (la * la + (rw - hp).powi(2));
        }
        let mut k = M5::zeros();
        let mut q_pre = V5::zeros();
        let mut contact = [V5::zeros(); 3];
        let mut axle_w = [V5::zeros(); 3];
        let mut chassis_above = [V5::zeros(); 3];
        let mut bellow_d = [V5::zeros(); 3];
        let mut damper_d = [V5::zeros(); 3];
        for (i, a) in Axle::ALL.iter().copied().enumerate() {
            let x = p.axle_x(a);
            let body = |xx: f64, h: f64| match a {
                Axle::Front => front(xx, h),
                _ => arm(a, xx, h),
            };
            let (ju_c, jw_ax) = body(x, 0.0);
            contact[i] = ju_c;
            axle_w[i] = jw_ax;
            chassis_above[i] = chassis(x, rw).1;
            // tyre: N = N0 − k_t J_w q, acting up on the axle
            k += p.tyre_stiffness(a) * jw_ax * jw_ax.transpose();
            q_pre += st.normal_n[i] * jw_ax;
            let (xb, xd) = match p.arm(a) {
                None => (0.0, 0.0),
                Some((_, la, lb, ld, _)) => (x - la + lb, x - la + ld),
            };
            // compression direction d = J_w(body) − J_w(chassis); force −d·B on q
            bellow_d[i] = body(xb, rw).1 - chassis(xb, rw).1;
            damper_d[i] = body(xd, rw).1 - chassis(xd, rw).1;
            k += p.bellow_stiffness(a) * bellow_d[i] * bellow_d[i].transpose();
            q_pre -= st.bellow_n[i] * bellow_d[i];
        }
        let resist = chassis(xc, p.resistance_height_m).0;
        let dampers = Axle::ALL.map(|a| p.damper(a));
        let m_inv = m
            .try_inverse()
            .expect("the mass matrix of checked parameters is positive definite");
        // spectral radius of the linearised first-order system with the steepest damper slopes
        let mut c = M5::zeros();
        for (i, d) in dampers.iter().enumerate() {
            let slope = |v: &[f64], f: &[f64]| {
                let mut s = f[0] / v[0];
                for w in 0..v.len() - 1 {
                    s = s.max((f[w + 1] - f[w]) / (v[w + 1] - v[w]));
                }
                s
            };
            let cmax = slope(&d.ext_v, &d.ext_f).max(slope(&d.comp_v, &d.comp_f));
            c += cmax * damper_d[i] * damper_d[i].transpose();
        }
        let mut a = SMatrix::<f64, 10, 10>::zeros();
        for r in 0..5 {
            a[(r, r + 5)] = 1.0;
        }
        let mk = -(m_inv * k);
        let mc = -(m_inv * c);
        for r in 0..5 {
            for col in 0..5 {
                a[(r + 5, col)] = mk[(r, col)];
                a[(r + 5, col + 5)] = mc[(r, col)];
            }
        }
        let rho = a
            .complex_eigenvalues()
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max);
        let h_mode = 0.5 / rho;
        let h_max = h_mode.min(2e-3);
        Self {
            p,
            st,
            m_inv,
            k,
            m_inv_k: m_inv * k,
            m_inv_damper_d: damper_d.map(|d| m_inv * d),
            m_inv_bellow_d: bellow_d.map(|d| m_inv * d),
            q_pre,
            g_w,
            g_u,
            contact,
            resist,
            axle_w,
            chassis_above,
            bellow_d,
            damper_d,
            dampers,
            h_max,
            h_mode,
            ext: AxleExtensions::default(),
            rear_arm: 3,
            segment_steps: false,
        }
    }

    /// The same model with the given extensions (see [`AxleExtensions`]).
    pub fn with_extensions(mut self, ext: AxleExtensions) -> Self {
        self.ext = ext;
        self
    }

    /// The same model integrated with a step of at most `h_s` (s) instead of 2 ms, and still at
    /// most 0.5/ρ (module doc; RK4 is stable to |hλ| ≈ 2.8). A non-positive or non-finite `h_s`
    /// leaves the step as it is. The error this trades for speed is the caller's to state: on
    /// recorded inputs it grows about linearly with the step, from the kinks of the inputs
    /// between their samples and of the damper tables at zero rate, not with RK4's fourth order
    /// (measured where the diagnosis sets its step, `diagnose::axle_model`).
    pub fn with_max_step(mut self, h_s: f64) -> Self {
        if h_s.is_finite() && h_s > 0.0 {
            self.h_max = self.h_mode.min(h_s);
        }
        self
    }

    /// The same model stepped exactly from one output time to the next wherever no damper
    /// changes segment over the interval, and by RK4 at the usual step elsewhere. Between the
    /// damper tables' points the model is linear, and recorded inputs are linear or held
    /// between their samples, so over an interval no longer than 2/ρ that holds no input
    /// sample, with every damper on one segment at both ends and along the cubic through its
    /// rate and the rate's slope at both ends, the state at its end is
    /// `Φ x₀ + Γ₀ w(t₀) + Γ₁ w(t₁⁻)` with the first-order-hold matrices of that segment
    /// configuration (`w` the external and damper-intercept accelerations; derivation in the
    /// source of `sim/axle/segment_steps.rs`). A damper that leaves its segment and comes back
    /// within one interval in a way that cubic does not show is stepped as if it had stayed.
    /// Without the bellows' progression (non-linear in the travel) only; with it the model
    /// steps by RK4 throughout.
    pub fn with_segment_steps(mut self) -> Self {
        self.segment_steps = true;
        self
    }

    /// The extensions in use.
    pub fn extensions(&self) -> &AxleExtensions {
        &self.ext
    }

    /// The static state the model is built on.
    pub fn static_state(&self) -> &StaticState {
        &self.st
    }

    /// The fixed integration step used, s.
    pub fn step_s(&self) -> f64 {
        self.h_max
    }

    /// The constant mass matrix M, rows and columns in the order of q (`z`, `θ`, `z_f`, `φ_r`,
    /// `φ_t`; kg, kg·m, kg·m²): for comparisons with other derivations.
    pub fn mass_matrix(&self) -> [[f64; 5]; 5] {
        let m = self
            .m_inv
            .try_inverse()
            .expect("the mass matrix is positive definite");
        std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
    }

    /// The stiffness matrix K (`M q̈ = Q − K q − …`), in the order of q: for comparisons.
    pub fn stiffness_matrix(&self) -> [[f64; 5]; 5] {
        std::array::from_fn(|i| std::array::from_fn(|j| self.k[(i, j)]))
    }

    /// Longitudinal forces at time `t` (docs/models/axle.md): with torque inputs, the contact
    /// forces come from them and the service brake, and the remainder acts at the resistance
    /// height; without, the driven axle takes everything the service brake does not.
    pub fn longitudinal(&self, u: &AxleInputs, t: f64) -> Longitudinal {
        self.longitudinal_with(u, t, &mut Cursor::default())
    }

    /// [`HalfTruck::longitudinal`] with a cursor over the input pieces, for increasing times.
    #[inline(always)]
    fn longitudinal_with(&self, u: &AxleInputs, t: f64, c: &mut Cursor) -> Longitudinal {
        self.longitudinal_by(u, |i, s| c.eval(i, s, t))
    }

    /// [`HalfTruck::longitudinal`] from the inputs' values `value(i, input)` (`i` the input's
    /// index in the order accel, slope, service brake, drive torque, auxiliary brake torque).
    #[inline(always)]
    fn longitudinal_by(
        &self,
        u: &AxleInputs,
        mut value: impl FnMut(usize, &Piecewise) -> f64,
    ) -> Longitudinal {
        let p = self.p;
        let a = value(0, &u.accel_mps2);
        // sin α and cos α of the slope s = tan α, algebraically (no atan, sin, cos per step)
        let s = value(1, &u.slope);
        let cos_alpha = 1.0 / (1.0 + s * s).sqrt();
        let sin_alpha = s * cos_alpha;
        let total = self.st.mass_kg * (a + p.gravity_m_per_s2 * sin_alpha);
        let fb = u.service_brake_n.as_ref().map_or(0.0, |s| value(2, s));
        let mut f = Axle::ALL.map(|ax| -p.brake_share(ax) * fb);
        let torque = u.drive_torque_wheel_nm.is_some() || u.aux_brake_torque_wheel_nm.is_some();
        let resistance = if torque {
            let td = u
                .drive_torque_wheel_nm
                .as_ref()
                .map_or(0.0, |s| value(3, s));
            let ta = u
                .aux_brake_torque_wheel_nm
                .as_ref()
                .map_or(0.0, |s| value(4, s));
            f[1] += (td - ta) / p.wheel_radius_m;
            total - f.iter().sum::<f64>()
        } else {
            f[1] = total - f[0] - f[2];
            0.0
        };
        Longitudinal {
            contact_n: f,
            resistance_n: resistance,
            accel_mps2: a,
            sin_alpha,
            cos_alpha,
        }
    }

    /// Generalised forces that do not depend on the state.
    #[inline(always)]
    fn external(&self, l: &Longitudinal) -> V5 {
        let g = self.p.gravity_m_per_s2;
        let mut q =
            self.q_pre - g * l.cos_alpha * self.g_w - (l.accel_mps2 + g * l.sin_alpha) * self.g_u
                + l.resistance_n * self.resist;
        for i in 0..3 {
            q += l.contact_n[i] * self.contact[i];
        }
        if self.ext.torque_reaction != 0.0 {
            let t = l.contact_n[1] * self.p.wheel_radius_m;
            q[self.rear_arm] += self.ext.torque_reaction * t;
            q[TH] += self.ext.torque_reaction * t;
        }
        if self.ext.grade_height_offset_m != 0.0 {
            q[TH] += self.p.chassis_mass_kg * g * l.sin_alpha * self.ext.grade_height_offset_m;
        }
        q
    }

    /// Generalised force of the bellows' progression at state q (0 without it).
    #[inline]
    fn progression(&self, q: &V5) -> V5 {
        let mut f = V5::zeros();
        if self.ext.bellow_progression_per_m != 0.0 {
            for i in 0..3 {
                let c = self.bellow_d[i].dot(q);
                let k = self.p.bellow_stiffness(Axle::ALL[i]);
                f -= (self.bellow_spring(k, c) - k * c) * self.bellow_d[i];
            }
        }
        f
    }

    /// Spring force beyond the preload of a bellow of stiffness `k` at compression `c`.
    #[inline]
    fn bellow_spring(&self, k: f64, c: f64) -> f64 {
        let gamma = self.ext.bellow_progression_per_m;
        if gamma == 0.0 {
            k * c
        } else {
            k * (2.0 * gamma * c).exp_m1() / (2.0 * gamma)
        }
    }

    /// Accelerations q̈ = M⁻¹ (Q_ext − K q + P(q) − Σ F_i(d_i·q̇) d_i) for state (q, q̇), with
    /// `ae = M⁻¹ Q_ext` the external forces' part ([`HalfTruck::forced`]), P the bellows'
    /// progression and F_i the damper tables.
    #[inline(always)]
    fn accel(&self, q: &V5, qd: &V5, ae: &V5) -> V5 {
        let mut a = ae - self.m_inv_k * q;
        if self.ext.bellow_progression_per_m != 0.0 {
            for i in 0..3 {
                let c = self.bellow_d[i].dot(q);
                let k = self.p.bellow_stiffness(Axle::ALL[i]);
                a -= (self.bellow_spring(k, c) - k * c) * self.m_inv_bellow_d[i];
            }
        }
        for i in 0..3 {
            let rate = self.damper_d[i].dot(qd);
            a -= self.dampers[i].force(rate) * self.m_inv_damper_d[i];
        }
        a
    }

    /// `M⁻¹ Q_ext`: the accelerations the external forces at time `t` give ([`HalfTruck::external`]).
    #[inline(always)]
    fn forced(&self, u: &AxleInputs, t: f64, c: &mut Cursor) -> V5 {
        self.m_inv * self.external(&self.longitudinal_with(u, t, c))
    }

    /// The steady state (q̇ = 0, q̈ = 0) under constant longitudinal forces: `K q = Q_ext`.
    pub fn steady_state(&self, l: &Longitudinal) -> V5 {
        let qe = self.external(l);
        let lu = self.k.lu();
        let solve = |rhs: &V5| {
            lu.solve(rhs)
                .expect("the stiffness matrix of checked parameters is regular")
        };
        let mut q = solve(&qe);
        if self.ext.bellow_progression_per_m != 0.0 {
            // K q = Q_ext + P(q): fixed-point iteration (the progression is a small correction)
            for _ in 0..50 {
                let next = solve(&(qe + self.progression(&q)));
                let done = (next - q).norm() <= 1e-12 * (1.0 + q.norm());
                q = next;
                if done {
                    break;
                }
            }
        }
        q
    }

    /// Normal forces front, rear, tag at state q, N.
    pub fn normal_forces(&self, q: &V5) -> [f64; 3] {
        [0, 1, 2].map(|i| {
            self.st.normal_n[i] - self.p.tyre_stiffness(Axle::ALL[i]) * self.axle_w[i].dot(q)
        })
    }

    /// Bellow forces front, rear, tag at state q, N (spring part; `p = F/A_eff`).
    pub fn bellow_forces(&self, q: &V5) -> [f64; 3] {
        [0, 1, 2].map(|i| {
            let c = self.bellow_d[i].dot(q);
            self.st.bellow_n[i] + self.bellow_spring(self.p.bellow_stiffness(Axle::ALL[i]), c)
        })
    }

    /// Right-hand side of the first-order system, for other integrators (state `[q, q̇]`).
    pub fn rhs(&self, u: &AxleInputs, t: f64, y: &[f64], dy: &mut [f64]) {
        let q = V5::from_column_slice(&y[..5]);
        let qd = V5::from_column_slice(&y[5..10]);
        let ae = self.forced(u, t, &mut Cursor::default());
        let qdd = self.accel(&q, &qd, &ae);
        dy[..5].copy_from_slice(qd.as_slice());
        dy[5..].copy_from_slice(qdd.as_slice());
    }

    /// Simulates from `t_out[0]` and samples the outputs at every `t_out` (increasing, s).
    pub fn simulate(&self, u: &AxleInputs, t_out: &[f64], start: Start) -> AxleTrajectory {
        let mut out = AxleTrajectory::default();
        let n = t_out.len();
        for v in out
            .normal_n
            .iter_mut()
            .chain(out.pressure_pa.iter_mut())
            .chain(out.travel_m.iter_mut())
        {
            v.reserve(n);
        }
        self.integrate(u, t_out, start, |q, qd, t| self.sample(q, qd, t, &mut out));
        out
    }

    /// The bellow gauge pressures front, rear, tag at every `t_out` (increasing, s), Pa: the
    /// [`AxleTrajectory::pressure_pa`] of [`HalfTruck::simulate`], bit for bit, without the
    /// other outputs.
    pub fn simulate_pressures(&self, u: &AxleInputs, t_out: &[f64], start: Start) -> [Vec<f64>; 3] {
        let mut out: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(t_out.len()));
        self.integrate(u, t_out, start, |q, _, _| {
            for (i, p) in self.pressures(q).into_iter().enumerate() {
                out[i].push(p);
            }
        });
        out
    }

    /// Integrates from `t_out[0]` and hands the state (q, q̇) at every `t_out` to `at`.
    ///
    /// On x86-64 CPUs with AVX (checked at run time) the loop is compiled with 256-bit
    /// registers; the operations and their order are the same (no fused multiply-adds), so
    /// every CPU gives the same bits.
    fn integrate(
        &self,
        u: &AxleInputs,
        t_out: &[f64],
        start: Start,
        at: impl FnMut(&V5, &V5, f64),
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: `integrate_avx` only requires AVX, which the CPU was just found to have.
            return unsafe { self.integrate_avx(u, t_out, start, at) };
        }
        self.integrate_on(u, t_out, start, at);
    }

    /// [`HalfTruck::integrate_on`] compiled with AVX enabled.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn integrate_avx(
        &self,
        u: &AxleInputs,
        t_out: &[f64],
        start: Start,
        at: impl FnMut(&V5, &V5, f64),
    ) {
        self.integrate_on(u, t_out, start, at);
    }

    /// The integration loop of [`HalfTruck::integrate`].
    #[inline(always)]
    fn integrate_on(
        &self,
        u: &AxleInputs,
        t_out: &[f64],
        start: Start,
        mut at: impl FnMut(&V5, &V5, f64),
    ) {
        let Some(&t0) = t_out.first() else {
            return;
        };
        let (mut q, mut qd) = match start {
            Start::Static => (V5::zeros(), V5::zeros()),
            Start::Steady => (self.steady_state(&self.longitudinal(u, t0)), V5::zeros()),
            Start::State(y) => (
                V5::from_column_slice(&y[..5]),
                V5::from_column_slice(&y[5..]),
            ),
        };
        let mut t = t0;
        let mut cur = Cursor::default();
        let mut exact = (self.segment_steps && self.ext.bellow_progression_per_m == 0.0)
            .then(|| segment_steps::SegmentSteps::new(self));
        for &tk in t_out {
            let span = tk - t;
            if span > 0.0 {
                let mut qe0 = self.forced(u, t, &mut cur);
                // a match, not a closure: the step is compiled into this loop (AVX)
                let stepped = match exact.as_mut() {
                    Some(x) => x.step(u, &cur, t, tk, &q, &qd, &qe0),
                    None => None,
                };
                if let Some((q1, qd1)) = stepped {
                    (q, qd, t) = (q1, qd1, tk);
                    at(&q, &qd, tk);
                    continue;
                }
                let steps = (span / self.h_max).ceil().max(1.0) as usize;
                let h = span / steps as f64;
                for _ in 0..steps {
                    let qe1 = self.forced(u, t + 0.5 * h, &mut cur);
                    let qe2 = self.forced(u, t + h, &mut cur);
                    let k1v = self.accel(&q, &qd, &qe0);
                    let k1x = qd;
                    let k2x = qd + 0.5 * h * k1v;
                    let k2v = self.accel(&(q + 0.5 * h * k1x), &k2x, &qe1);
                    let k3x = qd + 0.5 * h * k2v;
                    let k3v = self.accel(&(q + 0.5 * h * k2x), &k3x, &qe1);
                    let k4x = qd + h * k3v;
                    let k4v = self.accel(&(q + h * k3x), &k4x, &qe2);
                    q += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                    qd += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
                    t += h;
                    qe0 = qe2;
                }
                t = tk;
            }
            at(&q, &qd, tk);
        }
    }

    /// Bellow gauge pressures front, rear, tag at state q, Pa (`p = F/A_eff`).
    fn pressures(&self, q: &V5) -> [f64; 3] {
        let b = self.bellow_forces(q);
        [0, 1, 2].map(|i| b[i] / self.p.bellow_area(Axle::ALL[i]))
    }

    fn sample(&self, q: &V5, qd: &V5, t: f64, out: &mut AxleTrajectory) {
        let n = self.normal_forces(q);
        let p = self.pressures(q);
        out.t_s.push(t);
        for i in 0..3 {
            out.normal_n[i].push(n[i]);
            out.pressure_pa[i].push(p[i]);
            out.travel_m[i].push((self.chassis_above[i] - self.axle_w[i]).dot(q));
        }
        out.pitch_rad.push(q[TH]);
        out.pitch_rate_rad_per_s.push(qd[TH]);
        out.bounce_m.push(q[Z]);
        out.aux_brake_limit_wheel_nm
            .push(self.p.slip_limited_brake_force(n[1]) * self.p.wheel_radius_m);
    }
}
