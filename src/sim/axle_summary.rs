//! Peak changes of an axle-load simulation relative to the static state: for each axle the
//! normal-force change and the bellow-pressure change of largest magnitude, signed, with the time
//! it occurs (the axle-load thesis, §4.3, reads its figures 4.2–4.7 this way: which axle gains,
//! which loses, how much).
//!
//! Conventions: a change is `x(t) − x_static` (+ = more load / more pressure); of several
//! samples with the same largest magnitude the first counts; NaN samples are skipped. Normal
//! forces are also given as the scale reading `ΔN/g` (kg), pressures also in bar (1 bar = 1e5 Pa).

use super::axle::AxleTrajectory;
use crate::model::axle::{Axle, StaticState};
use std::fmt;
use thiserror::Error;

/// Why a trajectory could not be summarised.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SummaryError {
    /// No sample with a finite value (an empty trajectory, or all NaN).
    #[error("axle summary: no finite {0} samples")]
    NoSamples(&'static str),
    /// Signals of unequal length.
    #[error("axle summary: {signal} has {len} samples, the time axis {expected}")]
    Ragged {
        /// The offending signal.
        signal: &'static str,
        /// Its length.
        len: usize,
        /// Length of `t_s`.
        expected: usize,
    },
    /// Gravity not finite and > 0.
    #[error("axle summary: gravity {0} m/s^2 must be finite and > 0")]
    Gravity(f64),
}

/// One axle's peak changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxlePeaks {
    /// The axle.
    pub axle: Axle,
    /// Static normal force, N.
    pub static_normal_n: f64,
    /// Normal-force change of largest magnitude, N (+ = more load).
    pub normal_change_n: f64,
    /// The same change as a scale reading `ΔN/g`, kg.
    pub normal_change_kg: f64,
    /// When it occurs, s.
    pub normal_peak_time_s: f64,
    /// Static bellow gauge pressure, Pa.
    pub static_pressure_pa: f64,
    /// Bellow-pressure change of largest magnitude, Pa (+ = higher pressure).
    pub pressure_change_pa: f64,
    /// The same change, bar.
    pub pressure_change_bar: f64,
    /// When it occurs, s.
    pub pressure_peak_time_s: f64,
}

/// Peak changes of the three axles (front, rear, tag).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxleScenarioResult {
    /// Front, rear (driven), tag.
    pub axles: [AxlePeaks; 3],
    /// Gravity used for the kg figures, m/s².
    pub gravity_m_per_s2: f64,
}

/// The signed value of largest magnitude of `x − reference` and its time.
fn peak(
    t: &[f64],
    x: &[f64],
    reference: f64,
    what: &'static str,
) -> Result<(f64, f64), SummaryError> {
    if x.len() != t.len() {
        return Err(SummaryError::Ragged {
            signal: what,
            len: x.len(),
            expected: t.len(),
        });
    }
    t.iter()
        .zip(x)
        .map(|(&tk, &xk)| (xk - reference, tk))
        .filter(|(d, _)| !d.is_nan())
        .fold(None, |best: Option<(f64, f64)>, (d, tk)| match best {
            Some((b, _)) if b.abs() >= d.abs() => best,
            _ => Some((d, tk)),
        })
        .ok_or(SummaryError::NoSamples(what))
}

/// The peak changes of `traj` relative to the static state `st`.
///
/// # Errors
/// [`SummaryError`] for an empty or all-NaN signal, signals of unequal length, or a gravity
/// that is not finite and > 0.
pub fn summarize(
    traj: &AxleTrajectory,
    st: &StaticState,
    gravity_m_per_s2: f64,
) -> Result<AxleScenarioResult, SummaryError> {
    if !(gravity_m_per_s2.is_finite() && gravity_m_per_s2 > 0.0) {
        return Err(SummaryError::Gravity(gravity_m_per_s2));
    }
    const NORMAL: [&str; 3] = [
        "normal_force_front",
        "normal_force_rear",
        "normal_force_tag",
    ];
    const PRESSURE: [&str; 3] = [
        "bellow_pressure_front",
        "bellow_pressure_rear",
        "bellow_pressure_tag",
    ];
    let mut axles = Vec::with_capacity(3);
    for (i, axle) in Axle::ALL.into_iter().enumerate() {
        let (dn, tn) = peak(&traj.t_s, &traj.normal_n[i], st.normal_n[i], NORMAL[i])?;
        let (dp, tp) = peak(
            &traj.t_s,
            &traj.pressure_pa[i],
            st.pressure_pa[i],
            PRESSURE[i],
        )?;
        axles.push(AxlePeaks {
            axle,
            static_normal_n: st.normal_n[i],
            normal_change_n: dn,
            normal_change_kg: dn / gravity_m_per_s2,
            normal_peak_time_s: tn,
            static_pressure_pa: st.pressure_pa[i],
            pressure_change_pa: dp,
            pressure_change_bar: dp / 1e5,
            pressure_peak_time_s: tp,
        });
    }
    Ok(AxleScenarioResult {
        axles: [axles[0], axles[1], axles[2]],
        gravity_m_per_s2,
    })
}

impl fmt::Display for AxleScenarioResult {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "axle  | static [t]  peak dN [kg]  [N]        at [s] | static [bar]  peak dp [bar]  [Pa]      at [s]"
        )?;
        for a in &self.axles {
            writeln!(
                f,
                "{:<5} | {:>10.3} {:>+13.1} {:>+10.0} {:>7.2} | {:>12.3} {:>+14.4} {:>+9.0} {:>7.2}",
                a.axle.name(),
                a.static_normal_n / self.gravity_m_per_s2 / 1000.0,
                a.normal_change_kg,
                a.normal_change_n,
                a.normal_peak_time_s,
                a.static_pressure_pa / 1e5,
                a.pressure_change_bar,
                a.pressure_change_pa,
                a.pressure_peak_time_s
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_is_signed_largest_magnitude_first_on_ties_and_skips_nan() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let x = [10.0, 13.0, f64::NAN, 6.0, 7.0];
        assert_eq!(peak(&t, &x, 10.0, "x").unwrap(), (-4.0, 3.0));
        let tie = [10.0, 14.0, 6.0];
        assert_eq!(peak(&t[..3], &tie, 10.0, "x").unwrap(), (4.0, 1.0));
        assert_eq!(peak(&[], &[], 0.0, "x"), Err(SummaryError::NoSamples("x")));
        assert!(matches!(
            peak(&t, &x[..2], 0.0, "x"),
            Err(SummaryError::Ragged { len: 2, .. })
        ));
    }
}
