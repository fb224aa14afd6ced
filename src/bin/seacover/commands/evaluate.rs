//! `seacover evaluate`: a scenario document in, its evaluation out (cells,
//! centroids, H(P)); errors as `{"error": {"code", "message"}}` on stderr.
//!
//! A command is one evaluation, so it uses every core: the cells on rayon's
//! pool (`Options::parallel`: the same result, bit for bit, as on one
//! thread) and the two halves of the output on two threads ([`write`]: the
//! same bytes as `serde_json::to_string` and a newline). On fleet-1000 the
//! output is 0.4 MB of numbers, whose formatting took a tenth of the
//! process (docs/performance.md).

use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use seacover::coverage::Options;
use seacover::coverage::integrate::Tolerance;
use seacover::protocol::{CellDocument, ErrorDetail, ErrorDocument, EvaluationDocument};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scenario JSON file; standard input when omitted or "-".
    #[arg(value_name = "FILE")]
    file: Option<PathBuf>,
    /// Use adaptive quadrature to this estimated relative error (mass;
    /// centroid relative to the cell's size) instead of the default fixed
    /// resolution: slower, for reference results.
    #[arg(long, value_name = "REL")]
    tolerance: Option<f64>,
}

pub(crate) fn run(Args { file, tolerance }: Args) -> ExitCode {
    let tolerance = match tolerance {
        None => Tolerance::default(),
        Some(t) if t.is_finite() && (1e-14..=1e-2).contains(&t) => Tolerance::adaptive(t),
        Some(t) => {
            return fail(
                "invalid",
                format!("--tolerance: must be in [1e-14, 1e-2], got {t}"),
            );
        }
    };
    let mut text = String::new();
    let read = match &file {
        Some(path) if path.as_os_str() != "-" => std::fs::read_to_string(path).map(|t| text = t),
        _ => std::io::stdin().read_to_string(&mut text).map(|_| ()),
    };
    if let Err(e) = read {
        let what = match &file {
            Some(path) if path.as_os_str() != "-" => path.display().to_string(),
            _ => "standard input".to_string(),
        };
        return fail("io", format!("cannot read {what}: {e}"));
    }
    // A risk named as a raster, as in `sim --scenario` (docs/rasters.md),
    // relative to the file's directory.
    let dir = match &file {
        Some(path) if path.as_os_str() != "-" => path.parent().map(PathBuf::from),
        _ => None,
    };
    let text = match seacover::raster::resolve(&text, &dir.unwrap_or_else(|| ".".into())) {
        Ok(text) => text,
        Err(e) => {
            let code = match e {
                seacover::raster::RasterError::Io { .. } => "io",
                seacover::raster::RasterError::Tiff { .. } => "malformed",
                seacover::raster::RasterError::Bands { .. }
                | seacover::raster::RasterError::Crs { .. }
                | seacover::raster::RasterError::NotNorthUp { .. } => "unsupported",
                _ => "invalid",
            };
            return fail(code, seacover::chain::Chain(&e).to_string());
        }
    };
    let options = Options {
        tolerance,
        parallel: true,
    };
    match seacover::mission::scenario::evaluate_text(&text, &options) {
        Ok(doc) => match write(doc, &mut std::io::stdout().lock()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => fail("io", format!("cannot write standard output: {e}")),
        },
        Err(e) => fail(e.code().as_str(), e.to_string()),
    }
}

/// Writes `doc` as compact JSON and a newline: the bytes of
/// `serde_json::to_string(&doc)` + "\n", the cells serialized in two halves
/// on two threads. The document without its cells is serialized first and
/// the cells go between the brackets of its `"cells":[]`; should that not
/// be found exactly once (a change of the document), the whole document is
/// serialized on this thread.
pub(crate) fn write(mut doc: EvaluationDocument, out: &mut impl Write) -> std::io::Result<()> {
    const KEY: &[u8] = br#""cells":[]"#;
    let cells = std::mem::take(&mut doc.cells);
    let frame = serde_json::to_vec(&doc)?;
    let mut at = frame
        .windows(KEY.len())
        .enumerate()
        .filter(|(_, w)| *w == KEY);
    let bracket = match (at.next(), at.next()) {
        (Some((i, _)), None) if cells.len() >= 2 => i + KEY.len() - 1,
        _ => {
            doc.cells = cells;
            let mut text = serde_json::to_vec(&doc)?;
            text.push(b'\n');
            out.write_all(&text)?;
            return out.flush();
        }
    };
    let (first, second) = cells.split_at(cells.len() / 2);
    let (a, b) = std::thread::scope(|s| {
        let b = s.spawn(|| elements(second));
        (
            elements(first),
            b.join().expect("serializing cells does not panic"),
        )
    });
    out.write_all(&frame[..bracket])?;
    out.write_all(&a?)?;
    out.write_all(b",")?;
    out.write_all(&b?)?;
    out.write_all(&frame[bracket..])?;
    out.write_all(b"\n")?;
    out.flush()
}

/// The cells as the elements of a JSON array, comma-separated.
fn elements(cells: &[CellDocument]) -> serde_json::Result<Vec<u8>> {
    let mut text = Vec::with_capacity(512 * cells.len());
    for (i, cell) in cells.iter().enumerate() {
        if i > 0 {
            text.push(b',');
        }
        serde_json::to_writer(&mut text, cell)?;
    }
    Ok(text)
}

fn fail(code: &str, message: String) -> ExitCode {
    let doc = ErrorDocument {
        error: ErrorDetail {
            code: code.to_string(),
            message,
        },
    };
    eprintln!(
        "{}",
        serde_json::to_string(&doc).expect("error documents serialize")
    );
    ExitCode::from(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The output is the bytes of `serde_json::to_string` and a newline,
    /// for every size (the halves, and the fallback below two cells).
    #[test]
    fn output_is_serde_json_to_string() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/fleet-100.json"
        ))
        .unwrap();
        let options = Options::default();
        let doc = seacover::mission::scenario::evaluate_text(&text, &options).unwrap();
        for n in [0, 1, 2, 3, 100] {
            let mut doc = doc.clone();
            doc.cells.truncate(n);
            let expected = serde_json::to_string(&doc).unwrap() + "\n";
            let mut got = Vec::new();
            write(doc, &mut got).unwrap();
            assert_eq!(String::from_utf8(got).unwrap(), expected, "{n} cells");
        }
    }
}
