//! The pseudo-random number generator of synthetic roads, drives and noise copies: xoshiro256**
//! "Scrambled linear pseudorandom number generators", ACM TOMS 47(4), 2021) seeded through
//! SplitMix64 (Steele, Lea & Flood, OOPSLA 2014), written out here.
//!
//! Why our own and not a crate: a road is a function of its seed, and its bytes must not change
//! when a dependency is bumped (`rand`'s `StdRng` explicitly reserves the right to change its
//! algorithm between releases). These ~40 lines are fixed; the tests pin them to the published
//! reference outputs (xoshiro256** from the state {1, 2, 3, 4}; SplitMix64 from 1234567).
//!
//! Conventions:
//! - [`Xoshiro256StarStar::seed_from_u64`]: the four state words are the first four outputs of
//!   SplitMix64 started at `seed` (the seeding Vigna recommends; it never yields the all-zero
//!   state for any seed in practice and decorrelates neighbouring seeds such as a study's
//!   `seed, seed+1, …`).
//! - [`Xoshiro256StarStar::next_f64`]: the top 53 bits of one output scaled by 2⁻⁵³, uniform on
//!   [0, 1) with every value a multiple of 2⁻⁵³.
//! - [`Xoshiro256StarStar::uniform`]: `a + (b − a)·u`, uniform on [a, b) for a < b (and `a` for
//!   a = b).
//! - [`Xoshiro256StarStar::standard_normal`]: Box–Muller, `√(−2 ln(1 − u₁))·cos(2π u₂)` from two
//!   consecutive [`next_f64`](Xoshiro256StarStar::next_f64) draws (the sine half is discarded, so
//!   every normal consumes exactly two outputs and a stream's position never depends on history).

/// SplitMix64 step: advances `state` by the golden-ratio increment and returns the mixed value.
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// xoshiro256** generator (256-bit state, period 2²⁵⁶ − 1).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Xoshiro256StarStar {
    s: [u64; 4],
}

impl Xoshiro256StarStar {
    /// A generator with the given raw state (must not be all zero; used by the reference test).
    pub fn from_state(s: [u64; 4]) -> Self {
        Self { s }
    }

    /// A generator whose state is the first four SplitMix64 outputs from `seed`.
    pub fn seed_from_u64(seed: u64) -> Self {
        let mut sm = seed;
        let s = [
            splitmix64(&mut sm),
            splitmix64(&mut sm),
            splitmix64(&mut sm),
            splitmix64(&mut sm),
        ];
        Self { s }
    }

    /// Next 64-bit output: `rotl(s1·5, 7)·9`, then the xoshiro state transition.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform on [0, 1): `(next_u64 >> 11)·2⁻⁵³`.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform on [a, b): `a + (b − a)·next_f64()`.
    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next_f64()
    }

    /// Standard normal N(0, 1) by Box–Muller: `√(−2 ln(1 − u₁))·cos(2π u₂)`; `1 − u₁` lies in
    /// (0, 1], so the logarithm is finite. Consumes two outputs.
    pub fn standard_normal(&mut self) -> f64 {
        let u1 = self.next_f64();
        let u2 = self.next_f64();
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xoshiro_matches_the_published_reference_outputs() {
        // Reference outputs of xoshiro256starstar.c from the state {1, 2, 3, 4}, as published
        // with the reference implementations (e.g. the rand_xoshiro crate's test).
        let mut r = Xoshiro256StarStar::from_state([1, 2, 3, 4]);
        let want: [u64; 10] = [
            11520,
            0,
            1509978240,
            1215971899390074240,
            1216172134540287360,
            607988272756665600,
            16172922978634559625,
            8476171486693032832,
            10595114339597558777,
            2904607092377533576,
        ];
        for w in want {
            assert_eq!(r.next_u64(), w);
        }
    }

    #[test]
    fn splitmix_matches_the_published_reference_outputs() {
        // SplitMix64 from 1234567 (the reference sequence quoted by its ports).
        let mut s = 1234567u64;
        let want: [u64; 5] = [
            6457827717110365317,
            3203168211198807973,
            9817491932198370423,
            4593380528125082431,
            16408922859458223821,
        ];
        for w in want {
            assert_eq!(splitmix64(&mut s), w);
        }
        let mut s = 0u64;
        assert_eq!(splitmix64(&mut s), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn uniform_stays_in_range_and_seeds_differ() {
        let mut a = Xoshiro256StarStar::seed_from_u64(7);
        let mut b = Xoshiro256StarStar::seed_from_u64(8);
        let mut differ = false;
        for _ in 0..10_000 {
            let (x, y) = (a.uniform(-0.08, 0.08), b.uniform(-0.08, 0.08));
            assert!((-0.08..0.08).contains(&x));
            differ |= x != y;
        }
        assert!(differ);
        assert_eq!(a.uniform(3.0, 3.0), 3.0);
    }

    #[test]
    fn standard_normal_has_unit_variance_and_zero_mean() {
        // n = 200 000: the sample mean has σ = 1/√n ≈ 0.0022 and the sample variance
        // σ ≈ √(2/n) ≈ 0.0032; 5σ bounds.
        let mut r = Xoshiro256StarStar::seed_from_u64(42);
        let n = 200_000;
        let x: Vec<f64> = (0..n).map(|_| r.standard_normal()).collect();
        let mean = x.iter().sum::<f64>() / n as f64;
        let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        assert!(mean.abs() < 0.011, "mean {mean}");
        assert!((var - 1.0).abs() < 0.016, "variance {var}");
        assert!(x.iter().all(|v| v.is_finite()));
    }
}
