//! Exact steps of the half-truck over an output interval in which no damper changes segment
//! ([`HalfTruck::with_segment_steps`]).
//!
//! Between the damper tables' points each damper force is a line in its compression rate,
//! `F_i = a_i + b_i (d_i·q̇)` ([`crate::model::axle::DamperTable::segment`]). On one segment per
//! damper (a configuration σ) the model of [`super`] without the bellows' progression is linear:
//!
//! ```text
//! ẋ = A_σ x + B w(t),   x = [q; q̇],   B = [0; I],
//! A_σ = [[0, I], [−M⁻¹K, −Σ b_i M⁻¹d_i d_iᵀ]],
//! w(t) = M⁻¹ Q_ext(t) − Σ a_i M⁻¹d_i.
//! ```
//!
//! Recorded inputs are linear (acceleration, torques, brake force) or held (slope) between
//! their samples ([`crate::sim::axle_recorded`]), so over an interval that holds no input
//! sample `w` is linear in time (the held slope's `sin α`, `cos α` constant), and the step
//! with a first-order hold is exact:
//!
//! ```text
//! x(t₁) = Φ x(t₀) + Γ₀ w(t₀) + Γ₁ w(t₁⁻),
//! exp([[A_σ, B, 0], [0, 0, I], [0, 0, 0]] h) = [[Φ, F₁, F₂], …],   Γ₁ = F₂ / h,   Γ₀ = F₁ − Γ₁,
//! ```
//!
//! `h = t₁ − t₀`, `w(t₁⁻)` the inputs' pieces at `t₀` continued to `t₁` (a held slope's value
//! before its next sample). The step is taken when
//! - no input has a sample strictly inside the interval,
//! - the interval is at most `2/ρ` long (ρ the spectral radius of [`super`], a third of the
//!   fastest mode's period), and
//! - every damper's segment at `t₁` is its segment at `t₀`, and so is the segment of every
//!   extremum of the cubic through the damper's rate and the rate's slope at both ends (a
//!   cheaper band about the chord, 4/27 of the slopes' departures from it, settles most
//!   intervals first);
//!
//! otherwise the interval is integrated by RK4 as [`super`] does. A damper that leaves its
//! segment and comes back within one interval in a way that cubic does not show is stepped as
//! if it had stayed: its force is off by the slope difference times the rate's excursion past
//! the segment's end, for part of an interval (the error against the model's own 2 ms RK4 is
//! measured by `cargo bench --bench axle_step` and bounded by a test on the axle fixture
//! drive's inputs).
//!
//! The matrices `Φ`, `Γ₀`, `Γ₁` are computed once per (configuration, interval length to the
//! nanosecond, a log's time resolution: the state moves by its rate times at most 0.5 ns less
//! or more than the interval) met in one simulation, by the matrix exponential of `nalgebra`
//! (Padé with scaling and squaring); at
//! most [`MAX_KINDS`] of them, beyond which new kinds of interval are integrated by RK4 (a time
//! axis without repeated interval lengths costs RK4's time, not an exponential per row).

use super::{Cursor, HalfTruck, Piecewise, V5};
use crate::model::axle::DamperSegment;
use crate::sim::axle::AxleInputs;
use nalgebra::{SMatrix, SVector};

type V10 = SVector<f64, 10>;

/// Most (configuration, interval length) kinds one simulation computes matrices for.
pub const MAX_KINDS: usize = 512;

/// The step's matrices of one (configuration, interval length).
#[derive(Debug, Clone)]
struct Discrete {
    phi: SMatrix<f64, 10, 10>,
    g0: SMatrix<f64, 10, 5>,
    g1: SMatrix<f64, 10, 5>,
    /// The dampers' rates of change per unit state: `ṙ = R x + D w` with `D` the rows `d_iᵀ`.
    rate_dot: SMatrix<f64, 3, 10>,
    /// `Σ a_i M⁻¹d_i`: the accelerations of the segments' intercepts.
    intercepts: V5,
}

/// The exact stepper of one simulation: the model and the matrices met so far.
#[derive(Debug)]
pub(super) struct SegmentSteps<'m, 'a> {
    model: &'m HalfTruck<'a>,
    max_span_s: f64,
    /// The rows `d_iᵀ` of the three dampers' compression directions.
    rate_of: SMatrix<f64, 3, 5>,
    kinds: Vec<((u64, [i8; 3]), Discrete)>,
    last: usize,
    /// The segments at the end of the last interval stepped exactly (the next one's start).
    carried: Option<[i8; 3]>,
}

impl<'m, 'a> SegmentSteps<'m, 'a> {
    pub(super) fn new(model: &'m HalfTruck<'a>) -> Self {
        Self {
            model,
            // h_mode = 0.5/ρ
            max_span_s: 4.0 * model.h_mode,
            rate_of: SMatrix::<f64, 3, 5>::from_fn(|i, j| model.damper_d[i][j]),
            kinds: Vec::new(),
            last: 0,
            carried: None,
        }
    }

    /// The dampers' segments at rates `r`.
    fn segments(&self, r: &SVector<f64, 3>) -> [DamperSegment; 3] {
        std::array::from_fn(|i| self.model.dampers[i].segment(r[i]))
    }

    /// The identities of the dampers' segments at rates `r`.
    fn segment_ids(&self, r: &SVector<f64, 3>) -> [i8; 3] {
        std::array::from_fn(|i| self.model.dampers[i].segment_id(r[i]))
    }

    /// The state at `t1` from `(q, qd)` at `t0`, exactly, or `None` where the interval is for
    /// RK4 (module doc). `cur` holds the inputs' pieces at `t0` and `ae0` is `M⁻¹ Q_ext(t0)`.
    /// Called for consecutive intervals of one simulation.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn step(
        &mut self,
        u: &AxleInputs,
        cur: &Cursor,
        t0: f64,
        t1: f64,
        q: &V5,
        qd: &V5,
        ae0: &V5,
    ) -> Option<(V5, V5)> {
        // the state at t0 is the end of the last exact step only if this is the next call
        let carried = self.carried.take();
        let h = t1 - t0;
        if !(h >= 1e-9 && h <= self.max_span_s) {
            return None;
        }
        // no input sample strictly inside (t0, t1): each input's piece at t0 reaches t1
        let reaches = |i: usize, s: &Piecewise| {
            let k = cur.0[i].min(s.piece_count() - 1);
            s.piece_start(k) <= t0 && (k + 1 >= s.piece_count() || s.piece_start(k + 1) >= t1)
        };
        let optional = [
            (2, u.service_brake_n.as_ref()),
            (3, u.drive_torque_wheel_nm.as_ref()),
            (4, u.aux_brake_torque_wheel_nm.as_ref()),
        ];
        if !reaches(0, &u.accel_mps2)
            || !reaches(1, &u.slope)
            || optional
                .iter()
                .any(|(i, s)| s.is_some_and(|s| !reaches(*i, s)))
        {
            return None;
        }
        let r0 = self.rate_of * qd;
        let ids = carried.unwrap_or_else(|| self.segment_ids(&r0));
        // the interval to the nanosecond (a log's time resolution): the time axis of a log
        // holds a few lengths, each rounded differently in its last bits
        let key = ((h * 1e9).round() as u64, ids);
        let k = self.kind(key, &r0)?;
        let m = self.model;
        // w(t1⁻): the pieces at t0 continued to t1
        let l1 = m.longitudinal_by(u, |i, s| {
            s.eval_piece(cur.0[i].min(s.piece_count() - 1), t1)
        });
        let ae1 = m.m_inv * m.external(&l1);
        let d = &self.kinds[k].1;
        let (w0, w1) = (ae0 - d.intercepts, ae1 - d.intercepts);
        let mut x0 = V10::zeros();
        x0.fixed_rows_mut::<5>(0).copy_from(q);
        x0.fixed_rows_mut::<5>(5).copy_from(qd);
        let x1 = d.phi * x0 + d.g0 * w0 + d.g1 * w1;
        let qd1: V5 = x1.fixed_rows::<5>(5).into_owned();
        let r1 = self.rate_of * qd1;
        let ids1 = self.segment_ids(&r1);
        if ids1 != ids {
            return None;
        }
        // each rate stays in its segment over the interval: its cubic through the values and
        // slopes at both ends lies within 4/27 (|h ṙ0 − Δ| + |h ṙ1 − Δ|) of the chord (the
        // Hermite form's bumps s(1−s)² and s²(1−s) peak at 4/27), and both ends of that band
        // are in the segment
        let rd0 = d.rate_dot * x0 + self.rate_of * w0;
        let rd1 = d.rate_dot * x1 + self.rate_of * w1;
        for i in 0..3 {
            let delta = r1[i] - r0[i];
            let e = 4.0 / 27.0 * ((h * rd0[i] - delta).abs() + (h * rd1[i] - delta).abs());
            let table = &m.dampers[i];
            let id = key.1[i];
            let in_band = table.segment_id(r0[i].min(r1[i]) - e) == id
                && table.segment_id(r0[i].max(r1[i]) + e) == id;
            // near a segment's end, the cubic's extrema themselves
            if !in_band
                && cubic_extrema(r0[i], r1[i], h * rd0[i], h * rd1[i])
                    .into_iter()
                    .flatten()
                    .any(|r| table.segment_id(r) != id)
            {
                return None;
            }
        }
        self.carried = Some(ids1);
        Some((x1.fixed_rows::<5>(0).into_owned(), qd1))
    }

    /// Index of the matrices of `key`, computed when first met; `None` past [`MAX_KINDS`].
    fn kind(&mut self, key: (u64, [i8; 3]), r: &SVector<f64, 3>) -> Option<usize> {
        if self.kinds.get(self.last).is_some_and(|(k, _)| *k == key) {
            return Some(self.last);
        }
        if let Some(i) = self.kinds.iter().position(|(k, _)| *k == key) {
            self.last = i;
            return Some(i);
        }
        if self.kinds.len() >= MAX_KINDS {
            return None;
        }
        let h = key.0 as f64 * 1e-9;
        let d = self.discrete(h, &self.segments(r))?;
        self.kinds.push((key, d));
        self.last = self.kinds.len() - 1;
        Some(self.last)
    }

    /// `Φ`, `Γ₀`, `Γ₁` of configuration `seg` over `h` (module doc); `None` for a non-finite
    /// slope (a NaN rate).
    fn discrete(&self, h: f64, seg: &[DamperSegment; 3]) -> Option<Discrete> {
        if seg.iter().any(|s| !s.slope_n_s_per_m.is_finite()) {
            return None;
        }
        let m = self.model;
        let mut e = SMatrix::<f64, 20, 20>::zeros();
        let mut damping = SMatrix::<f64, 5, 5>::zeros();
        for (i, s) in seg.iter().enumerate() {
            damping += s.slope_n_s_per_m * m.m_inv_damper_d[i] * m.damper_d[i].transpose();
        }
        for r in 0..5 {
            e[(r, r + 5)] = h;
            e[(r + 5, r + 10)] = h; // B
            e[(r + 10, r + 15)] = h; // the ramp's slope feeds w
            for c in 0..5 {
                e[(r + 5, c)] = -h * m.m_inv_k[(r, c)];
                e[(r + 5, c + 5)] = -h * damping[(r, c)];
            }
        }
        let x = e.exp();
        let phi: SMatrix<f64, 10, 10> = x.fixed_view::<10, 10>(0, 0).into_owned();
        let f1: SMatrix<f64, 10, 5> = x.fixed_view::<10, 5>(0, 10).into_owned();
        let g1: SMatrix<f64, 10, 5> = x.fixed_view::<10, 5>(0, 15).into_owned() / h;
        // ṙ = D q̈ = D (w − M⁻¹K q − damping q̇)
        let mut accel_of_state = SMatrix::<f64, 5, 10>::zeros();
        accel_of_state
            .fixed_view_mut::<5, 5>(0, 0)
            .copy_from(&(-m.m_inv_k));
        accel_of_state
            .fixed_view_mut::<5, 5>(0, 5)
            .copy_from(&(-damping));
        let mut intercepts = V5::zeros();
        for (i, s) in seg.iter().enumerate() {
            intercepts += s.intercept_n * m.m_inv_damper_d[i];
        }
        let d = Discrete {
            phi,
            g0: f1 - g1,
            g1,
            rate_dot: self.rate_of * accel_of_state,
            intercepts,
        };
        (d.phi.iter().chain(d.g0.iter()).all(|v| v.is_finite())).then_some(d)
    }
}

/// The values at the interior extrema (0 < s < 1) of the cubic Hermite `r(s)` with `r(0) = r0`,
/// `r(1) = r1`, `r'(0) = m0`, `r'(1) = m1`.
fn cubic_extrema(r0: f64, r1: f64, m0: f64, m1: f64) -> [Option<f64>; 2] {
    // r(s) = a s³ + b s² + m0 s + r0, r'(s) = 3a s² + 2b s + m0
    let a = 2.0 * (r0 - r1) + m0 + m1;
    let b = 3.0 * (r1 - r0) - 2.0 * m0 - m1;
    let at = |s: f64| (s > 0.0 && s < 1.0).then_some(((a * s + b) * s + m0) * s + r0);
    let (qa, qb, qc) = (3.0 * a, 2.0 * b, m0);
    if qa.abs() <= 1e-12 * (qb.abs() + qc.abs()) {
        // (nearly) a parabola
        return [(qb != 0.0).then(|| -qc / qb).and_then(at), None];
    }
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return [None, None];
    }
    let sq = disc.sqrt();
    [at((-qb - sq) / (2.0 * qa)), at((-qb + sq) / (2.0 * qa))]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::vehicle::VehicleFile;
    use crate::sim::axle::Start;
    use crate::sim::inputs::Between;
    use std::sync::Arc;

    /// The axle-load thesis truck's axle parameters.
    fn thesis_truck() -> crate::model::axle::AxleParams {
        VehicleFile::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures/vehicles/seed002-6x2.toml"),
        )
        .unwrap()
        .axles
        .unwrap()
    }

    /// `n` rows of 50 Hz recorded-like inputs: acceleration and drive torque linear between
    /// samples, the slope held in 0.1 % steps; the times, the slope samples and the inputs.
    fn recorded_like(n: usize) -> (Arc<[f64]>, Vec<f64>, AxleInputs) {
        let t: Arc<[f64]> = (0..=n).map(|k| k as f64 * 0.02).collect();
        let accel: Vec<f64> = t
            .iter()
            .map(|&s| 0.6 * (0.9 * s).sin() + 0.25 * (7.3 * s).sin())
            .collect();
        let torque: Vec<f64> = accel.iter().map(|a| 8000.0 + 9000.0 * a).collect();
        let slope: Vec<f64> = t
            .iter()
            .map(|&s| 1e-3 * (20.0 * (0.05 * s).sin()).round())
            .collect();
        let lin = |v: &[f64]| Piecewise::through_samples(&t, v, Between::Linear).unwrap();
        let u = AxleInputs {
            accel_mps2: lin(&accel),
            slope: Piecewise::through_samples(&t, &slope, Between::Held).unwrap(),
            drive_torque_wheel_nm: Some(lin(&torque)),
            aux_brake_torque_wheel_nm: None,
            service_brake_n: None,
        };
        (t, slope, u)
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_loop_compiled_with_avx_gives_the_bits_of_the_plain_one() {
        // 60 s of recorded-like inputs through the exact steps with RK4 between them, RK4
        // alone, and RK4 with the bellows' progression (no exact steps): both loops must hand
        // out the same states, to the bit
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let p = thesis_truck();
        let (t, _, u) = recorded_like(3000);
        let ext = crate::model::axle::AxleExtensions {
            bellow_progression_per_m: 2.0,
            ..Default::default()
        };
        let models = [
            HalfTruck::new(&p).with_max_step(0.01).with_segment_steps(),
            HalfTruck::new(&p).with_max_step(0.01),
            HalfTruck::new(&p).with_max_step(0.01).with_extensions(ext),
        ];
        for (k, model) in models.iter().enumerate() {
            let mut plain = Vec::new();
            model.integrate_on(&u, &t, Start::Steady, |q, qd, _| {
                plain.extend(q.iter().chain(qd.iter()).map(|x| x.to_bits()))
            });
            let mut avx = Vec::new();
            // SAFETY: the CPU was found to have AVX above.
            unsafe {
                model.integrate_avx(&u, &t, Start::Steady, |q, qd, _| {
                    avx.extend(q.iter().chain(qd.iter()).map(|x| x.to_bits()))
                })
            };
            assert_eq!(plain.len(), 10 * t.len());
            assert!(plain == avx, "model {k}");
        }
    }

    #[test]
    fn an_interval_on_one_segment_per_damper_is_stepped_as_a_fine_rk4_integrates_it() {
        // the thesis truck over 60 s of 50 Hz recorded-like inputs (acceleration and drive
        // torque linear between samples, the slope held in 0.1 % steps); the reference is the
        // model's RK4 at 0.1 ms. On every row along which the reference's dampers all stay on
        // one segment (checked at each 0.1 ms sample), the exact step from the reference's
        // state at the row's start must land on the reference's state at its end. Tolerance:
        // 1e-9 of each coordinate's largest magnitude over the run, where RK4's own error at
        // 0.1 ms (hρ = 0.005) is far below it. On a row that ends where the held slope steps,
        // the reference's last stage reads the next slope (RK4 evaluates the inputs at the
        // step's end, which is the next sample's piece): an error of the reference of order
        // (h/6)·Δa over one 0.1 ms step, ~1e-6 of the range for a 0.1 % slope step, so those
        // rows are held to 1e-5.
        let p = thesis_truck();
        let model = HalfTruck::new(&p);
        let n = 3000;
        let (t, slope, u) = recorded_like(n);
        // the reference at 0.1 ms, its state at every 0.1 ms sample
        let fine_t: Vec<f64> = (0..=n * 200).map(|k| k as f64 * 1e-4).collect();
        let fine = model.clone().with_max_step(1e-4);
        let mut states = Vec::with_capacity(fine_t.len());
        fine.integrate(&u, &fine_t, Start::Steady, |q, qd, _| {
            states.push((*q, *qd))
        });
        let scale = |f: &dyn Fn(&(V5, V5)) -> V5| {
            states
                .iter()
                .fold(V5::zeros(), |m, s| m.zip_map(&f(s), |a, b| a.max(b.abs())))
        };
        let (q_max, qd_max) = (scale(&|s| s.0), scale(&|s| s.1));
        let mut steps = SegmentSteps::new(&model);
        let (mut on_one, mut taken) = (0, 0);
        let mut worst = [0.0f64; 2];
        for k in 0..n {
            let (a, b) = (k * 200, (k + 1) * 200);
            let ids = |s: &(V5, V5)| steps.segment_ids(&(steps.rate_of * s.1));
            let first = ids(&states[a]);
            if states[a..=b].iter().any(|s| ids(s) != first) {
                continue;
            }
            on_one += 1;
            let mut cur = Cursor::default();
            let ae0 = model.forced(&u, t[k], &mut cur);
            steps.carried = None;
            let (q0, qd0) = states[a];
            let Some((q1, qd1)) = steps.step(&u, &cur, t[k], t[k + 1], &q0, &qd0, &ae0) else {
                continue;
            };
            taken += 1;
            let (qr, qdr) = states[b];
            let w = &mut worst[usize::from(slope[k + 1] != slope[k])];
            for i in 0..5 {
                *w = w
                    .max((q1[i] - qr[i]).abs() / q_max[i])
                    .max((qd1[i] - qdr[i]).abs() / qd_max[i]);
            }
        }
        println!(
            "{on_one} of {n} rows on one segment per damper, {taken} stepped exactly; largest \
             difference {:.2e} of the coordinate's range ({:.2e} on rows ending on a slope step)",
            worst[0], worst[1]
        );
        assert!(on_one > n / 2, "{on_one}");
        // the test for staying (the cubic through both ends) may turn away a row that grazes a
        // segment's end; it must not turn away many
        assert!(taken as f64 >= 0.98 * on_one as f64, "{taken} of {on_one}");
        assert!(worst[0] <= 1e-9, "{worst:?}");
        assert!(worst[1] <= 1e-5, "{worst:?}");
    }
}
