//! Multi-rate alignment: channels recorded at their own rates onto one uniform time base.
//!
//! Rules (the per-column choice comes from `schemas/drive-log.toml`):
//! - The time base is uniform. Its period is the median sample period of the fastest channel,
//!   rounded to 0.1 ms (logger jitter must not leak into the grid), unless a rate is configured.
//! - It spans the interval every *required* channel covers (latest first sample to earliest last
//!   sample), so required columns are complete at the edges; optional channels that start later
//!   or end earlier are NaN there. The grid starts at that first time.
//! - `linear` columns are interpolated linearly between the two neighbouring samples; `hold`
//!   columns take the last sample at or before the grid time (zero-order hold).
//! - No extrapolation, and no bridging of gaps: between two samples further apart than 2.5 of the
//!   channel's own median periods (one lost frame plus jitter), the grid gets NaN. Whether such a
//!   gap is acceptable is decided afterwards by the NaN-run rule, per column.

use super::channel::Channel;
use super::IngestError;
use crate::schema::Interpolation;
use crate::table::Signal;
use std::path::Path;

/// How the common time base is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum TimeBase {
    /// The fastest channel's median rate (default).
    #[default]
    Fastest,
    /// A fixed rate, Hz.
    RateHz(f64),
}

const PERIOD_ROUNDING_NS: i64 = 100_000;

/// The result of aligning channels.
#[derive(Debug, Clone)]
pub struct Aligned {
    /// Grid times, ns.
    pub t_ns: Vec<i64>,
    /// One signal per channel, in input order.
    pub signals: Vec<Signal>,
    /// Grid period, ns.
    pub period_ns: i64,
}

/// Aligns `channels` onto one grid spanning the `required` columns.
///
/// # Errors
/// [`IngestError::NoData`] when the required channels do not overlap in time or no channel has
/// two samples; [`IngestError::GridTooLarge`] when the grid would hold more than
/// [`GRID_ROWS_PER_SAMPLE`] rows per sample of the densest channel (and over
/// [`GRID_ROWS_FLOOR`]).
pub fn align(
    file: &Path,
    channels: &[Channel],
    required: &[&str],
    base: TimeBase,
) -> Result<Aligned, IngestError> {
    let period_ns = match base {
        TimeBase::RateHz(hz) if hz > 0.0 => (1e9 / hz).round() as i64,
        _ => {
            let fastest = channels
                .iter()
                .map(Channel::median_period_ns)
                .filter(|&p| p > 0)
                .min()
                .ok_or_else(|| IngestError::NoData {
                    file: file.into(),
                    what: "no channel has two samples".into(),
                })?;
            ((fastest + PERIOD_ROUNDING_NS / 2) / PERIOD_ROUNDING_NS).max(1) * PERIOD_ROUNDING_NS
        }
    };
    let (start, end) = span(file, channels, required)?;
    let rows = end.saturating_sub(start) / period_ns + 1;
    let samples = channels.iter().map(Channel::len).max().unwrap_or(0) as u64;
    let limit = (GRID_ROWS_PER_SAMPLE * samples).max(GRID_ROWS_FLOOR);
    if rows as u64 > limit {
        return Err(IngestError::GridTooLarge {
            file: file.into(),
            period_ns,
            seconds: end.saturating_sub(start) as f64 * 1e-9,
            rows: rows as u64,
            samples,
            limit,
        });
    }
    let n = rows as usize;
    let t_ns: Vec<i64> = (0..n as i64).map(|k| start + k * period_ns).collect();
    let signals = channels
        .iter()
        .map(|c| Signal {
            name: c.column.clone(),
            unit: c.unit.clone(),
            values: resample_channel(c, &t_ns),
        })
        .collect();
    Ok(Aligned {
        t_ns,
        signals,
        period_ns,
    })
}

/// The grid may hold at most this many rows per sample of the densest channel (or
/// [`GRID_ROWS_FLOOR`]); beyond it the grid would be invented data, and its memory is refused.
pub const GRID_ROWS_PER_SAMPLE: u64 = 64;
/// Grids up to this many rows are always accepted (10 h at 100 Hz is 3.6 M rows).
pub const GRID_ROWS_FLOOR: u64 = 1 << 22;

/// The interval every required (non-empty) channel covers, ns: latest first sample to earliest
/// last sample; all non-empty channels when no required one has samples.
///
/// # Errors
/// [`IngestError::NoData`] when that interval is empty.
pub fn span(
    file: &Path,
    channels: &[Channel],
    required: &[&str],
) -> Result<(i64, i64), IngestError> {
    let spanning: Vec<&Channel> = channels
        .iter()
        .filter(|c| required.contains(&c.column.as_str()) && !c.is_empty())
        .collect();
    let spanning = if spanning.is_empty() {
        channels.iter().filter(|c| !c.is_empty()).collect()
    } else {
        spanning
    };
    let start = spanning.iter().map(|c| c.t_ns[0]).max();
    let end = spanning
        .iter()
        .map(|c| *c.t_ns.last().expect("non-empty"))
        .min();
    match (start, end) {
        (Some(s), Some(e)) if e > s => Ok((s, e)),
        _ => Err(IngestError::NoData {
            file: file.into(),
            what: "the required signals do not overlap in time".into(),
        }),
    }
}

/// The holes of the `required` channels: (channel, k) where samples k and k + 1 lie further
/// apart than 2.5 of the channel's median periods (so [`resample_channel`] leaves the grid NaN
/// between them) and the part of the gap inside `span` (ns) is longer than `limit_s` plus that
/// 2.5-period margin (the grid's edge rows may sit up to a period inside the span). In channel
/// order, then time order.
pub fn required_holes<'c>(
    channels: &'c [Channel],
    required: &'c [&str],
    limit_s: f64,
    (start, end): (i64, i64),
) -> impl Iterator<Item = (&'c Channel, usize)> + 'c {
    channels
        .iter()
        .filter(move |c| required.contains(&c.column.as_str()))
        .flat_map(move |c| {
            let max_gap = (c.median_period_ns() as f64 * 2.5) as i64;
            c.t_ns.windows(2).enumerate().filter_map(move |(k, w)| {
                let (t0, t1) = (w[0], w[1]);
                let inside = t1.min(end).saturating_sub(t0.max(start)) as f64 * 1e-9;
                (t1.saturating_sub(t0) > max_gap && inside > limit_s + max_gap as f64 * 1e-9)
                    .then_some((c, k))
            })
        })
}

/// Rejects the first of the [`required_holes`] within the grid's [`span`]. Such a hole would
/// fail the NaN-run rule after alignment anyway; checking the channels first keeps a year-long
/// hole from allocating a year of grid.
///
/// # Errors
/// [`IngestError::TimeGap`] naming the channel, the source row after the hole and its length.
pub fn check_gaps(
    file: &Path,
    channels: &[Channel],
    required: &[&str],
    limit_s: f64,
) -> Result<(), IngestError> {
    let Ok(span) = span(file, channels, required) else {
        return Ok(()); // align reports it
    };
    if let Some((c, k)) = required_holes(channels, required, limit_s, span).next() {
        let (t0, t1) = (c.t_ns[k], c.t_ns[k + 1]);
        return Err(IngestError::TimeGap {
            file: file.into(),
            column: c.column.clone(),
            row: c.rows[k + 1],
            time_ns: t1,
            previous_ns: t0,
            seconds: t1.saturating_sub(t0) as f64 * 1e-9,
            limit_s,
        });
    }
    Ok(())
}

/// Samples one channel at the (sorted) grid times, per the rules in the module doc.
pub fn resample_channel(c: &Channel, grid: &[i64]) -> Vec<f64> {
    let mut out = vec![f64::NAN; grid.len()];
    if c.is_empty() {
        return out;
    }
    let max_gap = (c.median_period_ns() as f64 * 2.5) as i64;
    let last = c.len() - 1;
    let mut j = 0usize;
    for (o, &t) in out.iter_mut().zip(grid) {
        if t < c.t_ns[0] || t > c.t_ns[last] {
            continue;
        }
        while j < last && c.t_ns[j + 1] <= t {
            j += 1;
        }
        if j == last {
            *o = c.values[last];
            continue;
        }
        let (t0, t1) = (c.t_ns[j], c.t_ns[j + 1]);
        if t1 - t0 > max_gap && t != t0 {
            continue;
        }
        *o = match c.interpolation {
            Interpolation::Hold | Interpolation::None => c.values[j],
            Interpolation::Linear => {
                let w = (t - t0) as f64 / (t1 - t0) as f64;
                c.values[j] + w * (c.values[j + 1] - c.values[j])
            }
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ch(name: &str, interp: Interpolation, t_ms: &[i64], v: &[f64]) -> Channel {
        let mut c = Channel::new(name, "1", interp);
        for (i, (&t, &v)) in t_ms.iter().zip(v).enumerate() {
            c.push(t * 1_000_000, v, i as u64);
        }
        c
    }

    #[test]
    fn linear_and_hold_on_the_fastest_grid() {
        // speed at 10 Hz (linear), gear at 5 Hz (hold), engine at 50 Hz sets the grid.
        let speed = ch(
            "vehicle_speed",
            Interpolation::Linear,
            &[0, 100, 200, 300],
            &[0.0, 1.0, 2.0, 3.0],
        );
        let gear = ch(
            "gear",
            Interpolation::Hold,
            &[0, 200, 400],
            &[1.0, 2.0, 3.0],
        );
        let t_eng: Vec<i64> = (0..=15).map(|k| k * 20 + 1).collect(); // 1 ms jitter offset
        let eng = ch(
            "engine_speed",
            Interpolation::Linear,
            &t_eng,
            &vec![100.0; t_eng.len()],
        );
        let a = align(
            Path::new("f"),
            &[speed, gear, eng],
            &["vehicle_speed", "gear"],
            TimeBase::Fastest,
        )
        .unwrap();
        assert_eq!(a.period_ns, 20_000_000);
        // span = required overlap [0, 300] ms
        assert_eq!(a.t_ns.first(), Some(&0));
        assert_eq!(a.t_ns.last(), Some(&300_000_000));
        let v = &a.signals[0].values;
        assert!((v[3] - 0.6).abs() < 1e-12); // 60 ms
        let g = &a.signals[1].values;
        assert_eq!(g[9], 1.0); // 180 ms: still gear 1
        assert_eq!(g[10], 2.0); // 200 ms
                                // engine channel starts at 1 ms: grid point 0 ms is before it -> NaN, no extrapolation
        assert!(a.signals[2].values[0].is_nan());
    }

    #[test]
    fn long_gaps_are_not_bridged() {
        let c = ch(
            "vehicle_speed",
            Interpolation::Linear,
            &[0, 100, 200, 900, 1000],
            &[0.0, 1.0, 2.0, 9.0, 10.0],
        );
        let grid: Vec<i64> = (0..=10).map(|k| k * 100_000_000).collect();
        let v = resample_channel(&c, &grid);
        assert_eq!(v[2], 2.0);
        assert!(v[3].is_nan() && v[8].is_nan());
        assert_eq!(v[9], 9.0);
    }
}
