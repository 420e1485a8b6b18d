//! Dormand–Prince 5(4) with adaptive steps, cubic-Hermite dense output and event location — the
//! accurate reference integrator of the hybrid simulations.
//!
//! Method: the embedded explicit Runge–Kutta pair of Dormand & Prince (1980), local
//! extrapolation (the 5th-order solution is propagated), FSAL. Error norm: RMS over components of
//! `err_i / (atol_i + rtol·max(|y_i|, |y_new,i|))` (Hairer, Nørsett & Wanner, *Solving ODE I*,
//! §II.4); a step is accepted when the norm is ≤ 1; the next step is
//! `h·min(5, max(0.2, 0.9·norm^(−1/5)))`. Between accepted points the solution is the cubic
//! Hermite interpolant of (y, f) at both ends (third-order accurate; with the steps a stiff
//! driveline forces this is far below the tolerances used).
//!
//! Events: a function g(t, y) whose crossing of zero in the given direction ends the interval;
//! the crossing is located on the interpolant by the Illinois variant of regula falsi to
//! 1e-13·max(1, |t|).

/// Work counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Accepted steps.
    pub accepted: u64,
    /// Rejected steps.
    pub rejected: u64,
}

impl std::ops::AddAssign for Stats {
    fn add_assign(&mut self, o: Self) {
        self.rhs_evals += o.rhs_evals;
        self.accepted += o.accepted;
        self.rejected += o.rejected;
    }
}

/// Tolerances.
#[derive(Debug, Clone, PartialEq)]
pub struct Tolerances {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance per component.
    pub atol: Vec<f64>,
}

/// How an interval ended.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Time reached.
    pub t: f64,
    /// State there.
    pub y: Vec<f64>,
    /// Index of the event function that crossed zero first (at `t`), if any.
    pub event: Option<usize>,
    /// Last accepted step size (a good first step for the next interval).
    pub h_last: f64,
    /// Work.
    pub stats: Stats,
}

/// Why integration stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DopriError {
    /// The step size underflowed (a singularity or an inconsistent model).
    #[error("step size underflow at t = {t} s (h = {h:e} s)")]
    StepUnderflow {
        /// Time.
        t: f64,
        /// Step.
        h: f64,
    },
    /// The right-hand side returned a non-finite value.
    #[error("non-finite derivative at t = {t} s, state component {index}")]
    NonFinite {
        /// Time.
        t: f64,
        /// Component.
        index: usize,
    },
}

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const B1: f64 = 35.0 / 384.0;
const B3: f64 = 500.0 / 1113.0;
const B4: f64 = 125.0 / 192.0;
const B5: f64 = -2187.0 / 6784.0;
const B6: f64 = 11.0 / 84.0;
// error coefficients: b (5th order) − b* (4th order)
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

/// A point of the solution: time, state and derivative.
#[derive(Debug, Clone, Copy)]
pub struct Knot<'a> {
    /// Time, s.
    pub t: f64,
    /// State.
    pub y: &'a [f64],
    /// Derivative f(t, y).
    pub f: &'a [f64],
}

/// Right-hand side `f(t, y, dy)`.
pub type Rhs<'a> = &'a mut dyn FnMut(f64, &[f64], &mut [f64]);
/// Event function g(t, y).
pub type EventFn<'a> = &'a dyn Fn(f64, &[f64]) -> f64;
/// Callback for each accepted step, from one knot to the next.
pub type OnStep<'a> = &'a mut dyn FnMut(&Knot, &Knot);

/// Cubic Hermite interpolation between knots `a` and `b` at `t`, into `out`.
pub fn hermite(a: &Knot, b: &Knot, t: f64, out: &mut [f64]) {
    let (t0, y0, f0, y1, f1) = (a.t, a.y, a.f, b.y, b.f);
    let h = b.t - t0;
    let s = (t - t0) / h;
    let h00 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s);
    let h10 = s * (1.0 - s) * (1.0 - s);
    let h01 = s * s * (3.0 - 2.0 * s);
    let h11 = s * s * (s - 1.0);
    for (i, o) in out.iter_mut().enumerate() {
        *o = h00 * y0[i] + h10 * h * f0[i] + h01 * y1[i] + h11 * h * f1[i];
    }
}

/// Integrates `ẏ = f(t, y)` from `t0` to `t1` (or to the first event).
///
/// `on_step(a, b)` is called with the two knots of every accepted step (the last one
/// truncated at an event), so the caller can sample the interpolant.
/// `events`: `(g, direction)` pairs with direction +1 (rising), −1 (falling) or 0 (both); the
/// earliest crossing in a step ends the interval.
///
/// # Errors
/// [`DopriError`] on step-size underflow or a non-finite derivative.
#[allow(clippy::too_many_arguments)]
pub fn integrate(
    f: Rhs,
    t0: f64,
    y0: &[f64],
    t1: f64,
    h0: f64,
    tol: &Tolerances,
    events: &[(EventFn, f64)],
    on_step: OnStep,
) -> Result<Outcome, DopriError> {
    let n = y0.len();
    let mut stats = Stats::default();
    let mut t = t0;
    let mut y = y0.to_vec();
    let mut k1 = vec![0.0; n];
    let (mut k2, mut k3, mut k4, mut k5, mut k6, mut k7) = (
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
    );
    let mut ytmp = vec![0.0; n];
    let mut ynew = vec![0.0; n];
    let mut yint = vec![0.0; n];
    f(t, &y, &mut k1);
    stats.rhs_evals += 1;
    check(t, &k1)?;
    let span = t1 - t0;
    if span <= 1e-12 * t0.abs().max(1.0) {
        // nothing to integrate (an interval between coinciding breakpoints)
        return Ok(Outcome {
            t: t1.max(t0),
            y,
            event: None,
            h_last: h0,
            stats,
        });
    }
    let mut h = h0.min(span).max(span * 1e-12);
    let mut g_prev: Vec<f64> = events.iter().map(|(g, _)| g(t, &y)).collect();
    // event values at the step's end; swapped with g_prev on acceptance (no allocation per step)
    let mut g_new: Vec<f64> = Vec::with_capacity(events.len());
    let mut h_last = h;
    while t < t1 {
        let last = t + h >= t1 - 1e-15 * t1.abs().max(1.0);
        if last {
            h = t1 - t;
        }
        if h <= 1e-14 * t.abs().max(1.0) {
            return Err(DopriError::StepUnderflow { t, h });
        }
        for i in 0..n {
            ytmp[i] = y[i] + h * A21 * k1[i];
        }
        f(t + C2 * h, &ytmp, &mut k2);
        for i in 0..n {
            ytmp[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        f(t + C3 * h, &ytmp, &mut k3);
        for i in 0..n {
            ytmp[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        f(t + C4 * h, &ytmp, &mut k4);
        for i in 0..n {
            ytmp[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        f(t + C5 * h, &ytmp, &mut k5);
        for i in 0..n {
            ytmp[i] =
                y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        }
        f(t + h, &ytmp, &mut k6);
        for i in 0..n {
            ynew[i] = y[i] + h * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i]);
        }
        f(t + h, &ynew, &mut k7);
        stats.rhs_evals += 6;
        check(t + h, &k7)?;
        let mut err = 0.0;
        for i in 0..n {
            let e =
                h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            let sc = tol.atol[i] + tol.rtol * y[i].abs().max(ynew[i].abs());
            err += (e / sc) * (e / sc);
        }
        let err = (err / n as f64).sqrt();
        if !err.is_finite() || err > 1.0 {
            stats.rejected += 1;
            let fac = if err.is_finite() {
                (0.9 * err.powf(-0.2)).max(0.2)
            } else {
                0.2
            };
            h *= fac;
            continue;
        }
        stats.accepted += 1;
        let t_new = if last { t1 } else { t + h };
        // events in this step: locate every crossing, keep the earliest
        let mut first: Option<(usize, f64)> = None;
        g_new.clear();
        for (k, ((g, dir), &gp)) in events.iter().zip(&g_prev).enumerate() {
            let gn = g(t_new, &ynew);
            g_new.push(gn);
            let crosses =
                (gp < 0.0 && gn >= 0.0 && *dir >= 0.0) || (gp > 0.0 && gn <= 0.0 && *dir <= 0.0);
            if crosses {
                let ka = Knot { t, y: &y, f: &k1 };
                let kb = Knot {
                    t: t_new,
                    y: &ynew,
                    f: &k7,
                };
                let mut at = |tt: f64, buf: &mut Vec<f64>| {
                    hermite(&ka, &kb, tt, buf);
                    g(tt, buf)
                };
                let te = locate(&mut at, t, gp, t_new, gn, &mut yint);
                if first.is_none_or(|(_, tf)| te < tf) {
                    first = Some((k, te));
                }
            }
        }
        if let Some((k, te)) = first {
            let ka = Knot { t, y: &y, f: &k1 };
            let kb = Knot {
                t: t_new,
                y: &ynew,
                f: &k7,
            };
            hermite(&ka, &kb, te, &mut yint);
            // derivative at the event for the truncated step's interpolant
            let mut fe = vec![0.0; n];
            f(te, &yint, &mut fe);
            stats.rhs_evals += 1;
            on_step(
                &ka,
                &Knot {
                    t: te,
                    y: &yint,
                    f: &fe,
                },
            );
            return Ok(Outcome {
                t: te,
                y: yint,
                event: Some(k),
                h_last: h,
                stats,
            });
        }
        std::mem::swap(&mut g_prev, &mut g_new);
        on_step(
            &Knot { t, y: &y, f: &k1 },
            &Knot {
                t: t_new,
                y: &ynew,
                f: &k7,
            },
        );
        t = t_new;
        std::mem::swap(&mut y, &mut ynew);
        std::mem::swap(&mut k1, &mut k7);
        h_last = h;
        let fac = if err == 0.0 {
            5.0
        } else {
            (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
        };
        h *= fac;
    }
    Ok(Outcome {
        t,
        y,
        event: None,
        h_last,
        stats,
    })
}

fn check(t: f64, k: &[f64]) -> Result<(), DopriError> {
    match k.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(DopriError::NonFinite { t, index }),
        None => Ok(()),
    }
}

/// Illinois regula falsi for the zero of `g` between (a, ga) and (b, gb) of opposite signs.
fn locate(
    g: &mut dyn FnMut(f64, &mut Vec<f64>) -> f64,
    mut a: f64,
    mut ga: f64,
    mut b: f64,
    mut gb: f64,
    buf: &mut Vec<f64>,
) -> f64 {
    let tol = 1e-13 * b.abs().max(1.0);
    let mut side = 0i8;
    for _ in 0..200 {
        if (b - a).abs() <= tol || gb == 0.0 {
            break;
        }
        let c = (a * gb - b * ga) / (gb - ga);
        let gc = g(c, buf);
        if gc == 0.0 {
            return c;
        }
        if (gc > 0.0) == (gb > 0.0) {
            b = c;
            gb = gc;
            if side == -1 {
                ga *= 0.5;
            }
            side = -1;
        } else {
            a = c;
            ga = gc;
            if side == 1 {
                gb *= 0.5;
            }
            side = 1;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponential_decay_to_tolerance() {
        let tol = Tolerances {
            rtol: 1e-10,
            atol: vec![1e-12],
        };
        let mut f = |_t: f64, y: &[f64], d: &mut [f64]| d[0] = -2.0 * y[0];
        let out = integrate(&mut f, 0.0, &[1.0], 3.0, 1e-3, &tol, &[], &mut |_, _| {}).unwrap();
        assert!((out.y[0] - (-6.0f64).exp()).abs() < 1e-11, "{}", out.y[0]);
        assert!(out.event.is_none());
    }

    #[test]
    fn event_is_located_precisely() {
        // harmonic oscillator y'' = -y from y = 1: first zero of y at t = pi/2
        let tol = Tolerances {
            rtol: 1e-11,
            atol: vec![1e-13; 2],
        };
        let mut f = |_t: f64, y: &[f64], d: &mut [f64]| {
            d[0] = y[1];
            d[1] = -y[0];
        };
        let g = |_t: f64, y: &[f64]| y[0];
        let out = integrate(
            &mut f,
            0.0,
            &[1.0, 0.0],
            10.0,
            1e-2,
            &tol,
            &[(&g, -1.0)],
            &mut |_, _| {},
        )
        .unwrap();
        assert_eq!(out.event, Some(0));
        assert!(
            (out.t - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "{}",
            out.t
        );
    }

    #[test]
    fn the_earliest_of_several_events_wins() {
        // y = cos t, y' = -sin t: y falls through 0 at pi/2, y' rises through 0 at pi
        let tol = Tolerances {
            rtol: 1e-11,
            atol: vec![1e-13; 2],
        };
        let mut f = |_t: f64, y: &[f64], d: &mut [f64]| {
            d[0] = y[1];
            d[1] = -y[0];
        };
        let late = |_t: f64, y: &[f64]| y[1];
        let early = |_t: f64, y: &[f64]| y[0];
        let out = integrate(
            &mut f,
            0.0,
            &[1.0, 0.0],
            10.0,
            1e-2,
            &tol,
            &[(&late, 1.0), (&early, -1.0)],
            &mut |_, _| {},
        )
        .unwrap();
        assert_eq!(out.event, Some(1));
        assert!((out.t - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        // started after pi/2, the other event is next
        let out = integrate(
            &mut f,
            2.0,
            &[2f64.cos(), -(2f64.sin())],
            10.0,
            1e-2,
            &tol,
            &[(&late, 1.0), (&early, -1.0)],
            &mut |_, _| {},
        )
        .unwrap();
        assert_eq!(out.event, Some(0));
        assert!((out.t - std::f64::consts::PI).abs() < 1e-9, "{}", out.t);
    }
}
