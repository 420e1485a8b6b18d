//! Where the fast driveline integrator ([`super::fast::FastDriveline`]) reads its inputs: a
//! forward cursor per input, and the values of the inputs that stay constant over a piece
//! (gear, clutch capacity, service brake), read once per piece.

/// Search cursors of the scenario's inputs for one simulation: the steps move forward in
/// time, so each lookup scans on from the last ([`super::inputs::Piecewise::piece_index_from`],
/// the same pieces as a binary search; a span that starts part-way into a long input finds its
/// first piece by the binary search).
#[derive(Default)]
pub(super) struct Cursors {
    pub(super) engine: std::cell::Cell<usize>,
    pub(super) gear: std::cell::Cell<usize>,
    pub(super) slope: std::cell::Cell<usize>,
    pub(super) brake: std::cell::Cell<usize>,
    pub(super) clutch: std::cell::Cell<usize>,
    /// The gear, the clutch capacity and the brake force over the constant piece last read.
    pub(super) held_gear: std::cell::Cell<Held>,
    pub(super) held_capacity: std::cell::Cell<Held>,
    pub(super) held_brake: std::cell::Cell<Held>,
}

/// A value read off a piece of an input where the input is constant: the piece's span
/// `[t0, t1)` and the value (an empty span: nothing held). On such a piece
/// [`super::inputs::Piece::eval`] is `v0 + 0·((t − t0)/(t1 − t0)) = v0 + 0` for every `t` in
/// the span, the same bits, so the value read once serves the whole piece.
#[derive(Clone, Copy, Default)]
pub(super) struct Held {
    t0: f64,
    t1: f64,
    value: f64,
}

/// `f` of `input` at `t`, through `held` while `t` stays on the constant piece it was read on.
#[inline]
pub(super) fn held_value(
    input: &super::inputs::Piecewise,
    cursor: &std::cell::Cell<usize>,
    held: &std::cell::Cell<Held>,
    t: f64,
    f: impl Fn(f64) -> f64,
) -> f64 {
    let h = held.get();
    if h.t0 <= t && t < h.t1 {
        return h.value;
    }
    let k = input.piece_index_from(cursor, t);
    let value = f(input.eval_piece(k, t));
    let (t0, t1, v0, v1) = input.piece(k);
    held.set(if v0.to_bits() == v1.to_bits() {
        Held { t0, t1, value }
    } else {
        Held::default()
    });
    value
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_held_value_is_the_inputs_value_bit_for_bit_wherever_it_is_read() {
        use super::super::inputs::Piecewise;
        use super::{held_value, Held};
        use std::cell::Cell;
        // constant, linear, constant (a negative zero too), linear pieces
        let input = Piecewise::new(vec![
            (0.0, 1.0, 3.0, 3.0),
            (1.0, 2.5, 3.0, 4.0),
            (2.5, 4.0, -0.0, -0.0),
            (4.0, 7.0, 4.0, 4.0),
            (7.0, 9.0, 4.0, 1.5),
        ])
        .unwrap();
        let f = |x: f64| 2.0 * x - 0.1;
        let (cursor, held) = (Cell::new(0), Cell::new(Held::default()));
        // forward in small and odd steps, then backward, across every knot and past the end
        let mut ts: Vec<f64> = (0..=1000).map(|i| i as f64 * 0.00937).collect();
        ts.extend([1.0, 2.5, 4.0, 7.0, 9.0, 9.5, 3.9, 0.5, 2.5, 8.0, 4.0]);
        for t in ts {
            let want = f(input.eval(t));
            let got = held_value(&input, &cursor, &held, t, f);
            assert_eq!(got.to_bits(), want.to_bits(), "t {t}");
        }
    }
}
