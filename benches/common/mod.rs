//! What the peer benchmarks share (benches/peer.rs, benches/split.rs): a
//! mission for `n` vessels on a square at the paper's density of vessels
//! and of risk objects, its objects placed by a seeded generator
//! (docs/performance.md).

use rand::RngExt;
use seacover::mission::Mission;
use seacover::protocol::{RegionDocument, RiskDocument, RiskObjectDocument};

/// The paper's density: 8 vessels on 100 m × 100 m.
const AREA_PER_VESSEL: f64 = 100.0 * 100.0 / 8.0;
/// And its risk objects: 3 for 8 vessels.
const OBJECTS_PER_VESSEL: f64 = 3.0 / 8.0;

/// The side of the square that holds `n` vessels at the paper's density [m].
pub(crate) fn side(n: usize) -> f64 {
    (n as f64 * AREA_PER_VESSEL).sqrt()
}

/// The paper's mission on [`side`]`(n)` square, with its density of risk
/// objects drawn from `rng` (their places, then their peaks, one object
/// after another).
pub(crate) fn dense_mission(n: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Mission {
    let side = side(n);
    let objects = (n as f64 * OBJECTS_PER_VESSEL).round() as usize;
    let mut doc = Mission::paper().document();
    doc.region = RegionDocument {
        polygon: vec![[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]],
        holes: vec![],
    };
    doc.risk = RiskDocument {
        base: 0.1,
        objects: (0..objects)
            .map(|_| RiskObjectDocument {
                id: None,
                x: rng.random_range(0.0..side),
                y: rng.random_range(0.0..side),
                alpha: rng.random_range(6.0..14.0),
                sigma: 10.0,
            })
            .collect(),
    };
    Mission::from_document(&doc).expect("a valid mission")
}
