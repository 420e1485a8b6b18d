//! A channel: one signal as its source recorded it, at its own times, before alignment.
//!
//! Checks done here, on source rows (so errors name the row a user can find in the file):
//! exact duplicates (same time, same value) are dropped and counted; the same time with another
//! value keeps the later sample ([`BadSamples::Mask`], counted) or is an error
//! ([`BadSamples::Error`]); time going backwards is an error unless [`TimeRepair::Sort`]; values
//! that are not finite, outside the schema's physical range, or a speed spike no truck can make
//! are masked to missing ([`BadSamples::Mask`], counted; [`bad_samples`]) or rejected.

use super::mapping::ResolvedSignal;
use super::IngestError;
use crate::schema::{drive_log, Interpolation};
use std::path::Path;

/// What to do when a channel's time goes backwards.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeRepair {
    /// Reject the drive (default): a logger clock jump is a fault worth seeing.
    #[default]
    Error,
    /// Sort samples by time (stable), then apply the duplicate rules.
    Sort,
}

/// What to do with an isolated bad sample (not finite, outside the physical range, a speed spike)
/// or a timestamp repeated with another value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BadSamples {
    /// Make the sample missing (a repeated timestamp: the later sample wins) and count it
    /// (default): a glitch costs that sample, not the drive. The gap limits still bound how
    /// much may be missing.
    #[default]
    Mask,
    /// Reject the drive, naming the sample.
    Error,
}

/// Largest acceleration or deceleration of a truck, m/s²: a speed sample that departs from both
/// neighbours by more than this over the sample interval, plus [`SPIKE_STEP_MPS`], in opposite
/// directions, is a spike no truck can make (emergency braking reaches about 8 m/s²).
pub const SPIKE_ACCEL_MPS2: f64 = 10.0;
/// Margin of the spike test for the speed signal's own resolution and jitter, m/s.
pub const SPIKE_STEP_MPS: f64 = 0.5;

/// One signal at its own sample times, already converted to SI.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Column name (canonical or pass-through).
    pub column: String,
    /// Unit of `values`.
    pub unit: String,
    /// How to carry the signal between samples.
    pub interpolation: Interpolation,
    /// Sample times, ns since the Unix epoch.
    pub t_ns: Vec<i64>,
    /// Values; NaN where the source had none.
    pub values: Vec<f64>,
    /// Source row of each sample (Parquet row, or message index within the MCAP topic).
    pub rows: Vec<u64>,
}

impl Channel {
    /// An empty channel.
    pub fn new(column: &str, unit: &str, interpolation: Interpolation) -> Self {
        Self {
            column: column.into(),
            unit: unit.into(),
            interpolation,
            t_ns: Vec::new(),
            values: Vec::new(),
            rows: Vec::new(),
        }
    }

    /// One empty channel per resolved mapping signal, with the canonical unit and interpolation.
    pub fn for_signals(resolved: &[ResolvedSignal]) -> Vec<Channel> {
        let canonical = drive_log();
        resolved
            .iter()
            .map(|r| {
                let spec = canonical
                    .column(&r.column)
                    .expect("resolved against the schema");
                Channel::new(&r.column, &spec.unit, spec.interpolation)
            })
            .collect()
    }

    /// Appends one sample.
    #[inline]
    pub fn push(&mut self, t_ns: i64, value: f64, row: u64) {
        self.t_ns.push(t_ns);
        self.values.push(value);
        self.rows.push(row);
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_ns.len()
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.t_ns.is_empty()
    }

    /// Median sample period, ns (0 with fewer than two samples).
    pub fn median_period_ns(&self) -> i64 {
        let mut d: Vec<i64> = self.t_ns.windows(2).map(|w| w[1] - w[0]).collect();
        if d.is_empty() {
            return 0;
        }
        let mid = d.len() / 2;
        *d.select_nth_unstable(mid).1
    }

    /// Enforces time order and drops exact duplicates; a repeated time with another value keeps
    /// the later sample under [`BadSamples::Mask`]. Returns the number of exact duplicates
    /// dropped and the times of the samples replaced by a later one.
    ///
    /// # Errors
    /// [`IngestError::NonMonotonicTime`] (with [`TimeRepair::Error`]) and
    /// [`IngestError::DuplicateTimestamp`] (with [`BadSamples::Error`]).
    pub fn order_and_dedup(
        &mut self,
        file: &Path,
        repair: TimeRepair,
        bad: BadSamples,
    ) -> Result<(u64, Vec<i64>), IngestError> {
        if repair == TimeRepair::Sort && self.t_ns.windows(2).any(|w| w[1] < w[0]) {
            let mut idx: Vec<usize> = (0..self.len()).collect();
            idx.sort_by_key(|&i| self.t_ns[i]);
            self.t_ns = idx.iter().map(|&i| self.t_ns[i]).collect();
            self.values = idx.iter().map(|&i| self.values[i]).collect();
            self.rows = idx.iter().map(|&i| self.rows[i]).collect();
        }
        let mut keep = 0usize;
        let (mut dropped, mut replaced) = (0u64, Vec::new());
        for i in 0..self.len() {
            if keep > 0 {
                let (tp, vp) = (self.t_ns[keep - 1], self.values[keep - 1]);
                let (t, v) = (self.t_ns[i], self.values[i]);
                if t < tp {
                    return Err(IngestError::NonMonotonicTime {
                        file: file.into(),
                        column: self.column.clone(),
                        row: self.rows[i],
                        time_ns: t,
                        previous_ns: tp,
                    });
                }
                if t == tp {
                    if v == vp || (v.is_nan() && vp.is_nan()) {
                        dropped += 1;
                        continue;
                    }
                    if bad == BadSamples::Mask {
                        // the later message wins
                        self.values[keep - 1] = v;
                        self.rows[keep - 1] = self.rows[i];
                        replaced.push(t);
                        continue;
                    }
                    return Err(IngestError::DuplicateTimestamp {
                        file: file.into(),
                        column: self.column.clone(),
                        row: self.rows[i],
                        time_ns: t,
                        value: v,
                        previous: vp,
                    });
                }
            }
            self.move_sample(i, keep);
            keep += 1;
        }
        self.truncate(keep);
        Ok((dropped, replaced))
    }

    /// Copies sample `from` to position `to` (compaction, `to ≤ from`).
    fn move_sample(&mut self, from: usize, to: usize) {
        self.t_ns[to] = self.t_ns[from];
        self.values[to] = self.values[from];
        self.rows[to] = self.rows[from];
    }

    /// A copy holding the samples with times in `[lo, hi]` (ns).
    pub fn window(&self, lo: i64, hi: i64) -> Channel {
        let a = self.t_ns.partition_point(|&t| t < lo);
        let b = self.t_ns.partition_point(|&t| t <= hi);
        Channel {
            column: self.column.clone(),
            unit: self.unit.clone(),
            interpolation: self.interpolation,
            t_ns: self.t_ns[a..b].to_vec(),
            values: self.values[a..b].to_vec(),
            rows: self.rows[a..b].to_vec(),
        }
    }

    /// Keeps the first `n` samples.
    fn truncate(&mut self, n: usize) {
        self.t_ns.truncate(n);
        self.values.truncate(n);
        self.rows.truncate(n);
    }

    /// Drops the samples at the positions `masked` marks (a channel's missing value is an absent
    /// sample, so the gap limits see the hole).
    pub fn drop_samples(&mut self, masked: &[bool]) {
        let mut keep = 0;
        for (i, &bad) in masked.iter().enumerate().take(self.len()) {
            if !bad {
                self.move_sample(i, keep);
                keep += 1;
            }
        }
        self.truncate(keep);
    }
}

/// The samples of `column` that are bad: not finite (±∞; NaN is missing, not bad), outside
/// `[min, max]`, or, for `vehicle_speed`, a spike (module documentation, [`SPIKE_ACCEL_MPS2`]).
/// `t_ns` are the sample times.
pub fn bad_samples(column: &str, t_ns: &[i64], values: &[f64], min: f64, max: f64) -> Vec<bool> {
    let mut bad: Vec<bool> = values
        .iter()
        .map(|v| !(v.is_nan() || (v.is_finite() && (min..=max).contains(v))))
        .collect();
    if column == "vehicle_speed" {
        // each good sample against its nearest good neighbours (one pass over the good ones)
        let good: Vec<usize> = (0..values.len())
            .filter(|&i| values[i].is_finite() && !bad[i])
            .collect();
        let limit = |a: usize, b: usize| {
            SPIKE_ACCEL_MPS2 * (t_ns[b].saturating_sub(t_ns[a]) as f64 * 1e-9) + SPIKE_STEP_MPS
        };
        for w in good.windows(3) {
            let (p, i, n) = (w[0], w[1], w[2]);
            let (d1, d2) = (values[i] - values[p], values[n] - values[i]);
            if d1.abs() > limit(p, i) && d2.abs() > limit(i, n) && d1.signum() != d2.signum() {
                bad[i] = true;
            }
        }
    }
    bad
}

/// Range check over parallel slices; `rows` maps positions to source rows (identity if `None`).
/// Non-finite values are out of any range.
///
/// # Errors
/// [`IngestError::OutOfRange`] for the first offending value.
#[allow(clippy::too_many_arguments)]
pub fn check_range(
    file: &Path,
    column: &str,
    unit: &str,
    t_ns: &[i64],
    values: &[f64],
    rows: Option<&[u64]>,
    min: f64,
    max: f64,
) -> Result<(), IngestError> {
    if let Some(i) = values
        .iter()
        .position(|v| !(v.is_nan() || (v.is_finite() && (min..=max).contains(v))))
    {
        return Err(IngestError::OutOfRange {
            file: file.into(),
            column: column.into(),
            row: rows.map_or(i as u64, |r| r[i]),
            time_ns: t_ns[i],
            value: values[i],
            unit: unit.into(),
            min,
            max,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ch(t: &[i64], v: &[f64]) -> Channel {
        let mut c = Channel::new("vehicle_speed", "m/s", Interpolation::Linear);
        for (i, (&t, &v)) in t.iter().zip(v).enumerate() {
            c.push(t, v, i as u64 + 10);
        }
        c
    }

    #[test]
    fn exact_duplicates_are_dropped_and_counted() {
        let mut c = ch(&[0, 1, 1, 2, 2, 3], &[0.0, 1.0, 1.0, 2.0, 2.0, 3.0]);
        assert_eq!(
            c.order_and_dedup(Path::new("f"), TimeRepair::Error, BadSamples::Error)
                .unwrap(),
            (2, vec![])
        );
        assert_eq!(c.t_ns, [0, 1, 2, 3]);
        assert_eq!(c.rows, [10, 11, 13, 15]);
    }

    #[test]
    fn conflicting_duplicate_and_backwards_time_name_the_row() {
        let mut c = ch(&[0, 1, 1], &[0.0, 1.0, 1.5]);
        match c.order_and_dedup(Path::new("f"), TimeRepair::Error, BadSamples::Error) {
            Err(IngestError::DuplicateTimestamp { row, .. }) => assert_eq!(row, 12),
            other => panic!("{other:?}"),
        }
        let mut c = ch(&[0, 5, 3], &[0.0, 1.0, 2.0]);
        match c.order_and_dedup(Path::new("f"), TimeRepair::Error, BadSamples::Mask) {
            Err(IngestError::NonMonotonicTime {
                row,
                time_ns,
                previous_ns,
                ..
            }) => {
                assert_eq!((row, time_ns, previous_ns), (12, 3, 5))
            }
            other => panic!("{other:?}"),
        }
        let mut c = ch(&[0, 5, 3], &[0.0, 1.0, 2.0]);
        c.order_and_dedup(Path::new("f"), TimeRepair::Sort, BadSamples::Error)
            .unwrap();
        assert_eq!(c.t_ns, [0, 3, 5]);
        assert_eq!(c.values, [0.0, 2.0, 1.0]);
    }

    #[test]
    fn a_conflicting_duplicate_keeps_the_later_sample_when_masking() {
        let mut c = ch(&[0, 1, 1, 2], &[0.0, 1.0, 1.5, 2.0]);
        let n = c
            .order_and_dedup(Path::new("f"), TimeRepair::Error, BadSamples::Mask)
            .unwrap();
        assert_eq!(n, (0, vec![1]));
        assert_eq!(c.t_ns, [0, 1, 2]);
        assert_eq!(c.values, [0.0, 1.5, 2.0]);
        assert_eq!(c.rows, [10, 12, 13]);
    }

    #[test]
    fn infinities_ranges_and_speed_spikes_are_bad_samples() {
        let t: Vec<i64> = (0..8).map(|k| k * 100_000_000).collect(); // 10 Hz
        let v = [15.0, 15.1, f64::INFINITY, 15.2, 250.0, 15.3, f64::NAN, 15.4];
        let bad = bad_samples("vehicle_speed", &t, &v, -2.0, 70.0);
        assert_eq!(bad, [false, false, true, false, true, false, false, false]);
        // a one-sample spike of 6 m/s in 0.1 s (60 m/s²) is bad; a braking step of 1 m/s per
        // sample (10 m/s² plus the margin) is not
        let v = [15.0, 15.0, 21.0, 15.0, 14.0, 13.0, 12.0, 11.0];
        let bad = bad_samples("vehicle_speed", &t, &v, -2.0, 70.0);
        assert_eq!(bad.iter().filter(|b| **b).count(), 1);
        assert!(bad[2]);
        // other columns: range and finiteness only
        let s = [0.01, 0.5, 0.01, f64::NEG_INFINITY];
        assert_eq!(
            bad_samples("road_slope", &t[..4], &s, -0.3, 0.3),
            [false, true, false, true]
        );
    }
}
