//! The dashboard (`web/`): plain HTML, CSS and ES modules, embedded in the
//! binary at compile time and served at `/`, so a release binary is the whole
//! product and the page always matches the server's API.

use axum::extract::Path;
use axum::http::{StatusCode, header};
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
];

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
        None => (StatusCode::NOT_FOUND, "not found").into_response(),
    }
}

/// `GET /`.
pub async fn index() -> Response {
    file("index.html")
}

/// `GET /{file}`: the page's other files.
pub async fn asset(Path(name): Path<String>) -> Response {
    file(&name)
}

#[cfg(test)]
mod tests {
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
