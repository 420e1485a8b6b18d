//! Step 2 of the diagnosis, locate, by operating condition (docs/diagnosis/method.md): the
//! comparison's condition columns as the locate step reads them, the operating condition of a
//! stretch in words, and the residual of a signal per operating-condition cell.
//!
//! # By operating condition
//! Cells gear × torque sign × speed band × grade band × braking × clutch actuated
//! ([`ConditionCell`]), each with rows, mean and RMS residual and an F test like the windows'
//! (Holm over the signal's cells).
//!
//! Speeds in m/s, grades as tan α (text in %), engine torque in N·m, durations in s; residuals in
//! the signal's unit.

use super::compare::Conditions;
use super::locate_config::{LocateConfig, LocateError};
use super::location::{ConditionCell, TorqueSign};
use super::noise::NoiseFloor;
use crate::signal::stats::{f_sf, holm};
use std::collections::BTreeMap;

/// A condition column: `None` when empty (not recorded), else checked for length.
fn opt_col<'a, T>(v: &'a [T], n: usize, what: &str) -> Result<Option<&'a [T]>, LocateError> {
    if v.is_empty() {
        Ok(None)
    } else if v.len() != n {
        Err(LocateError::Length {
            what: format!("conditions.{what}"),
            expected: n,
            got: v.len(),
        })
    } else {
        Ok(Some(v))
    }
}

/// Borrowed condition columns.
pub(super) struct Cond<'a> {
    pub(super) t: &'a [f64],
    pub(super) d: &'a [f64],
    pub(super) gear: Option<&'a [f64]>,
    pub(super) torque: Option<&'a [f64]>,
    pub(super) speed: Option<&'a [f64]>,
    pub(super) slope: Option<&'a [f64]>,
    pub(super) accel: Option<&'a [f64]>,
    pub(super) braking: Option<&'a [bool]>,
    pub(super) clutch: Option<&'a [bool]>,
    pub(super) dt: f64,
}

impl<'a> Cond<'a> {
    pub(super) fn new(c: &'a Conditions, n: usize) -> Result<Self, LocateError> {
        let need = |v: &'a [f64], what: &str| {
            if v.len() != n {
                Err(LocateError::Length {
                    what: format!("conditions.{what}"),
                    expected: n,
                    got: v.len(),
                })
            } else {
                Ok(v)
            }
        };
        let t = need(&c.t_s, "t_s")?;
        let d = need(&c.distance_m, "distance_m")?;
        let mut dts: Vec<f64> = t
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect();
        dts.sort_by(f64::total_cmp);
        let dt = dts.get(dts.len() / 2).copied().unwrap_or(f64::NAN);
        Ok(Self {
            t,
            d,
            gear: opt_col(&c.gear, n, "gear")?,
            torque: opt_col(&c.engine_torque_nm, n, "engine_torque_nm")?,
            speed: opt_col(&c.speed_mps, n, "speed_mps")?,
            slope: opt_col(&c.slope, n, "slope")?,
            accel: opt_col(&c.accel_mps2, n, "accel_mps2")?,
            braking: opt_col(&c.braking, n, "braking")?,
            clutch: opt_col(&c.clutch_actuated, n, "clutch_actuated")?,
            dt,
        })
    }

    fn torque_sign(&self, i: usize, zero: f64) -> TorqueSign {
        match self.torque.map(|m| m[i]) {
            Some(m) if m > zero => TorqueSign::Drive,
            Some(m) if m < -zero => TorqueSign::Brake,
            Some(m) if m.is_finite() => TorqueSign::Zero,
            _ => TorqueSign::Unknown,
        }
    }
}

/// The operating condition of `rows` in words.
pub(super) fn describe(c: &Cond<'_>, rows: &[usize], cfg: &LocateConfig) -> String {
    let mut parts = Vec::new();
    if rows.is_empty() {
        return "no rows".into();
    }
    let share = |f: &dyn Fn(usize) -> bool| {
        rows.iter().filter(|&&i| f(i)).count() as f64 / rows.len() as f64
    };
    if let Some(g) = c.gear {
        let gs: Vec<i64> = rows
            .iter()
            .filter(|&&i| g[i].is_finite())
            .map(|&i| g[i].round() as i64)
            .collect();
        if let (Some(lo), Some(hi)) = (gs.iter().min(), gs.iter().max()) {
            parts.push(if lo == hi {
                format!("gear {lo}")
            } else {
                format!("gears {lo}–{hi}")
            });
        }
    }
    if c.torque.is_some() {
        let drive = share(&|i| c.torque_sign(i, cfg.torque_zero_nm) == TorqueSign::Drive);
        let brake = share(&|i| c.torque_sign(i, cfg.torque_zero_nm) == TorqueSign::Brake);
        parts.push(if drive >= 0.8 {
            "drive torque".to_string()
        } else if brake >= 0.8 {
            "engine braking".to_string()
        } else {
            format!(
                "mixed torque ({:.0} % drive, {:.0} % engine braking)",
                100.0 * drive,
                100.0 * brake
            )
        });
    }
    let range = |v: &[f64]| {
        let xs: Vec<f64> = rows
            .iter()
            .map(|&i| v[i])
            .filter(|x| x.is_finite())
            .collect();
        let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo.is_finite()).then_some((lo, hi))
    };
    if let Some((lo, hi)) = c.speed.and_then(range) {
        parts.push(format!("speed {lo:.1}–{hi:.1} m/s"));
    }
    if let Some((lo, hi)) = c.slope.and_then(range) {
        parts.push(format!("grade {:+.1}…{:+.1} %", 100.0 * lo, 100.0 * hi));
    }
    if let Some(b) = c.braking {
        let s = share(&|i| b[i]);
        parts.push(if s == 0.0 {
            "not braking".into()
        } else {
            format!("braking {:.0} % of the time", 100.0 * s)
        });
    }
    if let Some(cl) = c.clutch {
        let s = share(&|i| cl[i]);
        if s > 0.0 {
            parts.push(format!("clutch actuated {:.0} % of the time", 100.0 * s));
        }
    }
    parts.join(", ")
}

/// Speed band index and edges.
fn speed_band(v: f64, w: f64) -> (i64, [f64; 2]) {
    let k = (v.max(0.0) / w).floor() as i64;
    (k, [k as f64 * w, (k + 1) as f64 * w])
}

pub(super) fn cells(
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    c: &Cond<'_>,
    cfg: &LocateConfig,
) -> Vec<ConditionCell> {
    type Key = (Option<i64>, TorqueSign, i64, usize, bool, bool);
    let mut groups: BTreeMap<Key, Vec<usize>> = BTreeMap::new();
    let edges = &cfg.grade_edges;
    for i in 0..r.len() {
        if !usable[i] {
            continue;
        }
        let gear = c
            .gear
            .and_then(|g| g[i].is_finite().then(|| g[i].round() as i64));
        let sp = c.speed.map_or(-1, |v| {
            if v[i].is_finite() {
                speed_band(v[i], cfg.speed_band_mps).0
            } else {
                -1
            }
        });
        let gr = c.slope.map_or(usize::MAX, |s| {
            if s[i].is_finite() {
                edges.partition_point(|e| *e <= s[i])
            } else {
                usize::MAX
            }
        });
        let key = (
            gear,
            c.torque_sign(i, cfg.torque_zero_nm),
            sp,
            gr,
            c.braking.is_some_and(|b| b[i]),
            c.clutch.is_some_and(|b| b[i]),
        );
        groups.entry(key).or_default().push(i);
    }
    let k_copies = floor.copies as f64;
    let dt = if c.dt.is_finite() { c.dt } else { 0.0 };
    let mut out: Vec<ConditionCell> = groups
        .into_iter()
        .map(|((gear, torque, sp, gr, braking, clutch), rows)| {
            let m = rows.len() as f64;
            let q: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
            let e: f64 = rows.iter().map(|&i| floor.null_variance[i]).sum();
            let mean = rows.iter().map(|&i| r[i]).sum::<f64>() / m;
            let duration = m * dt;
            let nu = floor.effective_dof(&rows);
            let speed = if sp >= 0 {
                [
                    sp as f64 * cfg.speed_band_mps,
                    (sp + 1) as f64 * cfg.speed_band_mps,
                ]
            } else {
                [f64::NAN, f64::NAN]
            };
            let (glo, ghi) = if gr == usize::MAX {
                (None, None)
            } else {
                (gr.checked_sub(1).map(|k| edges[k]), edges.get(gr).copied())
            };
            let tested = duration >= cfg.min_cell_s && e > 0.0;
            let mut label = Vec::new();
            label.push(gear.map_or("gear unknown".into(), |g| format!("gear {g}")));
            label.push(
                match torque {
                    TorqueSign::Drive => "drive torque",
                    TorqueSign::Brake => "engine braking",
                    TorqueSign::Zero => "zero torque",
                    TorqueSign::Unknown => "torque unknown",
                }
                .into(),
            );
            if sp >= 0 {
                label.push(format!("{:.0}–{:.0} m/s", speed[0], speed[1]));
            }
            if gr != usize::MAX {
                label.push(match (glo, ghi) {
                    (None, Some(h)) => format!("grade < {:+.0} %", 100.0 * h),
                    (Some(l), None) => format!("grade ≥ {:+.0} %", 100.0 * l),
                    (Some(l), Some(h)) => format!("grade {:+.0}…{:+.0} %", 100.0 * l, 100.0 * h),
                    (None, None) => "grade any".into(),
                });
            }
            label.push(if braking { "braking" } else { "not braking" }.into());
            if clutch {
                label.push("clutch actuated".into());
            }
            ConditionCell {
                gear,
                torque,
                speed_mps: speed,
                grade_lo: glo,
                grade_hi: ghi,
                braking,
                clutch_actuated: clutch,
                label: label.join(", "),
                rows: rows.len(),
                duration_s: duration,
                mean_residual: mean,
                rms_residual: (q / m).sqrt(),
                floor_rms: (e / m).sqrt(),
                ratio: if e > 0.0 { (q / e).sqrt() } else { f64::NAN },
                dof: nu,
                p_value: tested.then(|| f_sf(q / e, nu, k_copies * nu)),
                p_holm: None,
                significant: false,
            }
        })
        .collect();
    let tested: Vec<usize> = (0..out.len())
        .filter(|&k| out[k].p_value.is_some())
        .collect();
    let adj = holm(
        &tested
            .iter()
            .map(|&k| out[k].p_value.unwrap_or(1.0))
            .collect::<Vec<_>>(),
    );
    for (&k, a) in tested.iter().zip(adj) {
        out[k].p_holm = Some(a);
        out[k].significant = a <= cfg.alpha && out[k].ratio >= cfg.practical_ratio;
    }
    out
}
