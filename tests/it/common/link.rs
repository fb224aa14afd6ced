//! Vessel links as a vessel speaks them: a WebSocket, `hello`, frames.

use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

/// Opens a link to `url` as vessel `id` and waits for its welcome.
pub(crate) async fn hello(
    url: String,
    id: &str,
) -> (
    impl SinkExt<Message> + Unpin,
    impl StreamExt<Item = Result<Message, tokio_tungstenite::tungstenite::Error>> + Unpin,
) {
    let (socket, _) = tokio_tungstenite::connect_async(url.as_str())
        .await
        .unwrap();
    let (mut sink, mut stream) = socket.split();
    let _ = sink
        .send(Message::text(
            json!({"type": "hello", "vessel": id, "protocol": 1}).to_string(),
        ))
        .await;
    let welcome = next_json(&mut stream).await;
    assert_eq!(welcome["type"], "welcome", "{welcome}");
    assert_eq!(welcome["vessel"], id);
    (sink, stream)
}

/// The next text frame as JSON; `null` once the link is closed.
pub(crate) async fn next_json(
    stream: &mut (impl StreamExt<Item = Result<Message, tokio_tungstenite::tungstenite::Error>> + Unpin),
) -> Value {
    loop {
        match tokio::time::timeout(Duration::from_secs(5), stream.next())
            .await
            .expect("a frame in time")
        {
            Some(Ok(Message::Text(t))) => return serde_json::from_str(&t).unwrap(),
            Some(Ok(Message::Close(_))) | None => return Value::Null,
            Some(Ok(_)) => continue,
            // The peer went away: as good as a close for these tests.
            Some(Err(_)) => return Value::Null,
        }
    }
}
