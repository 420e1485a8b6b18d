//! Step 2 of the diagnosis, locate (docs/diagnosis/method.md): where, at what frequencies and under
//! which operating conditions the residual `measured − simulated` of a [`Comparison`] stands above
//! its noise floor ([`super::noise`]).
//!
//! # In time and distance
//! The drive is cut into windows ([`WindowAxis`], default 10 s: ≥ 100 native samples of a
//! 10 Hz channel, short enough to localise a launch, a shift or ~150 m of road). Per window and
//! signal, `F = Σ r² / Σ σ²` over the rows that count, σ² the floor's per-row null variance
//! (the mean of the Monte-Carlo copies' squared null residuals in the same rows). Under "no
//! mismatch" `Σ r²` is a scaled χ²_ν and the copies' mean a scaled χ²_{Kν}/K, so
//! `F ~ F(ν, K·ν)`; ν is the window's effective degrees of freedom, the smaller of the one
//! from the null's autocorrelation (the longitudinal null is correlated over the model's 20 s
//! re-initialisation windows, so ν is small there) and the one the copies' own covariance in
//! the window gives ([`NoiseFloor::window_dof`]: the pooled autocorrelation is stationary, the
//! null is not), so the test claims no more evidence than the null shows. The
//! p-values of **every window of every signal** of the drive form one family, corrected by
//! Holm's step-down method at α = [`LocateConfig::alpha`] (0.01): the chance that a drive
//! without mismatch shows any significant window is at most α. A window is a mismatch when its
//! Holm-adjusted p ≤ α **and** its RMS residual exceeds [`LocateConfig::practical_ratio`]
//! (1.5) × its floor RMS: a residual within 1.5× the floor is not worth explaining, and the
//! rule keeps a floor underestimated by up to a third from turning into findings. Adjacent
//! mismatch windows of one signal merge into a stretch — also across one window with too few
//! counting rows to be tested (a shift, a stop or a CAN dropout leaves such windows) — one
//! [`Mismatch`] record of the output contract each; its `significance` is the smallest Holm-adjusted p-value of its windows
//! (smaller = more significant).
//!
//! The other views of the residual: [`super::locate_frequency`] (by band, input coherence and
//! lags), [`super::locate_conditions`] (by operating condition),
//! [`super::locate_statements`] (plain statements); the settings in [`super::locate_config`],
//! the records in [`super::location`], the statistics in [`crate::signal::stats`].
//!
//! All quantities SI (s, m, m/s, the signal's unit); grades as tan α (text in %); frequencies in
//! Hz. Deterministic. Bad input (lengths that differ, bad settings) is a [`LocateError`]; empty
//! or all-NaN residuals give empty results.

use super::compare::{Compared, Comparison};
use super::locate_conditions::{cells, describe, Cond};
use super::locate_frequency::{
    band_power, band_powers, bands, coherence, lag, native_nyquist, psd_over,
};
use super::locate_statements::statements;
use super::noise::{NoiseFloor, NoiseFloors};
use crate::signal::stats::f_sf;
use crate::signal::stats::runs;
use std::collections::BTreeMap;

pub use super::locate_config::{
    inputs_from_log, recorded_inputs, shuffle_band_hz, InputSeries, LocateConfig, LocateError,
    NamedSeries, RecordedInput, WindowAxis,
};
pub use super::location::{
    BandCoherence, BandPower, ConditionCell, InputCoherence, InputLag, Location, Mismatch,
    SignalLocation, Statement, TorqueSign, WindowTest,
};
pub use crate::signal::stats::holm;

/// Everything about one signal that needs no cross-signal information.
struct Pending {
    loc: SignalLocation,
    usable: Vec<bool>,
    residual: Vec<f64>,
    window_rows: Vec<Vec<usize>>,
}

/// Locates the mismatch of `cmp` against `floors` (see the module documentation). `inputs`
/// are named input series on the comparison's rows for coherence and lags. A signal without a
/// floor in `floors` is skipped.
///
/// # Errors
/// [`LocateError::BadConfig`] for bad settings; [`LocateError::Length`] when a signal, a
/// condition column or an input does not have the comparison's rows.
pub fn locate(
    cmp: &Comparison,
    floors: &NoiseFloors,
    inputs: &[NamedSeries],
    cfg: &LocateConfig,
) -> Result<Location, LocateError> {
    locate_inputs(cmp, floors, inputs, cfg)
}

/// [`locate`] with inputs of any [`InputSeries`] kind, each made when its tests read it (a
/// log's [`recorded_inputs`]: one filled copy at a time). The same location as [`locate`] on
/// the same series.
///
/// # Errors
/// As [`locate`].
pub fn locate_inputs<S: InputSeries>(
    cmp: &Comparison,
    floors: &NoiseFloors,
    inputs: &[S],
    cfg: &LocateConfig,
) -> Result<Location, LocateError> {
    cfg.validate()?;
    let n = cmp.conditions.t_s.len();
    let cond = Cond::new(&cmp.conditions, n)?;
    for s in &cmp.signals {
        for (what, len) in [
            ("measured", s.measured.len()),
            ("simulated", s.simulated.len()),
            ("valid", s.valid.len()),
        ] {
            if len != n {
                return Err(LocateError::Length {
                    what: format!("{}.{what}", s.name),
                    expected: n,
                    got: len,
                });
            }
        }
    }
    for x in inputs {
        if x.len() != n {
            return Err(LocateError::Length {
                what: format!("input {}", x.name()),
                expected: n,
                got: x.len(),
            });
        }
    }
    let mut pending: Vec<Pending> = Vec::new();
    for s in &cmp.signals {
        let Some(floor) = floors.get(&s.name) else {
            continue;
        };
        if floor.null_variance.len() != n {
            return Err(LocateError::Length {
                what: format!("noise floor of {}", s.name),
                expected: n,
                got: floor.null_variance.len(),
            });
        }
        pending.push(windows_of(s, floor, &cond, cfg));
    }
    // Holm over every tested window of every signal
    let mut family: Vec<(usize, usize, f64)> = Vec::new();
    for (si, p) in pending.iter().enumerate() {
        for (wi, w) in p.loc.windows.iter().enumerate() {
            family.push((si, wi, w.p_value));
        }
    }
    let adj = holm(&family.iter().map(|f| f.2).collect::<Vec<_>>());
    for ((si, wi, _), a) in family.iter().zip(&adj) {
        let w = &mut pending[*si].loc.windows[*wi];
        w.p_holm = *a;
        w.significant = *a <= cfg.alpha && w.ratio >= cfg.practical_ratio;
    }
    let mut mismatch = Vec::new();
    let mut signals = Vec::new();
    for (p, s) in pending
        .into_iter()
        .zip(cmp.signals.iter().filter(|s| floors.get(&s.name).is_some()))
    {
        let floor = floors.get(&s.name).expect("filtered");
        let Pending {
            mut loc,
            usable,
            residual,
            window_rows,
        } = p;
        loc.significant = loc.windows.iter().any(|w| w.significant);
        // stretches
        let mut k = 0;
        while k < loc.windows.len() {
            if !loc.windows[k].significant {
                k += 1;
                continue;
            }
            let mut e = k;
            while e + 1 < loc.windows.len()
                && loc.windows[e + 1].significant
                && loc.windows[e + 1].index <= loc.windows[e].index + 2
            {
                e += 1;
            }
            let rows: Vec<usize> = window_rows[k..=e].iter().flatten().copied().collect();
            mismatch.push(stretch(
                &s.name,
                &loc.windows[k..=e],
                &rows,
                &residual,
                floor,
                &cond,
                cfg,
            ));
            k = e + 1;
        }
        loc.bands = band_powers(&residual, &usable, floor, cfg, cond.dt);
        // each input made, read by both tests and dropped before the next
        let (mut coh, mut lags) = (Vec::new(), Vec::new());
        for x in inputs {
            let Some(x) = x.series() else {
                continue;
            };
            coh.extend(coherence(&x, &residual, &usable, floor, cfg, cond.dt));
            lags.extend(lag(&x, &residual, &usable, cfg, cond.dt));
        }
        loc.coherence = coh;
        loc.lags = lags;
        loc.conditions = cells(&residual, &usable, floor, &cond, cfg);
        if loc.significant {
            loc.statements = statements(&s.name, &residual, &usable, floor, &cond, cfg);
        }
        signals.push(loc);
    }
    let any_significant = signals.iter().any(|s| s.significant);
    Ok(Location {
        mismatch,
        signals,
        any_significant,
        alpha: cfg.alpha,
        family_size: family.len(),
    })
}

fn windows_of(s: &Compared, floor: &NoiseFloor, c: &Cond<'_>, cfg: &LocateConfig) -> Pending {
    let n = s.valid.len();
    let residual = s.residual();
    let usable: Vec<bool> = (0..n)
        .map(|i| {
            residual[i].is_finite()
                && floor.null_variance[i].is_finite()
                && floor.null_variance[i] > 0.0
                && c.t[i].is_finite()
        })
        .collect();
    let (mut q, mut e, mut cnt) = (0.0, 0.0, 0usize);
    for i in 0..n {
        if usable[i] {
            q += residual[i] * residual[i];
            e += floor.null_variance[i];
            cnt += 1;
        }
    }
    // window index of every row
    let key = |i: usize| -> Option<i64> {
        let (x, w) = match cfg.window {
            WindowAxis::Time { window_s } => (c.t[i], window_s),
            WindowAxis::Distance { window_m } => (c.d[i], window_m),
        };
        x.is_finite().then(|| (x / w).floor() as i64)
    };
    let mut groups: BTreeMap<i64, (Vec<usize>, usize)> = BTreeMap::new();
    for (i, &u) in usable.iter().enumerate() {
        if let Some(k) = key(i) {
            let g = groups.entry(k).or_default();
            g.1 += 1;
            if u {
                g.0.push(i);
            }
        }
    }
    let k_copies = floor.copies as f64;
    let mut windows = Vec::new();
    let mut window_rows = Vec::new();
    for (idx, (rows, total)) in groups {
        if rows.is_empty() || (rows.len() as f64) < cfg.min_valid_fraction * total as f64 {
            continue;
        }
        let qw: f64 = rows.iter().map(|&i| residual[i] * residual[i]).sum();
        let ew: f64 = rows.iter().map(|&i| floor.null_variance[i]).sum();
        let nu = floor.window_dof(&rows);
        let f = qw / ew;
        let (a, b) = (rows[0], rows[rows.len() - 1]);
        windows.push(WindowTest {
            index: idx,
            start_s: c.t[a],
            end_s: c.t[b],
            start_m: c.d[a],
            end_m: c.d[b],
            rows: rows.len(),
            rms_residual: (qw / rows.len() as f64).sqrt(),
            floor_rms: (ew / rows.len() as f64).sqrt(),
            ratio: f.sqrt(),
            dof: nu,
            p_value: f_sf(f, nu, k_copies * nu),
            p_holm: 1.0,
            significant: false,
        });
        window_rows.push(rows);
    }
    Pending {
        loc: SignalLocation {
            signal: s.name.clone(),
            unit: s.unit.clone(),
            rows: cnt,
            rms_residual: if cnt > 0 {
                (q / cnt as f64).sqrt()
            } else {
                f64::NAN
            },
            floor_rms: if cnt > 0 {
                (e / cnt as f64).sqrt()
            } else {
                f64::NAN
            },
            windows,
            bands: Vec::new(),
            coherence: Vec::new(),
            lags: Vec::new(),
            conditions: Vec::new(),
            statements: Vec::new(),
            significant: false,
        },
        usable,
        residual,
        window_rows,
    }
}

/// One mismatch stretch.
fn stretch(
    signal: &str,
    w: &[WindowTest],
    rows: &[usize],
    r: &[f64],
    floor: &NoiseFloor,
    c: &Cond<'_>,
    cfg: &LocateConfig,
) -> Mismatch {
    let m = rows.len().max(1) as f64;
    let q: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    let e: f64 = rows.iter().map(|&i| floor.null_variance[i]).sum();
    let first = w.first().expect("a stretch has windows");
    let last = w.last().expect("a stretch has windows");
    let dt = c.dt;
    let nyq = if dt.is_finite() && dt > 0.0 {
        native_nyquist(floor, dt)
    } else {
        f64::NAN
    };
    let mut band_hz = [0.0, nyq];
    if let (Some(null), true) = (&floor.null_psd, dt.is_finite() && dt > 0.0) {
        let mut ok = vec![false; r.len()];
        for &i in rows {
            ok[i] = true;
        }
        let longest = runs(&ok).iter().map(|(a, b)| b - a).max().unwrap_or(0);
        let nperseg = null.nperseg.min(longest);
        let global_var = floor.floor * floor.floor;
        if nperseg >= 8 && global_var > 0.0 {
            if let Some((f, p, _, dc)) = psd_over(r, &ok, nperseg, dt) {
                let scale = (e / m) / global_var;
                let best = bands(cfg, 0.5 / dt)
                    .into_iter()
                    .filter(|b| b.lo < nyq)
                    .filter_map(|b| {
                        let hi = b.hi.min(nyq);
                        let (mut pr, k) = band_power(&f, &p, b.lo, hi);
                        let (mut pn, _) = band_power(&null.freq_hz, &null.psd, b.lo, hi);
                        if b.lo == 0.0 {
                            pr += dc;
                            pn += null.dc_power;
                        }
                        (k > 0 && pn > 0.0).then(|| (pr / (pn * scale), [b.lo, hi]))
                    })
                    .max_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((_, b)) = best {
                    band_hz = b;
                }
            }
        }
    }
    Mismatch {
        signal: signal.into(),
        start_s: first.start_s,
        end_s: last.end_s,
        start_m: first.start_m,
        end_m: last.end_m,
        band_hz,
        condition: describe(c, rows, cfg),
        rms_residual: (q / m).sqrt(),
        significance: w.iter().map(|x| x.p_holm).fold(1.0, f64::min),
        floor_rms: (e / m).sqrt(),
        windows: w.len(),
    }
}
