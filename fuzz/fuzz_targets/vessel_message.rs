//! Frames of the vessel link, as the coordinator and the agent read them:
//! text → `VesselMessage` (src/server/ws.rs) and → `CoordinatorMessage`
//! (src/agent). Parsing must never panic, and whatever parses must survive
//! the checks that follow it and serialize back into something that parses
//! as the same kind of message.
#![no_main]

use libfuzzer_sys::fuzz_target;
use seacover_protocol::{CoordinatorMessage, VesselMessage};
use seacover_mission::scenario::valid_id;

fuzz_target!(|data: &[u8]| {
    // WebSocket text frames are UTF-8 and at most 64 KiB (ws::MAX_FRAME).
    if data.len() > 64 * 1024 {
        return;
    }
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };

    if let Ok(message) = serde_json::from_str::<VesselMessage>(text) {
        // What the link and the tick task check after parsing.
        match &message {
            VesselMessage::Hello { vessel, .. } => {
                let _ = valid_id(vessel);
            }
            VesselMessage::Pose(p) => {
                // serde_json never yields a non-finite number.
                assert!(
                    [p.t, p.x, p.y, p.psi, p.u, p.v, p.r]
                        .iter()
                        .all(|v| v.is_finite())
                );
            }
            VesselMessage::Sample(s) => {
                assert!([s.x, s.y, s.value, s.sd].iter().all(|v| v.is_finite()));
            }
        }
        let json = serde_json::to_string(&message).expect("a parsed message serializes");
        let again: VesselMessage =
            serde_json::from_str(&json).expect("a serialized message parses");
        assert_eq!(
            std::mem::discriminant(&message),
            std::mem::discriminant(&again)
        );
    }

    if let Ok(message) = serde_json::from_str::<CoordinatorMessage>(text) {
        let json = serde_json::to_string(&message).expect("a parsed message serializes");
        let again: CoordinatorMessage =
            serde_json::from_str(&json).expect("a serialized message parses");
        assert_eq!(
            std::mem::discriminant(&message),
            std::mem::discriminant(&again)
        );
    }
});
