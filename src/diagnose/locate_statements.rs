//! Step 2 of the diagnosis, locate: statements about the shape of a signal's residual, derived
//! from the data (docs/diagnosis/method.md, "By operating condition").
//!
//! Statements ([`Statement`], put in words by the report) come from the data: the
//! residual is regressed on candidate shapes — constant, speed, speed², acceleration, grade,
//! engine torque, gear ratio — each in addition to a constant, and for the longitudinal
//! signals (whose residual integrates a force error from each re-initialisation,
//! [`LocateConfig::integrated_signals`]) on the shapes integrated from each window start. A
//! shape is stated when it adds at least [`LocateConfig::min_share`] (10 %) of the residual
//! energy to the constant's fit with an F-test p ≤ α / (number of shapes) on the effective
//! degrees of freedom; its reported share is what shape and constant explain together, and
//! statements are ranked by it. Indicator shapes (torque sign changes, clutch actuated,
//! braking, gear shifts) give "only …" statements when the residual is significant and
//! practically above the floor inside them, they cover at most half of the rows, and at least
//! 80 % of the excess energy `Σ(r² − σ²)` lies inside (or at least half of it, with the rows
//! outside within the practical ratio). Statements are only made for signals with a mismatch.
//!
//! Coefficients are in the signal's unit per shape unit (per shape unit·s for the integrated
//! signals); shares are fractions of the residual energy (of the excess energy for indicators).

use super::locate_conditions::Cond;
use super::locate_config::LocateConfig;
use super::location::Statement;
use super::noise::NoiseFloor;
use crate::signal::stats::f_sf;

/// Rows within ±`hw` rows of an event that `at(i)` marks between rows i−1 and i.
fn event_mask(n: usize, hw: usize, events: &[(usize, usize)]) -> Vec<bool> {
    let mut m = vec![false; n];
    for &(a, b) in events {
        let lo = a.saturating_sub(hw);
        let hi = (b + hw + 1).min(n);
        for x in &mut m[lo..hi] {
            *x = true;
        }
    }
    m
}

/// A candidate shape of the residual: id and values per row.
struct Shape {
    id: &'static str,
    values: Vec<f64>,
}

pub(super) fn statements(
    signal: &str,
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    c: &Cond<'_>,
    cfg: &LocateConfig,
) -> Vec<Statement> {
    let n = r.len();
    let dt = c.dt;
    if !(dt.is_finite() && dt > 0.0) {
        return Vec::new();
    }
    let integrated = cfg.integrated_signals.iter().any(|s| s == signal);
    // continuous shapes
    let mut shapes: Vec<Shape> = Vec::new();
    if let Some(v) = c.speed {
        shapes.push(Shape {
            id: "speed",
            values: v.to_vec(),
        });
        shapes.push(Shape {
            id: "speed_squared",
            values: v.iter().map(|x| x * x).collect(),
        });
    }
    if let Some(a) = c.accel {
        shapes.push(Shape {
            id: "acceleration",
            values: a.to_vec(),
        });
    }
    if let Some(s) = c.slope {
        shapes.push(Shape {
            id: "grade",
            values: s.to_vec(),
        });
    }
    if let Some(m) = c.torque {
        shapes.push(Shape {
            id: "engine_torque",
            values: m.to_vec(),
        });
    }
    if let (Some(g), false) = (c.gear, cfg.gear_ratios.is_empty()) {
        shapes.push(Shape {
            id: "gear_ratio",
            values: g
                .iter()
                .map(|&x| {
                    let k = x.round();
                    if k >= 1.0 && (k as usize) <= cfg.gear_ratios.len() {
                        cfg.gear_ratios[k as usize - 1]
                    } else {
                        0.0
                    }
                })
                .collect(),
        });
    }
    let integrate = |v: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; n];
        let mut acc = 0.0;
        let mut win = i64::MIN;
        for i in 0..n {
            let w = if !c.t[i].is_finite() {
                win
            } else if cfg.reinit_times_s.is_empty() {
                (c.t[i] / cfg.reinit_window_s).floor() as i64
            } else {
                cfg.reinit_times_s.partition_point(|&x| x <= c.t[i]) as i64
            };
            if w != win {
                acc = 0.0;
                win = w;
            } else if v[i].is_finite() && v[i - 1].is_finite() {
                acc += 0.5 * (v[i] + v[i - 1]) * (c.t[i] - c.t[i - 1]);
            }
            out[i] = acc;
        }
        out
    };
    let base: Vec<f64> = if integrated {
        integrate(&vec![1.0; n])
    } else {
        vec![1.0; n]
    };
    if integrated {
        for s in shapes.iter_mut() {
            s.values = integrate(&s.values);
        }
    }
    let rows: Vec<usize> = (0..n)
        .filter(|&i| usable[i] && base[i].is_finite())
        .collect();
    if rows.len() < 10 {
        return Vec::new();
    }
    let n_eff = floor.effective_dof(&rows).max(3.0);
    let sr2: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    if sr2 <= 0.0 {
        return Vec::new();
    }
    let n_masks = 4usize;
    let alpha_s = cfg.alpha / (shapes.len() + 1 + n_masks) as f64;
    let mut out = Vec::new();
    // the base (constant) alone
    let (sbb, sbr) = rows.iter().fold((0.0, 0.0), |(a, b), &i| {
        (a + base[i] * base[i], b + base[i] * r[i])
    });
    let ssr_base = if sbb > 0.0 {
        sr2 - sbr * sbr / sbb
    } else {
        sr2
    };
    let share_c = (sr2 - ssr_base) / sr2;
    let f_c = (sr2 - ssr_base) / (ssr_base / (n_eff - 1.0)).max(f64::MIN_POSITIVE);
    let p_c = f_sf(f_c, 1.0, n_eff - 1.0);
    if share_c >= cfg.min_share && p_c <= alpha_s {
        out.push(Statement {
            shape: "constant".into(),
            share: share_c,
            coefficient: if sbb > 0.0 { sbr / sbb } else { f64::NAN },
            p_value: p_c,
            best: false,
        });
    }
    for s in &shapes {
        let x = &s.values;
        let rs: Vec<usize> = rows.iter().copied().filter(|&i| x[i].is_finite()).collect();
        if rs.len() < 10 {
            continue;
        }
        // OLS on [base, x]
        let (mut a11, mut a12, mut a22, mut b1, mut b2, mut rr) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for &i in &rs {
            a11 += base[i] * base[i];
            a12 += base[i] * x[i];
            a22 += x[i] * x[i];
            b1 += base[i] * r[i];
            b2 += x[i] * r[i];
            rr += r[i] * r[i];
        }
        let det = a11 * a22 - a12 * a12;
        if det.is_nan() || det <= 1e-12 * a11 * a22 || a11 <= 0.0 {
            continue;
        }
        let c1 = (a22 * b1 - a12 * b2) / det;
        let c2 = (a11 * b2 - a12 * b1) / det;
        let ssr_full = rr - c1 * b1 - c2 * b2;
        let ssr_b = rr - b1 * b1 / a11;
        let gain = (ssr_b - ssr_full).max(0.0);
        // gate on what the shape adds to the constant; report (and rank by) what the two
        // explain together, so that a residual ∝ v² (always positive) ranks v² above the
        // constant that is part of it
        let share = (rr - ssr_full).max(0.0) / sr2;
        let added = gain / sr2;
        let f = gain / (ssr_full.max(0.0) / (n_eff - 2.0)).max(f64::MIN_POSITIVE);
        let p = f_sf(f, 1.0, (n_eff - 2.0).max(1.0));
        if added >= cfg.min_share && p <= alpha_s {
            out.push(Statement {
                shape: s.id.into(),
                share,
                coefficient: c2,
                p_value: p,
                best: false,
            });
        }
    }
    // indicator masks
    let hw = (cfg.event_halfwidth_s / dt).round() as usize;
    let mut masks: Vec<(&str, Vec<bool>)> = Vec::new();
    if let Some(m) = c.torque {
        let mut events = Vec::new();
        let mut last: Option<(f64, usize)> = None;
        for (i, &x) in m.iter().enumerate() {
            if !x.is_finite() || x.abs() <= cfg.torque_zero_nm {
                continue;
            }
            let s = x.signum();
            if let Some((ls, li)) = last {
                if ls != s {
                    events.push((li, i));
                }
            }
            last = Some((s, i));
        }
        masks.push(("torque_sign_change", event_mask(n, hw, &events)));
    }
    if let Some(cl) = c.clutch {
        masks.push(("clutch_actuated", cl.to_vec()));
    }
    if let Some(b) = c.braking {
        masks.push(("braking", b.to_vec()));
    }
    if let Some(g) = c.gear {
        let events: Vec<(usize, usize)> = (1..n)
            .filter(|&i| g[i].is_finite() && g[i - 1].is_finite() && g[i] != g[i - 1])
            .map(|i| (i - 1, i))
            .collect();
        masks.push(("gear_shift", event_mask(n, hw, &events)));
    }
    let k_copies = floor.copies as f64;
    for (id, m) in masks {
        let inside: Vec<usize> = rows.iter().copied().filter(|&i| m[i]).collect();
        let outside: Vec<usize> = rows.iter().copied().filter(|&i| !m[i]).collect();
        if inside.is_empty() || inside.len() * 2 > rows.len() {
            continue;
        }
        let sums = |rs: &[usize]| {
            rs.iter().fold((0.0, 0.0), |(q, e), &i| {
                (q + r[i] * r[i], e + floor.null_variance[i])
            })
        };
        let (qi, ei) = sums(&inside);
        let (qo, eo) = sums(&outside);
        let nu_i = floor.effective_dof(&inside);
        let p_in = f_sf(qi / ei, nu_i, k_copies * nu_i);
        let ratio_in = (qi / ei).sqrt();
        let ratio_out = if eo > 0.0 { (qo / eo).sqrt() } else { 0.0 };
        let (xi, xo) = ((qi - ei).max(0.0), (qo - eo).max(0.0));
        let share = if xi + xo > 0.0 { xi / (xi + xo) } else { 0.0 };
        if p_in <= alpha_s
            && ratio_in >= cfg.practical_ratio
            && (share >= 0.8 || ratio_out < cfg.practical_ratio)
            && share >= 0.5
        {
            out.push(Statement {
                shape: id.into(),
                share,
                coefficient: f64::NAN,
                p_value: p_in,
                best: false,
            });
        }
    }
    out.sort_by(|a, b| b.share.total_cmp(&a.share));
    if let Some(s) = out.first_mut() {
        s.best = true;
    }
    out
}
