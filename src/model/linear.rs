//! Linear driveline model (docs/models/driveline.md; Myklebust & Eriksson (2012), eq. (27)):
//! A, B, C for a gear and an operating speed, open loop and with the engine-speed PI controller,
//! and its frequency response.
//!
//! # Conventions
//! States (clutch locked, gear fixed, v > 0), all SI:
//! `x = (ω_e, θ_e − θ_t, ω_p, θ_p − θ_f, ω_d, θ_d − θ_w, ω_w)` — rad/s and rad.
//! Inputs `u = (M_e, F_dr)`: engine torque (N·m) and the drive-resistance force
//! `F_dr = F_g + F_b` (N, positive resists motion). Output `y = v = r_w·ω_w` (m/s).
//! The closed loop adds `x_8 = ∫(ω_ref − ω_e) dt` with `M_e = K_P·(ω_ref − ω_e) + K_I·x_8`; its
//! inputs are `(ω_ref, F_dr)`.
//!
//! Torques: `M_c = c_c(ω_e − i_t ω_p) + k_c x_2`, `M_p = c_p(ω_p − i_f ω_d) + k_p x_4`,
//! `M_d = c_d(ω_d − ω_w) + k_d x_6`; inertias J1 = J_e + J_c, J2 = J_t(i) + J_p, J3 = J_f + J_d
//! (the paper's `J_3 = J_p i_f² + J_f + J_d` counts J_p and J_d twice), J4 = m r_w² + J_w.
//! Linearised resistance: `A[7,7] += Δa77 = −r_w²·(c_r2·m·g + ρ_a·c_w·A_f·v0)/J4` (1-based
//! indices as in the paper).

use super::driveline::DrivelineParams;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// A continuous-time state-space model `ẋ = A x + B u`, `y = C x`.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// n × n.
    pub a: DMatrix<f64>,
    /// n × m.
    pub b: DMatrix<f64>,
    /// 1 × n.
    pub c: DMatrix<f64>,
}

impl StateSpace {
    /// Number of states.
    pub fn order(&self) -> usize {
        self.a.nrows()
    }

    /// Eigenvalues of A (rad/s), sorted by imaginary then real part.
    pub fn eigenvalues(&self) -> Vec<Complex64> {
        let mut e: Vec<Complex64> = self
            .a
            .clone()
            .complex_eigenvalues()
            .iter()
            .map(|z| Complex64::new(z.re, z.im))
            .collect();
        e.sort_by(|x, y| x.im.total_cmp(&y.im).then(x.re.total_cmp(&y.re)));
        e
    }

    /// Frequency response `C (jωI − A)⁻¹ B[:, input]` at `f_hz` (ω = 2π f).
    ///
    /// Returns NaN if `jω` is an eigenvalue (singular).
    pub fn freq_response(&self, input: usize, f_hz: f64) -> Complex64 {
        let n = self.order();
        let jw = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f_hz);
        let m = DMatrix::from_fn(n, n, |i, j| {
            let d = if i == j { jw } else { Complex64::new(0.0, 0.0) };
            d - Complex64::new(self.a[(i, j)], 0.0)
        });
        let rhs = DVector::from_fn(n, |i, _| Complex64::new(self.b[(i, input)], 0.0));
        match m.lu().solve(&rhs) {
            Some(x) => (0..n).map(|i| x[i] * self.c[(0, i)]).sum(),
            None => Complex64::new(f64::NAN, f64::NAN),
        }
    }

    /// Static gain `−C A⁻¹ B[:, input]` (NaN if A is singular).
    pub fn dc_gain(&self, input: usize) -> f64 {
        let rhs = self.b.column(input).into_owned();
        match self.a.clone().lu().solve(&rhs) {
            Some(x) => -(&self.c * x)[(0, 0)],
            None => f64::NAN,
        }
    }
}

/// The linear driveline model of one gear at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearDriveline {
    /// Gear (1 = lowest).
    pub gear: usize,
    /// Operating speed, m/s.
    pub v0_mps: f64,
    /// Overall ratio i_t·i_f.
    pub total_ratio: f64,
    /// Open loop, inputs (M_e, F_dr).
    pub open: StateSpace,
    /// With the engine-speed PI controller, inputs (ω_ref, F_dr).
    pub closed: StateSpace,
}

/// Builds the linear model for `gear` (1-based) with gearbox `ratios`, linearised at `v0_mps`.
///
/// # Panics
/// If `gear` is 0 or beyond `ratios` / the per-gear inertias (callers validate gears; the vehicle
/// file guarantees the lengths agree).
pub fn linearize(p: &DrivelineParams, ratios: &[f64], gear: usize, v0_mps: f64) -> LinearDriveline {
    assert!(
        gear >= 1 && gear <= ratios.len(),
        "gear {gear} outside 1..={}",
        ratios.len()
    );
    let it = ratios[gear - 1];
    let fi = p.final_drive_ratio;
    let rw = p.wheel_radius_m;
    let j1 = p.j_e_kg_m2 + p.j_c_kg_m2;
    let j2 = p.j_t_kg_m2[gear - 1] + p.j_p_kg_m2;
    let j3 = p.j_f_kg_m2 + p.j_d_kg_m2;
    let j4 = p.j4();
    let (kc, cc) = (p.k_c_nm_per_rad, p.c_c_nm_s_per_rad);
    let (kp, cp) = (p.k_p_nm_per_rad, p.c_p_nm_s_per_rad);
    let (kd, cd) = (p.k_d_nm_per_rad, p.c_d_nm_s_per_rad);
    let (bt, bf) = (p.b_t_nm_s_per_rad, p.b_f_nm_s_per_rad);
    let da77 = -rw
        * rw
        * (p.c_r2_s_per_m * p.mass_kg * p.gravity_m_per_s2
            + p.rho_air_kg_per_m3 * p.c_w_a_f_m2 * v0_mps)
        / j4;

    let mut a = DMatrix::zeros(7, 7);
    // ω̇_e = (M_e − M_c)/J1
    a[(0, 0)] = -cc / j1;
    a[(0, 1)] = -kc / j1;
    a[(0, 2)] = cc * it / j1;
    // clutch-spring torsion rate
    a[(1, 0)] = 1.0;
    a[(1, 2)] = -it;
    // ω̇_p = (i_t M_c − b_t ω_p − M_p)/J2
    a[(2, 0)] = it * cc / j2;
    a[(2, 1)] = it * kc / j2;
    a[(2, 2)] = -(cc * it * it + bt + cp) / j2;
    a[(2, 3)] = -kp / j2;
    a[(2, 4)] = cp * fi / j2;
    // propeller-shaft torsion rate
    a[(3, 2)] = 1.0;
    a[(3, 4)] = -fi;
    // ω̇_d = (i_f M_p − b_f ω_d − M_d)/J3
    a[(4, 2)] = fi * cp / j3;
    a[(4, 3)] = fi * kp / j3;
    a[(4, 4)] = -(cp * fi * fi + bf + cd) / j3;
    a[(4, 5)] = -kd / j3;
    a[(4, 6)] = cd / j3;
    // drive-shaft torsion rate
    a[(5, 4)] = 1.0;
    a[(5, 6)] = -1.0;
    // ω̇_w = (M_d − r_w F)/J4, linearised resistance in Δa77
    a[(6, 4)] = cd / j4;
    a[(6, 5)] = kd / j4;
    a[(6, 6)] = -cd / j4 + da77;

    let mut b = DMatrix::zeros(7, 2);
    b[(0, 0)] = 1.0 / j1;
    b[(6, 1)] = -rw / j4;
    let mut c = DMatrix::zeros(1, 7);
    c[(0, 6)] = rw;

    let (kpi, kii) = (p.pi_kp_nm_s_per_rad, p.pi_ki_nm_per_rad);
    let mut acl = DMatrix::zeros(8, 8);
    acl.view_mut((0, 0), (7, 7)).copy_from(&a);
    acl[(0, 0)] -= kpi / j1;
    acl[(0, 7)] = kii / j1;
    acl[(7, 0)] = -1.0;
    let mut bcl = DMatrix::zeros(8, 2);
    bcl[(0, 0)] = kpi / j1;
    bcl[(7, 0)] = 1.0;
    bcl[(6, 1)] = -rw / j4;
    let mut ccl = DMatrix::zeros(1, 8);
    ccl[(0, 6)] = rw;

    LinearDriveline {
        gear,
        v0_mps,
        total_ratio: it * fi,
        open: StateSpace { a, b, c },
        closed: StateSpace {
            a: acl,
            b: bcl,
            c: ccl,
        },
    }
}

/// The driven tyres as part of the driveline's main flexibility, for
/// [`linearize_with_tyres`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrivenTyres {
    /// Share `s` of the lumped compliance `1/k_d` that the tyres take, in `[0, 1)`: the drive
    /// shafts are `k_s = k_d/(1 − s)`, the tyres `k_ty = k_d/s` (in series: `k_d`).
    pub share: f64,
    /// Traction ratio `ρ = F_x/F_x,max` of the driven tyres, `|ρ| < 1`: their tangent stiffness
    /// is `k_ty·(1 − ρ²)` (a saturating force law `F = F_max·tanh(C_κ κ/F_max)` has the slope
    /// `C_κ·(1 − (F/F_max)²)`).
    pub traction_ratio: f64,
    /// Longitudinal relaxation length `σ`, m: the tyre deflection leaks at `|v₀|/σ`.
    pub relaxation_length_m: f64,
    /// Inertia of the driven wheels, kg·m², taken from the wheel-and-vehicle inertia `J4` to the
    /// node between shafts and tyres.
    pub wheel_inertia_kg_m2: f64,
}

/// The open-loop linear driveline of [`linearize`] with the main flexibility split into drive
/// shafts and driven tyres ([`DrivenTyres`]), the driven wheels between them:
/// `x = (ω_e, θ_e − θ_t, ω_p, θ_p − θ_f, ω_d, θ_d − θ_w, ω_w, u, ω_v)` — the first six as in
/// [`linearize`]; `ω_w` the driven wheels (inertia `J_wd`); `u` the tyres' deflection angle at
/// the wheel, `u̇ = ω_w − ω_v − (|v₀|/σ)·u` (Pacejka, "Tire and Vehicle Dynamics", 3rd ed.,
/// Elsevier 2012, §7.2, the stretched-string relaxation); `ω_v = v/r_w` the vehicle with the
/// other wheels (inertia `J4 − J_wd`). Torques: shafts `k_s·x₆ + c_d·(ω_d − ω_w)`, tyres
/// `k_ty·(1 − ρ²)·u`; the linearised resistance acts on `ω_v`. Inputs `(M_e, F_dr)`, output
/// `v = r_w·ω_v`. With `s = 0` the tyres are rigid and [`linearize`]'s open loop is returned.
pub fn linearize_with_tyres(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
    t: &DrivenTyres,
) -> StateSpace {
    let lin = linearize(p, ratios, gear, v0_mps);
    let s = t.share.clamp(0.0, 0.99);
    if s <= 1e-6 {
        return lin.open;
    }
    let rw = p.wheel_radius_m;
    let j4 = p.j4();
    let jwd = t.wheel_inertia_kg_m2.clamp(1e-3 * j4, 0.5 * j4);
    let jv = j4 - jwd;
    let kd = p.k_d_nm_per_rad;
    let (ks, kt) = (
        kd / (1.0 - s),
        kd / s * (1.0 - t.traction_ratio.powi(2)).max(0.01),
    );
    let cd = p.c_d_nm_s_per_rad;
    let j3 = p.j_f_kg_m2 + p.j_d_kg_m2;
    let leak = v0_mps.abs() / t.relaxation_length_m.max(1e-3);
    let mut a = DMatrix::zeros(9, 9);
    a.view_mut((0, 0), (6, 7))
        .copy_from(&lin.open.a.view((0, 0), (6, 7)));
    // ω̇_d: the shaft spring is k_s now
    a[(4, 5)] = -ks / j3;
    // ω̇_w = (k_s x₆ + c_d(ω_d − ω_w) − k_te u)/J_wd
    a[(6, 4)] = cd / jwd;
    a[(6, 5)] = ks / jwd;
    a[(6, 6)] = -cd / jwd;
    a[(6, 7)] = -kt / jwd;
    // u̇ = ω_w − ω_v − leak·u
    a[(7, 6)] = 1.0;
    a[(7, 7)] = -leak;
    a[(7, 8)] = -1.0;
    // ω̇_v = (k_te u − r_w F)/J_v, the linearised resistance as in linearize (per J4 there)
    a[(8, 7)] = kt / jv;
    a[(8, 8)] = lin.open.a[(6, 6)] * j4 / jv + cd / jv;
    let mut b = DMatrix::zeros(9, 2);
    b[(0, 0)] = lin.open.b[(0, 0)];
    b[(8, 1)] = -rw / jv;
    let mut c = DMatrix::zeros(1, 9);
    c[(0, 8)] = rw;
    StateSpace { a, b, c }
}

/// The rigid-driveline ("low-frequency") response the flexible model tends to below its
/// resonances: every inertia referred to the wheel, `J_tot = J4 + J3 + J2·i_f² + J1·(i_t i_f)²`,
/// losses referred likewise, `F_dr → v` and `M_e → v` as first-order lags. Used as the reference
/// for the resonance peak height.
pub fn rigid_response(
    p: &DrivelineParams,
    lin: &LinearDriveline,
    input: usize,
    f_hz: f64,
) -> Complex64 {
    let g = lin.gear;
    let fi = p.final_drive_ratio;
    let i = lin.total_ratio;
    let rw = p.wheel_radius_m;
    let j_tot = p.j4()
        + p.j_f_kg_m2
        + p.j_d_kg_m2
        + (p.j_t_kg_m2[g - 1] + p.j_p_kg_m2) * fi * fi
        + (p.j_e_kg_m2 + p.j_c_kg_m2) * i * i;
    // viscous losses referred to the wheel plus the linearised resistance
    let damping = p.b_f_nm_s_per_rad + p.b_t_nm_s_per_rad * fi * fi
        - lin.open.a[(6, 6)] * p.j4()
        - p.c_d_nm_s_per_rad;
    let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f_hz);
    let den = s * j_tot + damping;
    match input {
        0 => Complex64::new(i * rw, 0.0) / den,
        _ => Complex64::new(-rw * rw, 0.0) / den,
    }
}
