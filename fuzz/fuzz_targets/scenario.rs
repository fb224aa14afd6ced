//! Scenario documents, as `seacover evaluate` and `POST
//! /api/v1/coverage/evaluate` read them: parse, validate, evaluate. Any text
//! must give either an evaluation or a `ScenarioError`, never a panic; an
//! evaluation has one cell per vessel and no NaN (README, "Defined edge
//! cases").
#![no_main]

use libfuzzer_sys::fuzz_target;
use seacover_engine::coverage::Options;
use seacover_mission::scenario::evaluate_text;

fuzz_target!(|data: &[u8]| {
    // Bounds the work per input: 64 KiB is a few hundred vessels or a ring
    // of a few thousand vertices, milliseconds of evaluation.
    if data.len() > 64 * 1024 {
        return;
    }
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match evaluate_text(text, &Options::default()) {
        Ok(doc) => {
            assert!(!doc.h.is_nan(), "H is NaN");
            for cell in &doc.cells {
                let numbers = [
                    cell.mass,
                    cell.area,
                    cell.centroid[0],
                    cell.centroid[1],
                    cell.gradient[0],
                    cell.gradient[1],
                ];
                assert!(
                    numbers.iter().all(|v| !v.is_nan()),
                    "NaN in cell {}: {cell:?}",
                    cell.id
                );
            }
            // The CLI prints it; the server sends it.
            serde_json::to_string(&doc).expect("an evaluation serializes");
        }
        // What the CLI prints and the server answers.
        Err(e) => {
            let _ = serde_json::to_string(&e.to_document());
        }
    }
});
