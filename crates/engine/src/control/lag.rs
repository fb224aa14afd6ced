//! How far behind a goal that moves the `course` guidance settles: the
//! distance at which its speed profile S(E) asks for the goal's speed. A
//! peer vessel following a split plan (a goal moving at a constant speed)
//! steers that far ahead of where the plan has it, so that its hull is
//! where the plan has it.

use super::guidance::GuidanceGains;
use super::sigmoid;

impl GuidanceGains {
    /// The distance to its goal at which the `course` mode's speed profile
    /// S(E) asks for `speed` [m]: how far behind a goal that moves at that
    /// speed a vessel settles (the arrival fade, 5 cm, aside). S rises
    /// strictly from S(0) = 0, so bisection finds it; a speed at or above
    /// the cap has no such distance (infinity).
    pub fn lag(&self, speed: f64) -> f64 {
        if speed <= 0.0 {
            return 0.0;
        }
        if speed >= self.max_speed {
            return f64::INFINITY;
        }
        let s = |e: f64| self.k_u1 * (sigmoid(self.b2 * e) - 0.5) + self.k_u2 * e;
        let (mut lo, mut hi) = (0.0, 1.0);
        while s(hi) < speed {
            if hi > 1e6 {
                return f64::INFINITY;
            }
            hi *= 2.0;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if s(mid) < speed {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Vec3;
    use crate::control::guidance::Guidance;
    use crate::control::model::State;

    /// At the lag for a speed, the `course` law asks for that speed (read
    /// off `desired_velocity`, not off the profile `lag` inverts).
    #[test]
    fn the_lag_is_where_the_law_asks_for_the_speed() {
        let gains = GuidanceGains::default();
        let g = Guidance::new(gains);
        let s = State {
            x: 0.0,
            y: 0.0,
            psi: 0.0,
            vel: Vec3::zeros(),
        };
        for speed in [0.05, 0.2, 0.5, 1.5] {
            let e = gains.lag(speed);
            let (wx, wy) = g.desired_velocity(&s, (e, 0.0), e);
            assert!((wx.hypot(wy) - speed).abs() < 1e-9, "{speed}: {e} → {wx}");
        }
        assert_eq!(gains.lag(0.0), 0.0);
        assert_eq!(gains.lag(gains.max_speed), f64::INFINITY);
    }
}
