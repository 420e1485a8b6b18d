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
/// two samples.
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
    let (start, end) = match (start, end) {
        (Some(s), Some(e)) if e > s => (s, e),
        _ => {
            return Err(IngestError::NoData {
                file: file.into(),
                what: "the required signals do not overlap in time".into(),
            })
        }
    };
    let n = ((end - start) / period_ns) as usize + 1;
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
