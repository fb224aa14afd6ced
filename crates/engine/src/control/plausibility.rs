//! Whether a vessel's reported pose can be believed, judged per vessel: the
//! one rule every path that takes poses from outside applies (the
//! coordinator's vessel links, the MAVLink bridge, a peer's neighbours'
//! beacons), so that one bad member is set apart alone and the rest of the
//! fleet never stops.
//!
//! A pose is refused when
//! - a number is not finite, or a position is outside the engine's
//!   coordinates (±[`MAX_COORDINATE`]): the partition could not take it;
//! - its clock went backwards;
//! - it is farther outside the task region than [`Limits::margin`];
//! - a speed it reports (|u|, |v|, |r|) or the speed implied by the last
//!   believed pose (distance over the vessel's own clock, less a
//!   [`Limits::jump`] for position noise) is beyond the hull's limits;
//! - its source says its fix is poor ([`Fix`]).
//!
//! A refused pose puts the vessel in **quarantine**: out of the partition,
//! commanded to hold, until [`Limits::release`] poses in a row agree with
//! each other (each plausible after the one before, by the same rules),
//! spanning at least [`Limits::release_time`] of its clock. The track the
//! release is judged on starts at the first pose after the refusal, not at
//! the last believed one: a vessel whose clock restarted, or whose fix came
//! back somewhere else, is released once it is consistent again, and is
//! then judged by the region's margin like any other.
//!
//! Invariants: pure and deterministic; a refused pose never becomes the
//! reference of the next judgement of a vessel in good standing; every
//! number this module returns is finite.

use crate::geometry::Point;
use crate::geometry::region::{MAX_COORDINATE, Region};

/// What a vessel's pose is judged against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// The fastest a hull of the fleet goes over ground [m/s].
    pub max_speed: f64,
    /// The fastest it turns [rad/s].
    pub max_yaw_rate: f64,
    /// Position noise allowed between two poses on top of the speed [m]
    /// (a GNSS fix wanders by metres).
    pub jump: f64,
    /// How far outside the task region a vessel may be [m].
    pub margin: f64,
    /// Poses in a row that agree, to leave quarantine.
    pub release: u32,
    /// Vessel-clock time those poses must span [s].
    pub release_time: f64,
}

impl Default for Limits {
    /// 10 m/s (about 20 knots, beyond any survey USV's top speed and twice
    /// the Otter's), 2 rad/s, 5 m of noise, 500 m outside the region, and
    /// 10 poses over 2 s to be released.
    fn default() -> Self {
        Limits {
            max_speed: 10.0,
            max_yaw_rate: 2.0,
            jump: 5.0,
            margin: 500.0,
            release: 10,
            release_time: 2.0,
        }
    }
}

/// A pose as judged: the vessel's clock, its position in the mission's
/// plane and its body velocities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The vessel's own clock [s].
    pub t: f64,
    /// East position x [m].
    pub x: f64,
    /// North position y [m].
    pub y: f64,
    /// Heading ψ [rad].
    pub psi: f64,
    /// Surge speed u [m/s].
    pub u: f64,
    /// Sway speed v [m/s].
    pub v: f64,
    /// Yaw rate r [rad/s].
    pub r: f64,
}

/// The quality of a position fix, where the source reports one (an
/// autopilot's GNSS fix type and its estimator's health).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fix {
    /// The source says nothing (a simulated hull, a plain link).
    #[default]
    Unreported,
    /// A 3-D fix or better and a healthy estimator.
    Good,
    /// No 3-D fix.
    NoFix,
    /// The estimator reports its position unusable.
    Estimator,
}

/// Why a pose was refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fault {
    /// A number is NaN or infinite.
    NotFinite,
    /// x or y beyond ±[`MAX_COORDINATE`].
    OutOfRange,
    /// The vessel's clock went back by this much [s].
    TimeBackwards(f64),
    /// Farther outside the region than the margin, by this distance [m].
    OutsideRegion(f64),
    /// A reported speed beyond the hull's [m/s or rad/s].
    Reported(&'static str, f64),
    /// The speed implied by the last believed pose [m/s].
    Jump(f64),
    /// The source's fix is poor.
    Fix(Fix),
}

impl Fault {
    /// A short stable name, for counters' labels and wire codes.
    pub fn code(&self) -> &'static str {
        match self {
            Fault::NotFinite => "not_finite",
            Fault::OutOfRange => "out_of_range",
            Fault::TimeBackwards(_) => "time_backwards",
            Fault::OutsideRegion(_) => "outside_region",
            Fault::Reported(..) => "too_fast",
            Fault::Jump(_) => "jump",
            Fault::Fix(_) => "fix",
        }
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::NotFinite => write!(f, "a number is not finite"),
            Fault::OutOfRange => write!(
                f,
                "x and y must be in [-{MAX_COORDINATE:e}, {MAX_COORDINATE:e}] m"
            ),
            Fault::TimeBackwards(dt) => write!(f, "its clock went back {dt:.3} s"),
            Fault::OutsideRegion(d) => write!(f, "{d:.0} m outside the task region"),
            Fault::Reported(name, value) => {
                write!(f, "reported {name} {value:.2} is beyond the hull's limit")
            }
            Fault::Jump(speed) => write!(
                f,
                "moved at {speed:.1} m/s since its last believed pose, beyond the hull's limit"
            ),
            Fault::Fix(Fix::NoFix) => write!(f, "no 3-D GNSS fix"),
            Fault::Fix(_) => write!(f, "its estimator reports the position unusable"),
        }
    }
}

/// What [`Judge::judge`] decided about one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Believed: the vessel is in good standing.
    Accepted,
    /// Refused; the vessel is (or stays) in quarantine.
    Refused(Fault),
    /// Plausible, but the vessel is still in quarantine for `fault` until
    /// more poses agree.
    Probation(Fault),
}

impl Verdict {
    /// Whether the pose was believed ([`Verdict::Accepted`]).
    pub fn accepted(&self) -> bool {
        matches!(self, Verdict::Accepted)
    }
}

/// One vessel's judge: its last believed pose and its quarantine.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Judge {
    /// The last pose believed (in good standing) or, in quarantine, the
    /// last pose of the track being judged for release.
    last: Option<Sample>,
    quarantine: Option<Quarantine>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Quarantine {
    /// The first refusal's reason.
    fault: Fault,
    /// Poses in a row that agree, and the clock of the first of them.
    agreeing: u32,
    since: f64,
}

impl Judge {
    /// A judge for a vessel in good standing with no pose yet.
    pub fn new() -> Judge {
        Judge::default()
    }

    /// Why the vessel is in quarantine, if it is.
    pub fn quarantined(&self) -> Option<Fault> {
        self.quarantine.map(|q| q.fault)
    }

    /// Judges `pose` (with its source's `fix`) against `limits` and, when
    /// given, the task `region`.
    pub fn judge(
        &mut self,
        pose: &Sample,
        fix: Fix,
        limits: &Limits,
        region: Option<&Region>,
    ) -> Verdict {
        let fault = alone(pose, fix, limits, region)
            .or_else(|| self.last.and_then(|last| between(&last, pose, limits)));
        match (fault, &mut self.quarantine) {
            (None, None) => {
                self.last = Some(*pose);
                Verdict::Accepted
            }
            (Some(fault), quarantine) => {
                // A finite pose starts the track a release is judged on;
                // in good standing the believed one stays the reference.
                let finite = !matches!(fault, Fault::NotFinite | Fault::OutOfRange);
                match quarantine {
                    Some(q) => {
                        q.agreeing = 0;
                        if finite {
                            self.last = Some(*pose);
                        }
                    }
                    None => {
                        self.quarantine = Some(Quarantine {
                            fault,
                            agreeing: 0,
                            since: pose.t,
                        });
                        // Judging starts afresh from the next pose: the
                        // believed one may be the wrong one (a restarted
                        // clock, a fix that came back elsewhere).
                        self.last = None;
                    }
                }
                Verdict::Refused(fault)
            }
            (None, Some(q)) => {
                if q.agreeing == 0 {
                    q.since = pose.t;
                }
                q.agreeing += 1;
                self.last = Some(*pose);
                if q.agreeing >= limits.release && pose.t - q.since >= limits.release_time {
                    self.quarantine = None;
                    Verdict::Accepted
                } else {
                    Verdict::Probation(q.fault)
                }
            }
        }
    }
}

/// What is wrong with `pose` by itself.
fn alone(pose: &Sample, fix: Fix, limits: &Limits, region: Option<&Region>) -> Option<Fault> {
    let Sample {
        t,
        x,
        y,
        psi,
        u,
        v,
        r,
    } = *pose;
    if ![t, x, y, psi, u, v, r].iter().all(|n| n.is_finite()) {
        return Some(Fault::NotFinite);
    }
    if x.abs() > MAX_COORDINATE || y.abs() > MAX_COORDINATE {
        return Some(Fault::OutOfRange);
    }
    if matches!(fix, Fix::NoFix | Fix::Estimator) {
        return Some(Fault::Fix(fix));
    }
    let speed = u.hypot(v);
    if speed > limits.max_speed {
        return Some(Fault::Reported("speed", speed));
    }
    if r.abs() > limits.max_yaw_rate {
        return Some(Fault::Reported("yaw rate", r.abs()));
    }
    if let Some(region) = region {
        let p = Point { x, y };
        let q = region.closest_point(p);
        let outside = (p.x - q.x).hypot(p.y - q.y);
        if outside > limits.margin {
            return Some(Fault::OutsideRegion(outside));
        }
    }
    None
}

/// What is wrong with `pose` coming after `last`.
fn between(last: &Sample, pose: &Sample, limits: &Limits) -> Option<Fault> {
    let dt = pose.t - last.t;
    if dt < 0.0 {
        return Some(Fault::TimeBackwards(-dt));
    }
    let moved = (pose.x - last.x).hypot(pose.y - last.y);
    if moved > limits.max_speed * dt + limits.jump {
        // The speed it implies, beyond the noise allowed (a pose at the
        // same instant somewhere else is infinitely fast).
        let speed = if dt > 0.0 {
            (moved - limits.jump) / dt
        } else {
            f64::MAX
        };
        return Some(Fault::Jump(speed));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t: f64, x: f64, y: f64) -> Sample {
        Sample {
            t,
            x,
            y,
            psi: 0.0,
            u: 1.0,
            v: 0.0,
            r: 0.0,
        }
    }

    fn run(judge: &mut Judge, poses: &[Sample]) -> Vec<Verdict> {
        let limits = Limits::default();
        poses
            .iter()
            .map(|p| judge.judge(p, Fix::Unreported, &limits, None))
            .collect()
    }

    #[test]
    fn a_steady_track_is_believed() {
        let mut judge = Judge::new();
        let track: Vec<Sample> = (0..50)
            .map(|i| at(i as f64 * 0.05, i as f64 * 0.05, 0.0))
            .collect();
        assert!(run(&mut judge, &track).iter().all(Verdict::accepted));
        assert_eq!(judge.quarantined(), None);
    }

    #[test]
    fn a_thousand_kilometre_jump_is_refused_and_the_vessel_quarantined() {
        let mut judge = Judge::new();
        run(&mut judge, &[at(0.0, 0.0, 0.0), at(0.05, 0.05, 0.0)]);
        let v = run(&mut judge, &[at(0.10, 1.0e6, 0.0)]);
        assert!(
            matches!(v[0], Verdict::Refused(Fault::Jump(s)) if s > 1e6),
            "{v:?}"
        );
        assert!(matches!(judge.quarantined(), Some(Fault::Jump(_))));
        // Back where it was: judged afresh from there (the pose before it
        // was 1000 km away), released once ten poses over two seconds of
        // its clock agree.
        let back: Vec<Sample> = (0..60)
            .map(|i| at(0.15 + i as f64 * 0.05, 0.1, 0.0))
            .collect();
        let verdicts = run(&mut judge, &back);
        let first = verdicts.iter().position(Verdict::accepted).unwrap();
        assert!(
            verdicts[..first]
                .iter()
                .all(|v| matches!(v, Verdict::Probation(Fault::Jump(_))))
        );
        let span = back[first].t - back[0].t;
        assert!(
            (2.0 - 1e-9..2.05 + 1e-9).contains(&span),
            "released after {span} s"
        );
        assert!(verdicts[first..].iter().all(Verdict::accepted));
        assert_eq!(judge.quarantined(), None);
    }

    #[test]
    fn refusals_out_of_range_not_finite_backwards_and_too_fast() {
        let limits = Limits::default();
        let mut judge = Judge::new();
        let good = at(1.0, 0.0, 0.0);
        assert!(
            judge
                .judge(&good, Fix::Unreported, &limits, None)
                .accepted()
        );
        let cases = [
            (at(1.1, 2.0e7, 0.0), "out_of_range"),
            (at(f64::NAN, 0.0, 0.0), "not_finite"),
            (
                Sample {
                    u: 30.0,
                    ..at(1.1, 0.0, 0.0)
                },
                "too_fast",
            ),
            (
                Sample {
                    r: 5.0,
                    ..at(1.1, 0.0, 0.0)
                },
                "too_fast",
            ),
        ];
        for (pose, code) in cases {
            let mut j = judge.clone();
            match j.judge(&pose, Fix::Unreported, &limits, None) {
                Verdict::Refused(f) => assert_eq!(f.code(), code, "{pose:?}"),
                v => panic!("{pose:?}: {v:?}"),
            }
        }
        let mut j = judge.clone();
        assert!(matches!(
            j.judge(&at(0.5, 0.0, 0.0), Fix::Unreported, &limits, None),
            Verdict::Refused(Fault::TimeBackwards(dt)) if (dt - 0.5).abs() < 1e-12
        ));
        let mut j = judge.clone();
        assert!(matches!(
            j.judge(&at(1.1, 0.0, 0.0), Fix::NoFix, &limits, None),
            Verdict::Refused(Fault::Fix(Fix::NoFix))
        ));
    }

    #[test]
    fn a_vessel_in_quarantine_stays_while_its_poses_disagree() {
        let mut judge = Judge::new();
        run(&mut judge, &[at(0.0, 0.0, 0.0), at(0.1, 1.0e6, 0.0)]);
        // Jumping between two places every pose: never released.
        let flapping: Vec<Sample> = (0..200)
            .map(|i| {
                at(
                    0.2 + i as f64 * 0.05,
                    if i % 2 == 0 { 0.0 } else { 1.0e6 },
                    0.0,
                )
            })
            .collect();
        assert!(run(&mut judge, &flapping).iter().all(|v| !v.accepted()));
        assert!(judge.quarantined().is_some());
    }

    #[test]
    fn a_restarted_clock_is_released_once_consistent() {
        let mut judge = Judge::new();
        run(&mut judge, &[at(100.0, 0.0, 0.0), at(100.05, 0.05, 0.0)]);
        let restarted: Vec<Sample> = (0..60).map(|i| at(i as f64 * 0.05, 0.1, 0.0)).collect();
        let verdicts = run(&mut judge, &restarted);
        assert!(matches!(
            verdicts[0],
            Verdict::Refused(Fault::TimeBackwards(_))
        ));
        assert!(verdicts.last().unwrap().accepted());
    }

    #[test]
    fn far_outside_the_region_is_refused() {
        let region = crate::geometry::region::fixtures::square(false);
        let (_, max) = region.bounds();
        let limits = Limits::default();
        let mut judge = Judge::new();
        let near = at(0.0, max.x + 100.0, 0.0);
        assert!(
            judge
                .judge(&near, Fix::Good, &limits, Some(&region))
                .accepted()
        );
        let far = at(0.1, max.x + 600.0, 0.0);
        let mut j = Judge::new();
        assert!(matches!(
            j.judge(&far, Fix::Good, &limits, Some(&region)),
            Verdict::Refused(Fault::OutsideRegion(d)) if (d - 600.0).abs() < 1e-9
        ));
    }
}
