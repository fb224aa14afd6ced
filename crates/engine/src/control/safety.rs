//! Safe motion for the whole fleet, one coverage tick at a time: the one
//! function both `seacover sim` and the coordinator's tick call, so that a
//! simulated fleet and a networked one behave identically.
//!
//! ## Pipeline, per tick
//! 1. **Goal** ([`coverage::goal`](crate::coverage::goal)): the vessel's
//!    cell centroid, projected to the nearest point of its own piece of the
//!    cell and moved `shore_distance + goal_margin` off the shore — a
//!    centroid on an island or across a pier becomes a point the vessel can
//!    reach and hold.
//! 2. **Route** ([`Roadmap`]): the shortest path to the goal round islands and
//!    piers, through waypoints `shore_distance + goal_margin` off their
//!    corners; the vessel steers at the route's first point, with the speed
//!    the whole route's remaining length asks for.
//! 3. **Nominal command**: the `course` guidance's desired ground velocity
//!    along that line ([`Guidance::desired_velocity`]).
//! 4. **Filter** ([`barrier`](super::barrier), when `filter` is on): the
//!    nearest velocity to the nominal one that keeps every gap to other
//!    vessels (≥ `safety_distance`) and to the shore (≥ `shore_distance`)
//!    closing no faster than the hull can still stop.
//! 5. **Tracking**: the `course` guidance turns that ground velocity into
//!    (u_d, r_d) for the underactuated hull ([`Guidance::track`]); with the
//!    filter on, u_d is held to the surges that keep every gap along the
//!    bow with the present sway (the hull's thrust is along its bow while
//!    it turns; see [`barrier`](super::barrier)), reaching them at the rate
//!    the vessel declared it can follow.
//!
//! With `reachable_goals` off, steps 1–2 are skipped and each vessel steers
//! straight at its centroid: with the filter off too, that is exactly the
//! plain guidance of the paper's pipeline (`seacover sim --safety none`).
//!
//! Under `guidance = paper` the literal law steers the bow at the route's
//! first point; it has no desired ground velocity, so the filter cannot act
//! on it and reports no intervention (the literal law is for reproducing
//! the paper; the filter needs the default `course` mode).
//!
//! ## Contract of [`SafetyLayer::commands`]
//! - Inputs, all in the same order (the partition's): the vessels' states
//!   (x, y, ψ, u, v, r), their cells from the evaluation of exactly those
//!   positions ([`CellResult`]: centroid and geometry), and each vessel's
//!   [`Guidance`] (its filters carry history from tick to tick; pass the same
//!   one every tick). `t` is the mission time in seconds.
//! - The layer is built once per region and parameters
//!   ([`SafetyLayer::new`], which validates the parameters and precomputes
//!   the route map); rebuild it when either changes.
//! - Output: one [`SafeCommand`] per vessel, in the same order: the command to
//!   send, whether the filter changed the nominal velocity by more than
//!   `tolerance` (`intervened`), the goal and the point steered at.
//! - Pure and deterministic: no I/O, no clocks; a vessel's filter uses only
//!   the positions, so the result does not depend on the order of the
//!   vessels beyond being returned in it. It cannot fail: an empty cell, a
//!   goal without a route, or contradictory constraints all give a command
//!   (see the modules named above); it never returns NaN for finite states.
//! - Slices of different lengths are a caller's bug: only the common prefix
//!   is served (and debug builds assert).
//! - Cost: O(n k) for k neighbours within reach, plus, for vessels whose goal
//!   is out of sight, O(W) visibility tests against the route map's W
//!   waypoints; at 1000 vessels about a quarter of the evaluation's time
//!   (`cargo bench --bench sim -- safety` against `--bench evaluate`).

use std::borrow::{Borrow, BorrowMut};

use super::barrier::{Barrier, Margin, Mover, Safe, Scratch, Traffic};
use super::guidance::{Command, Guidance, GuidanceMode};
use super::model::State;
use crate::coverage::goal::reachable_goal;
use crate::coverage::{CellResult, InputError};
use crate::geometry::roadmap::Roadmap;
use crate::geometry::shore::Shore;
use crate::geometry::{Point, Region, norm2};

/// Safety parameters of a mission.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyParams {
    /// Whether the barrier filter acts.
    pub filter: bool,
    /// Whether vessels steer for reachable goals along routes round islands
    /// (steps 1–2 of the pipeline); without, they steer straight at their
    /// centroids, as the paper's fleet does.
    pub reachable_goals: bool,
    /// Least distance between two vessels' centres [m].
    pub safety_distance: f64,
    /// Least distance from a vessel's centre to the shore (shell and
    /// islands) [m].
    pub shore_distance: f64,
    /// The barrier's reaction time τ [s].
    pub reaction_time: f64,
    /// The barrier's braking deceleration a [m/s²].
    pub braking: f64,
    /// The barrier predicts gaps this far ahead at the actual closing speed
    /// [s].
    pub lookahead: f64,
    /// Goals and route waypoints keep this much more than `shore_distance`
    /// from the shore, so a vessel holding its goal does not lean on the
    /// filter [m].
    pub goal_margin: f64,
    /// A change of the desired velocity larger than this counts as an
    /// intervention [m/s].
    pub tolerance: f64,
}

impl Default for SafetyParams {
    /// Sized for the paper's vessel (a 2-tonne hull, taken as a disc of
    /// radius 2 m): 8 m between centres (twice the 4 m a collision needs),
    /// 4 m from the shore; τ and a measured in `docs/safety.md`.
    fn default() -> Self {
        SafetyParams {
            filter: true,
            reachable_goals: true,
            safety_distance: 8.0,
            shore_distance: 4.0,
            reaction_time: 2.5,
            braking: 0.5,
            lookahead: 2.0,
            goal_margin: 3.0,
            tolerance: 0.01,
        }
    }
}

impl SafetyParams {
    /// Checks every value; errors name the field as `safety.<name>`.
    pub fn validate(&self) -> Result<(), InputError> {
        use crate::coverage::check_range;
        let field = |name: &'static str| move || format!("safety.{name}");
        check_range(
            field("safety_distance"),
            self.safety_distance,
            0.0,
            true,
            1e4,
        )?;
        check_range(field("shore_distance"), self.shore_distance, 0.0, true, 1e4)?;
        check_range(
            field("reaction_time"),
            self.reaction_time,
            0.0,
            false,
            600.0,
        )?;
        check_range(field("braking"), self.braking, 0.0, false, 100.0)?;
        check_range(field("lookahead"), self.lookahead, 0.0, true, 600.0)?;
        check_range(field("goal_margin"), self.goal_margin, 0.0, true, 1e4)?;
        check_range(field("tolerance"), self.tolerance, 0.0, false, 1e3)?;
        Ok(())
    }

    /// The control barrier these parameters make.
    pub fn barrier(&self) -> Barrier {
        Barrier {
            safety_distance: self.safety_distance,
            shore_distance: self.shore_distance,
            reaction_time: self.reaction_time,
            braking: self.braking,
            lookahead: self.lookahead,
        }
    }

    /// The clearance goals and waypoints keep from the shore [m].
    pub fn goal_clearance(&self) -> f64 {
        self.shore_distance + self.goal_margin
    }
}

/// One vessel's result of a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafeCommand {
    /// What to send the vessel. `e` is the remaining route length to the goal.
    pub command: Command,
    /// The reachable goal (the centroid, projected; see the module doc).
    pub goal: Point,
    /// Where the vessel steers now: the goal, or the route's next waypoint.
    pub towards: Point,
    /// The nominal desired ground velocity [m/s].
    pub nominal: Point,
    /// The filtered desired ground velocity [m/s]: `nominal` when the filter
    /// is off or under the `paper` law.
    pub filtered: Point,
    /// Whether the filter changed the nominal velocity by more than the
    /// tolerance.
    pub intervened: bool,
}

/// The region's shore and route map with the mission's safety parameters.
#[derive(Debug, Clone)]
pub struct SafetyLayer {
    params: SafetyParams,
    shore: Shore,
    roadmap: Roadmap,
}

impl SafetyLayer {
    /// Validates `params` and precomputes the route map of `region`.
    pub fn new(region: &Region, params: SafetyParams) -> Result<SafetyLayer, InputError> {
        params.validate()?;
        let shore = Shore::new(region);
        // Chords of a waypoint arc pass at ≥ 0.7 of its radius from the
        // corner (see `geometry::roadmap`); a little less keeps them usable.
        let clearance = params.goal_clearance();
        let roadmap = Roadmap::new(&shore, clearance, 0.65 * clearance);
        Ok(SafetyLayer {
            params,
            shore,
            roadmap,
        })
    }

    /// The mission's safety parameters.
    pub fn params(&self) -> &SafetyParams {
        &self.params
    }

    /// The region's shore, indexed for distance queries.
    pub fn shore(&self) -> &Shore {
        &self.shore
    }

    /// The route map round the islands, at the goals' clearance.
    pub fn roadmap(&self) -> &Roadmap {
        &self.roadmap
    }

    /// The commands of one tick; see the module doc for the contract.
    /// [`SafetyLayer::prepare`] then [`SafetyLayer::command`] for every
    /// vessel, on every core for large fleets (the same result either way).
    pub fn commands<G: BorrowMut<Guidance> + Send>(
        &self,
        t: f64,
        states: &[State],
        cells: &[CellResult],
        guidance: &mut [G],
    ) -> Vec<SafeCommand> {
        debug_assert!(states.len() == cells.len() && cells.len() == guidance.len());
        let n = states.len().min(cells.len()).min(guidance.len());
        let tick = self.prepare(t, &states[..n], &guidance[..n]);
        crate::coverage::map_each(
            guidance[..n].iter_mut().collect(),
            n >= crate::coverage::PARALLEL_MIN,
            |i, g: &mut G, scratch: &mut Scratch| {
                self.command(&tick, i, &states[i], &cells[i], g.borrow_mut(), scratch)
            },
        )
    }

    /// The fleet-wide part of a tick: what every vessel's filter reads of
    /// the others (positions, actual velocities, the neighbour grid). Then
    /// [`SafetyLayer::command`] serves each vessel on its own.
    pub fn prepare<G: Borrow<Guidance>>(
        &self,
        t: f64,
        states: &[State],
        guidance: &[G],
    ) -> SafetyTick<'_> {
        self.prepare_with(t, states, guidance, |_| Margin::KNOWN)
    }

    /// [`SafetyLayer::prepare`] with a [`Margin`] for each vessel: a peer
    /// node passes its neighbours as it last heard them, each with the
    /// room it keeps for what it does not know of them (a silent neighbour
    /// is still there, somewhere near where it was last heard).
    pub fn prepare_with<G: Borrow<Guidance>>(
        &self,
        t: f64,
        states: &[State],
        guidance: &[G],
        margin: impl Fn(usize) -> Margin,
    ) -> SafetyTick<'_> {
        let traffic = self.params.filter.then(|| {
            Traffic::new(
                &self.params.barrier(),
                &self.shore,
                states
                    .iter()
                    .zip(guidance)
                    .enumerate()
                    .map(|(i, (s, g))| {
                        let gains = g.borrow().gains;
                        let (vx, vy) = s.ground_velocity();
                        Mover {
                            position: Point { x: s.x, y: s.y },
                            actual: Point { x: vx, y: vy },
                            bow: Point {
                                x: s.psi.cos(),
                                y: s.psi.sin(),
                            },
                            max_speed: gains.max_speed,
                            turn_rate: gains.max_yaw_rate,
                            margin: margin(i),
                        }
                    })
                    .collect(),
            )
        });
        SafetyTick { t, traffic }
    }

    /// Vessel `i`'s command: `state`, `cell` and `guidance` are its own, `i`
    /// its index in the states given to [`SafetyLayer::prepare`]. Vessels
    /// may be served in any order and on any thread.
    pub fn command(
        &self,
        tick: &SafetyTick<'_>,
        i: usize,
        state: &State,
        cell: &CellResult,
        guidance: &mut Guidance,
        scratch: &mut Scratch,
    ) -> SafeCommand {
        let s = state;
        let p = Point { x: s.x, y: s.y };
        // Goal, route and nominal velocity.
        let straight = |goal: Point| (goal, (goal.x - p.x).hypot(goal.y - p.y));
        let (goal, (towards, remaining)) = if self.params.reachable_goals {
            let goal = reachable_goal(&self.shore, cell, p, self.params.goal_clearance());
            let leg = self.roadmap.leg(&self.shore, p, goal);
            (goal, leg.map_or(straight(goal), |l| (l.towards, l.length)))
        } else {
            (cell.centroid, straight(cell.centroid))
        };
        let (wx, wy) = guidance.desired_velocity(s, (towards.x, towards.y), remaining);
        let nominal = Point { x: wx, y: wy };
        let to = (towards.x, towards.y);
        if guidance.gains.mode == GuidanceMode::Paper {
            let command = guidance.track(
                tick.t,
                s,
                to,
                remaining,
                (nominal.x, nominal.y),
                super::guidance::UNBOUNDED,
            );
            return SafeCommand {
                command,
                goal,
                towards,
                nominal,
                filtered: nominal,
                intervened: false,
            };
        }
        let Safe { velocity: w, surge } = match &tick.traffic {
            Some(traffic) => traffic.solve(i, nominal, scratch),
            None => Safe {
                velocity: nominal,
                surge: (f64::NEG_INFINITY, f64::INFINITY),
            },
        };
        // The thrust is along the bow: ask only for the surge that
        // keeps every gap while the hull turns (see `barrier`).
        let command = guidance.track(tick.t, s, to, remaining, (w.x, w.y), surge);
        SafeCommand {
            command,
            goal,
            towards,
            nominal,
            filtered: w,
            intervened: command.surge_cut > self.params.tolerance
                || norm2(w - nominal).sqrt() > self.params.tolerance,
        }
    }
}

/// One tick's fleet-wide inputs to [`SafetyLayer::command`]
/// ([`SafetyLayer::prepare`]).
#[derive(Debug)]
pub struct SafetyTick<'a> {
    t: f64,
    /// The others as the filter sees them; `None` with the filter off.
    traffic: Option<Traffic<'a>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Vec3;
    use crate::control::guidance::GuidanceGains;
    use crate::coverage::{Fleet, Options, RiskField, Vessel, evaluate};

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    #[test]
    fn in_open_water_far_from_everything_it_is_exactly_the_plain_guidance() {
        let region = crate::geometry::region::fixtures::square(false);
        let layer = SafetyLayer::new(&region, SafetyParams::default()).unwrap();
        let states: Vec<State> = [(20.0, 30.0, 0.3), (70.0, 65.0, -2.0), (40.0, 80.0, 1.0)]
            .iter()
            .map(|&(x, y, psi)| State {
                x,
                y,
                psi,
                vel: Vec3::new(0.4, 0.1, 0.05),
            })
            .collect();
        let fleet = Fleet::new(
            states
                .iter()
                .map(|s| Vessel {
                    position: p(s.x, s.y),
                    k: 0.5,
                    beta: 0.001,
                })
                .collect(),
        )
        .unwrap();
        let eval = evaluate(
            &region,
            &RiskField::new(0.1, vec![]).unwrap(),
            &fleet,
            &Options::default(),
        );
        let mut safe: Vec<Guidance> = (0..3)
            .map(|_| Guidance::new(GuidanceGains::default()))
            .collect();
        let mut plain = safe.clone();
        for tick in 0..3 {
            let t = tick as f64 * 0.1;
            let got = layer.commands(t, &states, &eval.cells, &mut safe);
            for i in 0..3 {
                let c = eval.cells[i].centroid;
                let want = plain[i].update(t, &states[i], (c.x, c.y));
                assert_eq!(got[i].command, want);
                assert!(!got[i].intervened);
            }
        }
    }

    #[test]
    fn without_goals_and_filter_it_is_the_plain_guidance_even_at_the_shore() {
        let region = crate::geometry::region::fixtures::square(false);
        let params = SafetyParams {
            filter: false,
            reachable_goals: false,
            ..SafetyParams::default()
        };
        let layer = SafetyLayer::new(&region, params).unwrap();
        let states = vec![State {
            x: 0.5,
            y: 3.0,
            psi: 1.0,
            vel: Vec3::new(0.3, 0.0, 0.0),
        }];
        let fleet = Fleet::new(vec![Vessel {
            position: p(0.5, 3.0),
            k: 0.5,
            beta: 0.001,
        }])
        .unwrap();
        let risk = RiskField::new(
            0.1,
            vec![crate::coverage::RiskObject {
                center: p(2.0, 2.0),
                alpha: 50.0,
                sigma: 3.0,
            }],
        )
        .unwrap();
        let eval = evaluate(&region, &risk, &fleet, &Options::default());
        let mut safe = vec![Guidance::new(GuidanceGains::default())];
        let mut plain = safe.clone();
        let got = layer.commands(0.0, &states, &eval.cells, &mut safe);
        let c = eval.cells[0].centroid;
        assert_eq!(got[0].command, plain[0].update(0.0, &states[0], (c.x, c.y)));
        assert_eq!(got[0].goal, c);
    }

    #[test]
    fn rejects_bad_parameters_naming_the_field() {
        let region = Region::new(vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)], vec![]).unwrap();
        let bad = SafetyParams {
            braking: 0.0,
            ..SafetyParams::default()
        };
        let e = SafetyLayer::new(&region, bad).unwrap_err();
        assert!(e.to_string().starts_with("safety.braking:"), "{e}");
    }
}
