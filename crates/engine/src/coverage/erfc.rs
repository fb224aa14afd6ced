//! erfc(z) given e^{−z²}: the lattice path ([`super::grid`]) needs, at every
//! node and column, both erfc(√a d) and e^{−a d²}, and the library's erfc
//! computes its own exponential (two, for accuracy) each time. Here the
//! caller's exponential is reused, so a column costs one exponential and a
//! rational function.
//!
//! The rational functions are W. J. Cody's Chebyshev approximations
//! ("Rational Chebyshev approximations for the error function", Math.
//! Comp. 23 (1969) 631–637; the coefficients of his CALERF): erf for
//! |z| ≤ 0.46875, e^{−z²} P(z)/Q(z) for 0.46875 < |z| ≤ 4, and
//! e^{−z²}/z (1/√π − R(1/z²)/z²) beyond, each to about 1e-17 relative. The
//! result's relative error is that plus the given exponential's: for an
//! exponential of the rounded −z², about z² ulp (the tests measure it).

/// 1/√π.
const FRAC_1_SQRT_PI: f64 = 0.5641895835477563;

/// erf on |z| ≤ 0.46875: z · A(z²) / B(z²), A's last coefficient first.
const A: [f64; 5] = [
    3.1611237438705655,
    113.86415415105016,
    377.485237685302,
    3209.3775891384694,
    0.18577770618460315,
];
const B: [f64; 4] = [
    23.601290952344122,
    244.02463793444417,
    1282.6165260773723,
    2844.236833439171,
];
/// erfc on 0.46875 < z ≤ 4: e^{−z²} C(z) / D(z).
const C: [f64; 9] = [
    0.5641884969886701,
    8.883149794388377,
    66.11919063714163,
    298.6351381974001,
    881.952221241769,
    1712.0476126340707,
    2051.0783778260716,
    1230.3393547979972,
    2.1531153547440383e-08,
];
const D: [f64; 8] = [
    15.744926110709835,
    117.6939508913125,
    537.1811018620099,
    1621.3895745666903,
    3290.7992357334597,
    4362.619090143247,
    3439.3676741437216,
    1230.3393548037495,
];
/// erfc beyond 4, in s = 1/z².
const P: [f64; 6] = [
    0.30532663496123236,
    0.36034489994980445,
    0.12578172611122926,
    0.016083785148742275,
    0.0006587491615298378,
    0.016315387137302097,
];
const Q: [f64; 5] = [
    2.568520192289822,
    1.8729528499234604,
    0.5279051029514285,
    0.06051834131244132,
    0.0023352049762686918,
];

/// erfc(z), where `e` = e^{−z²} (0 where that underflows).
#[inline]
pub(super) fn erfc_with(z: f64, e: f64) -> f64 {
    let y = z.abs();
    if y <= 0.468_75 {
        let s = y * y;
        let num = (((A[4] * s + A[0]) * s + A[1]) * s + A[2]) * s + A[3];
        let den = (((s + B[0]) * s + B[1]) * s + B[2]) * s + B[3];
        return 1.0 - z * num / den;
    }
    let r = if y <= 4.0 {
        let (mut num, mut den) = (C[8] * y, y);
        for k in 0..7 {
            num = (num + C[k]) * y;
            den = (den + D[k]) * y;
        }
        e * (num + C[7]) / (den + D[7])
    } else {
        let s = 1.0 / (y * y);
        let (mut num, mut den) = (P[5] * s, s);
        for k in 0..4 {
            num = (num + P[k]) * s;
            den = (den + Q[k]) * s;
        }
        e * (FRAC_1_SQRT_PI - s * (num + P[4]) / (den + Q[4])) / y
    };
    if z < 0.0 { 2.0 - r } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the library's erfc from −6 to 26 (where erfc nears the
    /// subnormals, 5.7e-296), with the library's e^{−z²}: within
    /// (4 + z²) · 2.2e-16 relative; beyond, below 1e-295 as the library's.
    #[test]
    fn erfc_with_is_the_librarys_to_rounding() {
        let mut worst: f64 = 0.0;
        for k in 0..=32_000 {
            let z = -6.0 + 0.001 * k as f64;
            let want = libm::erfc(z);
            let got = erfc_with(z, libm::exp(-z * z));
            let relative = (got - want).abs() / want;
            let scaled = relative / ((4.0 + z * z) * f64::EPSILON);
            worst = worst.max(scaled);
            assert!(scaled <= 1.0, "z {z}: {got:e} against {want:e}");
        }
        assert!(worst > 0.0, "two methods, not one");
        println!("worst {worst:.3} of the bound");
        for k in 0..=2000 {
            let z = 26.0 + 0.001 * k as f64;
            let got = erfc_with(z, libm::exp(-z * z));
            assert!(got < 1e-295 && libm::erfc(z) < 1e-295, "z {z}: {got:e}");
        }
    }
}
