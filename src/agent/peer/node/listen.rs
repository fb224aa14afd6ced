//! What a member hears: the beacons (its fleet's, and every other fleet's
//! to count them), the mission as it is published, and the mission
//! queries it answers with the revision it holds.

use std::sync::Arc;

use zenoh::Wait;

use crate::agent::peer::board::Revision;
use crate::agent::peer::wire::Keys;

/// Who takes what the member hears.
pub(super) trait Listener: Send + Sync + 'static {
    /// A beacon on key `key`.
    fn on_beacon(&self, key: &str, bytes: &[u8]);
    /// A mission document as it was published.
    fn offer_mission(&self, bytes: &[u8]);
    /// The revision a mission query is answered with.
    fn current_mission(&self) -> Option<Arc<Revision>>;
}

/// Declares the member's subscribers and its mission queryable, each
/// calling into `shared` for as long as the session lives.
pub(super) async fn declare<L: Listener>(
    session: &zenoh::Session,
    shared: &Arc<L>,
    keys: &Keys,
) -> Result<(), zenoh::Error> {
    let s = shared.clone();
    session
        .declare_subscriber(keys.beacons())
        .callback(move |sample| {
            s.on_beacon(sample.key_expr().as_str(), &sample.payload().to_bytes());
        })
        .background()
        .await?;
    // Another fleet's beacons are counted; the own fleet's arrive
    // through the subscription above as well as this one.
    let (s, own) = (shared.clone(), keys.fleet.clone());
    session
        .declare_subscriber(Keys::all_beacons())
        .callback(move |sample| {
            let key = sample.key_expr().as_str();
            if Keys::parse_beacon(key).is_some_and(|(fleet, _)| fleet != own) {
                s.on_beacon(key, &sample.payload().to_bytes());
            }
        })
        .background()
        .await?;
    let s = shared.clone();
    session
        .declare_subscriber(keys.mission())
        .callback(move |sample| s.offer_mission(&sample.payload().to_bytes()))
        .background()
        .await?;
    let s = shared.clone();
    let mission_key = keys.mission();
    session
        .declare_queryable(keys.mission())
        .callback(move |query| {
            if let Some(rev) = s.current_mission() {
                let _ = query.reply(&mission_key, rev.json.as_slice()).wait();
            }
        })
        .background()
        .await?;
    Ok(())
}
