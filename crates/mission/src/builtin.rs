//! The built-in scenarios, compiled into the binary from `examples/` so a
//! fresh install runs them without files.

/// The paper's scenario (paper section 5), built in.
pub const PAPER_SCENARIO: &str = include_str!("../../../examples/paper.json");

/// A harbour with three islands and a pier, 30 vessels, built in
/// (`harbour-8` takes its first eight vessels).
pub const HARBOUR_SCENARIO: &str = include_str!("../../../examples/harbour.json");

/// Names of the built-in scenarios.
pub const BUILT_IN: [&str; 3] = ["paper", "harbour-8", "harbour-30"];

/// A built-in scenario's document and how many of its vessels to keep, by
/// name; `None` for any other name (a file, for the callers that read one).
pub fn scenario(name: &str) -> Option<(&'static str, usize)> {
    match name {
        "paper" => Some((PAPER_SCENARIO, usize::MAX)),
        "harbour-8" => Some((HARBOUR_SCENARIO, 8)),
        "harbour-30" => Some((HARBOUR_SCENARIO, 30)),
        _ => None,
    }
}
