//! serde's messages as a client can read them: serde names the Rust type
//! it expected ("expected struct RiskObjectDocument"), which means nothing
//! outside this code; every edge that answers a client with a parse error
//! says what JSON was expected instead.

/// `e`'s message, with the Rust type names said as JSON.
///
/// ```
/// let e = serde_json::from_str::<seacover_protocol::PoseDocument>("[]").unwrap_err();
/// assert_eq!(
///     seacover_protocol::json_error(&e),
///     "invalid type: array, expected a JSON object at line 1 column 2"
/// );
/// ```
pub fn json_error(e: &serde_json::Error) -> String {
    let mut text = e.to_string();
    // serde reads a struct from an array too, and then counts its fields:
    // "invalid length 0, expected struct X with 10 elements".
    if let Some(at) = text.find("invalid length ")
        && let Some(to) = text[at..].find(" elements")
        && text[at..at + to].contains("expected struct ")
    {
        text.replace_range(
            at..at + to + " elements".len(),
            "invalid type: array, expected a JSON object",
        );
    }
    for (pattern, said) in [
        ("expected struct ", "expected a JSON object"),
        ("expected tuple struct ", "expected a JSON array"),
        (
            "data did not match any variant of untagged enum ",
            "the value has none of the forms this member takes",
        ),
        ("expected enum ", "expected one of the documented values"),
    ] {
        while let Some(at) = text.find(pattern) {
            let name = &text[at + pattern.len()..];
            let end = name
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(name.len());
            text.replace_range(at..at + pattern.len() + end, said);
        }
    }
    text
}
