//! Environmental disturbances τ_d = (τ_ud, τ_vd, τ_rd) in the body frame.
//!
//! All models are deterministic functions of time (and heading, for a current
//! fixed in the earth frame); randomness enters only through a seed, so a
//! simulation repeats exactly. Each model knows a bound on |τ̇_d| for a vessel
//! turning at most at `r_max`, which is what the observer's gain b₂ must exceed
//! (paper Assumption 2).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Vec3;

/// One disturbance model.
#[derive(Debug, Clone, PartialEq)]
pub enum Disturbance {
    /// τ_d = 0.
    None,
    /// The paper's τ_d = (sin(t + i), 1.5 cos(t + i), 2 sin(t + i)) for
    /// vessel number i (1-based).
    Paper {
        /// The vessel's number i, from 1.
        index: usize,
    },
    /// A constant force (N) in the earth frame, as a steady current or wind
    /// exerts on a hull; in the body frame it turns with the vessel.
    Current {
        /// The force along the earth frame's x (east) [N].
        fx: f64,
        /// The force along its y (north) [N].
        fy: f64,
    },
    /// Smooth random gusts: per channel a sum of sinusoids with random
    /// frequencies and phases, bounded in value and in derivative.
    Gusts(Gusts),
    /// The sum of several models.
    Sum(Vec<Disturbance>),
}

/// Σ_k a_k sin(ω_k t + φ_k) per channel: |value| ≤ Σ a_k and
/// |derivative| ≤ Σ a_k ω_k by construction.
#[derive(Debug, Clone, PartialEq)]
pub struct Gusts {
    channels: [Vec<(f64, f64, f64)>; 3],
}

impl Gusts {
    /// Random gusts with per-channel amplitude bound `amplitude` and
    /// derivative bound `rate`, from `seed`.
    pub fn random(seed: u64, amplitude: Vec3, rate: Vec3) -> Gusts {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut channel = |amp: f64, rate: f64| {
            let n = 4;
            let weights: Vec<f64> = (0..n).map(|_| rng.random_range(0.2..1.0)).collect();
            let total: f64 = weights.iter().sum();
            let mut parts: Vec<(f64, f64, f64)> = weights
                .iter()
                .map(|w| {
                    let omega = rng.random_range(0.05..1.5);
                    let phase = rng.random_range(0.0..std::f64::consts::TAU);
                    (amp * w / total, omega, phase)
                })
                .collect();
            let slope: f64 = parts.iter().map(|(a, w, _)| a * w).sum();
            if slope > rate {
                for p in &mut parts {
                    p.1 *= rate / slope;
                }
            }
            parts
        };
        Gusts {
            channels: [
                channel(amplitude.x, rate.x),
                channel(amplitude.y, rate.y),
                channel(amplitude.z, rate.z),
            ],
        }
    }

    fn value(&self, t: f64) -> Vec3 {
        let ch = |c: &Vec<(f64, f64, f64)>| c.iter().map(|(a, w, p)| a * (w * t + p).sin()).sum();
        Vec3::new(
            ch(&self.channels[0]),
            ch(&self.channels[1]),
            ch(&self.channels[2]),
        )
    }

    fn rate_bound(&self) -> Vec3 {
        let ch = |c: &Vec<(f64, f64, f64)>| c.iter().map(|(a, w, _)| a * w).sum();
        Vec3::new(
            ch(&self.channels[0]),
            ch(&self.channels[1]),
            ch(&self.channels[2]),
        )
    }
}

impl Disturbance {
    /// τ_d at time `t` for a vessel heading `psi`.
    pub fn value(&self, t: f64, psi: f64) -> Vec3 {
        match self {
            Disturbance::None => Vec3::zeros(),
            Disturbance::Paper { index } => {
                let s = t + *index as f64;
                Vec3::new(s.sin(), 1.5 * s.cos(), 2.0 * s.sin())
            }
            Disturbance::Current { fx, fy } => {
                let (sn, c) = psi.sin_cos();
                Vec3::new(fx * c + fy * sn, -fx * sn + fy * c, 0.0)
            }
            Disturbance::Gusts(g) => g.value(t),
            Disturbance::Sum(parts) => parts.iter().map(|d| d.value(t, psi)).sum(),
        }
    }

    /// A bound on |τ̇_d| per channel for a vessel turning at |r| ≤ `r_max`.
    pub fn rate_bound(&self, r_max: f64) -> Vec3 {
        match self {
            Disturbance::None => Vec3::zeros(),
            Disturbance::Paper { .. } => Vec3::new(1.0, 1.5, 2.0),
            Disturbance::Current { fx, fy } => {
                let f = fx.hypot(*fy) * r_max;
                Vec3::new(f, f, 0.0)
            }
            Disturbance::Gusts(g) => g.rate_bound(),
            Disturbance::Sum(parts) => parts.iter().map(|d| d.rate_bound(r_max)).sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gusts_are_seeded_and_respect_their_bounds() {
        let amp = Vec3::new(2.0, 1.0, 0.5);
        let rate = Vec3::new(0.8, 0.4, 0.3);
        let g = Gusts::random(7, amp, rate);
        assert_eq!(g, Gusts::random(7, amp, rate));
        assert_ne!(g, Gusts::random(8, amp, rate));
        let d = Disturbance::Gusts(g);
        let bound = d.rate_bound(0.0);
        assert!(bound.x <= 0.8 + 1e-12 && bound.y <= 0.4 + 1e-12 && bound.z <= 0.3 + 1e-12);
        let h = 1e-3;
        for k in 0..200_000 {
            let t = k as f64 * h;
            let (a, b) = (d.value(t, 0.0), d.value(t + h, 0.0));
            for c in 0..3 {
                assert!(a[c].abs() <= amp[c] + 1e-12);
                assert!(((b[c] - a[c]) / h).abs() <= bound[c] * 1.0001);
            }
        }
    }

    #[test]
    fn a_current_turns_with_the_vessel() {
        let d = Disturbance::Current { fx: 10.0, fy: 0.0 };
        let ahead = d.value(0.0, 0.0);
        assert!((ahead.x - 10.0).abs() < 1e-12 && ahead.y.abs() < 1e-12);
        // Heading north, an eastward push comes from the starboard... i.e. −y body.
        let north = d.value(0.0, std::f64::consts::FRAC_PI_2);
        assert!(north.x.abs() < 1e-12 && (north.y + 10.0).abs() < 1e-12);
    }
}
