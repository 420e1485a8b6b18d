//! The truth plant's own integrator: classical fixed-step Runge–Kutta of order 4 with event
//! location for hybrid (mode-switching) systems.
//!
//! # Method
//! A [`HybridSystem`] is smooth inside each of its modes. One macro step of length `h` from
//! `(t, x)` is the classical RK4 step (Kutta 1901; e.g. Hairer, Nørsett & Wanner, "Solving
//! Ordinary Differential Equations I", Springer, §II.1):
//!
//! `k1 = f(t, x)`, `k2 = f(t + h/2, x + h/2·k1)`, `k3 = f(t + h/2, x + h/2·k2)`,
//! `k4 = f(t + h, x + h·k3)`, `x⁺ = x + h/6·(k1 + 2k2 + 2k3 + k4)`.
//!
//! Local error O(h⁵), global error O(h⁴) inside a mode (measured by the integration tests).
//!
//! # Events
//! The system names its **guards** `g_j(t, x)` for the current mode; by convention a guard is
//! positive while the mode is valid and an **event fires when a guard goes from > 0 at the
//! step start to ≤ 0 at the step end**. The switching time is located on the step's own RK4
//! solution: `φ(s) = g_j(t + s, RK4(t, x, s))` is bracketed on `(0, h]` and its root found by the
//! Illinois variant of regula falsi (Dahlquist & Björck, "Numerical Methods", Prentice-Hall,
//! §6.2) until the bracket is shorter than [`EventRk4::time_tol_s`]. The earliest root over all
//! guards wins; the state is advanced to the bracket's right end (where the guard is ≤ 0), the
//! system's [`HybridSystem::on_event`] switches the mode (and may project the state, e.g. set
//! two speeds equal when a clutch locks), and the rest of the step is integrated in the new mode.
//! So mode switches are located, not smoothed: the switching-time error is at most
//! `time_tol_s` plus the RK4 error of `φ`.
//!
//! A guard at exactly zero at a step start (the mode was just entered on its boundary) is not
//! armed for that step. A guard that crosses and re-crosses zero within one step is not seen;
//! the step must be short against the fastest mode's period (documented by the plant).

use thiserror::Error;

/// Most guards a mode may have.
pub const MAX_GUARDS: usize = 12;

/// Why an integration failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum IntegratorError {
    /// More events than allowed inside one macro step (a Zeno / chattering mode).
    #[error("{count} events within one step at t = {t_s} s (guard {guard}): chattering mode")]
    TooManyEvents {
        /// Time, s.
        t_s: f64,
        /// Events counted.
        count: usize,
        /// The last guard index that fired.
        guard: usize,
    },
    /// A state component became NaN or infinite.
    #[error("state component {index} is not finite ({value}) at t = {t_s} s")]
    NonFinite {
        /// Time, s.
        t_s: f64,
        /// Component index.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// Integrator settings out of their domain.
    #[error("integrator {parameter} = {value} must be finite and > 0")]
    BadSetting {
        /// Parameter name.
        parameter: &'static str,
        /// The value given.
        value: f64,
    },
}

/// A hybrid ODE system `ẋ = f_mode(t, x)` with guards per mode.
pub trait HybridSystem<const N: usize> {
    /// `ẋ` in the current mode.
    fn derivative(&self, t: f64, x: &[f64; N]) -> [f64; N];
    /// Writes the current mode's guards into `g` and returns how many there are (≤
    /// [`MAX_GUARDS`]). Positive: the mode is valid.
    fn guards(&self, t: f64, x: &[f64; N], g: &mut [f64; MAX_GUARDS]) -> usize;
    /// Guard `j` crossed zero at `t`: switch the mode; may project `x`.
    fn on_event(&mut self, j: usize, t: f64, x: &mut [f64; N]);
}

/// One classical RK4 step of `sys` from `(t, x)` of length `h`.
pub fn rk4_step<const N: usize, S: HybridSystem<N> + ?Sized>(
    sys: &S,
    t: f64,
    x: &[f64; N],
    h: f64,
) -> [f64; N] {
    let k1 = sys.derivative(t, x);
    let mut y = [0.0; N];
    for i in 0..N {
        y[i] = x[i] + 0.5 * h * k1[i];
    }
    let k2 = sys.derivative(t + 0.5 * h, &y);
    for i in 0..N {
        y[i] = x[i] + 0.5 * h * k2[i];
    }
    let k3 = sys.derivative(t + 0.5 * h, &y);
    for i in 0..N {
        y[i] = x[i] + h * k3[i];
    }
    let k4 = sys.derivative(t + h, &y);
    let mut out = [0.0; N];
    for i in 0..N {
        out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    out
}

/// Fixed-step RK4 with located events (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventRk4 {
    /// Macro step, s.
    pub h_s: f64,
    /// Length of the final bracket of a located switching time, s.
    pub time_tol_s: f64,
    /// Most events inside one macro step before the integration is declared chattering.
    pub max_events_per_step: usize,
}

impl EventRk4 {
    /// Step `h_s`, switching-time tolerance 1e-9 s, at most 16 events per step.
    pub fn new(h_s: f64) -> Self {
        Self {
            h_s,
            time_tol_s: 1e-9,
            max_events_per_step: 16,
        }
    }

    /// Integrates `sys` from `(t, x)` up to `t_end`, handling events; returns the number of
    /// events. `t` and `x` are updated in place (`t` ends at `t_end` exactly).
    ///
    /// # Errors
    /// [`IntegratorError`] for a bad setting, chattering or a non-finite state.
    pub fn advance<const N: usize, S: HybridSystem<N> + ?Sized>(
        &self,
        sys: &mut S,
        t: &mut f64,
        x: &mut [f64; N],
        t_end: f64,
    ) -> Result<usize, IntegratorError> {
        for (parameter, value) in [("h_s", self.h_s), ("time_tol_s", self.time_tol_s)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(IntegratorError::BadSetting { parameter, value });
            }
        }
        let mut events = 0;
        // the guards at the end of an event-free step are those at the start of the next one
        // (neither the system nor its inputs change inside `advance`): evaluated once
        let mut cache: Option<([f64; MAX_GUARDS], usize)> = None;
        while *t < t_end {
            let h = self.h_s.min(t_end - *t);
            // the last sliver of a span: snap to t_end
            let h = if t_end - (*t + h) < 1e-12 {
                t_end - *t
            } else {
                h
            };
            events += self.step(sys, t, x, h, &mut cache)?;
            if let Some(index) = x.iter().position(|v| !v.is_finite()) {
                return Err(IntegratorError::NonFinite {
                    t_s: *t,
                    index,
                    value: x[index],
                });
            }
        }
        Ok(events)
    }

    /// One macro step of length `h` with events; returns the number of events.
    fn step<const N: usize, S: HybridSystem<N> + ?Sized>(
        &self,
        sys: &mut S,
        t: &mut f64,
        x: &mut [f64; N],
        h: f64,
        cache: &mut Option<([f64; MAX_GUARDS], usize)>,
    ) -> Result<usize, IntegratorError> {
        let t_target = *t + h;
        let mut count = 0;
        let mut g0 = [0.0; MAX_GUARDS];
        let mut g1 = [0.0; MAX_GUARDS];
        loop {
            let rest = t_target - *t;
            if rest <= 0.0 {
                return Ok(count);
            }
            let n = match cache.take() {
                Some((g, n)) => {
                    g0 = g;
                    n
                }
                None => sys.guards(*t, x, &mut g0),
            };
            let x1 = rk4_step(&*sys, *t, x, rest);
            let n1 = sys.guards(*t + rest, &x1, &mut g1);
            // earliest crossing among armed guards
            let mut best: Option<(usize, f64)> = None;
            for j in 0..n {
                if g0[j] > 0.0 && g1[j] <= 0.0 {
                    let s = self.locate(&*sys, *t, x, rest, j, g0[j], g1[j]);
                    if best.is_none_or(|(_, b)| s < b) {
                        best = Some((j, s));
                    }
                }
            }
            match best {
                None => {
                    *x = x1;
                    *t = t_target;
                    *cache = Some((g1, n1));
                    return Ok(count);
                }
                Some((j, s)) => {
                    *x = if s >= rest {
                        x1
                    } else {
                        rk4_step(&*sys, *t, x, s)
                    };
                    *t = if s >= rest { t_target } else { *t + s };
                    sys.on_event(j, *t, x);
                    count += 1;
                    if count > self.max_events_per_step {
                        return Err(IntegratorError::TooManyEvents {
                            t_s: *t,
                            count,
                            guard: j,
                        });
                    }
                }
            }
        }
    }

    /// Root of `φ(s) = g_j(t + s, RK4(t, x, s))` on `(0, h]` with `φ(0) = ga > 0`,
    /// `φ(h) = gb ≤ 0` (Illinois); returns the right end of the final bracket.
    #[allow(clippy::too_many_arguments)]
    fn locate<const N: usize, S: HybridSystem<N> + ?Sized>(
        &self,
        sys: &S,
        t: f64,
        x: &[f64; N],
        h: f64,
        j: usize,
        ga: f64,
        gb: f64,
    ) -> f64 {
        let (mut a, mut b, mut fa, mut fb) = (0.0, h, ga, gb);
        let mut side = 0i8;
        let mut g = [0.0; MAX_GUARDS];
        for _ in 0..200 {
            if b - a <= self.time_tol_s {
                break;
            }
            let mut s = (a * fb - b * fa) / (fb - fa);
            if !(s > a && s < b) {
                s = 0.5 * (a + b);
            }
            let xs = rk4_step(sys, t, x, s);
            let _ = sys.guards(t + s, &xs, &mut g);
            let fs = g[j];
            if fs > 0.0 {
                a = s;
                fa = fs;
                if side == -1 {
                    fb *= 0.5;
                }
                side = -1;
            } else {
                b = s;
                fb = fs;
                if side == 1 {
                    fa *= 0.5;
                }
                side = 1;
            }
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ẍ = −ω² x, one guard x > 0: the first zero of cos(ωt) at π/(2ω).
    struct Osc {
        w: f64,
        hit: Option<f64>,
    }
    impl HybridSystem<2> for Osc {
        fn derivative(&self, _t: f64, x: &[f64; 2]) -> [f64; 2] {
            [x[1], -self.w * self.w * x[0]]
        }
        fn guards(&self, _t: f64, x: &[f64; 2], g: &mut [f64; MAX_GUARDS]) -> usize {
            g[0] = x[0];
            1
        }
        fn on_event(&mut self, _j: usize, t: f64, _x: &mut [f64; 2]) {
            self.hit.get_or_insert(t);
        }
    }

    #[test]
    fn truth_integrator_locates_the_zero_of_a_cosine() {
        let w = 3.0;
        let mut sys = Osc { w, hit: None };
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        EventRk4::new(0.01)
            .advance(&mut sys, &mut t, &mut x, 1.0)
            .unwrap();
        let exact = std::f64::consts::FRAC_PI_2 / w;
        // RK4 with ωh = 0.03: phase error ~ (ωh)⁴/120 · ωt ≈ 1e-9; the bracket 1e-9 s
        assert!((sys.hit.unwrap() - exact).abs() < 1e-8, "{:?}", sys.hit);
    }

    #[test]
    fn truth_integrator_rejects_a_bad_step() {
        let mut sys = Osc { w: 1.0, hit: None };
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let e = EventRk4::new(f64::NAN).advance(&mut sys, &mut t, &mut x, 1.0);
        assert!(matches!(e, Err(IntegratorError::BadSetting { .. })));
    }
}
