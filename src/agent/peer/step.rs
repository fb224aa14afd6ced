//! One tick of the coverage loop on board a vessel of a peer fleet: its
//! range-limited cell among the neighbours it hears
//! ([`coverage::range`](crate::coverage::range)), its centroid, and the
//! mission's safety layer with the neighbours as the traffic; the same
//! engine functions as the coordinator's tick, for one vessel.
//!
//! Invariants: only fresh, believed neighbours are in the partition (a
//! silent one's water is taken over, a quarantined one is not trusted
//! with any); every neighbour not yet forgotten is in the safety filter's
//! traffic, a silent one with its uncertainty radius, and neither a
//! silent nor a quarantined one trusted to keep its half of a gap; a
//! neighbour with another β than this vessel's bounds its cell by a
//! circle (the engine's curved cells);
//! while the fleet is split and a plan is followed ([`split`](super::split)),
//! the vessel steers to its planned place instead of its centroid and the
//! other group is traffic both where the plan has it and where it fell
//! silent. Pure: no I/O, no clock.

use super::split::Orders;
use super::table::Neighbour;
use crate::control::Vec3;
use crate::control::barrier::{Margin, Scratch};
use crate::control::guidance::Guidance;
use crate::control::model::State;
use crate::coverage::range::{interaction_distance, local_cell, reach};
use crate::coverage::{CellGeometry, CellResult, Options, Vessel};
use crate::geometry::Point;
use crate::mission::Mission;
use crate::protocol::CommandDocument;

/// What the loop computed: the command for the hull, and the cell.
#[derive(Debug, Clone)]
pub struct Step {
    pub command: CommandDocument,
    pub cell: CellResult,
    /// Neighbours in the partition.
    pub partition: usize,
}

/// The neighbour's state as the safety filter reads it.
fn state_of(n: &Neighbour) -> State {
    let b = &n.beacon;
    State {
        x: b.x,
        y: b.y,
        psi: b.psi,
        vel: Vec3::new(b.u, b.v, b.r),
    }
}

/// How far from a vessel of `actuator` (k, β as the wire carries them) a
/// neighbour of actuator (k, β) can still matter [m]: its cell (the interaction
/// distance of [`coverage::range`](crate::coverage::range); 2r for the same
/// actuator) or its safety filter (the safety distance plus the barrier's
/// horizon for two hulls closing at the mission's top speed), whichever
/// is farther. A neighbour farther than that (plus how far it may have
/// gone since its beacon) changes neither; the table leaves it out
/// ([`Table::neighbours_near`](super::table::Table::neighbours_near)).
pub fn relevance(mission: &Mission, actuator: (f64, f64)) -> impl Fn(f64, f64) -> f64 {
    let (k, beta) = actuator;
    let origin = Point { x: 0.0, y: 0.0 };
    let own = Vessel {
        position: origin,
        k,
        beta,
    };
    let same = 2.0 * reach(beta);
    let barrier = mission.safety().barrier();
    let g = &mission.guidance();
    let safety = barrier.safety_distance + barrier.horizon(2.0 * g.max_speed, g.max_yaw_rate);
    move |other_k, other_beta| {
        let cell = if other_k == k && other_beta == beta {
            same
        } else {
            let other = Vessel {
                position: origin,
                k: other_k,
                beta: other_beta,
            };
            interaction_distance(&own, &other)
        };
        cell.max(safety)
    }
}

/// One tick: `own` is this vessel's state and actuator (k, β as the wire
/// carries them), `risk` the density it covers (the mission's, or the
/// fleet's learned belief), `t` its mission time, `tick` the command's number;
/// `orders` a split's plan's (the other group, silent in `neighbours`,
/// then kept clear of twice: where it fell silent and where the plan has
/// it).
#[allow(clippy::too_many_arguments)]
pub fn step(
    mission: &Mission,
    risk: &crate::coverage::RiskField,
    own: &State,
    actuator: (f64, f64),
    neighbours: &[Neighbour],
    orders: Option<&Orders>,
    guidance: &mut Guidance,
    t: f64,
    tick: u64,
    scratch: &mut Scratch,
) -> Step {
    let (k, beta) = actuator;
    let me = Vessel {
        position: Point { x: own.x, y: own.y },
        k,
        beta,
    };
    let fresh: Vec<Vessel> = neighbours
        .iter()
        .filter(|n| n.in_partition())
        .map(|n| Vessel {
            position: Point {
                x: n.beacon.x,
                y: n.beacon.y,
            },
            k: n.beacon.k,
            beta: n.beacon.beta,
        })
        .collect();
    let partition = fresh.len();
    let options = Options::default();
    let cell = local_cell(mission.region(), risk, me, fresh, &options)
        .or_else(|| local_cell(mission.region(), risk, me, [], &options))
        .expect("a lone vessel of a valid mission is a valid fleet");
    let planned = orders.map_or(&[][..], |o| &o.others[..]);
    let mut states = Vec::with_capacity(neighbours.len() + planned.len() + 1);
    states.push(*own);
    states.extend(neighbours.iter().map(state_of));
    states.extend(planned.iter().map(|(_, s)| *s));
    let template = Guidance::new(mission.guidance());
    let gains = vec![&template; states.len()];
    let layer = &mission.layer();
    let tick_inputs = layer.prepare_with(t, &states, &gains, |i| match i {
        0 => Margin::KNOWN,
        i if i <= neighbours.len() => match &neighbours[i - 1] {
            n if n.in_partition() => Margin::KNOWN,
            n => Margin {
                radius: n.silent.map_or(0.0, |s| s.radius),
                reciprocal: false,
            },
        },
        _ => Margin {
            radius: orders.map_or(0.0, |o| o.radius),
            reciprocal: false,
        },
    });
    // A plan's place is a goal of its own: no cell to keep it in.
    let goal = orders.map(|o| CellResult {
        mass: cell.mass,
        centroid: o.target,
        area: cell.area,
        gradient: cell.gradient,
        geometry: CellGeometry::Empty,
    });
    let safe = layer.command(
        &tick_inputs,
        0,
        own,
        goal.as_ref().unwrap_or(&cell),
        guidance,
        scratch,
    );
    let (cmd, c) = (safe.command, cell.centroid);
    Step {
        command: CommandDocument {
            tick,
            u_d: cmd.u_d,
            r_d: cmd.r_d,
            u_d_dot: cmd.u_d_dot,
            r_d_dot: cmd.r_d_dot,
            centroid: [c.x, c.y],
            e: cmd.e,
            psi_e: cmd.psi_e,
            hold: None,
            station: guidance
                .keeping_station()
                .then_some([safe.towards.x, safe.towards.y]),
        },
        cell,
        partition,
    }
}

/// A pose as the state the loop steps from.
pub fn state_of_pose(p: &crate::protocol::PoseDocument) -> crate::control::model::State {
    crate::control::model::State {
        x: p.x,
        y: p.y,
        psi: p.psi,
        vel: crate::control::Vec3::new(p.u, p.v, p.r),
    }
}

/// The command to keep station where the vessel is, and why.
pub fn hold(
    tick: u64,
    own: &crate::control::model::State,
    why: &str,
) -> crate::protocol::CommandDocument {
    crate::protocol::CommandDocument {
        tick,
        u_d: 0.0,
        r_d: 0.0,
        u_d_dot: 0.0,
        r_d_dot: 0.0,
        centroid: [own.x, own.y],
        e: 0.0,
        psi_e: 0.0,
        hold: Some(why.into()),
        station: None,
    }
}
