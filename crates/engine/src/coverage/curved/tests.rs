//! The arc quadrature against finer rules and an independent reference.

use super::*;
use crate::coverage::boundary::polygon_integrals;
use crate::coverage::boundary::tests::ulps;
use crate::coverage::dominance::cell_bounds;
use crate::coverage::fleet::Vessel;
use crate::geometry::Region;
use crate::geometry::arcs::{Bound, boundary, contains};
use crate::geometry::region::fixtures::square;
use geo::orient::{Direction, Orient};
use geo::{Area, BooleanOps, LineString, MultiPolygon, Polygon};
use rand::{RngExt, SeedableRng};
use std::f64::consts::PI;

/// The nodes' sines and cosines are within 2 ulp of the library's over
/// the whole interval they are used on.
#[test]
fn small_sin_cos_is_within_two_ulp() {
    let half = MAX_ANGLE / 2.0;
    assert_eq!(half, PI / 8.0);
    let mut ts: Vec<f64> = (0..=200_000)
        .map(|i| half * (f64::from(i) / 100_000.0 - 1.0))
        .collect();
    ts.extend([1e-300, -1e-20, 1e-8, half, -half]);
    for t in ts {
        let (s, c) = small_sin_cos(t);
        let (ls, lc) = t.sin_cos();
        assert!(ulps(s, ls) <= 2.0, "sin({t:e}): {s:e} vs {ls:e}");
        assert!(ulps(c, lc) <= 2.0, "cos({t:e}): {c:e} vs {lc:e}");
    }
}

/// Every non-empty cell of `fleet` in `region`: its vessel, bounds and
/// boundary pieces.
fn cells_of(region: &Region, fleet: &[Vessel]) -> Vec<(Vessel, Vec<Bound>, Vec<Piece>)> {
    (0..fleet.len())
        .filter_map(|i| {
            let others = (0..fleet.len()).filter(|&j| j != i).map(|j| &fleet[j]);
            let bounds = cell_bounds(&fleet[i], others)?;
            let pieces = boundary(region, &bounds);
            Some((fleet[i], bounds, pieces))
        })
        .collect()
}

/// Arc pieces of π/4 and 3/(aRD |sin φ|) where the Gaussian decays (the
/// straight edges' rule, module doc) against π/8 and 2/(aRD |sin φ|),
/// which has about half again as many nodes there: on the cells of random mixed fleets in
/// the square (with and without its island) and Gaussians of widths
/// from 1 to 30 m inside, near and far from each cell, mass and first
/// moments agree to 1e-12 of their size.
#[test]
fn arc_pieces_of_three_decay_lengths_agree_with_two() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(31);
    let (mut worst, mut arcs, mut compared) = (0.0f64, 0, 0);
    for fleet_no in 0..40 {
        let region = square(fleet_no % 2 == 1);
        let fleet: Vec<Vessel> = (0..rng.random_range(3..12))
            .map(|_| Vessel {
                position: Point {
                    x: rng.random_range(5.0..95.0),
                    y: rng.random_range(5.0..95.0),
                },
                k: rng.random_range(0.3..1.5),
                beta: [0.001, 0.002, 0.004, 0.02][rng.random_range(0..4)],
            })
            .collect();
        for (own, _, pieces) in cells_of(&region, &fleet) {
            arcs += pieces
                .iter()
                .filter(|p| matches!(p, Piece::Arc { .. }))
                .count();
            for _ in 0..6 {
                let sigma: f64 = rng.random_range(1.0..30.0);
                let g = Gaussian {
                    log_weight: rng.random_range(-3.0..3.0),
                    a: 1.0 / (2.0 * sigma * sigma) + own.beta,
                    center: Point {
                        x: rng.random_range(-50.0..150.0),
                        y: rng.random_range(-50.0..150.0),
                    },
                };
                let near2 = pieces
                    .iter()
                    .map(|p| p.distance2(g.center))
                    .fold(f64::INFINITY, f64::min);
                let far = !outline::contains(&pieces, g.center) && g.a * near2 >= 1.0;
                let near2 = if far { near2 } else { 0.0 };
                let fine = integrals_rule(&pieces, &g, far, near2, (2.0, PI / 8.0));
                let ours = integrals_rule(&pieces, &g, far, near2, (DECAY, MAX_ANGLE));
                if fine[0] < 1e-280 {
                    continue;
                }
                // Moments about g's centre, in units of the mass times
                // the cell's size (100 m).
                let scale = [fine[0], 100.0 * fine[0], 100.0 * fine[0]];
                let about = [0.0, g.center.x * fine[0], g.center.y * fine[0]];
                let about_ours = [0.0, g.center.x * ours[0], g.center.y * ours[0]];
                for k in 0..3 {
                    let d = ((ours[k] - about_ours[k]) - (fine[k] - about[k])).abs();
                    worst = worst.max(d / scale[k]);
                }
                compared += 1;
            }
        }
    }
    eprintln!("{compared} integrals over cells with {arcs} arcs: worst {worst:.2e} relative");
    assert!(
        arcs > 100 && compared > 500,
        "{arcs} arcs, {compared} integrals"
    );
    assert!(worst <= 1e-12, "worst {worst:e} relative");
}

/// The box the reference works in: the square and a margin. `geo`'s
/// boolean operations snap to a grid scaled to their inputs' extent,
/// so nothing given to them reaches beyond it.
const LO: f64 = -20.0;
const HI: f64 = 120.0;

/// A circle as a polygon of `n` vertices with the circle's area,
/// clipped to the box [LO, HI]² (Sutherland–Hodgman on its four sides).
fn circle(c: Point, r: f64, n: usize) -> Polygon<f64> {
    let step = std::f64::consts::TAU / n as f64;
    let r = r * (step / step.sin()).sqrt();
    let mut ring: Vec<Point> = (0..n)
        .map(|i| {
            let t = step * i as f64;
            c + Point {
                x: t.cos(),
                y: t.sin(),
            } * r
        })
        .collect();
    // Keep s(p) ≥ 0 for s = x − LO, HI − x, y − LO, HI − y.
    let sides: [fn(Point) -> f64; 4] = [|p| p.x - LO, |p| HI - p.x, |p| p.y - LO, |p| HI - p.y];
    for side in sides {
        let mut out = Vec::with_capacity(ring.len());
        for i in 0..ring.len() {
            let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
            let (sa, sb) = (side(a), side(b));
            if sa >= 0.0 {
                out.push(a);
            }
            if (sa >= 0.0) != (sb >= 0.0) {
                out.push(a + (b - a) * (sa / (sa - sb)));
            }
        }
        ring = out;
    }
    Polygon::new(LineString::new(ring), vec![])
}

/// The cell by another road: `geo`'s boolean operations on the region
/// and finely polygonized circles.
fn reference(region: &Region, bounds: &[Bound]) -> MultiPolygon<f64> {
    let mut cell = MultiPolygon(vec![region.polygon().clone()]);
    for b in bounds {
        cell = match *b {
            Bound::HalfPlane { normal, offset } => {
                let len = norm2(normal).sqrt();
                let n = normal / len;
                let o = n * (offset / len);
                let along = Point { x: -n.y, y: n.x } * 1e4;
                let back = n * -1e4;
                let quad = Polygon::new(
                    LineString::new(vec![
                        o - along,
                        o + along,
                        o + along + back,
                        o - along + back,
                    ]),
                    vec![],
                );
                cell.intersection(&quad)
            }
            Bound::Disc { centre, radius } => cell.intersection(&circle(centre, radius, 20_000)),
            Bound::Outside { centre, radius } => cell.difference(&circle(centre, radius, 20_000)),
        };
    }
    cell.orient(Direction::Default)
}

fn reference_integrals(cell: &MultiPolygon<f64>, g: &Gaussian) -> [f64; 3] {
    let mut out = [0.0; 3];
    for poly in &cell.0 {
        let open = |l: &LineString<f64>| l.0[..l.0.len() - 1].to_vec();
        let mut rings = vec![open(poly.exterior())];
        rings.extend(poly.interiors().iter().map(open));
        let d = crate::geometry::ring_distances(&rings, g.center);
        let far = !d.inside && g.a * d.boundary2 >= 1.0;
        let v = polygon_integrals(&rings, g, far);
        for k in 0..3 {
            out[k] += v[k];
        }
    }
    out
}

/// Some 50 cells of random mixed-β fleets (β 0.001, 0.002 and
/// 0.004; k 0.3–1.5), in the square with and without its island:
/// holes, several pieces, empty cells. Areas tile the region to
/// rounding. Against `geo`'s boolean operations on 20 000-gons, mass
/// and centroid of a risk object times the vessel's actuator agree to
/// what that reference resolves: its areas differ from the exact lens
/// and crescent areas of the arcs module's tests, which ours match to
/// 1e-10, by up to 5e-7 of a cell, so its masses are good to ~1e-5, not
/// to the 1e-6 the engine is held to on straight cells (a finer
/// reference is still to be built).
#[test]
fn curved_cells_tile_the_region_and_match_an_independent_reference() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let (mut worst_mass, mut worst_centroid, mut worst_tiling) = (0.0f64, 0.0f64, 0.0f64);
    let (mut arcs_seen, mut cells) = (0, 0);
    for fleet_no in 0..12 {
        let region = square(fleet_no % 2 == 1);
        let n = rng.random_range(3..9);
        let fleet: Vec<Vessel> = (0..n)
            .map(|_| Vessel {
                position: Point {
                    x: rng.random_range(5.0..95.0),
                    y: rng.random_range(5.0..95.0),
                },
                k: rng.random_range(0.3..1.5),
                beta: [0.001, 0.002, 0.004][rng.random_range(0..3)],
            })
            .collect();
        let object = Point {
            x: rng.random_range(0.0..100.0),
            y: rng.random_range(0.0..100.0),
        };
        let mut total_area = 0.0;
        for (own, bounds, pieces) in cells_of(&region, &fleet) {
            arcs_seen += pieces
                .iter()
                .filter(|p| matches!(p, Piece::Arc { .. }))
                .count();
            let area: f64 = pieces
                .iter()
                .map(|p| p.area_share(Point { x: 50.0, y: 50.0 }))
                .sum();
            total_area += area;
            let cell = reference(&region, &bounds);
            let ref_area = cell.unsigned_area();
            assert!(
                (area - ref_area).abs() <= 1e-6 * region.area(),
                "area {area} vs {ref_area}"
            );
            // The risk object (σ = 10 m) times the actuator: one Gaussian.
            let a_obj = 1.0 / (2.0 * 100.0);
            let a = a_obj + own.beta;
            let centre = (object * a_obj + own.position * own.beta) / a;
            let g = Gaussian {
                log_weight: (own.k * 8.0).ln()
                    - a_obj * own.beta / a * norm2(object - own.position),
                a,
                center: centre,
            };
            let far = is_far(&pieces, &g, contains(&region, &bounds, centre));
            let got = curved_integrals(&pieces, &g, far);
            let want = reference_integrals(&cell, &g);
            cells += 1;
            if want[0] > 1e-9 {
                let rel = (got[0] - want[0]).abs() / want[0];
                worst_mass = worst_mass.max(rel);
                let c = |v: [f64; 3]| Point {
                    x: v[1] / v[0],
                    y: v[2] / v[0],
                };
                worst_centroid = worst_centroid.max(norm2(c(got) - c(want)).sqrt());
            }
        }
        worst_tiling = worst_tiling.max((total_area - region.area()).abs() / region.area());
    }
    eprintln!(
        "{cells} cells, {arcs_seen} arcs: worst mass {worst_mass:.2e} relative, centroid \
         {worst_centroid:.2e} m, tiling {worst_tiling:.2e}"
    );
    assert!(arcs_seen > 50, "mixed fleets give curved cells");
    assert!(
        worst_tiling < 1e-9,
        "areas sum to the region's: {worst_tiling:e}"
    );
    assert!(worst_mass < 2e-5, "mass {worst_mass:e}");
    assert!(worst_centroid < 1e-4, "centroid {worst_centroid:e} m");
}

/// A fuzzer's timeout: a disc of radius 45 km at a
/// corner of a triangle of 10 000 km, and a Gaussian of σ = 1 mm 7 000 km
/// away, 1 m inside the triangle's long edge. Its arc approaches the point
/// nearest the Gaussian almost tangentially, where the former skip crept
/// in steps ∝ angle² (hundreds of millions of them). And a disc of 50 m
/// 100 km from the same Gaussian, whose former pieces of 3/(a r R) rad
/// were 1e-12 rad along the 9e-6 rad that matter (seven million). And
/// two more of its timeouts: a 32 km disc whose corner
/// is nearest the Gaussian, 5e6 m away, where steps of 1e-12 rad moved
/// the arc by less than its coordinates' resolution and r² never rose
/// past the cutoff; and a disc whose nearest point lies by its arc's end, where
/// the skip's proposal cancelled and fell back to 1e-12 rad steps. Now a handful of skips
/// and the few quadrature pieces that matter: every cell in well under a
/// second (the fuzzer's limit is 10 s), the one holding the Gaussian with
/// its whole mass π/a and centroid m, the others none.
#[test]
fn a_narrow_gaussian_far_from_a_disc_takes_few_pieces() {
    let region = Region::new(
        vec![
            Point { x: 0.0, y: 0.0 },
            Point { x: 1e7, y: 0.0 },
            Point { x: 1e7, y: 1e7 },
        ],
        vec![],
    )
    .unwrap();
    let vessel = |x: f64, y: f64, beta: f64| Vessel {
        position: Point { x, y },
        k: 1.0,
        beta,
    };
    let fleets = [
        [vessel(1e7, 1e7, 1e-4), vessel(1.0, 0.0, 1e-9)],
        [vessel(5.07e6, 7e4, 1.0), vessel(5.07e6 + 500.0, 7e4, 1e-2)],
        [vessel(1e7, 1e7, 1e-4), vessel(1.0, 0.0, 19.0)],
        [vessel(1e7, 1.0, 1e-4), vessel(1.0, 0.0, 1e-9)],
    ];
    let g = Gaussian {
        log_weight: 0.0,
        a: 1.0 / (2.0 * 1e-3 * 1e-3),
        center: Point { x: 5e6, y: 1.0 },
    };
    let started = std::time::Instant::now();
    for fleet in &fleets {
        let cells = cells_of(&region, fleet);
        assert_eq!(cells.len(), 2);
        let mut holding = 0;
        for (_, _, pieces) in &cells {
            let inside = outline::contains(pieces, g.center);
            let [mass, mx, my] = curved_integrals(pieces, &g, is_far(pieces, &g, inside));
            assert!(mass.is_finite() && mx.is_finite() && my.is_finite());
            if inside {
                holding += 1;
                let whole = PI / g.a;
                assert!(
                    (mass - whole).abs() <= 1e-12 * whole,
                    "{mass:e} vs {whole:e}"
                );
                let centroid = Point {
                    x: mx / mass,
                    y: my / mass,
                };
                assert!(norm2(centroid - g.center).sqrt() < 1e-6, "{centroid:?}");
            } else {
                assert!(mass.abs() <= f64::MIN_POSITIVE, "{mass:e}");
            }
        }
        assert_eq!(holding, 1);
    }
    let took = started.elapsed().as_secs_f64();
    assert!(took < 1.0, "{took:.2} s");
}

/// A fuzzer's crash: a vessel of β = 1.7e-100, whose
/// actuator is flat, beside one of β = 0.001 and the same k, which wins
/// a disc of radius 3e-47 m. That arc's pieces' floor, 1e-12 (1 + r/R)
/// rad, passed π/4 (past the half-angle the nodes' sine polynomial is
/// valid for, a debug assertion). The whole
/// evaluation: finite figures, and the two cells tile the square.
#[test]
fn a_flat_actuator_beside_a_normal_one_evaluates() {
    use crate::coverage::density::{RiskField, RiskObject};
    use crate::coverage::evaluate::{Options, evaluate};
    use crate::coverage::fleet::Fleet;
    let region = Region::new(
        vec![
            Point { x: 0.0, y: 0.0 },
            Point { x: 100.0, y: 0.0 },
            Point { x: 100.0, y: 100.0 },
            Point { x: 0.0, y: 100.0 },
        ],
        vec![],
    )
    .unwrap();
    let risk = RiskField::new(
        0.1,
        vec![RiskObject {
            center: Point { x: 25.0, y: 70.0 },
            alpha: 10.0,
            sigma: 10.0,
        }],
    )
    .unwrap();
    let fleet = Fleet::new(vec![
        Vessel {
            position: Point { x: 66.6, y: 10.4 },
            k: 0.5,
            beta: 1.692392065e-100,
        },
        Vessel {
            position: Point { x: 30.0, y: 80.0 },
            k: 0.5,
            beta: 0.001,
        },
    ])
    .unwrap();
    let result = evaluate(&region, &risk, &fleet, &Options::default());
    assert!(result.h.is_finite() && result.h > 0.0);
    let area: f64 = result.cells.iter().map(|c| c.area).sum();
    assert!((area - 1e4).abs() < 1e-9, "{area}");
    for cell in &result.cells {
        assert!(
            cell.mass.is_finite() && cell.centroid.x.is_finite() && cell.centroid.y.is_finite()
        );
    }
}
