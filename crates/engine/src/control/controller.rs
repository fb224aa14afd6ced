//! Robust velocity-tracking controller (paper eq. 33–35):
//!
//! ```text
//! τ_u = d11 u − m22 v r + m11 (u̇_d + ∇u) − τ̄_ud
//! τ_r = d33 r + (m22 − m11) u v + m33 (ṙ_d + ∇r) − τ̄_rd
//! ∇u = −k₁ sig^λ(u_e) − k₂ sig^η(u_e),  λ = 1 + ξ, η = 1 when |u_e| ≥ 1,
//!                                        λ = 1, η = 1 − ς when |u_e| < 1
//! ```
//!
//! With an exact disturbance estimate the error obeys u̇_e = ∇u, which reaches
//! 0 from any start within the fixed time (paper eq. 38, corrected)
//! T₂ = ln((k₁ + k₂)/k₂) / (k₁ ς) + ln((k₁ + k₂)/k₁) / (k₂ ξ).
//! The paper prints ς₁ in the second term; integrating ẏ = −k₁ y^{1+ξ} − k₂ y
//! from ∞ to 1 gives ξ. Actuator saturation is applied by the hull model.

use super::model::VesselParams;
use super::{Vec3, sig};

/// Gains of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelGains {
    /// k₁ > 0, the gain of the sig^λ term of ∇ (paper eq. 33–35).
    pub k1: f64,
    /// k₂ > 0, the gain of the sig^η term of ∇ (paper eq. 33–35).
    pub k2: f64,
    /// ξ > 0.
    pub xi: f64,
    /// 0 < ς < ½.
    pub varsigma: f64,
}

impl ChannelGains {
    /// ∇ for the error `e`.
    pub fn nabla(&self, e: f64) -> f64 {
        let (lambda, eta) = if e.abs() >= 1.0 {
            (1.0 + self.xi, 1.0)
        } else {
            (1.0, 1.0 - self.varsigma)
        };
        -self.k1 * sig(e, lambda) - self.k2 * sig(e, eta)
    }

    /// The fixed-time bound T₂ of eq. 38 (corrected).
    pub fn settling_bound(&self) -> f64 {
        let (k1, k2) = (self.k1, self.k2);
        ((k1 + k2) / k2).ln() / (k1 * self.varsigma) + ((k1 + k2) / k1).ln() / (k2 * self.xi)
    }
}

/// Gains for surge and yaw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerGains {
    /// The surge channel's gains (∇u).
    pub surge: ChannelGains,
    /// The yaw channel's gains (∇r).
    pub yaw: ChannelGains,
}

impl Default for ControllerGains {
    fn default() -> Self {
        let g = ChannelGains {
            k1: 1.0,
            k2: 1.0,
            xi: 0.5,
            varsigma: 0.25,
        };
        ControllerGains { surge: g, yaw: g }
    }
}

/// What the controller tracks.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Reference {
    /// Desired surge speed u_d [m/s].
    pub u_d: f64,
    /// Desired yaw rate r_d [rad/s].
    pub r_d: f64,
    /// Its rate of change u̇_d [m/s²], fed forward.
    pub u_d_dot: f64,
    /// Its rate of change ṙ_d [rad/s²], fed forward.
    pub r_d_dot: f64,
}

/// (τ_u, τ_r) before saturation, from the measured velocity `v`, the
/// reference and the disturbance estimate.
///
/// ```
/// use seacover_engine::control::Vec3;
/// use seacover_engine::control::controller::{ControllerGains, Reference, control};
/// use seacover_engine::control::model::{State, VesselParams, step};
///
/// let (params, gains) = (VesselParams::PAPER, ControllerGains::default());
/// let reference = Reference { u_d: 1.0, ..Reference::default() };
/// let calm = |_: f64, _: &State| Vec3::zeros();
/// // At rest: the surge error −1 m/s asks for m11 (k₁ + k₂) = 4000 N, which
/// // the hull's model saturates at its limit, 2000 N.
/// let state = State::default();
/// let (tau_u, tau_r) = control(&params, &gains, state.vel, &reference, Vec3::zeros());
/// assert_eq!((tau_u, tau_r), (4000.0, 0.0));
/// let (mut state, applied) = step(&params, &state, tau_u, tau_r, 0.0, 0.01, calm);
/// assert_eq!(applied, (2000.0, 0.0));
/// // Ten seconds of 10 ms steps later the surge speed is 1 m/s.
/// for k in 1..1000 {
///     let (tau_u, tau_r) = control(&params, &gains, state.vel, &reference, Vec3::zeros());
///     state = step(&params, &state, tau_u, tau_r, k as f64 * 0.01, 0.01, calm).0;
/// }
/// assert!((state.vel.x - 1.0).abs() < 1e-6, "{}", state.vel.x);
/// ```
pub fn control(
    p: &VesselParams,
    gains: &ControllerGains,
    v: Vec3,
    reference: &Reference,
    estimate: Vec3,
) -> (f64, f64) {
    let (u, sv, r) = (v.x, v.y, v.z);
    let tau_u = p.d11 * u - p.m22 * sv * r
        + p.m11 * (reference.u_d_dot + gains.surge.nabla(u - reference.u_d))
        - estimate.x;
    let tau_r = p.d33 * r
        + (p.m22 - p.m11) * u * sv
        + p.m33 * (reference.r_d_dot + gains.yaw.nabla(r - reference.r_d))
        - estimate.z;
    (tau_u, tau_r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::disturbance::Disturbance;
    use crate::control::model::{State, step};

    #[test]
    fn errors_vanish_within_the_fixed_time_bound() {
        // Exact disturbance knowledge, no saturation: eq. 37 holds exactly.
        let p = VesselParams {
            tau_u_max: 1e9,
            tau_u_reverse: 1e9,
            tau_r_max: 1e9,
            ..VesselParams::PAPER
        };
        for gains in [
            ControllerGains::default(),
            ControllerGains {
                surge: ChannelGains {
                    k1: 2.0,
                    k2: 0.5,
                    xi: 0.3,
                    varsigma: 0.4,
                },
                yaw: ChannelGains {
                    k1: 0.5,
                    k2: 3.0,
                    xi: 1.0,
                    varsigma: 0.1,
                },
            },
        ] {
            let dist = Disturbance::Paper { index: 3 };
            let reference = Reference {
                u_d: 1.5,
                r_d: -0.2,
                ..Reference::default()
            };
            for start in [
                Vec3::new(25.0, 0.0, 8.0),
                Vec3::new(-3.0, 0.5, -0.9),
                Vec3::new(1.6, 0.0, -0.1),
            ] {
                let mut s = State {
                    vel: start,
                    ..State::default()
                };
                let h = 1e-4;
                let (mut t_u, mut t_r) = (None, None);
                let mut t = 0.0;
                while t < 40.0 {
                    let est = dist.value(t, s.psi);
                    let (tu, tr) = control(&p, &gains, s.vel, &reference, est);
                    s = step(&p, &s, tu, tr, t, h, |t, st| dist.value(t, st.psi)).0;
                    t += h;
                    if t_u.is_none() && (s.vel.x - reference.u_d).abs() < 1e-6 {
                        t_u = Some(t);
                    }
                    if t_r.is_none() && (s.vel.z - reference.r_d).abs() < 1e-6 {
                        t_r = Some(t);
                    }
                }
                let (bu, br) = (gains.surge.settling_bound(), gains.yaw.settling_bound());
                let (tu, tr) = (t_u.expect("surge converges"), t_r.expect("yaw converges"));
                println!(
                    "start {start:?}: surge {tu:.2} s (bound {bu:.2} s), yaw {tr:.2} s (bound {br:.2} s)"
                );
                assert!(tu <= bu, "surge {tu} s > bound {bu} s");
                assert!(tr <= br, "yaw {tr} s > bound {br} s");
                // And it stays there.
                assert!(
                    (s.vel.x - reference.u_d).abs() < 1e-6
                        && (s.vel.z - reference.r_d).abs() < 1e-6
                );
            }
        }
    }

    #[test]
    fn settling_bound_matches_the_integral() {
        let g = ChannelGains {
            k1: 2.0,
            k2: 0.5,
            xi: 0.3,
            varsigma: 0.4,
        };
        // Midpoint rule on ∫₀¹ dy/(k₁ς y + k₂ς) (time from |u_e| = 1 to 0, in
        // y = |u_e|^ς) and on ∫₁^∞ dy/(k₁ y^{1+ξ} + k₂ y) (from ∞ to 1), the
        // latter with z = y^{−ξ}, which makes it ∫₀¹ dz / (ξ (k₁ + k₂ z)).
        let n = 200_000;
        let mut total = 0.0;
        for i in 0..n {
            let y = (i as f64 + 0.5) / n as f64;
            total += 1.0 / (g.k1 * g.varsigma * y + g.k2 * g.varsigma) / n as f64;
            total += 1.0 / (g.xi * (g.k1 + g.k2 * y)) / n as f64;
        }
        assert!(
            (total - g.settling_bound()).abs() < 1e-9 * total,
            "{total} vs {}",
            g.settling_bound()
        );
    }
}
