//! The WGS84 ellipsoid (a = 6 378 137 m, f = 1/298.257 223 563): Earth-centred Earth-fixed
//! coordinates of a point on its surface and the straight-line (chord) distance between two
//! such points, the step length of a GNSS road profile ([`super::gnss_profile`],
//! docs/models/road.md). Latitude and longitude in WGS84 degrees, distances in m.
//!
//! # The chord as a distance
//! The fixes are placed on the ellipsoid surface (altitude ignored, so the distance is
//! horizontal) by their Earth-centred Earth-fixed coordinates
//! `X = (N+0)·cos φ·cos λ, Y = N·cos φ·sin λ, Z = N·(1−e²)·sin φ`, `N = a/√(1−e² sin² φ)`.
//! On a surface of radius of curvature R the chord is shorter than the geodesic arc by
//! `c³/(24 R²)` (from `arc = 2R·asin(c/2R)`): relative 1·10⁻¹² for the 20 m steps of 1 Hz fixes
//! at 72 km/h, 4·10⁻¹¹ at 200 m, 1·10⁻⁸ for a 2 km gap in the fixes — far below the GNSS
//! position noise. A sphere (haversine with R = 6 371 008.8 m) would instead be off by the
//! ratio of the ellipsoid's radii of curvature to the mean radius, which depends on latitude
//! and heading: −0.56 % … +0.41 % (at 56° N +0.13 % north–south, +0.34 % east–west); on the
//! car drive haversine between the same points gives 40 496 m against 40 588 m (−0.23 %).
//! Rounding of the ECEF coordinates (≈ 10⁻⁹ m) is 5·10⁻¹¹ of a 20 m step.

/// WGS84 semi-major axis, m.
pub const WGS84_A_M: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// Earth-centred Earth-fixed coordinates of a point on the WGS84 ellipsoid surface, m.
pub fn ecef_on_ellipsoid(lat_deg: f64, lon_deg: f64) -> [f64; 3] {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let (phi, lam) = (lat_deg.to_radians(), lon_deg.to_radians());
    let n = WGS84_A_M / (1.0 - e2 * phi.sin().powi(2)).sqrt();
    [
        n * phi.cos() * lam.cos(),
        n * phi.cos() * lam.sin(),
        n * (1.0 - e2) * phi.sin(),
    ]
}

/// Chord length between two points on the WGS84 ellipsoid surface, m: the step distance of the
/// module doc (shorter than the geodesic by c³/(24 R²)).
pub fn chord_distance_m(lat1_deg: f64, lon1_deg: f64, lat2_deg: f64, lon2_deg: f64) -> f64 {
    let (a, b) = (
        ecef_on_ellipsoid(lat1_deg, lon1_deg),
        ecef_on_ellipsoid(lat2_deg, lon2_deg),
    );
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Meridian arc length from `lat1` to `lat2` on WGS84 by composite Simpson on
    /// M(φ) = a(1−e²)/(1−e² sin²φ)^{3/2} (independent of the chord formula).
    fn meridian_arc_m(lat1: f64, lat2: f64) -> f64 {
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let m = |phi: f64| WGS84_A_M * (1.0 - e2) / (1.0 - e2 * phi.sin().powi(2)).powf(1.5);
        let (a, b) = (lat1.to_radians(), lat2.to_radians());
        let n = 2000;
        let h = (b - a) / n as f64;
        let mut s = m(a) + m(b);
        for k in 1..n {
            s += m(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    #[test]
    fn chord_matches_the_meridian_arc_to_the_stated_error() {
        // c³/(24 R²) with R ≈ 6.39e6 m at 56°: 20 m → 1e-12 relative, 2 km → 1e-8
        // plus rounding: ECEF coordinates of 6.4e6 m carry ~1e-9 m, 5e-11 of a 20 m step
        for (step_m, tol_rel) in [(20.0, 2e-10), (200.0, 1e-10), (2000.0, 2e-8)] {
            let dlat = step_m / 111_000.0;
            let arc = meridian_arc_m(56.0, 56.0 + dlat);
            let chord = chord_distance_m(56.0, 10.0, 56.0 + dlat, 10.0);
            let rel = (arc - chord) / arc;
            assert!(rel >= -1e-13 && rel < tol_rel, "{step_m} m: {rel:e}");
        }
        // along a parallel the chord of a short step equals the arc N cosφ Δλ to (c/ρ)²/24
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let phi = 56f64.to_radians();
        let n = WGS84_A_M / (1.0 - e2 * phi.sin().powi(2)).sqrt();
        let dlon = 0.0005f64; // ≈ 31 m
        let arc = n * phi.cos() * dlon.to_radians();
        let chord = chord_distance_m(56.0, 10.0, 56.0, 10.0 + dlon);
        assert!(((arc - chord) / arc).abs() < 1e-10);
        // across the antimeridian
        let d = chord_distance_m(0.0, 179.9999, 0.0, -179.9999);
        assert!(
            (d - 2.0 * 0.0001f64.to_radians() * WGS84_A_M).abs() < 1e-6,
            "{d}"
        );
    }
}
