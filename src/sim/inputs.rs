//! Simulation inputs as functions of time: piecewise-linear signals with known breakpoints, so
//! integrators restart at every discontinuity instead of stepping across it.

/// A piecewise-linear signal: contiguous pieces `(t0, t1, v0, v1)` covering `[0, T]`.
///
/// On `[t0, t1)` the value is `v0 + (v1 − v0)·((t − t0)/(t1 − t0))` (the last piece also at its
/// end); a constant piece returns `v0` exactly. Times in s.
#[derive(Debug, Clone, PartialEq)]
pub struct Piecewise {
    pieces: Vec<(f64, f64, f64, f64)>,
}

/// A piecewise signal that is not contiguous, not increasing or not finite.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("piecewise input: {0}")]
pub struct PiecewiseError(pub String);

impl Piecewise {
    /// Builds a signal from pieces.
    ///
    /// # Errors
    /// [`PiecewiseError`] for an empty list, gaps, non-increasing pieces or non-finite values.
    pub fn new(pieces: Vec<(f64, f64, f64, f64)>) -> Result<Self, PiecewiseError> {
        if pieces.is_empty() {
            return Err(PiecewiseError("no pieces".into()));
        }
        for (k, p) in pieces.iter().enumerate() {
            if ![p.0, p.1, p.2, p.3].iter().all(|x| x.is_finite()) || p.1 <= p.0 {
                return Err(PiecewiseError(format!(
                    "piece {k} {p:?} is not finite and increasing"
                )));
            }
            if k > 0 && pieces[k - 1].1 != p.0 {
                return Err(PiecewiseError(format!(
                    "piece {k} does not start where piece {} ends",
                    k - 1
                )));
            }
        }
        Ok(Self { pieces })
    }

    /// A constant over `[0, t_end]`.
    pub fn constant(t_end: f64, v: f64) -> Self {
        Self {
            pieces: vec![(0.0, t_end, v, v)],
        }
    }

    /// The piece active at `t` (index; binary search, so long recorded drives stay cheap).
    pub fn piece_index(&self, t: f64) -> usize {
        // pieces are contiguous and increasing: the last piece starting at or before t
        self.pieces
            .partition_point(|p| p.0 <= t)
            .saturating_sub(1)
            .min(self.pieces.len() - 1)
    }

    /// Value of piece `k` at `t` (also outside the piece: linear continuation).
    #[inline]
    pub fn eval_piece(&self, k: usize, t: f64) -> f64 {
        let (t0, t1, v0, v1) = self.pieces[k];
        v0 + (v1 - v0) * ((t - t0) / (t1 - t0))
    }

    /// Value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        self.eval_piece(self.piece_index(t), t)
    }

    /// Interior breakpoints (piece starts after the first).
    pub fn breakpoints(&self) -> impl Iterator<Item = f64> + '_ {
        self.pieces.iter().skip(1).map(|p| p.0)
    }

    /// The pieces.
    pub fn pieces(&self) -> &[(f64, f64, f64, f64)] {
        &self.pieces
    }
}

impl Piecewise {
    /// The signal sampled at `fs_hz` over `[0, t_end]` and rebuilt from the samples: linear
    /// between samples (`hold = false`) or held (`hold = true`) — what a recording of this input
    /// at `fs_hz` would give.
    pub fn resampled(&self, t_end: f64, fs_hz: f64, hold: bool) -> Self {
        let n = (t_end * fs_hz).round().max(1.0) as usize;
        let t: Vec<f64> = (0..=n).map(|k| (k as f64 / fs_hz).min(t_end)).collect();
        let v: Vec<f64> = t.iter().map(|&x| self.eval(x)).collect();
        let pieces = t
            .windows(2)
            .zip(v.windows(2))
            .filter(|(tw, _)| tw[1] > tw[0])
            .map(|(tw, vw)| (tw[0], tw[1], vw[0], if hold { vw[0] } else { vw[1] }))
            .collect();
        Self { pieces }
    }
}
