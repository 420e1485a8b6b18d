//! The covariance of a sequence of road-segment means whose slope was read by a quantising
//! sensor ([`super::resistance_stretch`]): white noise of variance `σ₀²` plus one unknown
//! slope-quantisation error per run of consecutive segments that share their most frequent
//! slope reading,
//!
//! ```text
//! V_ij = σ₀² δ_ij + q² s_i s_j   (i, j in one run; 0 across runs),   q² = (m g q)²/12   (N²)
//! ```
//!
//! with `q` the sensor's resolution (tan α per step; the error of a reading is uniform over one
//! step) and `s_i` the share of segment `i`'s rows at the run's reading. `V` is block diagonal,
//! each block `V_B = σ₀² I + q² s sᵀ` a scaled identity plus a rank-one term, so its inverse
//! square root and the quadratic form of its inverse on any range of segments have closed forms
//! ([`RunCovariance`]): linear time and memory in the number of segments, where the dense
//! matrix would take cubic time and quadratic memory (about 3 000 segments on a 10-hour drive).

use std::ops::Range;

/// Fewest pairs of consecutive segments within one run for the white variance
/// ([`white_variance`]).
pub const MIN_RUN_PAIRS: usize = 6;

/// `σ₀²` for the segment means `y` (N) in the runs `run` (a run index per segment), N²: half
/// the squared robust spread (1.4826 × median absolute value) of the differences between
/// consecutive segments of one run, where the quantisation error cancels; with fewer than
/// [`MIN_RUN_PAIRS`] such pairs, the robust spread of the segment means about their median; 1
/// when that is zero.
pub fn white_variance(y: &[f64], run: &[usize]) -> f64 {
    // the upper middle value for an even count (the threshold of the scan was calibrated so)
    let median = |mut x: Vec<f64>| -> f64 {
        x.sort_by(f64::total_cmp);
        if x.is_empty() {
            0.0
        } else {
            x[x.len() / 2]
        }
    };
    let diffs: Vec<f64> = (1..y.len())
        .filter(|&i| run[i] == run[i - 1])
        .map(|i| (y[i] - y[i - 1]).abs())
        .collect();
    let white = if diffs.len() >= MIN_RUN_PAIRS {
        (1.4826 * median(diffs)).powi(2) / 2.0
    } else {
        let m = median(y.to_vec());
        (1.4826 * median(y.iter().map(|v| (v - m).abs()).collect())).powi(2)
    };
    if white > 0.0 {
        white
    } else {
        1.0
    }
}

/// The covariance `V` of the module documentation by its block structure.
#[derive(Debug, Clone)]
pub struct RunCovariance {
    /// `σ₀²`, N².
    white: f64,
    /// Per segment its block.
    block_of: Vec<usize>,
    /// Per block its segments.
    blocks: Vec<Range<usize>>,
    /// Per block `γ = 1 − 1/√(1 + q² sᵀs / σ₀²)` of `V_B^{-1/2} = (I − γ s sᵀ/sᵀs)/σ₀`.
    gamma: Vec<f64>,
    /// Per block `κ = q² / (σ₀² + q² sᵀs)` of `V_B⁻¹ = (I − κ s sᵀ)/σ₀²` (Sherman–Morrison).
    kappa: Vec<f64>,
    /// Per block `sᵀs`.
    ss: Vec<f64>,
    /// Reading shares.
    share: Vec<f64>,
    /// Prefix sums of the shares (`n + 1`).
    share_sum: Vec<f64>,
    /// Prefix sums over the blocks of `κ (Σ_B s)²` (`blocks + 1`).
    whole_blocks: Vec<f64>,
}

impl RunCovariance {
    /// The covariance of segments with run indices `run` (consecutive segments of one run share
    /// an index, each new run the next one) and reading shares `share`, white variance `white`
    /// (N²) and slope-step force `quantisation_n = m g q` (N).
    pub fn new(run: &[usize], share: &[f64], white: f64, quantisation_n: f64) -> Self {
        let q2 = quantisation_n * quantisation_n / 12.0;
        let mut share_sum = vec![0.0; share.len() + 1];
        for (k, s) in share.iter().enumerate() {
            share_sum[k + 1] = share_sum[k] + s;
        }
        let mut blocks: Vec<Range<usize>> = Vec::new();
        let mut block_of = Vec::with_capacity(run.len());
        for (k, &r) in run.iter().enumerate() {
            match blocks.last_mut() {
                Some(b) if r == run[b.start] => b.end = k + 1,
                _ => blocks.push(k..k + 1),
            }
            block_of.push(blocks.len() - 1);
        }
        let (mut gamma, mut kappa, mut ss) = (vec![], vec![], vec![]);
        let mut whole_blocks = vec![0.0];
        for b in &blocks {
            let s2: f64 = share[b.clone()].iter().map(|x| x * x).sum();
            let k = q2 / (white + q2 * s2);
            gamma.push(1.0 - 1.0 / (1.0 + q2 * s2 / white).sqrt());
            kappa.push(k);
            ss.push(s2);
            let total = share_sum[b.end] - share_sum[b.start];
            let last = whole_blocks[whole_blocks.len() - 1];
            whole_blocks.push(last + k * total * total);
        }
        Self {
            white,
            block_of,
            blocks,
            gamma,
            kappa,
            ss,
            share: share.to_vec(),
            share_sum,
            whole_blocks,
        }
    }

    /// `σ₀²`, N².
    pub fn white(&self) -> f64 {
        self.white
    }

    /// `V^{-1/2} u`, the symmetric whitening (`u` in N, the result in 1).
    pub fn whiten(&self, u: &[f64]) -> Vec<f64> {
        let sd = self.white.sqrt();
        let mut out = vec![0.0; u.len()];
        for (b, r) in self.blocks.iter().enumerate() {
            let d: f64 = r.clone().map(|k| self.share[k] * u[k]).sum();
            let c = if self.ss[b] > 0.0 {
                self.gamma[b] * d / self.ss[b]
            } else {
                0.0
            };
            for k in r.clone() {
                out[k] = (u[k] - c * self.share[k]) / sd;
            }
        }
        out
    }

    /// `1ᵀ V⁻¹ 1` over the segments `[i, j)` (`i < j`), 1/N².
    pub fn inverse_form(&self, i: usize, j: usize) -> f64 {
        let (bi, bj) = (self.block_of[i], self.block_of[j - 1]);
        let ps = &self.share_sum;
        let part = if bi == bj {
            self.kappa[bi] * (ps[j] - ps[i]).powi(2)
        } else {
            self.kappa[bi] * (ps[self.blocks[bi].end] - ps[i]).powi(2)
                + (self.whole_blocks[bj] - self.whole_blocks[bi + 1])
                + self.kappa[bj] * (ps[j] - ps[self.blocks[bj].start]).powi(2)
        };
        ((j - i) as f64 - part) / self.white
    }
}
