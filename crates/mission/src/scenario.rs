//! Scenario documents in, evaluation documents out: the shell between
//! [`seacover_protocol`] and the pure [`seacover_engine::coverage`] engine.
//!
//! Every rejection is a [`ScenarioError`] whose message starts with the path of
//! the offending field (`vessels[2].k`, `region.holes[0]`), so a user can fix
//! the document without reading code.

use std::collections::HashSet;

use geo::Area;

use seacover_engine::coverage::fleet::{DEFAULT_BETA, DEFAULT_K};
use seacover_engine::coverage::{
    CellGeometry, Evaluation, Fleet, InputError, Options, RiskField, RiskObject, Vessel, evaluate,
};
use seacover_engine::geometry::arcs::Piece;
use seacover_engine::geometry::{Point, Region};
use seacover_protocol::{
    CellDocument, EdgeDocument, ErrorCode, ErrorDetail, ErrorDocument, EvaluationDocument,
    OriginDocument, RegionDocument, RiskDocument, ScenarioDocument, VesselDocument, XY,
};

/// Why a scenario was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// Not JSON, or not the document's shape.
    #[error("malformed document: {0}")]
    Malformed(String),
    /// Well-formed, but a value is out of range or inconsistent.
    #[error(transparent)]
    Input(#[from] InputError),
}

impl ScenarioError {
    /// Stable machine-readable code.
    pub fn code(&self) -> ErrorCode {
        match self {
            ScenarioError::Malformed(_) => ErrorCode::Malformed,
            ScenarioError::Input(InputError::Unsupported { .. }) => ErrorCode::Unsupported,
            ScenarioError::Input(_) => ErrorCode::Invalid,
        }
    }

    /// The error as its wire document.
    pub fn to_document(&self) -> ErrorDocument {
        ErrorDocument {
            error: ErrorDetail {
                code: self.code().as_str().to_string(),
                message: self.to_string(),
            },
        }
    }
}

/// A validated scenario, ready for the engine.
#[derive(Debug, Clone)]
pub struct Scenario {
    pub region: Region,
    pub risk: RiskField,
    /// The field a simulation samples, never given to the fleet
    /// (`seacover sim` only; docs/learning.md).
    pub truth: Option<RiskField>,
    pub fleet: Fleet,
    /// Vessel ids, in the fleet's order.
    pub ids: Vec<String>,
}

/// Whether `id` matches `[A-Za-z0-9_.-]{1,64}`.
pub fn valid_id(id: &str) -> bool {
    (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'.' | b'-'))
}

/// A scenario in the local plane: the document with whatever it gave in
/// WGS84 placed in the plane of its origin (see [`crate::georef::input`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LocalScenario {
    /// The origin of the plane the document was placed in (its own, or the
    /// fallback), if any.
    pub origin: Option<OriginDocument>,
    pub region: Option<RegionDocument>,
    pub risk: Option<RiskDocument>,
    /// The field a simulation samples (`seacover sim` only).
    pub truth: Option<RiskDocument>,
    pub vessels: Vec<VesselDocument>,
}

/// Parses a scenario document as written, without placing it.
pub fn parse_input(text: &str) -> Result<ScenarioDocument, ScenarioError> {
    serde_json::from_str(text)
        .map_err(|e| ScenarioError::Malformed(seacover_protocol::json_error(&e)))
}

/// Parses a scenario document and places it in the plane of its own origin.
pub fn parse_document(text: &str) -> Result<LocalScenario, ScenarioError> {
    localize(&parse_input(text)?, None)
}

/// Places a document's geographic parts in the plane of its origin, or of
/// `fallback` when it has none (the server's mission origin).
pub fn localize(
    doc: &ScenarioDocument,
    fallback: Option<OriginDocument>,
) -> Result<LocalScenario, ScenarioError> {
    use crate::georef::input;
    let origin = doc.origin.or(fallback);
    let frame = input::frame(origin)?;
    let frame = frame.as_ref();
    Ok(LocalScenario {
        origin,
        region: doc
            .region
            .as_ref()
            .map(|r| input::region(r, frame))
            .transpose()?,
        risk: doc
            .risk
            .as_ref()
            .map(|r| input::risk(r, frame, "risk"))
            .transpose()?,
        truth: doc
            .truth
            .as_ref()
            .map(|r| input::risk(r, frame, "truth"))
            .transpose()?,
        vessels: doc
            .vessels
            .iter()
            .enumerate()
            .map(|(i, v)| input::vessel(v, frame, &format!("vessels[{i}]")))
            .collect::<Result<_, _>>()?,
    })
}

fn points(ring: &[XY]) -> Vec<Point> {
    ring.iter().map(|&[x, y]| Point { x, y }).collect()
}

/// Validates a region document.
pub fn region_from_document(doc: &RegionDocument) -> Result<Region, ScenarioError> {
    Ok(Region::new(
        points(&doc.polygon),
        doc.holes.iter().map(|h| points(h)).collect(),
    )
    .map_err(InputError::from)?)
}

/// A risk document as a field; `field` (`risk` or `truth`) names it in
/// errors.
fn risk_field(doc: &RiskDocument, field: &str) -> Result<RiskField, ScenarioError> {
    let mut object_ids = HashSet::new();
    for (i, o) in doc.objects.iter().enumerate() {
        if let Some(id) = &o.id {
            if !valid_id(id) {
                return Err(InputError::invalid(
                    format!("{field}.objects[{i}].id"),
                    "must match [A-Za-z0-9_.-]{1,64}",
                )
                .into());
            }
            if !object_ids.insert(id.as_str()) {
                return Err(InputError::invalid(
                    format!("{field}.objects[{i}].id"),
                    format!("duplicate id {id:?}"),
                )
                .into());
            }
        }
    }
    let objects = doc
        .objects
        .iter()
        .map(|o| RiskObject {
            center: Point { x: o.x, y: o.y },
            alpha: o.alpha,
            sigma: o.sigma,
        })
        .collect();
    // The engine names the fields of the one density it knows, `risk`.
    RiskField::new(doc.base, objects).map_err(|e| match e {
        InputError::Invalid { field: f, reason } => InputError::Invalid {
            field: f.replacen("risk", field, 1),
            reason,
        }
        .into(),
        e => e.into(),
    })
}

impl Scenario {
    /// Validates a document; `region` and `risk` must be present.
    pub fn from_document(doc: &LocalScenario) -> Result<Self, ScenarioError> {
        let region_doc = doc
            .region
            .as_ref()
            .ok_or_else(|| InputError::invalid("region", "is required"))?;
        let risk_doc = doc
            .risk
            .as_ref()
            .ok_or_else(|| InputError::invalid("risk", "is required"))?;
        let region = region_from_document(region_doc)?;

        let risk = risk_field(risk_doc, "risk")?;
        let truth = doc
            .truth
            .as_ref()
            .map(|t| risk_field(t, "truth"))
            .transpose()?;

        let mut ids = Vec::with_capacity(doc.vessels.len());
        let mut seen = HashSet::new();
        for (i, v) in doc.vessels.iter().enumerate() {
            if !valid_id(&v.id) {
                return Err(InputError::invalid(
                    format!("vessels[{i}].id"),
                    "must match [A-Za-z0-9_.-]{1,64}",
                )
                .into());
            }
            if !seen.insert(v.id.as_str()) {
                return Err(InputError::invalid(
                    format!("vessels[{i}].id"),
                    format!("duplicate id {:?}", v.id),
                )
                .into());
            }
            if let Some(psi) = v.psi
                && !psi.is_finite()
            {
                return Err(
                    InputError::invalid(format!("vessels[{i}].psi"), "must be finite").into(),
                );
            }
            ids.push(v.id.clone());
        }
        let fleet = Fleet::new(
            doc.vessels
                .iter()
                .map(|v| Vessel {
                    position: Point { x: v.x, y: v.y },
                    k: v.k.unwrap_or(DEFAULT_K),
                    beta: v.beta.unwrap_or(DEFAULT_BETA),
                })
                .collect(),
        )?;
        Ok(Scenario {
            region,
            risk,
            truth,
            fleet,
            ids,
        })
    }

    /// Runs the engine.
    pub fn evaluate(&self, options: &Options) -> Evaluation {
        evaluate(&self.region, &self.risk, &self.fleet, options)
    }
}

fn xy(p: Point) -> XY {
    [p.x, p.y]
}

fn ring_doc(ring: &geo::LineString<f64>) -> Vec<XY> {
    let mut pts: Vec<XY> = ring.coords().map(|c| xy(*c)).collect();
    if pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    pts
}

/// A cell's outline as the wire carries it: `polygon` (the largest
/// piece's outer ring), `pieces` (every piece with its holes, when it is
/// not one simple polygon) and, for a cell with an arc, `edges` (its exact
/// boundary). Arcs in `polygon` and `pieces` are chords within
/// [`ARC_TOLERANCE`](seacover_engine::coverage::partition::ARC_TOLERANCE) of them,
/// every vertex on the arc.
pub fn cell_outline(
    region: &Region,
    geometry: &CellGeometry,
) -> (Option<Vec<XY>>, Vec<RegionDocument>, Vec<Vec<EdgeDocument>>) {
    match geometry {
        CellGeometry::Empty => (None, Vec::new(), Vec::new()),
        CellGeometry::Convex(p) => (
            Some(p.vertices.iter().map(|v| xy(*v)).collect()),
            Vec::new(),
            Vec::new(),
        ),
        cut @ (CellGeometry::Clipped { .. } | CellGeometry::Curved { .. }) => {
            let mp = cut.pieces(region);
            let largest =
                mp.0.iter()
                    .max_by(|a, b| a.unsigned_area().total_cmp(&b.unsigned_area()))
                    .map(|p| ring_doc(p.exterior()));
            let simple = mp.0.len() == 1 && mp.0[0].interiors().is_empty();
            let pieces = if simple {
                Vec::new()
            } else {
                mp.0.iter()
                    .map(|p| RegionDocument {
                        polygon: ring_doc(p.exterior()),
                        holes: p.interiors().iter().map(ring_doc).collect(),
                    })
                    .collect()
            };
            let edges = match cut {
                CellGeometry::Curved { pieces: boundary } if largest.is_some() => {
                    edge_loops(boundary)
                }
                _ => Vec::new(),
            };
            (largest, pieces, edges)
        }
    }
}

fn edge_document(piece: &Piece) -> EdgeDocument {
    match *piece {
        Piece::Segment { from, to } => EdgeDocument::Segment {
            from: xy(from),
            to: xy(to),
        },
        Piece::Arc {
            centre,
            radius,
            start,
            sweep,
        } => EdgeDocument::Arc {
            centre: xy(centre),
            radius,
            start,
            sweep,
        },
    }
}

/// A curved cell's boundary chained into closed loops, as
/// [`CellDocument::edges`](seacover_protocol::CellDocument::edges) says, when
/// it has an arc (nothing otherwise): the loops of
/// `geometry::outline::loops`, which also make `polygon`, so the two agree.
pub fn edge_loops(pieces: &[Piece]) -> Vec<Vec<EdgeDocument>> {
    if !pieces.iter().any(|p| matches!(p, Piece::Arc { .. })) {
        return Vec::new();
    }
    seacover_engine::geometry::outline::loops(pieces)
        .iter()
        .map(|chain| chain.iter().map(edge_document).collect())
        .collect()
}

/// The wire form of an evaluation over `region`.
pub fn evaluation_document(
    region: &Region,
    ids: &[String],
    evaluation: &Evaluation,
) -> EvaluationDocument {
    let cells = evaluation
        .cells
        .iter()
        .zip(ids)
        .map(|(c, id)| {
            let (polygon, pieces, edges) = cell_outline(region, &c.geometry);
            CellDocument {
                id: id.clone(),
                mass: c.mass,
                centroid: xy(c.centroid),
                area: c.area,
                polygon,
                pieces,
                edges,
                gradient: xy(c.gradient),
            }
        })
        .collect();
    EvaluationDocument {
        h: evaluation.h,
        cells,
    }
}

/// Parses, validates and evaluates a scenario document given as text.
pub fn evaluate_text(text: &str, options: &Options) -> Result<EvaluationDocument, ScenarioError> {
    let doc = parse_document(text)?;
    let scenario = Scenario::from_document(&doc)?;
    Ok(evaluation_document(
        &scenario.region,
        &scenario.ids,
        &scenario.evaluate(options),
    ))
}

/// Scenarios, and what reads their documents back, that tests elsewhere in
/// the crate share.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::*;
    use seacover_engine::coverage::Options;

    /// `examples/island-mixed.json`: the paper's square with an island, four
    /// vessels with β = 0.001 and four with β = 0.004 (each of those wins a
    /// disc round itself).
    pub(crate) fn mixed_fleet() -> (Region, EvaluationDocument) {
        let text = include_str!("../../../examples/island-mixed.json");
        let scenario = Scenario::from_document(&parse_document(text).unwrap()).unwrap();
        let evaluation = scenario.evaluate(&Options::default());
        let doc = evaluation_document(&scenario.region, &scenario.ids, &evaluation);
        (scenario.region, doc)
    }

    /// An edge of a cell document as the core's piece.
    pub(crate) fn piece(edge: &EdgeDocument) -> Piece {
        let p = |[x, y]: XY| Point { x, y };
        match *edge {
            EdgeDocument::Segment { from, to } => Piece::Segment {
                from: p(from),
                to: p(to),
            },
            EdgeDocument::Arc {
                centre,
                radius,
                start,
                sweep,
            } => Piece::Arc {
                centre: p(centre),
                radius,
                start,
                sweep,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::{mixed_fleet, piece};
    use super::*;
    use seacover_engine::coverage::Options;

    fn start_and_end(e: &EdgeDocument) -> (XY, XY) {
        match *e {
            EdgeDocument::Segment { from, to } => (from, to),
            EdgeDocument::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                let at = |t: f64| [centre[0] + radius * t.cos(), centre[1] + radius * t.sin()];
                (at(start), at(start + sweep))
            }
        }
    }

    /// The loops close, bound exactly the cell's area (½∮ x dy − y dx
    /// along segments and arcs), and only curved cells have them.
    #[test]
    fn edge_loops_are_closed_and_bound_the_cell() {
        let (region, doc) = mixed_fleet();
        let mut curved = 0;
        for cell in &doc.cells {
            if cell.edges.is_empty() {
                continue;
            }
            curved += 1;
            let mut area = 0.0;
            for l in &cell.edges {
                for (k, e) in l.iter().enumerate() {
                    let (_, end) = start_and_end(e);
                    let (next, _) = start_and_end(&l[(k + 1) % l.len()]);
                    assert!(
                        (end[0] - next[0]).hypot(end[1] - next[1]) < 1e-9,
                        "{}",
                        cell.id
                    );
                    area += piece(e).area_share(Point { x: 50.0, y: 50.0 });
                }
            }
            assert!(
                (area - cell.area).abs() < 1e-9 * cell.area,
                "{}: {area} vs {}",
                cell.id,
                cell.area
            );
            assert!(cell.polygon.is_some());
        }
        assert!(curved >= 4, "{curved} curved cells");
        let total: f64 = doc.cells.iter().map(|c| c.area).sum();
        assert!(
            (total - region.area()).abs() < 1e-9 * total,
            "{total} vs {}",
            region.area()
        );
    }

    /// A fleet with one β: no cell has `edges`, and the JSON has no such
    /// member (straight-edged output unchanged byte for byte).
    #[test]
    fn one_beta_gives_no_edges() {
        let text = serde_json::json!({
            "region": {"polygon": [[0, 0], [100, 0], [100, 100], [0, 100]],
                       "holes": [[[44, 44], [56, 44], [56, 56], [44, 56]]]},
            "risk": {"base": 0.1, "objects": []},
            "vessels": [{"id": "a", "x": 20, "y": 20}, {"id": "b", "x": 80, "y": 70, "k": 2.0}],
        })
        .to_string();
        let doc = evaluate_text(&text, &Options::default()).unwrap();
        assert!(doc.cells.iter().all(|c| c.edges.is_empty()));
        assert!(!serde_json::to_string(&doc).unwrap().contains("edges"));
    }
}
