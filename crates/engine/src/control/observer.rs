//! Finite-time disturbance observer (paper eq. 30, its Δ written so that Ω
//! obeys the super-twisting law below), one super-twisting loop per channel:
//!
//! ```text
//! Ω = M (V̄ − V)
//! M dV̄/dt = N(V) + τ + Δ,   Δ = −b₁ |Ω|^½ sign(Ω) + τ̄_d,   dτ̄_d/dt = −b₂ sign(Ω)
//! ```
//!
//! so that Ω̇ = −b₁|Ω|^½ sign(Ω) + (τ̄_d − τ_d) and the estimate τ̄_d converges to
//! τ_d in finite time when |τ̇_d| < b₂ (Levant's conditions; b₁ = 1.5 √b₂ by
//! default).
//!
//! ## Discretization
//! Explicit Euler makes a super-twisting loop chatter: sign(Ω) flips every
//! step and τ̄_d jumps by ±h b₂. This uses the *implicit* (backward Euler)
//! discretization of Brogliato, Polyakov & Efimov, "The implicit
//! discretization of the super-twisting sliding-mode control algorithm",
//! IEEE TAC 65(8), 2020: with z = Ω predicted without the sliding terms, the
//! new Ω⁺ solves Ω⁺ = z − h b₁ |Ω⁺|^½ s − h² b₂ s with s ∈ Sign(Ω⁺). For
//! |z| ≤ h² b₂ the solution is Ω⁺ = 0 exactly with s = z / (h² b₂), otherwise
//! s = sign(z) and √|Ω⁺| is the positive root of a quadratic. Once on the
//! sliding set the estimate moves continuously: no chattering at any step,
//! and the continuous-time convergence is kept.

use super::Vec3;
use super::model::VesselParams;

/// Observer gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObserverGains {
    /// b₁, the gain of the −b₁ |Ω|^½ sign(Ω) term (paper eq. 30).
    pub b1: f64,
    /// b₂ [N/s], the rate of the estimate, dτ̄_d/dt = −b₂ sign(Ω); it must
    /// exceed |τ̇_d| (paper Assumption 2).
    pub b2: f64,
}

impl ObserverGains {
    /// Gains for disturbances whose derivative stays below `rate`:
    /// b₂ = 1.5 rate, b₁ = 1.5 √b₂.
    pub fn for_rate(rate: f64) -> Self {
        let b2 = 1.5 * rate;
        ObserverGains {
            b1: 1.5 * b2.sqrt(),
            b2,
        }
    }
}

impl Default for ObserverGains {
    /// Enough for the paper's disturbances (|τ̇_d| ≤ 2) and gusts up to 3 N/s.
    fn default() -> Self {
        ObserverGains::for_rate(3.0)
    }
}

/// Observer state for one vessel.
#[derive(Debug, Clone, PartialEq)]
pub struct Observer {
    /// The observer's gains.
    pub gains: ObserverGains,
    params: VesselParams,
    /// V̄.
    v_bar: Vec3,
    /// τ̄_d.
    estimate: Vec3,
    /// The previous measurement.
    last_v: Option<Vec3>,
    /// The input acting since then.
    input: Vec3,
}

impl Observer {
    /// An observer for a hull with `params`, estimating τ̄_d = 0 until its
    /// second measurement (the first only sets V̄).
    pub fn new(params: VesselParams, gains: ObserverGains) -> Self {
        Observer {
            gains,
            params,
            v_bar: Vec3::zeros(),
            estimate: Vec3::zeros(),
            last_v: None,
            input: Vec3::zeros(),
        }
    }

    /// The current estimate τ̄_d.
    pub fn estimate(&self) -> Vec3 {
        self.estimate
    }

    /// Feeds the velocity measured now, `h` after the previous measurement:
    /// integrates the observer over that interval with the input recorded by
    /// [`actuate`](Self::actuate).
    pub fn measure(&mut self, v: Vec3, h: f64) {
        let Some(v_prev) = self.last_v.replace(v) else {
            self.v_bar = v;
            return;
        };
        let m = self.params.mass();
        // Trapezoidal drift: both ends are measured, and the explicit N(V_prev)
        // would leave an O(h |dN/dt|) error that the observer reads as a
        // disturbance during hard manoeuvres.
        let drive = (self.params.n(v_prev) + self.params.n(v)) * 0.5 + self.input;
        let (b1, b2) = (self.gains.b1, self.gains.b2);
        for c in 0..3 {
            // Ω⁺ without the sliding terms.
            let z = m[c] * (self.v_bar[c] - v[c]) + h * (drive[c] + self.estimate[c]);
            let (omega, s) = if z.abs() <= h * h * b2 {
                (0.0, z / (h * h * b2))
            } else {
                let s = z.signum();
                let rest = z.abs() - h * h * b2;
                let y = 0.5 * (-h * b1 + (h * h * b1 * b1 + 4.0 * rest).sqrt());
                (s * y * y, s)
            };
            self.estimate[c] -= h * b2 * s;
            // V̄⁺ from Ω⁺ = M (V̄⁺ − V⁺).
            self.v_bar[c] = v[c] + omega / m[c];
        }
    }

    /// Records the input τ = (τ_u, 0, τ_r) that acts from now until the next
    /// measurement (after saturation: what the hull really gets).
    pub fn actuate(&mut self, tau: Vec3) {
        self.input = tau;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::disturbance::{Disturbance, Gusts};
    use crate::control::model::{State, step};

    /// Runs a vessel under a steady input and `dist` for `seconds`; returns
    /// the largest estimation error after `after` seconds, and the error
    /// trace's total variation after that time (a chattering estimate has a
    /// large one).
    fn run(dist: &Disturbance, gains: ObserverGains, seconds: f64, after: f64) -> (f64, f64) {
        let p = VesselParams::PAPER;
        let mut obs = Observer::new(p, gains);
        let mut s = State::default();
        let h = 1e-3;
        let (mut worst, mut variation, mut prev) = (0.0f64, 0.0, None::<Vec3>);
        let n = (seconds / h) as usize;
        for k in 0..n {
            let t = k as f64 * h;
            // A manoeuvring vessel: surge, and a slow turn.
            let tau = Vec3::new(200.0 * (0.3 * t).sin(), 0.0, 50.0 * (0.2 * t).cos());
            obs.measure(s.vel, h);
            obs.actuate(tau);
            let err = obs.estimate() - dist.value(t, s.psi);
            if t >= after {
                worst = worst.max(err.amax());
                if let Some(p) = prev {
                    variation += (obs.estimate() - p).amax();
                }
                prev = Some(obs.estimate());
            }
            s = step(&p, &s, tau.x, tau.z, t, h, |t, st| dist.value(t, st.psi)).0;
        }
        (worst, variation)
    }

    #[test]
    fn estimates_the_papers_disturbances_within_10_s() {
        for i in 1..=8 {
            let (worst, variation) = run(
                &Disturbance::Paper { index: i },
                ObserverGains::default(),
                30.0,
                10.0,
            );
            assert!(worst < 0.05, "vessel {i}: error {worst}");
            // The true disturbance varies by ≈ 2·(2/π)·20 s·2 ≈ 50 over 20 s
            // in the largest channel; a chattering estimate would add h·b₂ per
            // step, i.e. ≥ 90 more.
            assert!(
                variation < 60.0,
                "vessel {i}: estimate varies by {variation}"
            );
        }
    }

    #[test]
    fn estimates_random_gusts_below_the_gain() {
        for seed in 0..5 {
            let gusts = Gusts::random(seed, Vec3::new(20.0, 10.0, 5.0), Vec3::new(2.5, 2.5, 2.5));
            let dist = Disturbance::Gusts(gusts);
            let b = dist.rate_bound(0.0);
            let gains = ObserverGains::default();
            assert!(b.amax() < gains.b2);
            let (worst, _) = run(&dist, gains, 30.0, 10.0);
            assert!(worst < 0.05, "seed {seed}: error {worst}");
        }
    }
}
