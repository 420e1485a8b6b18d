//! Digital Butterworth design in second-order-section (SOS) form.
//!
//! [`butter`] reproduces `scipy.signal.butter(order, cutoff_hz, btype,
//! output='sos', fs=fs_hz)` step by step so that every coefficient agrees
//! with scipy to about 1e-12 relative:
//!
//! 1. analog prototype (`scipy.signal.buttap`): poles
//!    `p_m = -exp(j·π·m/(2N))`, m = −N+1, −N+3, …, N−1, no zeros, gain 1;
//! 2. pre-warping with scipy's normalisation: `Wn = 2·cutoff/fs` (cut-off as
//!    a fraction of Nyquist), `fs' = 2`, `warped = 2·fs'·tan(π·Wn/fs')`;
//! 3. `lp2lp_zpk` / `lp2hp_zpk` to the warped frequency;
//! 4. `bilinear_zpk` with `fs' = 2`;
//! 5. `zpk2sos(..., pairing='nearest')`: poles closest to the unit circle
//!    go into the LAST section, a lone real pole becomes a first-order
//!    section (`a2 = 0`), and the overall gain `k` is folded into the first
//!    section's numerator.
//!
//! The complex arithmetic deliberately follows numpy's formulas (Smith's
//! division, sequential products) so that rounding matches as closely as is
//! practical.
//!
//! The road-slope filter of Myklebust & Eriksson (2012), §5
//! (docs/models/road.md) is `butter(3, 4e-3, 1.0, Lowpass)` with distance as
//! the independent variable (fs = 1 sample/m, cut-off 4e-3 1/m): −30 dB is
//! required at 2e-2 1/m and about −42 dB is obtained (single pass; twice that
//! in dB for the zero-phase forward–backward use).

use std::f64::consts::PI;

use num_complex::Complex64;

use super::error::SignalError;

type C = Complex64;

/// Filter band type for [`butter`] (scipy's `btype`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BandType {
    /// Pass frequencies below the cut-off (`btype='lowpass'`).
    Lowpass,
    /// Pass frequencies above the cut-off (`btype='highpass'`).
    Highpass,
}

/// A cascade of second-order sections, scipy's `sos` array.
///
/// Each row is `[b0, b1, b2, a0, a1, a2]` (scipy's row order) with
/// `a0 == 1`; a section implements
/// `H_s(z) = (b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²)` and the filter
/// is the product of the sections, applied first to last.
#[derive(Debug, Clone, PartialEq)]
pub struct Sos {
    sections: Vec<[f64; 6]>,
}

impl Sos {
    /// Builds a cascade from rows `[b0, b1, b2, a0, a1, a2]`.
    ///
    /// Like scipy's `_validate_sos`, every row must have `a0 == 1` exactly;
    /// all coefficients must be finite. An empty cascade is the identity.
    pub fn from_sections(sections: Vec<[f64; 6]>) -> Result<Sos, SignalError> {
        for (i, s) in sections.iter().enumerate() {
            if s[3] != 1.0 || s.iter().any(|c| !c.is_finite()) {
                return Err(SignalError::InvalidSos {
                    section: i,
                    a0: s[3],
                });
            }
        }
        Ok(Sos { sections })
    }

    /// The rows `[b0, b1, b2, a0, a1, a2]`, first section first.
    pub fn sections(&self) -> &[[f64; 6]] {
        &self.sections
    }

    /// Number of second-order sections.
    pub fn n_sections(&self) -> usize {
        self.sections.len()
    }

    /// Complex frequency response `H(e^{jω})`, `ω = 2π·f_hz/fs_hz`, like one
    /// point of `scipy.signal.sosfreqz(sos, worN=[f_hz], fs=fs_hz)`.
    ///
    /// Sign convention: `z⁻¹ = e^{−jω}`, so a causal low-pass has negative
    /// phase (delay) above DC.
    pub fn frequency_response(&self, f_hz: f64, fs_hz: f64) -> Complex64 {
        let w = 2.0 * PI * f_hz / fs_hz;
        let z1 = Complex64::new(w.cos(), -w.sin());
        let z2 = z1 * z1;
        self.sections
            .iter()
            .fold(Complex64::new(1.0, 0.0), |acc, s| {
                let num = z2 * s[2] + z1 * s[1] + s[0];
                let den = z2 * s[5] + z1 * s[4] + s[3];
                acc * num / den
            })
    }

    /// Gain `20·log10|H|` in dB at `f_hz` (`fs_hz` in the same unit), i.e.
    /// `20*log10(abs(h))` of `scipy.signal.sosfreqz`. Negative means
    /// attenuation. The zero-phase forward–backward filter has twice this.
    pub fn gain_db(&self, f_hz: f64, fs_hz: f64) -> f64 {
        20.0 * self.frequency_response(f_hz, fs_hz).norm().log10()
    }

    /// Gain at DC, `H(1) = Π (b0+b1+b2)/(a0+a1+a2)`.
    pub fn dc_gain(&self) -> f64 {
        self.sections
            .iter()
            .map(|s| (s[0] + s[1] + s[2]) / (s[3] + s[4] + s[5]))
            .product()
    }
}

/// Largest Butterworth order tried by [`lowest_order_meeting`].
pub const MAX_SEARCH_ORDER: usize = 64;

/// Digital Butterworth filter as second-order sections.
///
/// Equal to `scipy.signal.butter(order, cutoff_hz, btype, output='sos',
/// fs=fs_hz)` to ≤ 1e-12 relative per coefficient (see the module docs for
/// the exact path). `cutoff_hz` is the −3 dB frequency and `fs_hz` the
/// sampling rate, in any one unit (Hz, or 1/m for distance-sampled
/// signals). Requires `order >= 1` and `0 < cutoff_hz < fs_hz/2`.
///
/// Section order is scipy's: the section whose poles are closest to the unit
/// circle is last; the gain is in the first section's numerator; for odd
/// orders the real pole sits in a section with `a2 = 0`.
pub fn butter(
    order: usize,
    cutoff_hz: f64,
    fs_hz: f64,
    band: BandType,
) -> Result<Sos, SignalError> {
    if order == 0 {
        return Err(SignalError::InvalidOrder { order });
    }
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        return Err(SignalError::InvalidSampleRate { fs_hz });
    }
    // scipy: Wn = 2*Wn/fs, then 0 < Wn < 1.
    let wn = 2.0 * cutoff_hz / fs_hz;
    if !(wn > 0.0 && wn < 1.0) {
        return Err(SignalError::InvalidCutoff { cutoff_hz, fs_hz });
    }

    // buttap: p = -exp(1j*pi*m/(2*N)); numpy divides the complex by the
    // integer via Smith's algorithm, i.e. multiplies by 1/(2N).
    let n = order as i64;
    let inv_2n = 1.0 / (2 * n) as f64;
    let p_analog: Vec<C> = (0..n)
        .map(|i| {
            let m = (-n + 1 + 2 * i) as f64;
            let theta = (PI * m) * inv_2n;
            C::new(-theta.cos(), -theta.sin())
        })
        .collect();

    // Pre-warp (fs' = 2).
    let fs2 = 2.0;
    let warped = 2.0 * fs2 * (PI * wn / fs2).tan();

    let (z_s, p_s, k_s): (Vec<C>, Vec<C>, f64) = match band {
        BandType::Lowpass => {
            // lp2lp_zpk: p*wo, k*wo**degree
            let p: Vec<C> = p_analog
                .iter()
                .map(|&q| C::new(warped * q.re, warped * q.im))
                .collect();
            (Vec::new(), p, warped.powf(order as f64))
        }
        BandType::Highpass => {
            // lp2hp_zpk: p = wo/p, zeros at the origin, k = real(prod(-z)/prod(-p))
            let p: Vec<C> = p_analog
                .iter()
                .map(|&q| np_div(C::new(warped, 0.0), q))
                .collect();
            let prod_neg_p = np_prod(p_analog.iter().map(|&q| -q));
            let k = np_div(C::new(1.0, 0.0), prod_neg_p).re;
            (vec![C::new(0.0, 0.0); order], p, k)
        }
    };

    // bilinear_zpk with fs' = 2: fs2 = 2*fs' = 4.
    let four = 2.0 * fs2;
    let bil = |q: C| np_div(C::new(four + q.re, q.im), C::new(four - q.re, -q.im));
    let mut z_z: Vec<C> = z_s.iter().map(|&q| bil(q)).collect();
    let p_z: Vec<C> = p_s.iter().map(|&q| bil(q)).collect();
    let degree = p_s.len() - z_s.len();
    z_z.extend(std::iter::repeat_n(C::new(-1.0, 0.0), degree));
    let num = np_prod(z_s.iter().map(|&q| C::new(four - q.re, -q.im)));
    let den = np_prod(p_s.iter().map(|&q| C::new(four - q.re, -q.im)));
    let k_z = k_s * np_div(num, den).re;

    Ok(Sos {
        sections: zpk2sos_nearest(z_z, p_z, k_z),
    })
}

/// Lowest Butterworth low-pass order whose attenuation at `stop_hz` is at
/// least `stop_atten_db` (a positive number of dB).
///
/// With `zero_phase = true` the filter is meant to be run forward and
/// backward ([`crate::signal::sosfiltfilt`]), whose gain is `|H|²`, i.e.
/// twice the single-pass attenuation in dB. For the road-slope filter of
/// Myklebust & Eriksson (2012), §5 (cut-off 4e-3 1/m, −30 dB at 2e-2 1/m,
/// fs = 1/m) this returns 3 single-pass and 2 zero-phase.
///
/// Returns 0 if the arguments are invalid (see [`butter`]) or no order up
/// to [`MAX_SEARCH_ORDER`] meets the requirement; use
/// [`try_lowest_order_meeting`] to get the reason instead.
pub fn lowest_order_meeting(
    cutoff_hz: f64,
    stop_hz: f64,
    stop_atten_db: f64,
    fs_hz: f64,
    zero_phase: bool,
) -> usize {
    try_lowest_order_meeting(cutoff_hz, stop_hz, stop_atten_db, fs_hz, zero_phase)
        .ok()
        .flatten()
        .unwrap_or(0)
}

/// Like [`lowest_order_meeting`] but reports invalid design arguments as
/// `Err` and "no order up to [`MAX_SEARCH_ORDER`] suffices" as `Ok(None)`.
pub fn try_lowest_order_meeting(
    cutoff_hz: f64,
    stop_hz: f64,
    stop_atten_db: f64,
    fs_hz: f64,
    zero_phase: bool,
) -> Result<Option<usize>, SignalError> {
    let passes = if zero_phase { 2.0 } else { 1.0 };
    for order in 1..=MAX_SEARCH_ORDER {
        let sos = butter(order, cutoff_hz, fs_hz, BandType::Lowpass)?;
        let atten = -passes * sos.gain_db(stop_hz, fs_hz);
        if atten >= stop_atten_db {
            return Ok(Some(order));
        }
    }
    Ok(None)
}

/// numpy's complex division (Smith's algorithm, as in numpy's
/// `CDOUBLE_divide` loop).
fn np_div(a: C, b: C) -> C {
    let (ar, ai, br, bi) = (a.re, a.im, b.re, b.im);
    if br.abs() >= bi.abs() {
        if br == 0.0 && bi == 0.0 {
            return C::new(ar / br.abs(), ai / br.abs());
        }
        let rat = bi / br;
        let scl = 1.0 / (br + bi * rat);
        C::new((ar + ai * rat) * scl, (ai - ar * rat) * scl)
    } else {
        let rat = br / bi;
        let scl = 1.0 / (bi + br * rat);
        C::new((ar * rat + ai) * scl, (ai * rat - ar) * scl)
    }
}

/// Sequential complex product, `numpy.prod` of a 1-D complex array
/// (empty product = 1).
fn np_prod(it: impl Iterator<Item = C>) -> C {
    let mut acc: Option<C> = None;
    for v in it {
        acc = Some(match acc {
            None => v,
            Some(a) => a * v,
        });
    }
    acc.unwrap_or(C::new(1.0, 0.0))
}

/// `numpy.poly`: monic polynomial (highest power first) with the given
/// roots, by repeated convolution with `[1, -r]`.
fn np_poly(roots: &[C]) -> Vec<C> {
    let mut a = vec![C::new(1.0, 0.0)];
    for &r in roots {
        let v = -r;
        let mut c = vec![C::new(0.0, 0.0); a.len() + 1];
        c[0] = a[0];
        for k in 1..a.len() {
            c[k] = a[k] + a[k - 1] * v;
        }
        c[a.len()] = a[a.len() - 1] * v;
        a = c;
    }
    a
}

/// scipy's `_single_zpksos`: one row from ≤ 2 zeros and ≤ 2 poles, gain 1,
/// right-aligned (`sos[3-len(b):3] = b`, `sos[6-len(a):6] = a`). The roots
/// come as conjugate pairs or reals, so the polynomials are real.
fn single_zpksos(z: &[C], p: &[C]) -> [f64; 6] {
    let mut s = [0.0; 6];
    let b = np_poly(z);
    let a = np_poly(p);
    for (i, c) in b.iter().enumerate() {
        s[3 - b.len() + i] = c.re;
    }
    for (i, c) in a.iter().enumerate() {
        s[6 - a.len() + i] = c.re;
    }
    s
}

/// scipy's `_cplxreal`: sort, split into complex (positive imaginary part,
/// averaged with the conjugate partner) and real roots.
fn cplxreal(z: &[C]) -> (Vec<C>, Vec<f64>) {
    if z.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let tol = 100.0 * f64::EPSILON;
    // np.lexsort((abs(z.imag), z.real)): primary real, secondary |imag|, stable.
    let mut z: Vec<C> = z.to_vec();
    z.sort_by(|a, b| {
        a.re.partial_cmp(&b.re)
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(
                a.im.abs()
                    .partial_cmp(&b.im.abs())
                    .unwrap_or(std::cmp::Ordering::Equal),
            )
    });
    let is_real = |q: &C| q.im.abs() <= tol * q.norm();
    let zr: Vec<f64> = z.iter().filter(|q| is_real(q)).map(|q| q.re).collect();
    if zr.len() == z.len() {
        return (Vec::new(), zr);
    }
    let zc_all: Vec<C> = z.into_iter().filter(|q| !is_real(q)).collect();
    let mut zp: Vec<C> = zc_all.iter().copied().filter(|q| q.im > 0.0).collect();
    let mut zn: Vec<C> = zc_all.iter().copied().filter(|q| q.im < 0.0).collect();
    debug_assert_eq!(zp.len(), zn.len(), "unpaired complex root");
    // Runs of (approximately) equal real part: sort each by |imag|.
    let same_real: Vec<bool> = (0..zp.len().saturating_sub(1))
        .map(|i| zp[i + 1].re - zp[i].re <= tol * zp[i].norm())
        .collect();
    let mut i = 0;
    while i < same_real.len() {
        if same_real[i] {
            let start = i;
            while i < same_real.len() && same_real[i] {
                i += 1;
            }
            let stop = i + 1; // exclusive
            let key = |a: &C, b: &C| {
                a.im.abs()
                    .partial_cmp(&b.im.abs())
                    .unwrap_or(std::cmp::Ordering::Equal)
            };
            zp[start..stop].sort_by(key);
            zn[start..stop].sort_by(key);
        } else {
            i += 1;
        }
    }
    let zc = zp
        .iter()
        .zip(zn.iter())
        .map(|(a, b)| C::new((a.re + b.re) * 0.5, (a.im - b.im) * 0.5))
        .collect();
    (zc, zr)
}

/// scipy's `_nearest_real_complex_idx` (ties resolved to the lower index).
fn nearest_idx(fro: &[C], to: C, which: Which) -> usize {
    let mut order: Vec<usize> = (0..fro.len()).collect();
    order.sort_by(|&a, &b| {
        (fro[a] - to)
            .norm()
            .partial_cmp(&(fro[b] - to).norm())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    match which {
        Which::Any => order[0],
        Which::Real => *order
            .iter()
            .find(|&&i| fro[i].im == 0.0)
            .expect("a real zero is available"),
        Which::Complex => *order
            .iter()
            .find(|&&i| fro[i].im != 0.0)
            .expect("a complex zero is available"),
    }
}

#[derive(Clone, Copy)]
enum Which {
    Real,
    Complex,
    Any,
}

/// Index of the pole closest to the unit circle (`argmin |1 - |p||`, first
/// on ties).
fn idx_worst(p: &[C]) -> usize {
    let mut best = 0;
    let mut best_d = f64::INFINITY;
    for (i, q) in p.iter().enumerate() {
        let d = (1.0 - q.norm()).abs();
        if d < best_d {
            best_d = d;
            best = i;
        }
    }
    best
}

/// scipy's `zpk2sos(z, p, k, pairing='nearest')` for a digital filter.
fn zpk2sos_nearest(mut z: Vec<C>, mut p: Vec<C>, k: f64) -> Vec<[f64; 6]> {
    let zero = C::new(0.0, 0.0);
    if z.is_empty() && p.is_empty() {
        return vec![[k, 0.0, 0.0, 1.0, 0.0, 0.0]];
    }
    // Same number of poles and zeros; pad an odd count with a pole and a
    // zero at the origin.
    while p.len() < z.len() {
        p.push(zero);
    }
    while z.len() < p.len() {
        z.push(zero);
    }
    let n_sections = p.len().div_ceil(2);
    if p.len() % 2 == 1 {
        p.push(zero);
        z.push(zero);
    }
    let join = |(c, r): (Vec<C>, Vec<f64>)| -> Vec<C> {
        c.into_iter()
            .chain(r.into_iter().map(|x| C::new(x, 0.0)))
            .collect()
    };
    let mut z = join(cplxreal(&z));
    let mut p = join(cplxreal(&p));
    let isreal = |q: &C| q.im == 0.0;

    let mut sos = vec![[0.0; 6]; n_sections];
    for si in (0..n_sections).rev() {
        let p1 = p.remove(idx_worst(&p));
        let n_real_p = p.iter().filter(|q| isreal(q)).count();
        if isreal(&p1) && n_real_p == 0 {
            // Special case (1): last remaining real pole.
            let zi = nearest_idx(&z, p1, Which::Real);
            let z1 = z.remove(zi);
            sos[si] = single_zpksos(&[z1, zero], &[p1, zero]);
        } else if p.len() + 1 == z.len()
            && !isreal(&p1)
            && n_real_p == 1
            && z.iter().filter(|q| isreal(q)).count() == 1
        {
            // Special case (2): must pair with a complex zero.
            let zi = nearest_idx(&z, p1, Which::Complex);
            let z1 = z.remove(zi);
            sos[si] = single_zpksos(&[z1, z1.conj()], &[p1, p1.conj()]);
        } else {
            let p2 = if isreal(&p1) {
                let real_idx: Vec<usize> = (0..p.len()).filter(|&i| isreal(&p[i])).collect();
                let reals: Vec<C> = real_idx.iter().map(|&i| p[i]).collect();
                let j = real_idx[idx_worst(&reals)];
                p.remove(j)
            } else {
                p1.conj()
            };
            if !z.is_empty() {
                let zi = nearest_idx(&z, p1, Which::Any);
                let z1 = z.remove(zi);
                if !isreal(&z1) {
                    sos[si] = single_zpksos(&[z1, z1.conj()], &[p1, p2]);
                } else if !z.is_empty() {
                    let zj = nearest_idx(&z, p1, Which::Real);
                    let z2 = z.remove(zj);
                    sos[si] = single_zpksos(&[z1, z2], &[p1, p2]);
                } else {
                    sos[si] = single_zpksos(&[z1], &[p1, p2]);
                }
            } else {
                sos[si] = single_zpksos(&[], &[p1, p2]);
            }
        }
    }
    debug_assert!(p.is_empty() && z.is_empty());
    for c in sos[0][..3].iter_mut() {
        *c *= k;
    }
    sos
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_filter_meets_seed000_sec5() {
        let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).unwrap();
        assert_eq!(sos.n_sections(), 2);
        assert!((sos.dc_gain() - 1.0).abs() < 1e-12);
        assert!((sos.gain_db(4e-3, 1.0) + 3.0103).abs() < 1e-3);
        let g = sos.gain_db(2e-2, 1.0);
        assert!(g < -30.0 && (g + 42.0).abs() < 0.5, "{g}");
        assert_eq!(lowest_order_meeting(4e-3, 2e-2, 30.0, 1.0, false), 3);
        assert_eq!(lowest_order_meeting(4e-3, 2e-2, 30.0, 1.0, true), 2);
    }

    #[test]
    fn rejects_bad_arguments() {
        assert!(matches!(
            butter(0, 1.0, 10.0, BandType::Lowpass),
            Err(SignalError::InvalidOrder { order: 0 })
        ));
        assert!(butter(2, 5.0, 10.0, BandType::Lowpass).is_err());
        assert!(butter(2, 0.0, 10.0, BandType::Highpass).is_err());
        assert!(butter(2, f64::NAN, 10.0, BandType::Highpass).is_err());
        assert!(butter(2, 1.0, -10.0, BandType::Highpass).is_err());
        assert_eq!(lowest_order_meeting(6.0, 7.0, 30.0, 10.0, false), 0);
    }

    #[test]
    fn highpass_has_unit_nyquist_gain_and_zero_dc() {
        for order in 1..8 {
            let sos = butter(order, 0.1, 1.0, BandType::Highpass).unwrap();
            assert!(sos.dc_gain().abs() < 1e-12);
            assert!(sos.frequency_response(0.5, 1.0).norm() - 1.0 < 1e-12);
        }
    }
}
