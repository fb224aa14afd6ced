//! Vessel parameters, presets and the 3-DOF dynamics (paper eq. 1 and 3):
//!
//! ```text
//! ẋ = u cos ψ − v sin ψ,  ẏ = u sin ψ + v cos ψ,  ψ̇ = r
//! m11 u̇ = m22 v r − d11 u + τ_u + τ_ud
//! m22 v̇ = −m11 u r − d22 v + τ_vd
//! m33 ṙ = −(m22 − m11) u v − d33 r + τ_r + τ_rd
//! ```
//!
//! Integrated with classical RK4 at a fixed step, the control input held over
//! the step (zero-order hold, as a digital controller applies it) and the
//! disturbance evaluated at the stage times. Inputs saturate at the preset's
//! force and moment limits before they reach the hull.

use super::{Vec3, wrap};

/// Rigid-body plus added mass and linear damping of the diagonal model, and
/// actuator limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VesselParams {
    /// Surge mass, added mass included [kg].
    pub m11: f64,
    /// Sway mass, added mass included [kg].
    pub m22: f64,
    /// Yaw moment of inertia, added inertia included [kg m²].
    pub m33: f64,
    /// Linear surge damping [kg/s].
    pub d11: f64,
    /// Linear sway damping [kg/s].
    pub d22: f64,
    /// Linear yaw damping [kg m²/s].
    pub d33: f64,
    /// Surge force limits [N]: τ_u ∈ [−tau_u_reverse, tau_u_max].
    pub tau_u_max: f64,
    /// The astern surge force limit, as a magnitude [N].
    pub tau_u_reverse: f64,
    /// Yaw moment limit [N m]: |τ_r| ≤ tau_r_max.
    pub tau_r_max: f64,
}

impl VesselParams {
    /// The paper's vessel (section 5): m11 = m22 = m33 = 2000, d11 = 20,
    /// d22 = 30, d33 = 35. The paper gives no actuator limits; 2000 N and
    /// 2000 N m (1 m/s², 1 rad/s² at rest) are generous enough never to bind
    /// in its scenario.
    pub const PAPER: VesselParams = VesselParams {
        m11: 2000.0,
        m22: 2000.0,
        m33: 2000.0,
        d11: 20.0,
        d22: 30.0,
        d33: 35.0,
        tau_u_max: 2000.0,
        tau_u_reverse: 2000.0,
        tau_r_max: 2000.0,
    };

    /// The Maritime Robotics Otter, a 2 m twin-hull USV, reduced to the
    /// diagonal model from T. I. Fossen, *Handbook of Marine Craft
    /// Hydrodynamics and Motion Control*, 2nd ed., Wiley 2021, and his Otter
    /// model in the MSS / Python Vehicle Simulator:
    /// - mass 55 kg hull + 25 kg payload = 80 kg; added mass X_u̇ = −0.1·55,
    ///   Y_v̇ = −1.5·55, N_ṙ = −1.7 I_z, giving m11 = 85.5 kg, m22 = 162.5 kg,
    ///   m33 = 41.4 kg m² (Fossen's own figure for yaw inertia with added mass);
    /// - X_u = −24.4 g / U_max with U_max = 6 kn: d11 = 77.5 kg/s;
    ///   N_r = −m33 / T_yaw with T_yaw = 1 s: d33 = 41.4 kg m²/s;
    /// - Y_v is 0 in that model (sway is damped by quadratic cross-flow drag,
    ///   ≈ 200 |v| v N for its 2 m × 0.2 m draft pontoons with Hoerner's
    ///   C_d ≈ 1); d22 = 100 kg/s is its secant at 0.5 m/s;
    /// - bollard pull 24.4 kgf ahead and 13.6 kgf astern for the two
    ///   propellers together, 0.395 m either side of the centre line: τ_u ∈
    ///   [−133, 239] N and |τ_r| ≤ 73 N m (one ahead, one astern).
    pub const OTTER: VesselParams = VesselParams {
        m11: 85.5,
        m22: 162.5,
        m33: 41.4,
        d11: 77.5,
        d22: 100.0,
        d33: 41.4,
        tau_u_max: 239.0,
        tau_u_reverse: 133.0,
        tau_r_max: 73.0,
    };

    /// A preset by name (`paper`, `otter`).
    pub fn preset(name: &str) -> Option<VesselParams> {
        match name {
            "paper" => Some(Self::PAPER),
            "otter" => Some(Self::OTTER),
            _ => None,
        }
    }

    /// Names accepted by [`preset`](Self::preset).
    pub const PRESETS: [&'static str; 2] = ["paper", "otter"];

    /// M as a vector (m11, m22, m33).
    pub fn mass(&self) -> Vec3 {
        Vec3::new(self.m11, self.m22, self.m33)
    }

    /// N(V) = (m22 v r − d11 u, −m11 u r − d22 v, −(m22 − m11) u v − d33 r):
    /// Coriolis and damping forces, so that M V̇ = N(V) + τ + τ_d.
    pub fn n(&self, v: Vec3) -> Vec3 {
        let (u, sv, r) = (v.x, v.y, v.z);
        Vec3::new(
            self.m22 * sv * r - self.d11 * u,
            -self.m11 * u * r - self.d22 * sv,
            -(self.m22 - self.m11) * u * sv - self.d33 * r,
        )
    }

    /// Clamps (τ_u, τ_r) to the actuator limits.
    pub fn saturate(&self, tau_u: f64, tau_r: f64) -> (f64, f64) {
        (
            tau_u.clamp(-self.tau_u_reverse, self.tau_u_max),
            tau_r.clamp(-self.tau_r_max, self.tau_r_max),
        )
    }
}

/// Pose η = (x, y, ψ) and body velocity V = (u, v, r).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct State {
    /// East position x in the mission's plane [m].
    pub x: f64,
    /// North position y [m].
    pub y: f64,
    /// Heading ψ, counter-clockwise from east, in (−π, π] [rad].
    pub psi: f64,
    /// Body velocity V: surge u [m/s], sway v [m/s] (to port), yaw rate
    /// r [rad/s].
    pub vel: Vec3,
}

impl State {
    /// Velocity over ground in the earth frame.
    pub fn ground_velocity(&self) -> (f64, f64) {
        let (s, c) = self.psi.sin_cos();
        (
            self.vel.x * c - self.vel.y * s,
            self.vel.x * s + self.vel.y * c,
        )
    }
}

type Deriv = (f64, f64, f64, Vec3);

fn deriv(p: &VesselParams, s: &State, tau: Vec3, tau_d: Vec3) -> Deriv {
    let (c, sn) = (s.psi.cos(), s.psi.sin());
    let (u, v, r) = (s.vel.x, s.vel.y, s.vel.z);
    let acc = (p.n(s.vel) + tau + tau_d).component_div(&p.mass());
    (u * c - v * sn, u * sn + v * c, r, acc)
}

fn add(s: &State, d: &Deriv, h: f64) -> State {
    State {
        x: s.x + h * d.0,
        y: s.y + h * d.1,
        psi: s.psi + h * d.2,
        vel: s.vel + d.3 * h,
    }
}

/// One RK4 step of length `h` from time `t` with the input (τ_u, τ_r) held
/// (after saturation) and the disturbance `tau_d(t, state)` sampled at stage
/// times (it may depend on the heading, as a current's force does).
/// Returns the new state and the input actually applied.
pub fn step(
    p: &VesselParams,
    s: &State,
    tau_u: f64,
    tau_r: f64,
    t: f64,
    h: f64,
    tau_d: impl Fn(f64, &State) -> Vec3,
) -> (State, (f64, f64)) {
    let (tu, tr) = p.saturate(tau_u, tau_r);
    let tau = Vec3::new(tu, 0.0, tr);
    let stage = |s: &State, t: f64| deriv(p, s, tau, tau_d(t, s));
    let k1 = stage(s, t);
    let k2 = stage(&add(s, &k1, h / 2.0), t + h / 2.0);
    let k3 = stage(&add(s, &k2, h / 2.0), t + h / 2.0);
    let k4 = stage(&add(s, &k3, h), t + h);
    let mut next = State {
        x: s.x + h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0),
        y: s.y + h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1),
        psi: s.psi + h / 6.0 * (k1.2 + 2.0 * k2.2 + 2.0 * k3.2 + k4.2),
        vel: s.vel + (k1.3 + k2.3 * 2.0 + k3.3 * 2.0 + k4.3) * (h / 6.0),
    };
    next.psi = wrap(next.psi);
    (next, (tu, tr))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surge_decays_with_its_time_constant() {
        let p = VesselParams::PAPER;
        let mut s = State {
            vel: Vec3::new(1.0, 0.0, 0.0),
            ..State::default()
        };
        let h = 0.01;
        for k in 0..10_000 {
            s = step(&p, &s, 0.0, 0.0, k as f64 * h, h, |_, _| Vec3::zeros()).0;
        }
        // u(t) = e^{−d11 t / m11}, t = 100 s.
        assert!((s.vel.x - (-20.0 * 100.0 / 2000.0f64).exp()).abs() < 1e-9);
        // x(t) = (m11/d11)(1 − e^{−t d11/m11}).
        assert!((s.x - 100.0 * (1.0 - (-1.0f64).exp())).abs() < 1e-6);
    }

    #[test]
    fn turning_with_equal_masses_rotates_the_body_not_the_velocity() {
        // m11 = m22 and no damping: the ground velocity is conserved while
        // the hull spins: why the literal law fails on the paper's vessel
        // (docs/reproducing-the-paper.md), in its pure form.
        let p = VesselParams {
            d11: 0.0,
            d22: 0.0,
            d33: 0.0,
            ..VesselParams::PAPER
        };
        let mut s = State {
            vel: Vec3::new(1.0, 0.0, 0.5),
            ..State::default()
        };
        let h = 0.001;
        for k in 0..5000 {
            s = step(&p, &s, 0.0, 0.0, k as f64 * h, h, |_, _| Vec3::zeros()).0;
        }
        let (vx, vy) = s.ground_velocity();
        assert!((vx - 1.0).abs() < 1e-9 && vy.abs() < 1e-9, "{vx} {vy}");
        assert!((s.psi - 2.5).abs() < 1e-9);
    }

    #[test]
    fn inputs_saturate() {
        let p = VesselParams::OTTER;
        let (_, applied) = step(&p, &State::default(), 1e6, -1e6, 0.0, 0.001, |_, _| {
            Vec3::zeros()
        });
        assert_eq!(applied, (239.0, -73.0));
    }
}
