//! The vessel side of the paper (its sections 3–5): 3-DOF dynamics with
//! actuator saturation, disturbance models, the finite-time disturbance
//! observer, the robust velocity-tracking controller, and the guidance laws
//! that turn a centroid into desired surge speed and yaw rate.
//!
//! Invariants: pure and deterministic (randomness only through an explicit
//! seed); no I/O; every step function takes the time step explicitly; angles
//! are wrapped to (−π, π].
//!
//! Code map: [`model`] parameters, presets and RK4 dynamics; [`disturbance`]
//! τ_d(t); [`observer`] eq. 30; [`controller`] eq. 33–35; [`guidance`]
//! eq. 10–13 and the converging `course` mode, [`station`] its station
//! keeping on arrival (experimental), [`lag`] how far it trails a moving
//! goal; [`lloyd`] the single-integrator
//! baseline; [`safety`] the tick's safe motion among islands and vessels
//! (goal, route, [`barrier`] filter over [`halfplanes`], tracking).

pub mod barrier;
pub mod controller;
pub mod disturbance;
pub mod guidance;
pub mod halfplanes;
pub mod lag;
pub mod lloyd;
pub mod model;
pub mod ned;
pub mod observer;
pub mod plausibility;
pub mod reference;
pub mod safety;
pub mod station;

use std::f64::consts::PI;

/// Wraps an angle to (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
}

/// σ(s) = 1 / (1 + e^{−s}).
pub fn sigmoid(s: f64) -> f64 {
    1.0 / (1.0 + (-s).exp())
}

/// sig^a(s) = sign(s) |s|^a.
pub fn sig(s: f64, a: f64) -> f64 {
    s.signum() * s.abs().powf(a)
}

/// Body-frame velocity V = (u, v, r) or any 3-vector over the same axes.
pub type Vec3 = nalgebra::Vector3<f64>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_is_half_open() {
        assert_eq!(wrap(PI), PI);
        assert!((wrap(-PI) - PI).abs() < 1e-15);
        assert!((wrap(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap(0.1 + 20.0 * PI) - 0.1).abs() < 1e-9);
    }
}
