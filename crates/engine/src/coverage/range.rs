//! The range-limited cell: what one vessel of a peer fleet computes on
//! board from the neighbours it hears, and why it is the centralized cell
//! where it matters.
//!
//! ## Definition
//! A vessel's actuator reaches r_i = √(ln(1/ε) / β_i), ε = [`NEGLIGIBLE`]:
//! beyond it f_i(q)/k_i = exp(−β_i ‖q − p_i‖²) < ε, so the vessel neither
//! covers anything there nor is needed there. Its range-limited cell is its
//! generalized Voronoi cell among itself and the vessels j within the
//! [`interaction_distance`] of it ([`relevant`]; 2r in a fleet of one
//! actuator), and
//! [`local_cell`] evaluates it with the same engine as the centralized
//! [`evaluate`](super::evaluate()).
//!
//! ## Equality with the centralized cell
//! One k and one β first. Let q be in the disc D_i = {‖q − p_i‖ ≤ r_i}
//! and j a vessel with ‖p_j − p_i‖ > 2r. Then ‖q − p_j‖ ≥ ‖p_j − p_i‖ −
//! ‖q − p_i‖ > r ≥ ‖q − p_i‖, so f_i(q) > f_j(q): j takes nothing of D_i
//! from i. Hence V_i(local) ∩ D_i = V_i(all) ∩ D_i: the two cells are the
//! same set on the disc, and outside it they can differ only where f_i <
//! ε k_i, so the mass M_i = ∫ f_i Φ and the f_i Φ-weighted centroid differ
//! by less than ε k_i Φ_max |Q| (`tests/it/engine.rs` and the tests below
//! check both, and that with every vessel within range the cells are the
//! centralized ones bit for bit).
//!
//! Any k and β (the generalized cells of eq. 6, curved where β differs):
//! on D_i, f_i ≥ ε k_i. Let ρ(j, i) = √(ln(max(k_j/k_i, 1)/ε)/β_j): beyond
//! it from p_j, f_j < ε k_i. If ‖p_j − p_i‖ > r_i + ρ(j, i), every q in D_i
//! is farther than ρ(j, i) from p_j, so f_j(q) < ε k_i ≤ f_i(q), and the
//! argument above holds as it stands. [`interaction_distance`] is the
//! larger of r_i + ρ(j, i) and r_j + ρ(i, j), so that i and j agree;
//! with one actuator it is 2r. (An earlier form summed both radii each
//! widened by the other's gain, which falls short when the stronger vessel
//! is also the wider: a test below.)

//! ## Cost
//! Selecting neighbours is one distance test per vessel heard; the cell
//! is then [`cell`] (the power diagram's when β is common): the relevant vessels (~140 at the paper's
//! density) sorted by distance, the own cell clipped by the nearest until
//! no farther one can cut it (~15), and its integrals. Bounded by the
//! density, not the fleet (`cargo bench --bench peer`,
//! docs/performance.md).

use super::cells::cell;
use super::density::RiskField;
use super::evaluate::{CellResult, Options, cell_figures};
use super::fleet::{Fleet, Vessel};
use crate::geometry::{Region, norm2};

/// ε: the share of its peak below which an actuator's performance counts
/// as nothing.
pub const NEGLIGIBLE: f64 = 1e-6;

/// r: the distance beyond which exp(−β r²) < [`NEGLIGIBLE`].
pub fn reach(beta: f64) -> f64 {
    ((1.0 / NEGLIGIBLE).ln() / beta).sqrt()
}

/// How far from `own` `other` can still take water within `own`'s reach,
/// or `own` within `other`'s (see the module doc): the larger of
/// r_own + ρ(other, own) and r_other + ρ(own, other). Symmetric, so two
/// vessels agree on whether they matter to each other.
pub fn interaction_distance(own: &Vessel, other: &Vessel) -> f64 {
    let one_way = |a: &Vessel, b: &Vessel| reach(a.beta) + outreach(b, a);
    one_way(own, other).max(one_way(other, own))
}

/// ρ(v, w): beyond it v's actuator is below ε k_w, what w's own is at
/// w's reach: √(ln(max(k_v / k_w, 1) / ε) / β_v).
fn outreach(v: &Vessel, w: &Vessel) -> f64 {
    let ratio = (v.k / w.k).max(1.0);
    ((ratio / NEGLIGIBLE).ln() / v.beta).sqrt()
}

/// Whether `other` can matter to `own`'s range-limited cell.
pub fn relevant(own: &Vessel, other: &Vessel) -> bool {
    let d = interaction_distance(own, other);
    norm2(other.position - own.position) <= d * d
}

/// The range-limited cell of `own` among `others` (every vessel it hears;
/// the irrelevant ones are left out here): its figures, computed exactly
/// as [`evaluate`](super::evaluate()) computes a cell. `None` when the
/// relevant vessels do not make a valid [`Fleet`] (a position or an
/// actuator out of range).
pub fn local_cell(
    region: &Region,
    risk: &RiskField,
    own: Vessel,
    others: impl IntoIterator<Item = Vessel>,
    options: &Options,
) -> Option<CellResult> {
    let mut vessels = vec![own];
    vessels.extend(others.into_iter().filter(|o| relevant(&own, o)));
    let fleet = Fleet::new(vessels).ok()?;
    let geometry = cell(region, &fleet, 0);
    let mut near = Vec::new();
    Some(cell_figures(
        region, risk, &own, geometry, options, &mut near,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::evaluate;
    use crate::coverage::{RiskObject, evaluate::Options};
    use crate::geometry::Point;
    use rand::{RngExt, SeedableRng};

    fn square(side: f64) -> Region {
        Region::new(
            vec![
                Point { x: 0.0, y: 0.0 },
                Point { x: side, y: 0.0 },
                Point { x: side, y: side },
                Point { x: 0.0, y: side },
            ],
            vec![],
        )
        .unwrap()
    }

    fn fleet(n: usize, side: f64, seed: u64) -> Vec<Vessel> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| Vessel {
                position: Point {
                    x: rng.random_range(0.0..side),
                    y: rng.random_range(0.0..side),
                },
                k: 0.5,
                beta: 0.001,
            })
            .collect()
    }

    #[test]
    fn the_reach_is_where_the_actuator_falls_to_a_millionth() {
        let r = reach(0.001);
        assert!((r - 117.539).abs() < 0.001, "{r}");
        assert!(((-0.001 * r * r).exp() - NEGLIGIBLE).abs() < 1e-12);
    }

    #[test]
    fn with_every_vessel_in_range_the_cells_are_the_centralized_ones_bit_for_bit() {
        let region = square(100.0);
        let risk = RiskField::new(1.0, vec![]).unwrap();
        let vessels = fleet(8, 100.0, 3);
        let all = evaluate(
            &region,
            &risk,
            &Fleet::new(vessels.clone()).unwrap(),
            &Options::default(),
        );
        for (i, own) in vessels.iter().enumerate() {
            // The node puts itself first; the others in any order.
            let others = vessels
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, v)| *v);
            let local = local_cell(&region, &risk, *own, others, &Options::default()).unwrap();
            assert_eq!(local.mass, all.cells[i].mass, "vessel {i}");
            assert_eq!(local.centroid, all.cells[i].centroid, "vessel {i}");
        }
    }

    /// A weaker, narrower vessel and a stronger, wider one just beyond
    /// what each needs of the other: on the weaker one's disc of reach
    /// the stronger still wins nothing, so leaving it out changes nothing
    /// there. On the boundary point toward it (the likeliest to be lost)
    /// and just outside the interaction distance.
    #[test]
    fn a_stronger_wider_vessel_beyond_the_interaction_distance_takes_nothing_within_reach() {
        for (weak, strong) in [((0.5, 0.004), (1.0, 0.001)), ((0.2, 0.01), (2.0, 0.0005))] {
            let own = Vessel {
                position: Point { x: 0.0, y: 0.0 },
                k: weak.0,
                beta: weak.1,
            };
            let mut other = Vessel {
                position: Point { x: 0.0, y: 0.0 },
                k: strong.0,
                beta: strong.1,
            };
            let d = interaction_distance(&own, &other) * (1.0 + 1e-9);
            other.position.x = d;
            assert!(!relevant(&own, &other));
            assert_eq!(
                interaction_distance(&other, &own),
                interaction_distance(&own, &other)
            );
            // Where own's actuator falls to ε, toward the other.
            let r = reach(own.beta);
            let f = |v: &Vessel, x: f64| v.k * (-v.beta * (x - v.position.x).powi(2)).exp();
            assert!(
                f(&other, r) < f(&own, r),
                "{weak:?} vs {strong:?}: at {r} m the other has {:e} against {:e}",
                f(&other, r),
                f(&own, r)
            );
        }
    }

    #[test]
    fn in_a_wide_fleet_the_local_cell_is_the_centralized_one_within_reach() {
        // 300 vessels over 1.2 km: most neighbours are out of range.
        let side = 1200.0;
        let region = square(side);
        let risk = RiskField::new(
            0.02,
            vec![RiskObject {
                center: Point { x: 600.0, y: 600.0 },
                alpha: 3.0,
                sigma: 150.0,
            }],
        )
        .unwrap();
        let vessels = fleet(300, side, 7);
        let options = Options::default();
        let all = evaluate(
            &region,
            &risk,
            &Fleet::new(vessels.clone()).unwrap(),
            &options,
        );
        let r = reach(0.001);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut left_out = 0;
        for (i, own) in vessels.iter().enumerate().step_by(7) {
            let others: Vec<Vessel> = vessels
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, v)| *v)
                .collect();
            left_out += others.iter().filter(|o| !relevant(own, o)).count();
            let local = local_cell(&region, &risk, *own, others, &options).unwrap();
            let central = &all.cells[i];
            // The same set on the disc of reach.
            for _ in 0..400 {
                let a = rng.random_range(0.0..std::f64::consts::TAU);
                let d = r * rng.random_range(0.0f64..1.0).sqrt();
                let q = own.position
                    + Point {
                        x: a.cos(),
                        y: a.sin(),
                    } * d;
                if region.contains(q) {
                    assert_eq!(
                        local.geometry.contains(q),
                        central.geometry.contains(q),
                        "vessel {i} at {q:?}"
                    );
                }
            }
            // Mass and centroid agree but for what lies beyond the reach.
            let bound = NEGLIGIBLE * own.k * risk.value(Point { x: 600.0, y: 600.0 }) * side * side;
            assert!(
                (local.mass - central.mass).abs() <= bound,
                "vessel {i}: {} vs {}",
                local.mass,
                central.mass
            );
            let shift = norm2(local.centroid - central.centroid).sqrt();
            assert!(shift < 1e-3, "vessel {i}: centroid moved {shift} m");
        }
        assert!(
            left_out > 1000,
            "the fleet was not wide: {left_out} left out"
        );
    }
}
