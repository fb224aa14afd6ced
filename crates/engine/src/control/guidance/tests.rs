//! The guidance laws held to their formulas and to the command line's
//! bounds.

use super::*;
use crate::control::Vec3;

#[test]
fn paper_law_matches_its_formula_and_holds_station_on_arrival() {
    let gains = GuidanceGains {
        mode: GuidanceMode::Paper,
        ..GuidanceGains::default()
    };
    let mut g = Guidance::new(gains);
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::zeros(),
    };
    let c = g.update(0.0, &s, (3.0, 4.0));
    let psi_e = 4f64.atan2(3.0);
    assert!((c.e - 5.0).abs() < 1e-12 && (c.psi_e - psi_e).abs() < 1e-12);
    assert!((c.u_d - ((sigmoid(5.0) - 0.5) + 0.5)).abs() < 1e-12);
    assert!((c.r_d - ((sigmoid(psi_e) - 0.5) + psi_e)).abs() < 1e-12);
    let stop = g.update(0.1, &s, (0.01, 0.0));
    assert_eq!((stop.u_d, stop.r_d), (0.0, 0.0));
}

/// `n` commands 0.1 s apart for a vessel held in `state`, the last one.
fn settle(g: &mut Guidance, t0: f64, n: usize, state: &State, goal: (f64, f64)) -> Command {
    (0..n)
        .map(|k| g.update(t0 + 0.1 * k as f64, state, goal))
        .last()
        .unwrap()
}

#[test]
fn course_mode_turns_towards_the_velocity_error_and_brakes() {
    let mut g = Guidance::new(GuidanceGains::default());
    // Drifting north at 1 m/s with the bow east, goal due east.
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::new(0.0, 1.0, 0.0),
    };
    let c = g.update(0.0, &s, (10.0, 0.0));
    // w_d = (S, 0); Δw = (S, −1): the bow must turn to starboard (ψ_e < 0).
    // The first command starts at the hull's own velocity and heads there.
    assert!(c.psi_e < 0.0 && c.r_d == 0.0 && c.r_d_dot < 0.0, "{c:?}");
    assert!(c.u_d == 0.0 && c.u_d_dot > 0.0, "{c:?}");
    let c = settle(&mut g, 0.1, 10, &s, (10.0, 0.0));
    assert!(c.r_d < 0.0 && c.u_d > 0.0, "{c:?}");
    // Goal behind: surge is asked to go astern, not to turn round first.
    let back = settle(
        &mut g,
        2.0,
        30,
        &State {
            vel: Vec3::zeros(),
            ..s
        },
        (-10.0, 0.0),
    );
    assert!(back.u_d < 0.0, "{back:?}");
    assert!(back.psi_e.abs() < 1e-12);
}

#[test]
fn course_commands_are_continuous_lines_with_bounded_rates() {
    let gains = GuidanceGains::default();
    let mut g = Guidance::new(gains);
    let mut last: Option<(f64, Command)> = None;
    // A vessel swinging about while its goal jumps round it: the raw law
    // jumps (astern flips, heading error swings); the commands may not.
    for k in 0..400 {
        let t = 0.1 * k as f64;
        let a = 0.37 * k as f64;
        let s = State {
            x: a.sin(),
            y: (1.3 * a).cos(),
            psi: 2.0 * (0.5 * a).sin(),
            vel: Vec3::new(1.5 * (0.7 * a).cos(), 0.3 * a.sin(), 0.8 * (1.1 * a).sin()),
        };
        let goal = if (k / 25) % 2 == 0 {
            (20.0, 5.0)
        } else {
            (-15.0, -8.0)
        };
        let bound = if (k / 40) % 3 == 2 {
            (-0.2, 0.4)
        } else {
            UNBOUNDED
        };
        let c = g.track(t, &s, goal, 20.0, g.desired_velocity(&s, goal, 20.0), bound);
        assert!(c.r_d.abs() <= gains.max_yaw_rate + 1e-12, "{c:?}");
        assert!(c.r_d_dot.abs() <= gains.yaw_accel + 1e-12, "{c:?}");
        assert!(c.u_d_dot.abs() <= gains.surge_accel + 1e-12, "{c:?}");
        assert!((bound.0..=bound.1).contains(&c.u_d), "{c:?}");
        if let Some((t0, p)) = last {
            // Where the previous line got to, except where the surge
            // bound moved past it.
            assert!((c.r_d - (p.r_d + p.r_d_dot * (t - t0))).abs() < 1e-12);
            let u = p.u_d + p.u_d_dot * (t - t0);
            assert!(
                (c.u_d - u).abs() < 1e-12 || c.surge_cut > 0.0,
                "{c:?} {p:?}"
            );
        }
        last = Some((t, c));
    }
    // A command after a gap starts afresh, from the vessel's velocity.
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::new(0.3, 0.0, -0.2),
    };
    let c = g.update(100.0, &s, (5.0, 5.0));
    assert_eq!((c.u_d, c.r_d), (0.3, -0.2));
}

#[test]
fn a_vessel_is_asked_for_no_more_than_its_declared_agility() {
    let gains = GuidanceGains::default();
    let agility = Agility {
        yaw_accel: 0.3,
        surge_accel: 0.2,
    };
    let mut slow = Guidance::new(gains);
    slow.agility = agility;
    let mut nimble = Guidance::new(gains);
    let (mut slow_peak, mut nimble_peak) = (0.0f64, 0.0f64);
    // At rest, bow east, goal behind to the north-west: a hard turn.
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::zeros(),
    };
    for k in 0..50 {
        let t = 0.1 * k as f64;
        let c = slow.update(t, &s, (-20.0, 15.0));
        assert!(c.r_d_dot.abs() <= agility.yaw_accel + 1e-12, "{c:?}");
        assert!(c.u_d_dot.abs() <= agility.surge_accel + 1e-12, "{c:?}");
        slow_peak = slow_peak.max(c.r_d_dot.abs());
        nimble_peak = nimble_peak.max(nimble.update(t, &s, (-20.0, 15.0)).r_d_dot.abs());
    }
    // Both ramp as fast as they may: the bound is the one that binds.
    assert!((slow_peak - agility.yaw_accel).abs() < 1e-12, "{slow_peak}");
    assert!(
        (nimble_peak - gains.yaw_accel).abs() < 1e-12,
        "{nimble_peak}"
    );
}

/// The paper's run without the filter, t = 20.9 s: usv-8 going astern
/// at 0.41 m/s with 1 m/s of sway to starboard, turning at 0.92 rad/s.
/// Unforced, its surge falls at v r = −0.93 m/s²; its actuators' share
/// (0.75 m/s²) cannot make it rise. Bounded around zero, the command
/// asked for +0.75 m/s² and the vessel's governor fell 0.075 m/s behind.
#[test]
fn a_declared_surge_agility_bounds_the_rate_around_the_hulls_own() {
    let agility = Agility {
        yaw_accel: 0.75,
        surge_accel: 0.75,
    };
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::new(-0.41, -1.0, 0.925),
    };
    let natural = s.vel.y * s.vel.z;
    // Goal ahead, bow nearly along the velocity change: the law wants
    // the surge to rise from astern to ahead.
    let goal = (10.0, 0.0);
    let mut g = Guidance::new(GuidanceGains::default());
    g.agility = agility;
    let mut free = Guidance::new(GuidanceGains::default());
    for k in 0..5 {
        let t = 0.1 * k as f64;
        let c = g.update(t, &s, goal);
        assert!(
            (c.u_d_dot - natural).abs() <= agility.surge_accel + 1e-12,
            "{c:?}"
        );
        // A vessel that declared nothing is bounded by the mission's
        // 0.75 m/s² around zero, and asked for more than the hull can.
        let f = free.update(t, &s, goal);
        assert!(f.u_d_dot > natural + agility.surge_accel, "{f:?}");
    }
}

/// The safety filter's surge bound jumps where a bow swings across the
/// normal of a constraint its sway alone does not meet (the networked demo:
/// usv-8's bound went from u ≥ 0.46 to u ≤ −0.41 in one tick). A vessel
/// that declared its agility has its line go there along its slope at that
/// rate, no step: its governor would take the step no faster. One that
/// declared nothing is put inside at once.
#[test]
fn a_bound_that_jumps_is_approached_at_the_declared_agility() {
    let agility = Agility {
        yaw_accel: 0.75,
        surge_accel: 0.75,
    };
    // Going ahead at 0.4 m/s, bow east, goal ahead: the law wants more.
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::new(0.4, 0.0, 0.0),
    };
    let goal = (30.0, 0.0);
    let w = Guidance::new(GuidanceGains::default()).desired_velocity(&s, goal, 30.0);
    let mut g = Guidance::new(GuidanceGains::default());
    g.agility = agility;
    let mut free = Guidance::new(GuidanceGains::default());
    let (jump, after) = ((0.3, 2.0), (-2.0, -0.4));
    let mut last: Option<(f64, Command)> = None;
    let mut inside_by = None;
    for k in 0..40 {
        let t = 0.1 * k as f64;
        let bound = if k < 10 { jump } else { after };
        let c = g.track(t, &s, goal, 30.0, w, bound);
        let f = free.track(t, &s, goal, 30.0, w, bound);
        assert!((bound.0..=bound.1).contains(&f.u_d), "{f:?}");
        if let Some((t0, p)) = last {
            // Continuous (where the previous line got to), at no more
            // than the declared rate (v r = 0).
            let since = t - t0;
            let expected = p.u_d + p.u_d_dot * since;
            assert!((c.u_d - expected).abs() < 1e-12, "{c:?} {p:?}");
            assert!(p.u_d_dot.abs() <= agility.surge_accel + 1e-12, "{p:?}");
            if k == 10 {
                // From where the line was to the bound at the declared rate.
                let needed = (expected - after.1) / agility.surge_accel;
                inside_by = Some(t + needed);
            }
        }
        if k >= 10 {
            // The law wants more than the bound: the command is cut.
            assert!(c.surge_cut > 0.0, "{k}: {c:?}");
            if c.u_d > after.1 {
                // Outside, it heads down as fast as declared, and not for
                // longer than that takes.
                let reaches = (c.u_d + c.u_d_dot * 0.1 - after.1).abs() < 1e-12;
                assert!(c.u_d_dot == -agility.surge_accel || reaches, "{c:?}");
                assert!(t < inside_by.unwrap(), "{k}: {c:?}");
            }
        }
        last = Some((t, c));
    }
    let (_, end) = last.unwrap();
    assert!((end.u_d - after.1).abs() < 1e-12, "{end:?}");
}

#[test]
fn a_vessel_that_cannot_go_astern_turns_round_instead() {
    let mut g = Guidance::new(GuidanceGains::default());
    g.ahead_only = true;
    // At rest, bow east, goal due west and a little north: it must turn
    // to port (the shorter way round) and not ask for a negative surge.
    let s = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::zeros(),
    };
    let max = GuidanceGains::default().max_yaw_rate;
    for k in 0..20 {
        let c = g.update(0.1 * k as f64, &s, (-10.0, 1.0));
        assert!(c.u_d >= 0.0, "{c:?}");
        assert!((c.r_d_dot > 0.0 || c.r_d == max) && c.psi_e > 1.9, "{c:?}");
        assert!(k == 0 || c.r_d > 0.0, "{c:?}");
    }
    // ... and makes steerage way to do it, which a vessel that can go
    // astern does not (it coasts, and thrusts astern).
    let c = settle(&mut g, 2.0, 20, &s, (-10.0, 1.0));
    assert!((c.u_d - STEERAGE).abs() < 1e-9, "{c:?}");
    let mut both = Guidance::new(GuidanceGains::default());
    assert!(settle(&mut both, 0.0, 20, &s, (-10.0, 1.0)).u_d < 0.0);
    // At its goal it stays put.
    let mut at_goal = Guidance::new(GuidanceGains::default());
    at_goal.ahead_only = true;
    assert_eq!(settle(&mut at_goal, 0.0, 20, &s, (0.0, 0.0)).u_d, 0.0);
    // Moving ahead at 1 m/s, goal behind: no astern thrust to brake.
    let moving = State {
        vel: Vec3::new(1.0, 0.0, 0.0),
        ..s
    };
    let c = settle(&mut g, 2.0, 10, &moving, (-10.0, 1.0));
    assert!(c.u_d >= 0.0 && c.r_d > 0.0, "{c:?}");
}

/// A vessel that holds a position by itself keeps station from its own,
/// wider radius; never where the mission turned station keeping off.
#[test]
fn a_declared_station_radius_widens_where_keeping_starts() {
    let at_rest = State {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        vel: Vec3::zeros(),
    };
    let goal = (2.0, 0.0);
    let keeps = |hold_radius: f64, station_radius: Option<f64>| {
        let mut g = Guidance::new(GuidanceGains {
            hold_radius,
            ..GuidanceGains::default()
        });
        g.station_radius = station_radius;
        settle(&mut g, 0.0, 30, &at_rest, goal);
        g.keeping_station()
    };
    assert!(!keeps(0.2, None));
    assert!(keeps(0.2, Some(3.0)));
    assert!(!keeps(0.2, Some(1.5)));
    assert!(!keeps(0.0, Some(3.0)));
    // And it ends beyond twice the radius (the vessel pushed off).
    let mut g = Guidance::new(GuidanceGains::default());
    g.station_radius = Some(3.0);
    settle(&mut g, 0.0, 30, &at_rest, goal);
    let off = |x: f64| State { x, ..at_rest };
    settle(&mut g, 3.0, 30, &off(-3.5), goal);
    assert!(g.keeping_station());
    settle(&mut g, 6.0, 30, &off(-4.5), goal);
    assert!(!g.keeping_station());
}
