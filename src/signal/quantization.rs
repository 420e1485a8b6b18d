//! Sensor resolution from data: the quantisation step of a signal, estimated from its values.
//!
//! Production road-slope sensors report whole percent (a step of 0.01 in tan α); J1939 speed has
//! 1/256 km/h, engine speed 0.125 rpm. Knowing the step tells how much of a signal's
//! high-frequency content is quantisation (a one-percentage-point step excites shuffle;
//! Myklebust & Eriksson (2012), §3).
//!
//! Method: sort the distinct finite values, take the smallest gap between neighbours as the
//! candidate step `q`, and accept it only if (a) at least 99 % of samples lie within 1 % of `q`
//! of the lattice `v₀ + k·q` and (b) values repeat: at most one distinct value per 2 samples, which a continuous
//! noisy signal (every sample distinct) does not satisfy. Otherwise the signal
//! is reported as not quantised.

/// An estimated quantisation lattice `offset + k·step`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantization {
    /// Lattice step, in the signal's unit.
    pub step: f64,
    /// Lattice offset in `[0, step)`.
    pub offset: f64,
    /// Fraction of finite samples on the lattice.
    pub fraction_on_lattice: f64,
    /// Number of distinct values.
    pub distinct: usize,
}

/// Estimates the quantisation step of `values` (NaN ignored); `None` when not quantised or when
/// fewer than two distinct values occur.
pub fn estimate_quantization(values: &[f64]) -> Option<Quantization> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len();
    if n < 8 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let scale = v[n - 1].abs().max(v[0].abs()).max(f64::MIN_POSITIVE);
    let tol = scale * 1e-9;
    v.dedup_by(|a, b| (*a - *b).abs() <= tol);
    let distinct = v.len();
    if distinct < 2 || distinct * 2 > n {
        return None;
    }
    let q = v
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    if q.is_nan() || q <= tol {
        return None;
    }
    let v0 = v[0];
    let on = |x: f64| {
        let k = (x - v0) / q;
        (k - k.round()).abs() <= 0.01
    };
    let on_lattice = values
        .iter()
        .filter(|x| x.is_finite())
        .filter(|&&x| on(x))
        .count();
    let fraction = on_lattice as f64 / n as f64;
    if fraction < 0.99 {
        return None;
    }
    Some(Quantization {
        step: q,
        offset: v0.rem_euclid(q),
        fraction_on_lattice: fraction,
        distinct,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_percent_slope_is_found() {
        let x: Vec<f64> = (0..2000)
            .map(|i| ((i as f64 * 0.01).sin() * 4.0).round() / 100.0)
            .collect();
        let q = estimate_quantization(&x).unwrap();
        assert!((q.step - 0.01).abs() < 1e-12, "{q:?}");
        assert!(q.offset.abs() < 1e-12 || (q.offset - 0.01).abs() < 1e-12);
    }

    #[test]
    fn continuous_signal_is_not_quantised() {
        let x: Vec<f64> = (0..2000)
            .map(|i| (i as f64 * 0.0123).sin() * 0.04)
            .collect();
        assert_eq!(estimate_quantization(&x), None);
    }

    #[test]
    fn j1939_speed_resolution() {
        // 1/256 km/h in m/s
        let lsb = 1.0 / 256.0 / 3.6;
        let x: Vec<f64> = (0..5000)
            .map(|i| ((20.0 + (i as f64 * 0.001).sin()) / lsb).round() * lsb)
            .collect();
        let q = estimate_quantization(&x).unwrap();
        assert!((q.step - lsb).abs() < 1e-9 * lsb.max(1.0), "{q:?}");
    }
}
