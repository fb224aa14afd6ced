//! OpenAPI schemas of the rings. utoipa reads field types by name and cannot
//! see through the [`XY`](super::XY) alias (schemars can): a lone `XY` field says
//! `value_type = Vec<f64>, min_items = 2, max_items = 2`, and lists of them
//! come from here, with their descriptions (utoipa drops a field's doc
//! comment when `schema_with` builds its schema).

use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, SchemaType, Type};
use utoipa::openapi::{KnownFormat, SchemaFormat};

/// `[x, y]`: exactly two numbers, as serde reads `[f64; 2]`.
fn xy() -> ArrayBuilder {
    ArrayBuilder::new()
        .items(
            ObjectBuilder::new()
                .schema_type(Type::Number)
                .format(Some(SchemaFormat::KnownFormat(KnownFormat::Double))),
        )
        .min_items(Some(2))
        .max_items(Some(2))
}

/// `[[x, y], …]`.
fn points() -> ArrayBuilder {
    ArrayBuilder::new().items(xy())
}

fn ring(description: &str) -> ArrayBuilder {
    points().description(Some(description))
}

fn or_null(array: ArrayBuilder) -> ArrayBuilder {
    array.schema_type(
        [Type::Array, Type::Null]
            .into_iter()
            .collect::<SchemaType>(),
    )
}

pub(crate) fn region_polygon() -> ArrayBuilder {
    ring("Outer ring `[[x, y], …]` in metres, without the closing vertex.")
}

pub(crate) fn region_holes() -> ArrayBuilder {
    ArrayBuilder::new().items(points()).description(Some(
        "Islands: rings strictly inside the polygon and disjoint.",
    ))
}

pub(crate) fn cell_polygon() -> ArrayBuilder {
    or_null(ring(
        "Outer ring of the cell (of its largest piece when it has several), \
         counter-clockwise, without the closing vertex; `null` when empty. A curved \
         cell's arcs are vertices on the arc, every point of the arc within 0.1 m of \
         the chords (the exact arcs are in `edges`).",
    ))
}

pub(crate) fn status_polygon() -> ArrayBuilder {
    or_null(ring(
        "The cell's outer ring (as a cell's `polygon`: arcs as vertices within 0.1 m); \
         `null` when the vessel has no cell.",
    ))
}
