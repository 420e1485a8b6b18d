//! Simulation inputs as functions of time: piecewise-linear signals with known breakpoints, so
//! integrators restart at every discontinuity instead of stepping across it.

use std::sync::Arc;

/// Pieces [`Piecewise::piece_index_from`] scans on from its cursor before it searches the
/// rest: a step of a simulation moves on by one piece or none.
pub const CURSOR_SCAN: usize = 8;

/// A piecewise-linear signal: contiguous pieces `(t0, t1, v0, v1)` covering `[0, T]`.
///
/// On `[t0, t1)` the value is `v0 + (v1 − v0)·((t − t0)/(t1 − t0))` (the last piece also at its
/// end); a constant piece returns `v0` exactly. Times in s.
///
/// **Storage.** The pieces are kept as their boundaries (`knots`, shared through an [`Arc`] so
/// that inputs sampled on one time axis — a recorded drive's five — hold it once) and their
/// values in the cheapest exact form: the value at every knot for a continuous signal, one
/// value per piece for a held one, both ends per piece otherwise. Every piece reads back as the
/// tuple it was built from, bit for bit, so evaluation is the same arithmetic on the same
/// numbers whatever the storage (a 10-hour recorded drive: 8 B per row and input instead of
/// 32 B; docs/validation/benchmarks.md).
#[derive(Debug, Clone)]
pub struct Piecewise {
    /// Piece boundaries, increasing: piece `k` covers `[knots[k], knots[k + 1])`.
    knots: Arc<[f64]>,
    values: Values,
}

/// One linear piece from `(t0, v0)` to `(t1, v1)` ([`Piecewise::frozen_piece`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    t0: f64,
    t1: f64,
    v0: f64,
    v1: f64,
}

impl Piece {
    /// Value at `t` (also outside the piece: linear continuation).
    #[inline]
    pub fn eval(&self, t: f64) -> f64 {
        self.v0 + (self.v1 - self.v0) * ((t - self.t0) / (self.t1 - self.t0))
    }
}

/// The values of a [`Piecewise`]'s pieces.
#[derive(Debug, Clone)]
enum Values {
    /// The value at every knot: piece `k` runs from `v[k]` to `v[k + 1]`.
    Continuous(Vec<f64>),
    /// One value per piece, held over it.
    Held(Vec<f64>),
    /// `(v0, v1)` of every piece.
    Ends(Vec<(f64, f64)>),
}

impl PartialEq for Piecewise {
    /// Equal pieces, whatever the storage.
    fn eq(&self, other: &Self) -> bool {
        self.piece_count() == other.piece_count()
            && self.pieces().zip(other.pieces()).all(|(a, b)| a == b)
    }
}

/// A piecewise signal that is not contiguous, not increasing or not finite.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("piecewise input: {0}")]
pub struct PiecewiseError(pub String);

/// How a [`Piecewise`] goes from one sample to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Between {
    /// Linear from each sample to the next.
    Linear,
    /// Each sample held until the next.
    Held,
}

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
        Ok(Self::from_contiguous(&pieces))
    }

    /// Pieces already known to be contiguous and increasing.
    fn from_contiguous(pieces: &[(f64, f64, f64, f64)]) -> Self {
        let knots = pieces
            .iter()
            .map(|p| p.0)
            .chain(pieces.last().map(|p| p.1))
            .collect();
        Self {
            knots,
            values: Values::Ends(pieces.iter().map(|p| (p.2, p.3)).collect()),
        }
    }

    /// The signal through samples `(t[k], v[k])`, linear between them or held, as `between`
    /// says. Consecutive constant pieces of the same value (bit for bit) are stored as one: a
    /// closed clutch, a released brake or a gear held for minutes costs one piece per stretch.
    /// Every evaluation gives the bits of the one-piece-per-sample signal
    /// (`v0 + (v1 − v0)·w = v` for `v0 = v1 = v`); only piece boundaries inside such a stretch
    /// disappear. Without such a stretch the signal keeps `t` itself (shared, not copied).
    ///
    /// # Errors
    /// [`PiecewiseError`] for fewer than 2 samples, lengths that differ, times that are not
    /// finite and strictly increasing, or values that are not finite.
    pub fn through_samples(
        t: &Arc<[f64]>,
        v: &[f64],
        between: Between,
    ) -> Result<Self, PiecewiseError> {
        if t.len() < 2 || v.len() != t.len() {
            return Err(PiecewiseError(format!(
                "{} times and {} values; need at least 2 of each, as many values as times",
                t.len(),
                v.len()
            )));
        }
        let follows = |k: usize| t[k] > t[k - 1] && t[k].is_finite();
        if let Some(k) = (1..t.len())
            .find(|&k| !follows(k))
            .or((!t[0].is_finite()).then_some(0))
        {
            return Err(PiecewiseError(format!(
                "time {} at sample {k} is not finite or does not follow the one before",
                t[k]
            )));
        }
        if let Some(k) = v.iter().position(|x| !x.is_finite()) {
            return Err(PiecewiseError(format!("value {} at sample {k}", v[k])));
        }
        let count = merged_pieces(t, v, between).count();
        let knots: Arc<[f64]> = if count == t.len() - 1 {
            Arc::clone(t)
        } else {
            merged_pieces(t, v, between)
                .map(|p| p.0)
                .chain(std::iter::once(t[t.len() - 1]))
                .collect()
        };
        let values = match between {
            // continuous: each piece starts at the value the one before ends at (merged pieces
            // included: a merged stretch ends at its own value, which the next piece starts at)
            Between::Linear => Values::Continuous({
                let mut w = Vec::with_capacity(count + 1);
                w.extend(merged_pieces(t, v, between).map(|p| p.2));
                w.push(v[v.len() - 1]);
                w
            }),
            Between::Held => Values::Held({
                let mut w = Vec::with_capacity(count);
                w.extend(merged_pieces(t, v, between).map(|p| p.2));
                w
            }),
        };
        Ok(Self { knots, values })
    }

    /// A constant over `[0, t_end]`.
    pub fn constant(t_end: f64, v: f64) -> Self {
        Self {
            knots: Arc::from([0.0, t_end]),
            values: Values::Held(vec![v]),
        }
    }

    /// Number of pieces.
    #[inline]
    pub fn piece_count(&self) -> usize {
        self.knots.len() - 1
    }

    /// Start time of piece `k`, s.
    #[inline]
    pub fn piece_start(&self, k: usize) -> f64 {
        self.knots[k]
    }

    // `piece`, `frozen_piece`, `eval_piece`, `piece_index_from` and `eval_from` run at every
    // integration step and are always inlined: left to the compiler's heuristics, whether they
    // were inlined into the windowed simulation's parallel path changed with unrelated code
    // elsewhere in the crate, and with it a 10-hour drive's diagnosis on 2 threads by a third
    // (59 against 44 s, identical outputs).

    /// Piece `k` as `(t0, t1, v0, v1)`.
    #[inline(always)]
    pub fn piece(&self, k: usize) -> (f64, f64, f64, f64) {
        let (v0, v1) = match &self.values {
            Values::Continuous(v) => (v[k], v[k + 1]),
            Values::Held(v) => (v[k], v[k]),
            Values::Ends(v) => v[k],
        };
        (self.knots[k], self.knots[k + 1], v0, v1)
    }

    /// The piece active at `t` (index; binary search, so long recorded drives stay cheap).
    pub fn piece_index(&self, t: f64) -> usize {
        // pieces are contiguous and increasing: the last piece starting at or before t
        let n = self.piece_count();
        self.knots[..n]
            .partition_point(|&t0| t0 <= t)
            .saturating_sub(1)
            .min(n - 1)
    }

    /// Value of piece `k` at `t` (also outside the piece: linear continuation).
    #[inline(always)]
    pub fn eval_piece(&self, k: usize, t: f64) -> f64 {
        self.frozen_piece(k).eval(t)
    }

    /// Piece `k` copied out, for a caller that evaluates it many times (an integrator inside
    /// one input interval): [`Piece::eval`] is [`Piecewise::eval_piece`], bit for bit, without
    /// reading the storage again.
    #[inline(always)]
    pub fn frozen_piece(&self, k: usize) -> Piece {
        let (t0, t1, v0, v1) = self.piece(k);
        Piece { t0, t1, v0, v1 }
    }

    /// Value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        self.eval_piece(self.piece_index(t), t)
    }

    /// [`Piecewise::piece_index`] for times that mostly move forward: `cursor` holds the last
    /// answer and the search scans on from it for up to [`CURSOR_SCAN`] pieces (amortised
    /// constant time over a simulation that steps through the input), then binary-searches
    /// the pieces after it (a simulation that starts part-way into a long input, with a fresh
    /// cursor, costs a logarithm, not a scan of every piece before its start); it falls back
    /// to the binary search over all pieces when `t` lies before the cursor's piece. The same
    /// index as `piece_index(t)` for every `t`: knots increase, so the last knot at or before
    /// `t` found from the cursor is the global one.
    #[inline(always)]
    pub fn piece_index_from(&self, cursor: &std::cell::Cell<usize>, t: f64) -> usize {
        let n = self.piece_count();
        let mut k = cursor.get().min(n - 1);
        if self.knots[k] <= t {
            let mut scanned = 0;
            while k + 1 < n && self.knots[k + 1] <= t {
                k += 1;
                scanned += 1;
                if scanned == CURSOR_SCAN {
                    k += self.knots[k + 1..n].partition_point(|&t0| t0 <= t);
                    break;
                }
            }
        } else {
            k = self.piece_index(t);
        }
        cursor.set(k);
        k
    }

    /// [`Piecewise::eval`] with a [`Piecewise::piece_index_from`] cursor: the same value, bit
    /// for bit.
    #[inline(always)]
    pub fn eval_from(&self, cursor: &std::cell::Cell<usize>, t: f64) -> f64 {
        self.eval_piece(self.piece_index_from(cursor, t), t)
    }

    /// Interior breakpoints (piece starts after the first).
    pub fn breakpoints(&self) -> impl Iterator<Item = f64> + '_ {
        self.knots[1..self.piece_count()].iter().copied()
    }

    /// The pieces, as `(t0, t1, v0, v1)`.
    pub fn pieces(&self) -> impl ExactSizeIterator<Item = (f64, f64, f64, f64)> + '_ {
        (0..self.piece_count()).map(|k| self.piece(k))
    }
}

/// The pieces through samples, one per sample interval, runs of equal constant pieces merged
/// (see [`Piecewise::through_samples`]).
fn merged_pieces<'a>(
    t: &'a [f64],
    v: &'a [f64],
    between: Between,
) -> impl Iterator<Item = (f64, f64, f64, f64)> + 'a {
    let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
    let mut k = 0;
    std::iter::from_fn(move || {
        if k + 1 >= t.len() {
            return None;
        }
        let piece = |k: usize| match between {
            Between::Linear => (t[k], t[k + 1], v[k], v[k + 1]),
            Between::Held => (t[k], t[k + 1], v[k], v[k]),
        };
        let mut p = piece(k);
        k += 1;
        while k + 1 < t.len() && same(p.2, p.3) {
            let q = piece(k);
            if !(same(p.3, q.2) && same(q.2, q.3)) {
                break;
            }
            p.1 = q.1;
            k += 1;
        }
        Some(p)
    })
}

impl Piecewise {
    /// The signal sampled at `fs_hz` over `[0, t_end]` and rebuilt from the samples: linear
    /// between samples (`hold = false`) or held (`hold = true`) — what a recording of this input
    /// at `fs_hz` would give.
    pub fn resampled(&self, t_end: f64, fs_hz: f64, hold: bool) -> Self {
        let n = (t_end * fs_hz).round().max(1.0) as usize;
        let t: Vec<f64> = (0..=n).map(|k| (k as f64 / fs_hz).min(t_end)).collect();
        let v: Vec<f64> = t.iter().map(|&x| self.eval(x)).collect();
        let pieces: Vec<_> = t
            .windows(2)
            .zip(v.windows(2))
            .filter(|(tw, _)| tw[1] > tw[0])
            .map(|(tw, vw)| (tw[0], tw[1], vw[0], if hold { vw[0] } else { vw[1] }))
            .collect();
        Self::from_contiguous(&pieces)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pieces as the one-tuple-per-piece storage held them before: one per sample
    /// interval, runs of equal constant pieces merged (written out here independently of
    /// `merged_pieces`).
    fn reference_pieces(t: &[f64], v: &[f64], between: Between) -> Vec<(f64, f64, f64, f64)> {
        let mut p: Vec<(f64, f64, f64, f64)> = Vec::new();
        for k in 0..t.len() - 1 {
            let (v0, v1) = match between {
                Between::Linear => (v[k], v[k + 1]),
                Between::Held => (v[k], v[k]),
            };
            if let Some(last) = p.last_mut() {
                let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
                if same(last.2, last.3) && same(last.3, v0) && same(v0, v1) {
                    last.1 = t[k + 1];
                    continue;
                }
            }
            p.push((t[k], t[k + 1], v0, v1));
        }
        p
    }

    /// Evaluation over a tuple slice, as the tuple storage did it.
    fn reference_eval(p: &[(f64, f64, f64, f64)], t: f64) -> f64 {
        let k = p
            .partition_point(|q| q.0 <= t)
            .saturating_sub(1)
            .min(p.len() - 1);
        let (t0, t1, v0, v1) = p[k];
        v0 + (v1 - v0) * ((t - t0) / (t1 - t0))
    }

    fn bits(p: (f64, f64, f64, f64)) -> [u64; 4] {
        [p.0.to_bits(), p.1.to_bits(), p.2.to_bits(), p.3.to_bits()]
    }

    /// Uneven sample times and values with runs of equal samples (also ±0.0 and a run at the
    /// start and at the end) between changing ones.
    fn samples() -> (Arc<[f64]>, Vec<f64>) {
        let v = vec![
            2.0, 2.0, 2.0, 0.5, -1.25, -1.25, 0.0, -0.0, -0.0, 7.0, 7.0, 7.0, 7.0, 3.1, 0.1, 0.2,
            0.2, 0.2,
        ];
        let t: Arc<[f64]> = (0..v.len())
            .map(|k| 0.3 + k as f64 * 0.021 + 0.0037 * ((k * 7) % 5) as f64)
            .collect();
        (t, v)
    }

    #[test]
    fn every_storage_reads_back_and_evaluates_bit_for_bit_as_the_tuples() {
        let (t, v) = samples();
        for between in [Between::Linear, Between::Held] {
            let reference = reference_pieces(&t, &v, between);
            let stored = Piecewise::through_samples(&t, &v, between).unwrap();
            let from_tuples = Piecewise::new(reference.clone()).unwrap();
            assert!(reference.len() < t.len() - 1, "runs were merged");
            for s in [&stored, &from_tuples] {
                assert_eq!(s.piece_count(), reference.len());
                for (k, (a, b)) in s.pieces().zip(&reference).enumerate() {
                    assert_eq!(bits(a), bits(*b), "{between:?} piece {k}");
                    assert_eq!(s.piece_start(k).to_bits(), b.0.to_bits());
                }
                let b: Vec<f64> = s.breakpoints().collect();
                let r: Vec<f64> = reference[1..].iter().map(|p| p.0).collect();
                assert_eq!(b, r);
                // at every sample time, between them and beyond both ends
                let mut times: Vec<f64> = t.to_vec();
                times.extend((0..=3000).map(|k| 0.2 + 0.6 * k as f64 / 3000.0));
                for x in times {
                    let i = s.piece_index(x);
                    assert_eq!(
                        s.eval(x).to_bits(),
                        reference_eval(&reference, x).to_bits(),
                        "{between:?} t = {x}"
                    );
                    assert_eq!(s.eval_piece(i, x).to_bits(), s.eval(x).to_bits());
                }
            }
            assert_eq!(stored, from_tuples, "equal pieces are equal signals");
        }
    }

    #[test]
    fn samples_without_equal_runs_keep_the_time_axis_shared() {
        let (t, v) = samples();
        let changing: Vec<f64> = v.iter().enumerate().map(|(k, x)| x + k as f64).collect();
        let a = Piecewise::through_samples(&t, &changing, Between::Linear).unwrap();
        let b = Piecewise::through_samples(&t, &changing, Between::Held).unwrap();
        assert!(Arc::ptr_eq(&a.knots, &t) && Arc::ptr_eq(&b.knots, &t));
        assert_eq!(a.piece_count(), t.len() - 1);
        // merged runs: own, fewer knots
        let c = Piecewise::through_samples(&t, &v, Between::Held).unwrap();
        assert!(!Arc::ptr_eq(&c.knots, &t) && c.piece_count() < t.len() - 1);
    }

    #[test]
    fn bad_samples_are_errors() {
        let t: Arc<[f64]> = Arc::from([0.0, 1.0, 2.0]);
        let ok = [1.0, 2.0, 3.0];
        let err = |t: &Arc<[f64]>, v: &[f64]| Piecewise::through_samples(t, v, Between::Linear);
        assert!(err(&t, &ok).is_ok());
        assert!(err(&t, &[1.0, f64::NAN, 3.0]).is_err(), "NaN value");
        assert!(err(&t, &ok[..2]).is_err(), "fewer values than times");
        assert!(err(&Arc::from([0.0]), &[1.0]).is_err(), "one sample");
        assert!(
            err(&Arc::from([0.0, 1.0, 1.0]), &ok).is_err(),
            "repeated time"
        );
        assert!(
            err(&Arc::from([0.0, 2.0, 1.0]), &ok).is_err(),
            "time going back"
        );
        assert!(
            err(&Arc::from([f64::NEG_INFINITY, 1.0, 2.0]), &ok).is_err(),
            "infinite time"
        );
    }

    #[test]
    fn a_constant_is_one_held_piece() {
        let c = Piecewise::constant(5.0, -3.5);
        assert_eq!(c.piece_count(), 1);
        assert_eq!(bits(c.piece(0)), bits((0.0, 5.0, -3.5, -3.5)));
        assert_eq!(c.eval(7.0), -3.5);
        assert_eq!(c.breakpoints().count(), 0);
    }

    /// The cursor search gives the binary search's piece for every time — forwards in
    /// steps, repeated, backwards, before the start, past the end, on knots and NaN — and the
    /// cursor-based value has the same bits.
    #[test]
    fn cursor_search_equals_the_binary_search() {
        let t: Arc<[f64]> = (0..50).map(|k| k as f64 * 0.1).collect();
        let v: Vec<f64> = (0..50).map(|k| ((k * 7) % 5) as f64).collect();
        let p = Piecewise::through_samples(&t, &v, Between::Linear).unwrap();
        let cursor = std::cell::Cell::new(0);
        let mut times: Vec<f64> = (0..700).map(|k| -0.3 + k as f64 * 0.0077).collect();
        times.extend([
            2.0,
            2.0,
            0.1,
            0.05,
            4.9,
            10.0,
            -1.0,
            f64::NAN,
            3.3,
            0.0,
            4.8,
        ]);
        for &x in &times {
            let k = p.piece_index_from(&cursor, x);
            assert_eq!(k, p.piece_index(x), "t = {x}");
            let c = std::cell::Cell::new(cursor.get());
            assert_eq!(p.eval_from(&c, x).to_bits(), p.eval(x).to_bits(), "t = {x}");
        }
    }

    #[test]
    fn a_fresh_cursor_finds_a_piece_far_into_a_long_input_as_the_binary_search_does() {
        // ten hours at 50 Hz: a simulation window that starts part-way in starts its cursor at
        // the first piece; every jump, short or long, lands on the binary search's piece
        let n = 1_800_001;
        let t: Arc<[f64]> = (0..n).map(|k| k as f64 * 0.02).collect();
        let v: Vec<f64> = (0..n).map(|k| (k % 17) as f64).collect();
        let p = Piecewise::through_samples(&t, &v, Between::Held).unwrap();
        for start in [0.0, 0.013, 0.17, 35_999.99, 36_000.0, 17_333.337, 40_000.0] {
            let cursor = std::cell::Cell::new(0);
            for dt in [0.0, 0.005, 0.02, 0.1, 7.0] {
                let x = start + dt;
                assert_eq!(p.piece_index_from(&cursor, x), p.piece_index(x), "t = {x}");
            }
        }
    }
}
