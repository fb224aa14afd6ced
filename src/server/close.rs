//! `Connection: close` on a response whose request body was not read.
//!
//! A request refused before its handler reads the body (a 401 or 429 from
//! the auth layer, a 404 or 405 from the router, a 413 from the body limit)
//! leaves the body unread, and hyper then closes the connection after the
//! response instead of reading on to the next request. Without a word that
//! is a broken pipe for an HTTP/1.1 client that reuses the connection; with
//! `Connection: close` the client knows to open a new one (RFC 9112 §9.6).
//! Requests without a body, and those whose body was read to its end, keep
//! their connection.

use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::task::{Context, Poll};

use axum::body::{Body, Bytes, HttpBody};
use axum::extract::Request;
use axum::http::{HeaderValue, header};
use axum::middleware::Next;
use axum::response::Response;
use http_body::{Frame, SizeHint};

/// A request body that notes when it has been read to its end.
struct Tracked {
    inner: Body,
    finished: Arc<AtomicBool>,
}

impl HttpBody for Tracked {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        let polled = Pin::new(&mut self.inner).poll_frame(cx);
        if matches!(polled, Poll::Ready(None)) || self.inner.is_end_stream() {
            self.finished.store(true, Ordering::Relaxed);
        }
        polled
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

/// Marks the response `Connection: close` when the request had a body that
/// nobody read to its end.
pub(super) async fn unread_bodies(request: Request, next: Next) -> Response {
    if request.body().is_end_stream() {
        return next.run(request).await;
    }
    let finished = Arc::new(AtomicBool::new(false));
    let tracked = finished.clone();
    let request = request.map(|inner| {
        Body::new(Tracked {
            inner,
            finished: tracked,
        })
    });
    let mut response = next.run(request).await;
    if !finished.load(Ordering::Relaxed) {
        response
            .headers_mut()
            .insert(header::CONNECTION, HeaderValue::from_static("close"));
    }
    response
}
