//! The tick held to `evaluate` and `SafetyLayer::commands`, bit for bit.

use super::*;
use crate::control::Vec3;
use crate::control::plausibility::Limits;

/// A coordinator of `mission` in real time, with no store. (Its
/// snapshots go to no reader: publishing needs none.)
fn coordinator(mission: &Mission) -> Coordinator {
    let settings = TickSettings {
        time_warp: 1.0,
        liveness: 3.0,
        limits: Limits::default(),
        learning: None,
    };
    Coordinator::new(mission.clone(), settings, None).0
}

/// Registers a vessel through the same request a link sends; returns
/// its pose slot and command queue.
fn register(
    c: &mut Coordinator,
    id: &str,
    link: u64,
) -> (
    watch::Sender<Option<PoseDocument>>,
    mpsc::Receiver<Outgoing>,
) {
    let (tx, rx) = mpsc::channel(16);
    let (pose_tx, poses) = watch::channel(None);
    let (reply, answer) = oneshot::channel();
    c.on_request(Request::Register {
        id: id.into(),
        link,
        actuator: None,
        astern: true,
        agility: None,
        mission: None,
        station_radius: None,
        tx,
        poses,
        reply,
    });
    assert!(answer.blocking_recv().unwrap().is_ok());
    (pose_tx, rx)
}

fn pose(x: f64, y: f64, psi: f64, u: f64) -> PoseDocument {
    serde_json::from_value(serde_json::json!({
        "t": 0.0, "x": x, "y": y, "psi": psi, "u": u, "v": 0.0, "r": 0.0
    }))
    .unwrap()
}

/// Asserts that a tick's cells and H are `evaluate`'s for the vessels
/// at `states` with the mission's actuator.
fn assert_is_the_evaluation(mission: &Mission, states: &[State], eval: &Evaluation) {
    let fleet = Fleet::new(
        states
            .iter()
            .map(|s| Vessel {
                position: Point { x: s.x, y: s.y },
                k: mission.actuator().k,
                beta: mission.actuator().beta,
            })
            .collect(),
    )
    .unwrap();
    assert_eq!(
        eval,
        &evaluate(
            mission.region(),
            mission.risk(),
            &fleet,
            &Options::default()
        )
    );
}

/// The command waiting on a link's queue (`what` names it in failures).
fn command(rx: &mut mpsc::Receiver<Outgoing>, what: &str) -> CommandDocument {
    let Ok(Outgoing::Command { text, .. }) = rx.try_recv() else {
        panic!("{what}: no command");
    };
    let Ok(CoordinatorMessage::Command(got)) = serde_json::from_str(&text) else {
        panic!("{what}: not a command: {text}");
    };
    got
}

/// The tick's commands are exactly the safety layer's for the same poses
/// and cells (the function `seacover sim` calls), over several ticks, and
/// two vessels closing head on inside the safety distance make the
/// filter act.
#[test]
fn tick_commands_are_the_safety_layers() {
    let mission = Mission::paper();
    let mut c = coordinator(&mission);
    let starts = [
        ("usv-1", 40.0, 50.0, 0.0, 1.2),
        ("usv-2", 45.0, 50.0, std::f64::consts::PI, 1.2),
        ("usv-3", 20.0, 80.0, 1.0, 0.3),
    ];
    let mut links: Vec<_> = starts
        .iter()
        .enumerate()
        .map(|(i, s)| register(&mut c, s.0, i as u64))
        .collect();
    let mut local: Vec<Guidance> = starts
        .iter()
        .map(|_| Guidance::new(mission.guidance()))
        .collect();
    let mut intervened = 0;
    for tick in 0..3 {
        let states: Vec<State> = starts
            .iter()
            .map(|s| State {
                x: s.1 + 0.1 * tick as f64,
                y: s.2,
                psi: s.3,
                vel: Vec3::new(s.4, 0.0, 0.0),
            })
            .collect();
        for ((pose_tx, _), s) in links.iter().zip(&states) {
            pose_tx.send_replace(Some(pose(s.x, s.y, s.psi, s.vel.x)));
        }
        let (written_tx, mut written) = mpsc::channel(1);
        let published = c.on_tick(1, std::time::Instant::now(), written_tx);
        let eval = published.evaluation.as_ref().unwrap();
        // The pipelined tick's cells and H are the evaluation's.
        assert_is_the_evaluation(&mission, &states, eval);
        let expected = mission
            .layer()
            .commands(published.time, &states, &eval.cells, &mut local);
        intervened += expected.iter().filter(|s| s.intervened).count();
        for ((_, rx), want) in links.iter_mut().zip(&expected) {
            let got = command(rx, &format!("tick {tick}"));
            assert_eq!(got.tick, tick + 1);
            assert_eq!(
                (got.u_d, got.r_d, got.e),
                (want.command.u_d, want.command.r_d, want.command.e),
                "tick {tick}"
            );
        }
        // Every command was taken (and its guard dropped with it): the
        // fan-out is over.
        assert_eq!(
            written.try_recv(),
            Err(mpsc::error::TryRecvError::Disconnected)
        );
    }
    assert!(
        intervened >= 2,
        "the head-on pair never triggered the filter"
    );
}

/// A fleet large enough for the tick to run on every core: its cells, H
/// and every command are still exactly those of `evaluate` and the
/// safety layer, and each link gets its own vessel's command.
#[test]
fn a_large_fleets_parallel_tick_is_the_evaluation_and_the_safety_layer() {
    let mission = Mission::paper();
    let mut c = coordinator(&mission);
    let n = 2 * crate::coverage::PARALLEL_MIN;
    // Ids in the coordinator's (id) order.
    let ids: Vec<String> = (0..n).map(|i| format!("usv-{i:03}")).collect();
    let mut links: Vec<_> = ids
        .iter()
        .enumerate()
        .map(|(i, id)| register(&mut c, id, i as u64))
        .collect();
    let states: Vec<State> = (0..n)
        .map(|i| State {
            x: 5.0 + 90.0 * ((i * 37) % n) as f64 / n as f64,
            y: 5.0 + 90.0 * (i % 16) as f64 / 16.0,
            psi: 0.1 * i as f64,
            vel: Vec3::new(0.5, 0.0, 0.0),
        })
        .collect();
    for ((pose_tx, _), s) in links.iter().zip(&states) {
        pose_tx.send_replace(Some(pose(s.x, s.y, s.psi, s.vel.x)));
    }
    let (written_tx, _written) = mpsc::channel(1);
    let published = c.on_tick(1, std::time::Instant::now(), written_tx);
    let eval = published.evaluation.as_ref().unwrap();
    assert_is_the_evaluation(&mission, &states, eval);
    let mut local: Vec<Guidance> = (0..n).map(|_| Guidance::new(mission.guidance())).collect();
    let expected = mission
        .layer()
        .commands(published.time, &states, &eval.cells, &mut local);
    for (i, ((_, rx), want)) in links.iter_mut().zip(&expected).enumerate() {
        let got = command(rx, &format!("vessel {i}"));
        assert_eq!(
            (got.u_d, got.r_d, got.e, got.centroid),
            (
                want.command.u_d,
                want.command.r_d,
                want.command.e,
                [eval.cells[i].centroid.x, eval.cells[i].centroid.y]
            ),
            "vessel {i}"
        );
    }
}

/// The tick task's H history, as readers get it through the `watch`: every
/// tick's H (the evaluation's) until it holds 1000, then every other one
/// dropped and the stride doubled, from the first tick on; a mission
/// change publishing the same tick again adds nothing.
#[test]
fn the_watch_carries_a_bounded_history_from_the_first_tick() {
    let mission = Mission::paper();
    let settings = TickSettings {
        time_warp: 1.0,
        liveness: 1e9,
        limits: Limits::default(),
        learning: None,
    };
    let (mut c, snapshots) = Coordinator::new(mission.clone(), settings, None);
    let (pose_tx, _rx) = register(&mut c, "usv-1", 1);
    let mut hs = Vec::new();
    for tick in 1..=2500u64 {
        // A vessel creeping east: H changes every tick.
        pose_tx.send_replace(Some(pose(10.0 + 0.03 * tick as f64, 40.0, 0.0, 0.3)));
        let (written_tx, _written) = mpsc::channel(1);
        let published = c.on_tick(1, std::time::Instant::now(), written_tx);
        hs.push(published.evaluation.as_ref().unwrap().h);
        c.finish_tick(published);
        let snapshot = snapshots.borrow().clone();
        assert_eq!(snapshot.document.tick, tick);
        assert!(snapshot.history.samples.len() < history::CAPACITY);
        if tick == 10 {
            // A change at tick 10 publishes tick 10 again.
            let (reply, _answer) = oneshot::channel();
            c.on_request(Request::Change {
                change: MissionChange::Base(2.0),
                reply,
            });
            assert_eq!(snapshots.borrow().history.samples.len(), 10);
        }
    }
    let history = snapshots.borrow().history.clone();
    // 2500 ticks: full at tick 1000 (then ticks 1, 3, …, 999 kept, stride
    // 2), again at 1999 (1, 5, …, 1997, stride 4), then every fourth tick.
    assert_eq!(history.stride, 4);
    assert_eq!(history.samples[0].tick, 1);
    for pair in history.samples.windows(2) {
        assert_eq!(pair[1].tick - pair[0].tick, 4);
    }
    for s in &history.samples {
        assert_eq!(s.time, s.tick as f64 / mission.tick_hz());
        assert_eq!(s.h, hs[s.tick as usize - 1], "tick {}", s.tick);
    }
    assert!(2500 - history.samples.last().unwrap().tick < 4);
}

/// A coordinator that only has its start-up mission holds a vessel that
/// names another (welcomed without a name, out of the partition, told to
/// hold); an operator's change releases it and names the new mission.
#[test]
fn a_provisional_mission_holds_a_vessel_that_follows_another_until_a_change() {
    let mission = Mission::paper();
    let mut c = coordinator(&mission).provisional();
    let ours = mission_name(&mission.document());
    assert_eq!(ours.len(), 16);
    assert_eq!(
        ours,
        mission_name(&Mission::paper().document()),
        "a name is the mission's alone"
    );
    let hello = |c: &mut Coordinator, id: &str, followed: Option<&str>| {
        let (tx, rx) = mpsc::channel(16);
        let (pose_tx, poses) = watch::channel(None);
        let (reply, answer) = oneshot::channel();
        c.on_request(Request::Register {
            id: id.into(),
            link: 1,
            actuator: None,
            astern: true,
            agility: None,
            mission: followed.map(String::from),
            station_radius: None,
            tx,
            poses,
            reply,
        });
        pose_tx.send_replace(Some(pose(30.0, 30.0 + id.len() as f64, 0.0, 0.0)));
        (answer.blocking_recv().unwrap().unwrap(), pose_tx, rx)
    };
    let (same, _p1, _r1) = hello(&mut c, "same", Some(&ours));
    assert_eq!(same.mission.as_deref(), Some(ours.as_str()));
    let (fresh, _p2, _r2) = hello(&mut c, "fresh", None);
    assert_eq!(fresh.mission.as_deref(), Some(ours.as_str()));
    let (stray, _p3, mut rx) = hello(&mut c, "stray", Some("0123456789abcdef"));
    assert_eq!(stray.mission, None, "a held vessel keeps the name it had");
    let (written_tx, _written) = mpsc::channel(8);
    let published = c.on_tick(1, std::time::Instant::now(), written_tx);
    assert_eq!(published.live, ["fresh", "same"]);
    c.finish_tick(published);
    let held = command(&mut rx, "a hold");
    assert!(
        held.hold
            .as_deref()
            .is_some_and(|h| h.contains("0123456789abcdef")),
        "{held:?}"
    );
    assert_eq!(held.centroid, [30.0, 35.0]);

    let (reply, answer) = oneshot::channel();
    c.on_request(Request::Change {
        change: MissionChange::Base(2.0),
        reply,
    });
    assert!(answer.blocking_recv().unwrap().is_ok());
    let named = loop {
        match rx.try_recv().expect("the new mission named on the link") {
            Outgoing::Notice(CoordinatorMessage::Mission { mission }) => break mission,
            _ => continue,
        }
    };
    assert_ne!(named, ours);
    assert_eq!(named, c.name);
    let (written_tx, _written) = mpsc::channel(8);
    let published = c.on_tick(1, std::time::Instant::now(), written_tx);
    assert_eq!(published.live, ["fresh", "same", "stray"]);
    // A later hello naming a mission it does not hold re-tasks: the
    // mission is the fleet's now.
    let (late, _p4, _r4) = hello(&mut c, "late", Some("0123456789abcdef"));
    assert_eq!(late.mission.as_deref(), Some(named.as_str()));
}

/// A link that goes down after writing its command, while the tick's
/// other commands are still being written, is connected in that tick's
/// recorded snapshot, command and all: the recording holds every command
/// written. (A CI run once recorded 253 of 255: its fleet stopped in the
/// middle of a fan-out, and the links' goodbyes were served first.)
#[test]
fn a_link_lost_in_the_fanout_is_recorded_with_its_command() {
    use crate::recorder::reader::Recording;
    use crate::recorder::{RecorderConfig, Target, messages};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let config = RecorderConfig {
        target: Target::File(path.clone()),
        wall_clock: false,
    };
    let (recorder, thread) = Recorder::start(config, true);
    let mission = Mission::paper();
    let clock = MissionClock::first_tick_now(1.0, mission.tick_hz());
    let mut c = coordinator(&mission).recording(recorder.clone(), clock);
    let (pose_tx, mut rx) = register(&mut c, "usv-1", 7);
    pose_tx.send_replace(Some(pose(40.0, 50.0, 0.0, 0.5)));
    let (written_tx, written) = mpsc::channel(1);
    let published = c.on_tick(1, std::time::Instant::now(), written_tx);
    let mut pending = Some(Fanout {
        published,
        written,
        deadline: tokio::time::Instant::now() + Duration::from_secs(1),
    });
    // The link writes its command, then goes down.
    command(&mut rx, "tick 1");
    drop(rx);
    c.serve(
        Request::Gone {
            id: "usv-1".into(),
            link: 7,
        },
        &mut pending,
    );
    // Then the fan-out ends, as the tick task would see it.
    if let Some(tick) = pending.take() {
        c.finish_tick(tick.published);
    }
    recorder.finish();
    thread.join();
    let recording = Recording::open(&path).unwrap();
    let commands = recording
        .channels()
        .into_iter()
        .find(|(channel, _)| &*channel.topic == messages::COMMAND)
        .map_or(0, |(_, n)| n);
    assert_eq!(commands, 1, "the command written is recorded");
}
