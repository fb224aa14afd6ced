//! The engine as a library by itself: a small scenario built with its own
//! types, evaluated once, and printed: the partition (each vessel's cell),
//! the coverage metric H(P) and each cell's centroid.
//!
//! Run with `cargo run -p seacover-engine --example evaluate`.

use seacover_engine::coverage::fleet::{DEFAULT_BETA, DEFAULT_K};
use seacover_engine::coverage::{
    CellGeometry, Evaluation, Fleet, InputError, Options, RiskField, RiskObject, Vessel, evaluate,
};
use seacover_engine::geometry::{Point, Region};

/// The square's side [m].
const SIDE: f64 = 200.0;

fn main() -> Result<(), InputError> {
    let p = |x, y| Point { x, y };
    let region = Region::new(
        vec![p(0.0, 0.0), p(SIDE, 0.0), p(SIDE, SIDE), p(0.0, SIDE)],
        vec![],
    )?;
    let hot = RiskObject {
        center: p(140.0, 120.0),
        alpha: 5.0,
        sigma: 25.0,
    };
    let risk = RiskField::new(0.1, vec![hot])?;
    let vessel = |x, y| Vessel {
        position: p(x, y),
        k: DEFAULT_K,
        beta: DEFAULT_BETA,
    };
    let fleet = Fleet::new(vec![
        vessel(30.0, 30.0),
        vessel(70.0, 40.0),
        vessel(40.0, 80.0),
        vessel(90.0, 90.0),
    ])?;

    let evaluation = evaluate(&region, &risk, &fleet, &Options::default());

    println!("region: {SIDE} m × {SIDE} m square");
    println!(
        "risk: φ0 = {}, one object at ({}, {}) m, α = {}, σ = {} m",
        risk.base(),
        hot.center.x,
        hot.center.y,
        hot.alpha,
        hot.sigma
    );
    println!(
        "fleet: {} vessels, k = {DEFAULT_K}, β = {DEFAULT_BETA} 1/m²",
        fleet.len()
    );
    println!();
    print_cells(&fleet, &evaluation);
    println!();
    println!("H(P) = Σ M_i = {:.3}", evaluation.h);
    Ok(())
}

/// Each vessel's cell: its vertices, area, mass M_i and centroid C_i.
fn print_cells(fleet: &Fleet, evaluation: &Evaluation) {
    for (i, (v, cell)) in fleet.vessels().iter().zip(&evaluation.cells).enumerate() {
        let at = |q: Point| format!("({}, {})", tenths(q.x), tenths(q.y));
        println!("vessel {i} at {}", at(v.position));
        let outline = match &cell.geometry {
            CellGeometry::Empty => "empty".to_string(),
            CellGeometry::Convex(c) => {
                let vertices: Vec<String> = c.vertices.iter().map(|&q| at(q)).collect();
                format!("convex, {}", vertices.join(" "))
            }
            CellGeometry::Clipped { rings, .. } => {
                format!("cut by the region's boundary, {} ring(s)", rings.len())
            }
            CellGeometry::Curved { pieces } => format!("curved, {} boundary pieces", pieces.len()),
        };
        println!("  cell:     {outline}");
        println!("  area:     {:.1} m²", cell.area);
        println!("  mass M_i: {:.3}", cell.mass);
        println!("  centroid: {} m", at(cell.centroid));
    }
}

/// `x` to a tenth, written without a sign when it rounds to zero.
fn tenths(x: f64) -> String {
    format!("{:.1}", (x * 10.0).round() / 10.0 + 0.0)
}
