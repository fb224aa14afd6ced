//! The dashboard (`web/`): plain HTML, CSS and ES modules, embedded in the
//! binary at compile time and served at `/`, so a release binary is the whole
//! product and the page always matches the server's API.
//!
//! The page is served marked with what serves it (`<html data-mode="live">`
//! or `"replay"`, [`PageMode`]): the page knows from its first paint whether
//! to offer editing, with no request that a coordinator would answer 404.

use axum::Extension;
use axum::extract::Path;
use axum::http::header;
use axum::response::{IntoResponse, Response};

/// (file name, content type, content).
const FILES: &[(&str, &str, &str)] = &[
    (
        "index.html",
        "text/html; charset=utf-8",
        include_str!("../../web/index.html"),
    ),
    (
        "style.css",
        "text/css; charset=utf-8",
        include_str!("../../web/style.css"),
    ),
    (
        "app.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/app.js"),
    ),
    (
        "api.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/api.js"),
    ),
    (
        "map.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/map.js"),
    ),
    (
        "charts.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/charts.js"),
    ),
    (
        "wgs84.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/wgs84.js"),
    ),
    (
        "geo-overlay.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/geo-overlay.js"),
    ),
    (
        "replay.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/replay.js"),
    ),
    (
        "belief.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/belief.js"),
    ),
];

/// What serves the page when it is not a coordinator (the default, with
/// no extension): a replay adds `Extension(PageMode::Replay)` to its
/// router.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PageMode {
    Replay,
}

/// The opening tag the mode is written into.
const HTML_TAG: &str = "<html lang=\"en\">";

/// `index.html`, marked with `mode`.
fn page(mode: Option<Extension<PageMode>>) -> Response {
    let mode = match mode {
        Some(Extension(PageMode::Replay)) => "replay",
        None => "live",
    };
    let html = include_str!("../../web/index.html").replacen(
        HTML_TAG,
        &format!("<html lang=\"en\" data-mode=\"{mode}\">"),
        1,
    );
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        html,
    )
        .into_response()
}

fn file(name: &str) -> Response {
    match FILES.iter().find(|(n, _, _)| *n == name) {
        Some((_, mime, body)) => (
            [
                (header::CONTENT_TYPE, *mime),
                // Small files, and the page must follow a server upgrade.
                (header::CACHE_CONTROL, "no-cache"),
            ],
            *body,
        )
            .into_response(),
        None => super::error::ApiError::NotFound(format!("no such file: /{name}")).into_response(),
    }
}

/// `GET /`.
pub(super) async fn index(mode: Option<Extension<PageMode>>) -> Response {
    page(mode)
}

/// `GET /{file}`: the page's other files (and the page again as
/// `/index.html`).
pub(super) async fn asset(mode: Option<Extension<PageMode>>, Path(name): Path<String>) -> Response {
    if name == "index.html" {
        page(mode)
    } else {
        file(&name)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_page_is_marked_with_its_mode_once() {
        let page = include_str!("../../web/index.html");
        assert_eq!(page.matches(super::HTML_TAG).count(), 1);
        assert_eq!(page.matches("data-mode").count(), 0);
    }

    #[test]
    fn every_module_the_page_imports_is_served() {
        let names: Vec<&str> = super::FILES.iter().map(|(n, _, _)| *n).collect();
        for (_, _, body) in super::FILES {
            for line in body.lines() {
                if let Some(rest) = line.trim().strip_prefix("import ")
                    && let Some(start) = rest.find("\"./")
                {
                    let path = &rest[start + 3..];
                    let name = &path[..path.find('"').unwrap()];
                    assert!(names.contains(&name), "{name} is imported but not served");
                }
            }
        }
    }
}
