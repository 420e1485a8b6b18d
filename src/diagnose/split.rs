//! The train / held-out split of a recording in step 3 of the diagnosis, explain
//! (docs/diagnosis/method.md): alternating blocks of whole longitudinal windows ([`Split`]), and
//! which part a row is in ([`Part`]). Times in s from the first row.
//!
//! # Train / held-out split: alternating blocks in time
//! The drive is cut into contiguous blocks of whole longitudinal windows (block length
//! [`Split::block_s`], a multiple of the 20 s re-initialisation window), and the blocks alternate
//! train, held-out, train, …. Why this and not "the last 30 %": both parts must see similar
//! conditions, and a drive's end is often a different road (a city approach after a highway, a
//! final stop), whereas alternating blocks give both parts samples from every stretch of the
//! drive — climbs and descents, speeds, gears, stops. Why blocks and not samples: residuals are
//! autocorrelated over seconds (the longitudinal model drifts within a window, the axle model's
//! pressures follow the driving), so a random-sample split would score the fit on samples it
//! has effectively seen. Block boundaries fall on window boundaries, so a longitudinal window
//! (one independent simulation from the measured state) lies wholly in one part. Blocks are one
//! window long for drives shorter than 16 windows (5 min 20 s) and grow with the drive to keep
//! about [`TARGET_BLOCKS`] (8) of them, up to [`MAX_BLOCK_WINDOWS`] windows (5 min) each: a
//! 9-minute drive gets 60 s blocks, a one-hour drive 12 blocks of 5 min. Long blocks also keep
//! a road stretch's own bias (the slope sensor's quantisation error over a long grade) from
//! appearing in both parts; the fit's interval accounts for it through the between-block
//! sample count ([`super::fit`]).

use serde::Serialize;

/// Longest block of the split, in longitudinal windows (15 × 20 s = 5 min).
pub const MAX_BLOCK_WINDOWS: usize = 15;
/// Blocks the split aims at (half train, half held-out).
pub const TARGET_BLOCKS: usize = 8;

/// The time split of a recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Split {
    /// Method, in words.
    pub method: String,
    /// Block length, s.
    pub block_s: f64,
    /// Number of blocks (train and held-out together).
    pub blocks: usize,
    /// Duration in the train part, s.
    pub train_s: f64,
    /// Duration in the held-out part, s.
    pub heldout_s: f64,
    /// Per row: in the held-out part.
    #[serde(skip)]
    pub heldout: Vec<bool>,
    /// Per row: block index (0 first; even blocks train, odd held-out).
    #[serde(skip)]
    pub block: Vec<usize>,
}

impl Split {
    /// Alternating blocks of `block_windows` windows of `window_s` over the times `t_s` (s from
    /// the first row); `None` chooses the block length as the module documentation says.
    pub fn alternating(t_s: &[f64], window_s: f64, block_windows: Option<usize>) -> Split {
        let dur = t_s.last().copied().unwrap_or(0.0);
        let n_windows = (dur / window_s).ceil().max(1.0) as usize;
        let k = block_windows
            .unwrap_or((n_windows / TARGET_BLOCKS).clamp(1, MAX_BLOCK_WINDOWS))
            .max(1);
        let block_s = k as f64 * window_s;
        let block: Vec<usize> = t_s
            .iter()
            .map(|&t| (t / block_s).floor().max(0.0) as usize)
            .collect();
        let heldout: Vec<bool> = block.iter().map(|b| b % 2 == 1).collect();
        let dt = if t_s.len() > 1 {
            dur / (t_s.len() - 1) as f64
        } else {
            0.0
        };
        let n_held = heldout.iter().filter(|h| **h).count();
        Split {
            method: format!(
                "alternating blocks of {k} × {window_s} s windows (train, held-out, train, …)"
            ),
            block_s,
            blocks: (dur / block_s).ceil().max(1.0) as usize,
            train_s: (t_s.len() - n_held) as f64 * dt,
            heldout_s: n_held as f64 * dt,
            heldout,
            block,
        }
    }
}

/// Which part of the split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// Training blocks.
    Train,
    /// Held-out blocks.
    Heldout,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_alternates_whole_windows() {
        let t: Vec<f64> = (0..10_000).map(|i| i as f64 * 0.02).collect(); // 200 s
        let s = Split::alternating(&t, 20.0, None);
        assert_eq!(s.block_s, 20.0);
        assert_eq!(s.blocks, 10);
        assert!(!s.heldout[0] && s.heldout[1000] && !s.heldout[2000]);
        assert!((s.train_s - 100.0).abs() < 0.1 && (s.heldout_s - 100.0).abs() < 0.1);
        // an hour: 12 blocks of 5 min
        let t: Vec<f64> = (0..180_000).map(|i| i as f64 * 0.02).collect();
        let s = Split::alternating(&t, 20.0, None);
        assert_eq!((s.block_s, s.blocks), (300.0, 12));
    }
}
