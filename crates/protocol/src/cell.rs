//! The wire form of cells: their figures, their outline as polygons that
//! every client and GIS reads, and, for a curved cell (vessels with
//! different reaches β, paper eq. 6), its exact boundary of segments and arcs.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::{RegionDocument, XY, schema};

/// Result of `evaluate`: cells in the order of the request's vessels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct EvaluationDocument {
    /// The coverage metric H(P) = Σ M_i.
    #[serde(rename = "H")]
    pub h: f64,
    pub cells: Vec<CellDocument>,
}

/// Figures of one cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct CellDocument {
    pub id: String,
    /// M_i = ∫_{V_i} f_i Φ.
    pub mass: f64,
    /// C_i; the nearest point of the region for an empty cell.
    #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
    pub centroid: XY,
    /// [m²].
    pub area: f64,
    /// Outer ring of the cell (of its largest piece when it has several),
    /// counter-clockwise, without the closing vertex; `null` when empty.
    /// A curved cell's arcs are vertices on the arc, every point of the
    /// arc within 0.1 m of the chords (the exact arcs are in `edges`).
    #[schema(schema_with = schema::cell_polygon, required = true)]
    pub polygon: Option<Vec<XY>>,
    /// Every piece with its holes, present only when the cell is not one
    /// simple polygon (several pieces, or a hole inside it: an island of
    /// Q, or the disc another vessel wins), arcs as in `polygon`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pieces: Vec<RegionDocument>,
    /// The exact boundary of a cell with curved edges, present only when
    /// it has an arc (a fleet with different β): closed loops, each a list
    /// of edges that starts where the previous one ends (to rounding) and
    /// ends where the first starts, the cell on the left of every edge —
    /// so a piece's outline runs counter-clockwise and a hole's clockwise,
    /// and a path of all loops fills the cell with either fill rule.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub edges: Vec<Vec<EdgeDocument>>,
    /// ∂H/∂p_i = 2β M_i (C_i − p_i).
    #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
    pub gradient: XY,
}

/// One edge of a curved cell's boundary, the cell on its left.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum EdgeDocument {
    /// The straight line from `from` to `to` [m].
    Segment {
        #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
        from: XY,
        #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
        to: XY,
    },
    /// The points `centre + radius (cos θ, sin θ)` for θ from `start` to
    /// `start + sweep` [rad, from the +x axis towards +y]: counter-clockwise
    /// when `sweep` > 0 (the cell inside the circle: this vessel wins the
    /// disc), clockwise when `sweep` < 0 (the cell outside it: another
    /// vessel wins the disc); |sweep| ≤ 2π, a whole circle when it is 2π.
    Arc {
        #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
        centre: XY,
        /// [m], > 0.
        radius: f64,
        /// [rad].
        start: f64,
        /// [rad].
        sweep: f64,
    },
}
