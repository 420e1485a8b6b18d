//! Synthetic roads from road-design rules (Myklebust & Eriksson (2012), §4; docs/models/road.md).
//!
//! **Geometry.** A road is a sequence of constant grades g₀, g₁, … (tan α) whose grade lines meet
//! at points of vertical intersection (PVIs). Grade `i` runs from PVI `i−1` to PVI `i`
//! (`lengths_m[i]` apart; grade 0 starts at x = 0, the last grade runs on to the end of the road).
//! At each PVI a symmetric parabolic vertical curve of radius R joins the two grades, Myklebust &
//! Eriksson (2012), eq. (34) `z = x²/(2R)`: its slope changes linearly, eq. (35) `tan α = x/R`, at
//! the rate ±1/R (− on a crest, + on a sag) over the length `R·|g_{i+1} − g_i|`, centred on the
//! PVI. So the slope is piecewise linear and continuous and |d(slope)/dx| ≤ 1/R_min everywhere —
//! eq. (36) `α = v t/R` is the same statement in time at speed v. The elevation is the exact
//! integral of the slope, z(0) = 0.
//!
//! **Random roads** ([`generate`]), "for simplicity uniform distributions for all variables"
//! (Myklebust & Eriksson (2012), §4), drawn in this fixed order from one [`Xoshiro256StarStar`]
//! seeded with the road's seed: the first grade and its length; then per PVI the next grade g ~
//! U(−max_grade, max_grade), its segment length L ~ U(L_min, L_max(g)) with
//! `L_max(g) = L_min + (L_flat − L_min)·exp(−|g|/g_e)` (flat ground widest), and the curve's radius
//! R ~ U(R_min, R_min + band) with the crest or sag minimum as the grade falls or rises. Generation
//! stops once the next PVI would lie at or beyond the road's length.
//!
//! **Curves that do not fit.** A curve takes half its length from each neighbouring grade
//! segment; when the two half-curves on a segment (from its start and end PVIs) are together
//! longer than the segment, the segment is **lengthened** until they fit exactly (its constant
//! part then has zero length: one curve runs straight into the next). Grades and radii are kept
//! as drawn, so no grade change is ever steeper than the radius allows; only the segment-length
//! distribution of steep, short segments is shifted upwards. The count of lengthened segments is
//! reported ([`SyntheticRoad::lengthened_segments`]) and written to the road's metadata.
//!
//! **Grid.** Samples at `x_k = k·step_m`, k = 0 … ⌊length_m/step_m⌋ (the last sample may fall
//! short of `length_m` by less than a step), evaluated analytically on each piece.

use super::rules::RoadRules;
use crate::rng::Xoshiro256StarStar;
use thiserror::Error;

/// Most grid samples one road may have (a 50 000 km road at 1 m): beyond this the request is
/// rejected instead of exhausting memory (3 columns of 8 bytes per sample).
pub const MAX_SAMPLES: usize = 50_000_000;

/// Most grade segments one road may have (bounded before generating: length / min_length_m).
pub const MAX_SEGMENTS: f64 = 10_000_000.0;

/// Why a road could not be made.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SynthError {
    /// Road length not finite and positive.
    #[error("road length {length_m} m must be finite and > 0")]
    InvalidLength {
        /// Length asked for, m.
        length_m: f64,
    },
    /// Grid step not finite, positive and at most the road length.
    #[error("grid step {step_m} m must be finite, > 0 and <= the road length {length_m} m")]
    InvalidStep {
        /// Step, m.
        step_m: f64,
        /// Road length, m.
        length_m: f64,
    },
    /// The grid would have too many samples.
    #[error("{samples} grid samples requested (length / step); at most {limit} are allowed")]
    TooManySamples {
        /// Samples requested.
        samples: f64,
        /// Limit ([`MAX_SAMPLES`]).
        limit: usize,
    },
    /// The rules would need too many grade segments for this length.
    #[error("up to {segments} grade segments (length {length_m} m / min_length_m {min_length_m} m); at most {limit} are allowed")]
    TooManySegments {
        /// Upper bound on segments.
        segments: f64,
        /// Road length, m.
        length_m: f64,
        /// Shortest segment, m.
        min_length_m: f64,
        /// Limit ([`MAX_SEGMENTS`]).
        limit: f64,
    },
    /// An alignment whose vectors do not fit together.
    #[error("alignment: {grades} grades need {need} segment lengths and radii, got {lengths} lengths and {radii} radii")]
    Shape {
        /// Grades given.
        grades: usize,
        /// Lengths and radii needed (grades − 1).
        need: usize,
        /// Lengths given.
        lengths: usize,
        /// Radii given.
        radii: usize,
    },
    /// A non-finite grade, or a segment length or radius that is not finite and positive.
    #[error("alignment: {what}[{index}] = {value} is not allowed ({requirement})")]
    BadValue {
        /// Which vector.
        what: &'static str,
        /// Index in it.
        index: usize,
        /// Value.
        value: f64,
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// Two half-curves longer than the grade segment between them.
    #[error("alignment: grade segment {index} is {length_m} m long but its curves take {before_m} m (from the PVI before) + {after_m} m (from the PVI after)")]
    CurveDoesNotFit {
        /// Segment index.
        index: usize,
        /// Its PVI-to-PVI length, m.
        length_m: f64,
        /// Half-length of the curve at its start, m.
        before_m: f64,
        /// Half-length of the curve at its end, m.
        after_m: f64,
    },
}

/// The vertical alignment of a road: grades, PVI spacing and curve radii (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Alignment {
    /// Constant grades, tan α; at least one.
    pub grades: Vec<f64>,
    /// Length of grade segment i (x = 0 or PVI i−1 to PVI i), m; one fewer than `grades` (the
    /// last grade runs on to the end of the road).
    pub lengths_m: Vec<f64>,
    /// Radius of the vertical curve at PVI i (joining grade i to grade i+1), m.
    pub radii_m: Vec<f64>,
}

/// One piece of the profile: slope `g0 + k·(x − x0)` and elevation
/// `z0 + g0·(x − x0) + k·(x − x0)²/2` on `[x0, x1)`; `k = 0` on a constant grade.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// Start, m.
    pub x0_m: f64,
    /// End, m (`+∞` for the last piece).
    pub x1_m: f64,
    /// Elevation at the start, m.
    pub z0_m: f64,
    /// Slope at the start, tan α.
    pub g0: f64,
    /// Rate of change of the slope, 1/m (±1/R on a curve).
    pub k_per_m: f64,
}

impl Piece {
    /// Slope at `x`, tan α.
    pub fn slope(&self, x: f64) -> f64 {
        self.g0 + self.k_per_m * (x - self.x0_m)
    }
    /// Elevation at `x`, m.
    pub fn elevation(&self, x: f64) -> f64 {
        let d = x - self.x0_m;
        self.z0_m + self.g0 * d + 0.5 * self.k_per_m * d * d
    }
}

/// Half-length of the curve of radius `r` joining grades `g0` and `g1`, m: `R·|g1 − g0|/2`.
pub fn half_length(r: f64, g0: f64, g1: f64) -> f64 {
    r * (g1 - g0).abs() / 2.0
}

/// A road sampled on its distance grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// Grid step, m.
    pub step_m: f64,
    /// Distance from the start, m (`k·step_m`).
    pub distance_m: Vec<f64>,
    /// Elevation above the start, m.
    pub elevation_m: Vec<f64>,
    /// Slope tan α (1).
    pub slope: Vec<f64>,
}

fn check_grid(length_m: f64, step_m: f64) -> Result<usize, SynthError> {
    if !(length_m.is_finite() && length_m > 0.0) {
        return Err(SynthError::InvalidLength { length_m });
    }
    if !(step_m.is_finite() && step_m > 0.0 && step_m <= length_m) {
        return Err(SynthError::InvalidStep { step_m, length_m });
    }
    let samples = (length_m / step_m + 1e-9).floor() + 1.0;
    if samples > MAX_SAMPLES as f64 {
        return Err(SynthError::TooManySamples {
            samples,
            limit: MAX_SAMPLES,
        });
    }
    Ok(samples as usize)
}

impl Alignment {
    /// The profile's pieces, in order (constant grades and curves; zero-length pieces left
    /// out), the last one running to `+∞`.
    ///
    /// # Errors
    /// [`SynthError::Shape`], [`SynthError::BadValue`], [`SynthError::CurveDoesNotFit`].
    pub fn pieces(&self) -> Result<Vec<Piece>, SynthError> {
        let n = self.grades.len();
        let need = n.saturating_sub(1);
        if n == 0 || self.lengths_m.len() != need || self.radii_m.len() != need {
            return Err(SynthError::Shape {
                grades: n,
                need,
                lengths: self.lengths_m.len(),
                radii: self.radii_m.len(),
            });
        }
        let bad = |what, index, value, requirement| SynthError::BadValue {
            what,
            index,
            value,
            requirement,
        };
        for (i, &g) in self.grades.iter().enumerate() {
            if !g.is_finite() {
                return Err(bad("grades", i, g, "must be finite"));
            }
        }
        for (i, &l) in self.lengths_m.iter().enumerate() {
            if !(l.is_finite() && l > 0.0) {
                return Err(bad("lengths_m", i, l, "must be finite and > 0"));
            }
        }
        for (i, &r) in self.radii_m.iter().enumerate() {
            if !(r.is_finite() && r > 0.0) {
                return Err(bad("radii_m", i, r, "must be finite and > 0"));
            }
        }
        let g = &self.grades;
        let h: Vec<f64> = (0..need)
            .map(|i| half_length(self.radii_m[i], g[i], g[i + 1]))
            .collect();
        let mut pieces: Vec<Piece> = Vec::with_capacity(2 * n);
        let mut z = 0.0;
        let mut push = |pieces: &mut Vec<Piece>, x0: f64, x1: f64, g0: f64, g1: f64| {
            if x1 > x0 {
                let k = if x1.is_finite() {
                    (g1 - g0) / (x1 - x0)
                } else {
                    0.0
                };
                let p = Piece {
                    x0_m: x0,
                    x1_m: x1,
                    z0_m: z,
                    g0,
                    k_per_m: k,
                };
                if x1.is_finite() {
                    z = p.elevation(x1);
                }
                pieces.push(p);
            }
        };
        let mut pvi_prev = 0.0;
        let mut x = 0.0;
        for i in 0..need {
            let before = if i > 0 { h[i - 1] } else { 0.0 };
            if before + h[i] > self.lengths_m[i] {
                return Err(SynthError::CurveDoesNotFit {
                    index: i,
                    length_m: self.lengths_m[i],
                    before_m: before,
                    after_m: h[i],
                });
            }
            let pvi = pvi_prev + self.lengths_m[i];
            // a segment lengthened to fit its curves exactly may round the curve's start a hair
            // before the previous curve's end: start it there instead
            let curve_start = (pvi - h[i]).max(x);
            push(&mut pieces, x, curve_start, g[i], g[i]);
            push(&mut pieces, curve_start, pvi + h[i], g[i], g[i + 1]);
            x = (pvi + h[i]).max(curve_start);
            pvi_prev = pvi;
        }
        push(&mut pieces, x, f64::INFINITY, g[n - 1], g[n - 1]);
        Ok(pieces)
    }

    /// Samples the road on the grid `k·step_m` up to `length_m`.
    ///
    /// # Errors
    /// Those of [`Alignment::pieces`], [`SynthError::InvalidLength`],
    /// [`SynthError::InvalidStep`], [`SynthError::TooManySamples`].
    pub fn profile(&self, length_m: f64, step_m: f64) -> Result<Profile, SynthError> {
        let samples = check_grid(length_m, step_m)?;
        let pieces = self.pieces()?;
        let mut distance_m = Vec::with_capacity(samples);
        let mut elevation_m = Vec::with_capacity(samples);
        let mut slope = Vec::with_capacity(samples);
        let mut j = 0;
        for k in 0..samples {
            let x = k as f64 * step_m;
            while j + 1 < pieces.len() && x >= pieces[j].x1_m {
                j += 1;
            }
            let p = &pieces[j];
            distance_m.push(x);
            elevation_m.push(p.elevation(x));
            slope.push(p.slope(x));
        }
        Ok(Profile {
            step_m,
            distance_m,
            elevation_m,
            slope,
        })
    }
}

/// A generated road: its rules, seed, alignment and sampled profile.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticRoad {
    /// Rules it was drawn from.
    pub rules: RoadRules,
    /// Seed of its generator.
    pub seed: u64,
    /// Requested length, m.
    pub length_m: f64,
    /// The drawn alignment (after lengthening segments that could not hold their curves).
    pub alignment: Alignment,
    /// Grade segments lengthened so that their curves fit (see the module doc).
    pub lengthened_segments: usize,
    /// The sampled road.
    pub profile: Profile,
}

/// Draws the alignment of a road of `length_m` from `rules` with generator seed `seed` (see
/// the module doc for the order of the draws and the fitting rule).
///
/// # Errors
/// [`SynthError::InvalidLength`], [`SynthError::TooManySegments`].
pub fn draw_alignment(
    rules: &RoadRules,
    length_m: f64,
    seed: u64,
) -> Result<(Alignment, usize), SynthError> {
    if !(length_m.is_finite() && length_m > 0.0) {
        return Err(SynthError::InvalidLength { length_m });
    }
    let segments = length_m / rules.min_length_m + 1.0;
    if segments > MAX_SEGMENTS {
        return Err(SynthError::TooManySegments {
            segments,
            length_m,
            min_length_m: rules.min_length_m,
            limit: MAX_SEGMENTS,
        });
    }
    let mut rng = Xoshiro256StarStar::seed_from_u64(seed);
    let gmax = rules.max_grade;
    let draw_length = |rng: &mut Xoshiro256StarStar, g: f64| {
        rng.uniform(rules.min_length_m, rules.max_length_at(g))
    };
    let mut g = rng.uniform(-gmax, gmax);
    let mut len = draw_length(&mut rng, g);
    let (mut grades, mut lengths_m, mut radii_m) = (vec![g], Vec::new(), Vec::new());
    let (mut pvi, mut h_before, mut lengthened) = (0.0, 0.0, 0usize);
    while pvi + len < length_m {
        let g_next = rng.uniform(-gmax, gmax);
        let mut len_next = draw_length(&mut rng, g_next);
        let r_min = rules.min_radius(g_next < g);
        let r = rng.uniform(r_min, r_min + rules.radius_band_m);
        let h = half_length(r, g, g_next);
        if h_before + h > len {
            len = h_before + h;
            lengthened += 1;
        }
        if h > len_next {
            len_next = h;
            lengthened += 1;
        }
        lengths_m.push(len);
        radii_m.push(r);
        grades.push(g_next);
        pvi += len;
        h_before = h;
        g = g_next;
        len = len_next;
    }
    Ok((
        Alignment {
            grades,
            lengths_m,
            radii_m,
        },
        lengthened,
    ))
}

/// Generates a road of `length_m` on a grid of `step_m` from `rules` and `seed`.
///
/// # Errors
/// [`SynthError`] for a bad length or step, or a request too large.
pub fn generate(
    rules: &RoadRules,
    length_m: f64,
    step_m: f64,
    seed: u64,
) -> Result<SyntheticRoad, SynthError> {
    check_grid(length_m, step_m)?;
    let (alignment, lengthened_segments) = draw_alignment(rules, length_m, seed)?;
    let profile = alignment.profile(length_m, step_m)?;
    Ok(SyntheticRoad {
        rules: rules.clone(),
        seed,
        length_m,
        alignment,
        lengthened_segments,
        profile,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_join_continuously() {
        let a = Alignment {
            grades: vec![0.0, 0.04, -0.02],
            lengths_m: vec![100.0, 200.0],
            radii_m: vec![1000.0, 2000.0],
        };
        let p = a.pieces().unwrap();
        for w in p.windows(2) {
            assert_eq!(w[0].x1_m, w[1].x0_m);
            assert!((w[0].slope(w[0].x1_m) - w[1].g0).abs() < 1e-15);
            assert!((w[0].elevation(w[0].x1_m) - w[1].z0_m).abs() < 1e-12);
        }
        assert!(p.last().unwrap().x1_m.is_infinite());
    }

    #[test]
    fn bad_alignments_are_rejected() {
        let a = Alignment {
            grades: vec![0.0, 0.1],
            lengths_m: vec![10.0],
            radii_m: vec![1000.0],
        };
        assert!(matches!(
            a.pieces(),
            Err(SynthError::CurveDoesNotFit { index: 0, .. })
        ));
        let b = Alignment {
            grades: vec![0.0, 0.1],
            lengths_m: vec![],
            radii_m: vec![],
        };
        assert!(matches!(b.pieces(), Err(SynthError::Shape { .. })));
        let c = Alignment {
            grades: vec![0.0, f64::NAN],
            lengths_m: vec![100.0],
            radii_m: vec![100.0],
        };
        assert!(matches!(c.pieces(), Err(SynthError::BadValue { .. })));
    }
}
