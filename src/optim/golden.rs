//! Golden-section search ([`golden_section`]).

/// Golden-section search for a minimum of `f` on `[a, b]` (`f` unimodal there): `iterations`
/// reductions of the bracket by `1/φ ≈ 0.618`, one evaluation each (the interior point that
/// stays is reused; on a tie the lower part is dropped). Returns the better of the last two
/// interior points and its value. The final bracket is `(b − a) · 0.618^iterations` wide.
pub fn golden_section(
    mut f: impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    iterations: usize,
) -> (f64, f64) {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (a, b);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iterations {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    if fc < fd {
        (c, fc)
    } else {
        (d, fd)
    }
}
