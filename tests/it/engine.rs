//! The coverage engine against closed forms and definitions, through the same
//! path the CLI and the server use (scenario document → evaluation).

use seacover::coverage::integrate::Tolerance;
use seacover::coverage::{CellGeometry, Evaluation, Options};
use seacover::geometry::Point;
use seacover::mission::scenario::{Scenario, evaluate_text, parse_document};
use serde_json::{Value, json};

fn scenario(doc: &Value) -> Scenario {
    Scenario::from_document(&parse_document(&doc.to_string()).unwrap()).unwrap()
}

fn eval(doc: &Value) -> (Scenario, Evaluation) {
    let s = scenario(doc);
    let e = s.evaluate(&Options::default());
    (s, e)
}

fn square(x0: f64, y0: f64, x1: f64, y1: f64) -> Value {
    json!([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
}

/// ∫_{x0}^{x1} e^{−a (x − m)²} dx.
fn g1(a: f64, m: f64, x0: f64, x1: f64) -> f64 {
    let s = a.sqrt();
    0.5 * (std::f64::consts::PI / a).sqrt() * (libm::erf(s * (x1 - m)) - libm::erf(s * (x0 - m)))
}

/// ∫_{x0}^{x1} x e^{−a (x − m)²} dx.
fn g1x(a: f64, m: f64, x0: f64, x1: f64) -> f64 {
    let e = |x: f64| (-a * (x - m) * (x - m)).exp();
    m * g1(a, m, x0, x1) + (e(x0) - e(x1)) / (2.0 * a)
}

#[test]
fn flat_density_and_vanishing_beta_give_the_area_centroid() {
    // An L-shaped region with a hole; one vessel; Φ ≡ 1; β → 0 makes f ≡ k.
    let doc = json!({
        "region": {
            "polygon": [[0, 0], [60, 0], [60, 20], [20, 20], [20, 50], [0, 50]],
            "holes": [[[5, 5], [15, 5], [15, 15], [5, 15]]]
        },
        "risk": {"base": 1.0, "objects": []},
        "vessels": [{"id": "a", "x": 30, "y": 10, "k": 2.0, "beta": 1e-14}]
    });
    let (_, e) = eval(&doc);
    let area = 60.0 * 20.0 + 20.0 * 30.0 - 100.0;
    let c = &e.cells[0];
    assert!((c.area - area).abs() < 1e-9 * area);
    assert!((c.mass - 2.0 * area).abs() < 1e-8 * area, "{}", c.mass);
    // Area centroid by decomposition: bottom bar, upper arm, minus the hole.
    let cx = (1200.0 * 30.0 + 600.0 * 10.0 - 100.0 * 10.0) / area;
    let cy = (1200.0 * 10.0 + 600.0 * 35.0 - 100.0 * 10.0) / area;
    assert!(
        (c.centroid.x - cx).abs() < 1e-6 && (c.centroid.y - cy).abs() < 1e-6,
        "{:?}",
        c.centroid
    );
}

#[test]
fn one_gaussian_over_a_large_square_matches_the_erf_closed_form() {
    // f_i Φ = k α e^{−β‖q−p‖² − b‖q−s‖²} = k α e^{−βb/(β+b)‖p−s‖²} e^{−a‖q−m‖²}.
    let (k, alpha, sigma, beta): (f64, f64, f64, f64) = (0.7, 9.0, 12.0, 0.002);
    let (p, s): ((f64, f64), (f64, f64)) = ((30.0, -20.0), (-15.0, 25.0));
    let (x0, y0, x1, y1) = (-400.0, -350.0, 500.0, 420.0);
    let doc = json!({
        "region": {"polygon": square(x0, y0, x1, y1)},
        "risk": {"base": 0.0, "objects": [{"x": s.0, "y": s.1, "alpha": alpha, "sigma": sigma}]},
        "vessels": [{"id": "a", "x": p.0, "y": p.1, "k": k, "beta": beta}]
    });
    let (_, e) = eval(&doc);
    let b = 1.0 / (2.0 * sigma * sigma);
    let a = beta + b;
    let m = ((beta * p.0 + b * s.0) / a, (beta * p.1 + b * s.1) / a);
    let d2 = (p.0 - s.0).powi(2) + (p.1 - s.1).powi(2);
    let w = k * alpha * (-beta * b / a * d2).exp();
    let (gx, gy) = (g1(a, m.0, x0, x1), g1(a, m.1, y0, y1));
    let mass = w * gx * gy;
    let c = &e.cells[0];
    assert!(
        ((c.mass - mass) / mass).abs() < 1e-12,
        "{} vs {mass}",
        c.mass
    );
    assert!(((e.h - mass) / mass).abs() < 1e-12);
    let (cx, cy) = (g1x(a, m.0, x0, x1) / gx, g1x(a, m.1, y0, y1) / gy);
    assert!((c.centroid.x - cx).abs() < 1e-9 && (c.centroid.y - cy).abs() < 1e-9);
    // The gradient is 2β M (C − p).
    assert!((c.gradient.x - 2.0 * beta * mass * (cx - p.0)).abs() < 1e-9 * mass);
}

#[test]
fn symmetric_configuration_gives_symmetric_results() {
    let doc = json!({
        "region": {"polygon": square(0.0, 0.0, 100.0, 100.0)},
        "risk": {"base": 0.1, "objects": [{"x": 50, "y": 50, "alpha": 10, "sigma": 15}]},
        "vessels": [
            {"id": "a", "x": 25, "y": 30}, {"id": "b", "x": 75, "y": 30},
            {"id": "c", "x": 25, "y": 70}, {"id": "d", "x": 75, "y": 70}
        ]
    });
    let (_, e) = eval(&doc);
    let c = &e.cells;
    // Mirror in x = 50: a ↔ b, c ↔ d. Mirror in y = 50: a ↔ c, b ↔ d.
    for (i, j) in [(0, 1), (2, 3), (0, 2), (1, 3)] {
        assert!((c[i].mass - c[j].mass).abs() < 1e-12 * c[i].mass);
        assert!((c[i].area - c[j].area).abs() < 1e-9);
    }
    assert!((c[0].centroid.x + c[1].centroid.x - 100.0).abs() < 1e-10);
    assert!((c[0].centroid.y - c[1].centroid.y).abs() < 1e-10);
    assert!((c[0].centroid.y + c[2].centroid.y - 100.0).abs() < 1e-10);
}

#[test]
fn gradient_matches_finite_differences_of_h() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json"))
        .unwrap();
    let base: Value = serde_json::from_str(&text).unwrap();
    let (_, e) = eval(&base);
    let delta = 1e-3;
    for i in [0usize, 3, 6] {
        for (axis, key) in [(0, "x"), (1, "y")] {
            let h_at = |d: f64| {
                let mut doc = base.clone();
                let v = doc["vessels"][i][key].as_f64().unwrap();
                doc["vessels"][i][key] = json!(v + d);
                eval(&doc).1.h
            };
            let fd = (h_at(delta) - h_at(-delta)) / (2.0 * delta);
            let g = if axis == 0 {
                e.cells[i].gradient.x
            } else {
                e.cells[i].gradient.y
            };
            assert!(
                (fd - g).abs() < 1e-5 * g.abs().max(1.0),
                "vessel {i} {key}: fd {fd} vs {g}"
            );
        }
    }
}

#[test]
fn a_cell_cut_by_the_region_comes_in_pieces() {
    // A U-shaped harbour; vessel "a" floats in the notch (outside Q) and owns
    // the upper halves of both arms.
    let doc = json!({
        "region": {"polygon": [[0, 0], [30, 0], [30, 30], [20, 30], [20, 10], [10, 10], [10, 30], [0, 30]]},
        "risk": {"base": 1.0, "objects": []},
        "vessels": [{"id": "a", "x": 15, "y": 25}, {"id": "b", "x": 15, "y": 2}]
    });
    let (_, e) = eval(&doc);
    let edge = (25.0 + 2.0) / 2.0;
    let upper = 2.0 * 10.0 * (30.0 - edge);
    let (s, _) = eval(&doc);
    assert!(matches!(e.cells[0].geometry, CellGeometry::Clipped { .. }));
    assert_eq!(e.cells[0].geometry.pieces(&s.region).0.len(), 2);
    assert!((e.cells[0].area - upper).abs() < 1e-9);
    assert!((e.cells[0].area + e.cells[1].area - 700.0).abs() < 1e-9);
    // By symmetry the centroid is on x = 15: in the notch, outside Q.
    assert!((e.cells[0].centroid.x - 15.0).abs() < 1e-9);
    // The document lists both pieces.
    let out: Value =
        serde_json::to_value(evaluate_text(&doc.to_string(), &Options::default()).unwrap())
            .unwrap();
    assert_eq!(out["cells"][0]["pieces"].as_array().unwrap().len(), 2);
    assert!(out["cells"][0]["polygon"].as_array().unwrap().len() >= 4);
    assert!(out["cells"][1].get("pieces").is_none());
}

#[test]
fn vessels_outside_the_region_and_coincident_vessels_are_defined() {
    let doc = json!({
        "region": {"polygon": square(0.0, 0.0, 100.0, 100.0),
                   "holes": [[[40, 40], [60, 40], [60, 60], [40, 60]]]},
        "risk": {"base": 0.1, "objects": [{"x": 20, "y": 80, "alpha": 5, "sigma": 10}]},
        "vessels": [
            {"id": "in", "x": 20, "y": 20},
            {"id": "twin-a", "x": 80, "y": 80},
            {"id": "twin-b", "x": 80, "y": 80},
            {"id": "far", "x": 5000, "y": -300},
            {"id": "in-hole", "x": 50, "y": 52},
            {"id": "near", "x": 120, "y": 10}
        ]
    });
    let (s, e) = eval(&doc);
    let c = &e.cells;
    for cell in c {
        assert!(
            cell.mass.is_finite() && cell.centroid.x.is_finite() && cell.centroid.y.is_finite()
        );
        assert!(cell.gradient.x.is_finite() && cell.gradient.y.is_finite());
    }
    // The first of two coincident vessels keeps the cell; the second holds
    // station where it is.
    assert!(c[1].mass > 0.0);
    assert_eq!(c[2].mass, 0.0);
    assert!(c[2].geometry.is_empty());
    assert_eq!(c[2].centroid, Point { x: 80.0, y: 80.0 });
    assert_eq!(c[2].gradient, Point { x: 0.0, y: 0.0 });
    // Far away: empty, pointed at the nearest point of Q.
    assert!(c[3].geometry.is_empty());
    assert!((c[3].centroid.x - 100.0).abs() < 1e-12 && c[3].centroid.y.abs() < 1e-12);
    // In the hole: the cell around the hole, never the hole itself.
    assert!(!c[4].geometry.is_empty());
    assert!(!c[4].geometry.contains(Point { x: 50.0, y: 50.0 }));
    // Just outside: a real share of Q.
    assert!(c[5].area > 0.0 && c[5].mass > 0.0);
    assert!(s.region.contains(c[5].centroid));
    let total: f64 = c.iter().map(|c| c.area).sum();
    assert!((total - s.region.area()).abs() < 1e-9 * s.region.area());
    // The document serialises (no NaN anywhere).
    assert!(evaluate_text(&doc.to_string(), &Options::default()).is_ok());
}

#[test]
fn zero_density_gives_zero_mass_and_finite_centroids() {
    let doc = json!({
        "region": {"polygon": square(0.0, 0.0, 100.0, 100.0)},
        "risk": {"base": 0.0, "objects": []},
        "vessels": [{"id": "a", "x": 30, "y": 50}, {"id": "b", "x": 70, "y": 50}]
    });
    let (_, e) = eval(&doc);
    assert_eq!(e.h, 0.0);
    for c in &e.cells {
        assert_eq!(c.mass, 0.0);
        assert!(c.centroid.x.is_finite() && c.centroid.y.is_finite());
    }
    assert!(e.cells[0].centroid.x < 50.0 && e.cells[1].centroid.x > 50.0);
}

#[test]
fn default_and_reference_integrators_agree_on_the_shipped_scenarios() {
    for name in ["paper", "fleet-100"] {
        let path = format!("{}/examples/{name}.json", env!("CARGO_MANIFEST_DIR"));
        let s = Scenario::from_document(
            &parse_document(&std::fs::read_to_string(path).unwrap()).unwrap(),
        )
        .unwrap();
        let fast = s.evaluate(&Options::default());
        let slow = s.evaluate(&Options {
            tolerance: Tolerance::adaptive(1e-10),
            ..Options::default()
        });
        for (a, b) in fast.cells.iter().zip(&slow.cells) {
            assert!(
                ((a.mass - b.mass) / b.mass).abs() < 1e-9,
                "{name}: {} vs {}",
                a.mass,
                b.mass
            );
            assert!(
                (a.centroid.x - b.centroid.x).abs() < 1e-7
                    && (a.centroid.y - b.centroid.y).abs() < 1e-7
            );
        }
    }
}

/// Found by the fuzzer: a needle-thin object millions of metres from a cell's
/// edges once made the edge integration loop forever (its steps fell below
/// one float step). The mass must still come out right, and in time.
#[test]
fn a_needle_object_far_from_a_cell_terminates_with_the_right_mass() {
    let doc = json!({
        "region": {"polygon": [[0, 0], [1e7, 0], [1e7, 1e7]]},
        "risk": {"base": 0, "objects": [{"x": 5e6, "y": 1, "alpha": 1e6, "sigma": 1e-3}]},
        "vessels": [
            {"id": "far", "x": 1e7, "y": 1e7, "k": 0.5, "beta": 1e-15},
            {"id": "near", "x": 1, "y": 0, "k": 0.5, "beta": 1e-15}
        ]
    });
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(eval(&doc).1);
    });
    let e = rx
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("evaluation finished");
    // The whole object lies in one cell; f = k e^{-β d²} is k to 1e-1
    // relative at most over the object, so compare with the f at the object.
    let owner = e
        .cells
        .iter()
        .max_by(|a, b| a.mass.total_cmp(&b.mass))
        .unwrap();
    let expected = 1e6 * 2.0 * std::f64::consts::PI * 1e-6 * 0.5;
    let d2_far = (1e7f64 - 5e6).powi(2) + (1e7f64 - 1.0).powi(2);
    let d2_near = (5e6f64 - 1.0).powi(2) + 1.0;
    let f = 0.5 * (-1e-15 * d2_far.min(d2_near)).exp();
    assert!(
        (owner.mass - expected * f / 0.5).abs() < 1e-6 * owner.mass,
        "{} vs {}",
        owner.mass,
        expected * f / 0.5
    );
    for c in &e.cells {
        assert!(c.mass.is_finite() && c.centroid.x.is_finite() && c.centroid.y.is_finite());
    }
    assert!((e.h - e.cells.iter().map(|c| c.mass).sum::<f64>()).abs() <= 1e-9 * e.h);
}

#[test]
fn parallel_evaluation_is_the_sequential_one_bit_for_bit() {
    let path = format!("{}/examples/fleet-1000.json", env!("CARGO_MANIFEST_DIR"));
    let s =
        Scenario::from_document(&parse_document(&std::fs::read_to_string(path).unwrap()).unwrap())
            .unwrap();
    let one = s.evaluate(&Options::default());
    let all = s.evaluate(&Options {
        parallel: true,
        ..Options::default()
    });
    assert_eq!(one.h.to_bits(), all.h.to_bits());
    // PartialEq on f64 would let -0.0 == 0.0 through; Debug shows every bit
    // that matters here and every vertex.
    assert_eq!(format!("{:?}", one.cells), format!("{:?}", all.cells));
}
