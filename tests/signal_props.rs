//! Property tests of `fleetdyn::signal`: invariants that must hold for any
//! filter and input (zero phase, unit DC gain, linearity, Parseval), and
//! in-test naive references (direct-form difference equation, naive DFT
//! periodogram average) for `sosfilt` and `welch`.

use fleetdyn::signal::*;
use proptest::prelude::*;

/// SplitMix64 + Box–Muller: reproducible Gaussian noise from a seed.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
    fn noise(&mut self, n: usize, sigma: f64) -> Vec<f64> {
        (0..n).map(|_| sigma * self.normal()).collect()
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn band(hp: bool) -> BandType {
    if hp {
        BandType::Highpass
    } else {
        BandType::Lowpass
    }
}

/// Overall transfer-function polynomials (b, a) of a cascade.
fn to_tf(sos: &Sos) -> (Vec<f64>, Vec<f64>) {
    let conv = |p: &[f64], q: &[f64]| {
        let mut r = vec![0.0; p.len() + q.len() - 1];
        for (i, a) in p.iter().enumerate() {
            for (j, b) in q.iter().enumerate() {
                r[i + j] += a * b;
            }
        }
        r
    };
    sos.sections()
        .iter()
        .fold((vec![1.0], vec![1.0]), |(b, a), s| {
            (conv(&b, &s[..3]), conv(&a, &s[3..]))
        })
}

/// Textbook direct-form difference equation, zero initial state.
fn direct_form(b: &[f64], a: &[f64], x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; x.len()];
    for n in 0..x.len() {
        let mut acc = 0.0;
        for (k, bk) in b.iter().enumerate() {
            if n >= k {
                acc += bk * x[n - k];
            }
        }
        for (k, ak) in a.iter().enumerate().skip(1) {
            if n >= k {
                acc -= ak * y[n - k];
            }
        }
        y[n] = acc / a[0];
    }
    y
}

/// Naive Welch: textbook periodic Hann, O(n²) DFT per segment.
fn naive_welch(x: &[f64], fs: f64, nperseg: usize, noverlap: usize) -> Vec<f64> {
    use std::f64::consts::PI;
    let n = nperseg;
    // scipy's get_window returns ones for a length-1 window.
    let w: Vec<f64> = if n == 1 {
        vec![1.0]
    } else {
        (0..n)
            .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / n as f64).cos())
            .collect()
    };
    let s2: f64 = w.iter().map(|v| v * v).sum();
    let step = n - noverlap;
    let nseg = (x.len() - noverlap) / step;
    let nf = n / 2 + 1;
    let mut p = vec![0.0; nf];
    for s in 0..nseg {
        let seg = &x[s * step..s * step + n];
        let m = seg.iter().sum::<f64>() / n as f64;
        for (f, pf) in p.iter_mut().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (t, v) in seg.iter().enumerate() {
                let ph = -2.0 * PI * ((f * t) % n) as f64 / n as f64;
                re += w[t] * (v - m) * ph.cos();
                im += w[t] * (v - m) * ph.sin();
            }
            let two_sided = f == 0 || (n.is_multiple_of(2) && f == n / 2);
            *pf += (re * re + im * im) / (fs * s2) * if two_sided { 1.0 } else { 2.0 };
        }
    }
    p.iter().map(|v| v / nseg as f64).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Zero phase: a pulse symmetric about its centre comes out symmetric
    /// about the same centre, and the effective frequency response
    /// (transform of the filtered impulse about the centre) is real and
    /// equal to |H|². The pulse sits in zeros long enough that the
    /// impulse response has decayed to ~1e-16 at the ends, so the edge
    /// treatment cannot break the symmetry; tolerance 1e-10 of the peak
    /// covers the rounding of two recursive passes.
    #[test]
    fn zero_phase_symmetric_pulse(order in 1usize..=6, fc in 0.03f64..0.4, hp in any::<bool>(),
                                  half in 0usize..20, seed in any::<u64>(), matched in any::<bool>()) {
        let sos = butter(order, fc, 1.0, band(hp)).unwrap();
        let margin = 2 * impulse_decay_len(&sos, 1e-8) + 50;
        let mut rng = Rng(seed);
        let halfv = rng.noise(half + 1, 1.0);
        let mut x = vec![0.0; margin];
        x.extend(halfv.iter().rev());
        x.extend(halfv.iter().skip(1));
        x.extend(std::iter::repeat_n(0.0, margin));
        let c = margin + half;
        let edge = if matched { EdgeMode::default() } else { EdgeMode::Scipy { padlen: None } };
        let y = sosfiltfilt(&sos, &x, &edge).unwrap();
        let tol = 1e-10 * max_abs(&y).max(1e-300);
        for k in 0..=c.min(x.len() - 1 - c) {
            prop_assert!((y[c - k] - y[c + k]).abs() <= tol, "k={} {} vs {}", k, y[c - k], y[c + k]);
        }
        // Effective response of a centred impulse.
        let mut d = vec![0.0; 2 * margin + 1];
        d[margin] = 1.0;
        let h = sosfiltfilt(&sos, &d, &edge).unwrap();
        let hsum: f64 = h.iter().map(|v| v.abs()).sum();
        for f in [0.0, 0.5 * fc, fc, 0.3, 0.49] {
            let w = 2.0 * std::f64::consts::PI * f;
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in h.iter().enumerate() {
                let k = i as f64 - margin as f64;
                re += v * (w * k).cos();
                im -= v * (w * k).sin();
            }
            let h2 = sos.frequency_response(f, 1.0).norm_sqr();
            prop_assert!(im.abs() <= 1e-10 * hsum, "f={} phase not zero: im={}", f, im);
            prop_assert!((re - h2).abs() <= 1e-9 * hsum.max(1.0), "f={} {} vs |H|²={}", f, re, h2);
        }
    }

    /// Unit DC gain of a low-pass: a constant comes out unchanged, causally
    /// (started in steady state with sosfilt_zi·c) and zero-phase in both
    /// edge modes. Tolerance 1e-8·|c|: the internal DC gain of a section
    /// at a low cut-off is ~1/(2π·fc)², which amplifies the rounding of the
    /// state; 1e-8 covers fc = 0.005 at order 6.
    #[test]
    fn lowpass_dc_gain_is_one(order in 1usize..=6, fc in 0.005f64..0.45, c in -100.0f64..100.0,
                              len in 1usize..300) {
        let sos = butter(order, fc, 1.0, BandType::Lowpass).unwrap();
        let x = vec![c; len];
        let tol = 1e-8 * c.abs().max(1e-3);
        let zi: Vec<[f64; 2]> = sosfilt_zi(&sos).iter().map(|z| [z[0] * c, z[1] * c]).collect();
        let (y, _) = sosfilt(&sos, &x, Some(&zi));
        prop_assert!(y.iter().all(|v| (v - c).abs() <= tol), "sosfilt");
        let y = sosfiltfilt(&sos, &x, &EdgeMode::default()).unwrap();
        prop_assert!(y.iter().all(|v| (v - c).abs() <= tol), "matched");
        if len > scipy_default_padlen(&sos) {
            let y = sosfiltfilt(&sos, &x, &EdgeMode::Scipy { padlen: None }).unwrap();
            prop_assert!(y.iter().all(|v| (v - c).abs() <= tol), "scipy");
        }
    }

    /// Linearity: F(a·x + b·y) = a·F(x) + b·F(y) for sosfilt and both
    /// sosfiltfilt modes (Matched's fits, extension and initial conditions
    /// are linear too). Tolerance 1e-9 of the input + output scale:
    /// rounding only (the input scale matters where the output is itself
    /// only round-off, e.g. a high-pass of a 2-sample line).
    #[test]
    fn filters_are_linear(order in 1usize..=6, fc in 0.01f64..0.45, hp in any::<bool>(),
                          len in 1usize..400, a in -10.0f64..10.0, b in -10.0f64..10.0,
                          seed in any::<u64>()) {
        let sos = butter(order, fc, 1.0, band(hp)).unwrap();
        let mut rng = Rng(seed);
        let x = rng.noise(len, 1.0);
        let y = rng.noise(len, 1.0);
        let z: Vec<f64> = x.iter().zip(&y).map(|(p, q)| a * p + b * q).collect();
        let mut modes: Vec<Option<EdgeMode>> = vec![None, Some(EdgeMode::default())];
        if len > scipy_default_padlen(&sos) {
            modes.push(Some(EdgeMode::Scipy { padlen: None }));
        }
        for m in modes {
            let run = |v: &[f64]| match m {
                None => sosfilt(&sos, v, None).0,
                Some(e) => sosfiltfilt(&sos, v, &e).unwrap(),
            };
            let (fx, fy, fz) = (run(&x), run(&y), run(&z));
            let scale = a.abs() * (max_abs(&x) + max_abs(&fx)) + b.abs() * (max_abs(&y) + max_abs(&fy));
            for i in 0..len {
                let err = (fz[i] - (a * fx[i] + b * fy[i])).abs();
                prop_assert!(err <= 1e-9 * scale, "{:?} i={} err {} scale {} out {}", m, i, err, scale, fz[i]);
            }
        }
    }

    /// sosfilt equals the textbook direct-form difference equation of the
    /// expanded transfer function. Orders ≤ 4 and cut-offs ≥ 0.05 keep the
    /// expanded polynomial well conditioned, so 1e-9 of max|y| holds.
    #[test]
    fn sosfilt_matches_direct_form(order in 1usize..=4, fc in 0.05f64..0.45, hp in any::<bool>(),
                                   len in 1usize..300, seed in any::<u64>()) {
        let sos = butter(order, fc, 1.0, band(hp)).unwrap();
        let x = Rng(seed).noise(len, 1.0);
        let (b, a) = to_tf(&sos);
        let want = direct_form(&b, &a, &x);
        let (got, _) = sosfilt(&sos, &x, None);
        let tol = 1e-9 * max_abs(&want).max(1e-300);
        for i in 0..len {
            prop_assert!((got[i] - want[i]).abs() <= tol, "i={} {} vs {}", i, got[i], want[i]);
        }
    }

    /// welch equals a naive DFT periodogram average (textbook periodic
    /// Hann, mean removal, one-sided density). The naive DFT accumulates
    /// ~n·eps of rounding, so 1e-9 per bin relative (floor 1e-12 of the
    /// largest bin for round-off-only bins) is ample.
    #[test]
    fn welch_matches_naive_periodogram(len in 2usize..600, nfrac in 0.05f64..1.0, ofrac in 0.0f64..0.95,
                                       fs in 0.1f64..100.0, seed in any::<u64>()) {
        let x = Rng(seed).noise(len, 2.0);
        let nperseg = ((len as f64 * nfrac) as usize).max(1);
        let noverlap = ((nperseg as f64 * ofrac) as usize).min(nperseg - 1);
        let r = welch(&x, &WelchConfig { fs_hz: fs, nperseg: Some(nperseg), noverlap: Some(noverlap), confidence: 0.9 }).unwrap();
        let want = naive_welch(&x, fs, nperseg, noverlap);
        prop_assert_eq!(r.psd.len(), want.len());
        let floor = 1e-12 * max_abs(&want);
        for (k, (g, w)) in r.psd.iter().zip(&want).enumerate() {
            prop_assert!((g - w).abs() <= 1e-9 * w.abs().max(floor), "bin {} {} vs {}", k, g, w);
        }
    }

    /// Parseval: Σ psd·Δf is the Hann-weighted sample variance, so for
    /// white noise of variance σ² it must be within a statistical bound of
    /// σ². The estimator is Σ_t A_t·x_t² (A_t = mean over segments of
    /// w²/Σw²), whose relative standard deviation for Gaussian noise is
    /// sqrt(2·ΣA_t²); we allow 6 of those (false alarm ~1e-9) plus 2/nperseg
    /// for the bias of removing each segment's mean.
    #[test]
    fn welch_parseval_white_noise(len in 512usize..8192, p in 5u32..10, sigma in 0.1f64..10.0,
                                  fs in 0.5f64..200.0, seed in any::<u64>()) {
        let nperseg = 1usize << p;
        let x = Rng(seed).noise(len, sigma);
        let r = welch(&x, &WelchConfig { fs_hz: fs, nperseg: Some(nperseg), ..WelchConfig::default() }).unwrap();
        let df = fs / r.nperseg as f64;
        let total: f64 = r.psd.iter().sum::<f64>() * df;
        let w = hann_periodic(r.nperseg);
        let s2: f64 = w.iter().map(|v| v * v).sum();
        let step = r.nperseg - r.noverlap;
        let mut a = vec![0.0; len];
        for s in 0..r.n_segments {
            for (t, wt) in w.iter().enumerate() {
                a[s * step + t] += wt * wt / s2 / r.n_segments as f64;
            }
        }
        let sd = (2.0 * a.iter().map(|v| v * v).sum::<f64>()).sqrt();
        let rel = total / (sigma * sigma) - 1.0;
        prop_assert!(rel.abs() <= 6.0 * sd + 2.0 / r.nperseg as f64, "rel {} sd {}", rel, sd);
    }
}
