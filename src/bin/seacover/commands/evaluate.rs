//! `seacover evaluate`: a scenario document in, its evaluation out (cells,
//! centroids, H(P)); errors as `{"error": {"code", "message"}}` on stderr.

use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

use seacover::coverage::Options;
use seacover::coverage::integrate::Tolerance;
use seacover::protocol::{ErrorDetail, ErrorDocument};

#[derive(clap::Args)]
pub struct Args {
    /// Scenario JSON file; standard input when omitted or "-".
    #[arg(value_name = "FILE")]
    file: Option<PathBuf>,
    /// Use adaptive quadrature to this estimated relative error (mass;
    /// centroid relative to the cell's size) instead of the default fixed
    /// resolution: slower, for reference results.
    #[arg(long, value_name = "REL")]
    tolerance: Option<f64>,
}

pub fn run(Args { file, tolerance }: Args) -> ExitCode {
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
    let options = Options {
        tolerance,
        ..Options::default()
    };
    match seacover::mission::scenario::evaluate_text(&text, &options) {
        Ok(doc) => {
            println!(
                "{}",
                serde_json::to_string(&doc).expect("evaluations serialize")
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(e.code(), e.to_string()),
    }
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
