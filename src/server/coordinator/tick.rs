//! The tick: collect the newest poses, partition, then each vessel's cell,
//! goal, safety filter and command on its own (on every core from 64
//! vessels), each command handed to its link as soon as it is ready; the
//! snapshot for readers is built once the commands are written.

use std::collections::BTreeSet;
use std::sync::Arc;

use tokio::sync::mpsc;

use super::*;

/// Serializes `doc` (on the thread that computed it) and hands it to
/// `link`. A link that cannot keep up misses this command, counted; the
/// next one supersedes it anyway.
fn send_command(
    link: &Link,
    doc: &CommandDocument,
    due: std::time::Instant,
    written: &mpsc::Sender<()>,
) {
    let text = serde_json::to_string(&CoordinatorMessage::Command(doc.clone()))
        .expect("commands serialize");
    let sent = link.tx.try_send(Outgoing::Command {
        text: Utf8Bytes::from(text),
        due,
        written: written.clone(),
    });
    if sent.is_err() {
        metrics::counter!(crate::server::metrics::MESSAGES_REJECTED, "reason" => "link_full")
            .increment(1);
    }
}

/// The density the fleet covers: the learned belief once fitted, else the
/// mission's risk.
fn covered<'a>(
    learning: &'a Option<super::learning::Learning>,
    mission: &'a crate::mission::Mission,
) -> &'a crate::coverage::RiskField {
    learning
        .as_ref()
        .and_then(|l| l.belief())
        .unwrap_or(mission.risk())
}

impl Coordinator {
    /// Takes every link's newest pose, if it has a new one, judged
    /// ([`judging`]).
    pub(super) fn collect_poses(&mut self) {
        let tick = self.tick;
        let bench = judging::Bench {
            limits: &self.settings.limits,
            region: self.mission.region(),
            time: self.time(),
            recorder: &self.recorder,
        };
        for (id, entry) in self.vessels.iter_mut() {
            if let Some(mut link) = entry.link.take() {
                take_pose(id, entry, &mut link, tick, &bench);
                entry.link = Some(link);
            }
        }
    }

    /// Heard within the liveness window.
    pub(super) fn is_heard(&self, entry: &Entry) -> bool {
        let window = (self.settings.liveness * self.mission.tick_hz()).round() as u64;
        entry
            .last_seen_tick
            .is_some_and(|t| self.tick - t <= window)
    }

    /// In the partition: heard, with a believed pose, and not quarantined.
    pub(super) fn is_live(&self, entry: &Entry) -> bool {
        entry.pose.is_some() && !entry.standing.held() && self.is_heard(entry)
    }

    /// Each quarantined vessel that is still heard is told to hold, every
    /// tick, so that a vessel whose poses are refused never drives on
    /// its last command.
    pub(super) fn hold_quarantined(&mut self, due: std::time::Instant, written: &mpsc::Sender<()>) {
        let tick = self.tick;
        let heard: Vec<String> = self
            .vessels
            .iter()
            .filter(|(_, e)| e.standing.held() && e.link.is_some() && self.is_heard(e))
            .map(|(id, _)| id.clone())
            .collect();
        for id in heard {
            let entry = self.vessels.get_mut(&id).expect("listed above");
            let (Some(doc), Some(link)) = (
                entry.standing.hold_command(tick, entry.pose.as_ref()),
                &entry.link,
            ) else {
                continue;
            };
            send_command(link, &doc, due, written);
            entry.last_command = Some(doc);
        }
    }

    /// Ids of the vessels in the partition, in id order.
    pub(super) fn live_ids(&self) -> Vec<String> {
        self.vessels
            .iter()
            .filter(|(_, e)| self.is_live(e))
            .map(|(id, _)| id.clone())
            .collect()
    }

    /// One tick, `advance` ticks after the previous one (more than one when
    /// the interval skipped some), due at `due`.
    ///
    /// Pipelined: after the partition (which needs every position), each
    /// vessel's cell figures, goal, filter and command are computed on their
    /// own (on every core for large fleets) and the command is serialized
    /// and handed to its link at once, so the first commands are on the
    /// wire while the last are still being computed. Each handed command
    /// holds a clone of `written`. The cells and H are those of
    /// [`evaluate`], and the commands those of
    /// [`SafetyLayer::commands`](crate::control::safety::SafetyLayer::commands),
    /// bit for bit.
    pub(super) fn on_tick(
        &mut self,
        advance: u64,
        due: std::time::Instant,
        written: mpsc::Sender<()>,
    ) -> Published {
        self.tick += advance;
        if let Some(l) = &mut self.learning {
            l.poll(
                &self.mission,
                self.tick as f64 / self.mission.tick_hz(),
                &self.recorder,
            );
        }
        self.collect_poses();
        self.hold_quarantined(due, &written);
        let time = self.tick as f64 / self.mission.tick_hz();
        let live = self.live_ids();
        self.note_liveness(time, &live);
        let Some(fleet) = self.fleet(&live) else {
            return Published {
                time,
                live,
                evaluation: None,
            };
        };
        // The live entries, in `live`'s order (both are in id order).
        let mut wanted = live.iter().peekable();
        let mut entries: Vec<&mut Entry> = Vec::with_capacity(live.len());
        for (id, entry) in self.vessels.iter_mut() {
            if wanted.next_if(|w| *w == id).is_some() {
                entries.push(entry);
            }
        }
        let states: Vec<State> = entries
            .iter()
            .map(|entry| {
                let pose = entry.pose.as_ref().expect("live vessels have a pose");
                State {
                    x: pose.x,
                    y: pose.y,
                    psi: pose.psi,
                    vel: crate::control::Vec3::new(pose.u, pose.v, pose.r),
                }
            })
            .collect();
        let mission = &self.mission;
        let risk = covered(&self.learning, mission);
        let options = Options {
            parallel: true,
            ..Options::default()
        };
        let parallel = entries.len() >= crate::coverage::PARALLEL_MIN;
        let geometries = cells_with(mission.region(), &fleet, parallel);
        // Goals inside the vessel's own piece of water, routes round islands
        // and the collision filter: the same functions as `seacover sim`.
        let layer = &mission.layer();
        let safety = {
            let guidance: Vec<&Guidance> = entries.iter().map(|e| &e.guidance).collect();
            layer.prepare(time, &states, &guidance)
        };
        let tick = self.tick;
        let one = |i: usize,
                   entry: &mut Entry,
                   geometry,
                   (near, scratch): &mut (Vec<usize>, Scratch)|
         -> (CellResult, bool) {
            let vessel = &fleet.vessels()[i];
            let cell = cell_figures(mission.region(), risk, vessel, geometry, &options, near);
            let sc = layer.command(&safety, i, &states[i], &cell, &mut entry.guidance, scratch);
            let (cmd, c) = (sc.command, cell.centroid);
            let doc = CommandDocument {
                tick,
                u_d: cmd.u_d,
                r_d: cmd.r_d,
                u_d_dot: cmd.u_d_dot,
                r_d_dot: cmd.r_d_dot,
                centroid: [c.x, c.y],
                e: cmd.e,
                psi_e: cmd.psi_e,
                hold: None,
                station: entry
                    .guidance
                    .keeping_station()
                    .then_some([sc.towards.x, sc.towards.y]),
            };
            if let Some(link) = &entry.link {
                send_command(link, &doc, due, &written);
            }
            entry.last_command = Some(doc);
            (cell, sc.intervened)
        };
        let done: Vec<(CellResult, bool)> = crate::coverage::map_each(
            entries.into_iter().zip(geometries).collect(),
            parallel,
            |i, (entry, geometry), scratch| one(i, entry, geometry, scratch),
        );
        let interventions = done.iter().filter(|(_, intervened)| *intervened).count();
        metrics::counter!(crate::server::metrics::SAFETY_INTERVENTIONS)
            .increment(interventions as u64);
        let cells: Vec<CellResult> = done.into_iter().map(|(cell, _)| cell).collect();
        let h = cells.iter().map(|c| c.mass).sum();
        Published {
            time,
            live,
            evaluation: Some(Evaluation { h, cells }),
        }
    }

    /// Records who left the partition by falling silent (the others take
    /// their water) and who came back.
    pub(super) fn note_liveness(&mut self, time: f64, live: &[String]) {
        if !self.recorder.is_on() {
            return;
        }
        let now: BTreeSet<String> = live.iter().cloned().collect();
        for gone in self.live_before.difference(&now) {
            if self.vessels.contains_key(gone) {
                self.recorder.event(
                    EventRecord::new(time, EventKind::LivenessTakeover).vessel(gone.clone()),
                );
                self.lapsed.insert(gone.clone());
            }
        }
        for back in now.difference(&self.live_before) {
            if self.lapsed.remove(back) {
                self.recorder.event(
                    EventRecord::new(time, EventKind::LivenessRegained).vessel(back.clone()),
                );
            }
        }
        self.live_before = now;
    }

    /// The second half of a tick, once its commands are on their way: the
    /// snapshot for readers and the gauges.
    pub(super) fn finish_tick(&mut self, tick: Published) {
        let Published {
            time,
            live,
            evaluation,
        } = tick;
        self.publish(time, &live, evaluation.as_ref());
        let connected = self.vessels.values().filter(|e| e.link.is_some()).count();
        metrics::gauge!(crate::server::metrics::VESSELS_CONNECTED).set(connected as f64);
        metrics::gauge!(crate::server::metrics::VESSELS_LIVE).set(live.len() as f64);
        let held = self.vessels.values().filter(|e| e.standing.held()).count();
        metrics::gauge!(crate::server::metrics::VESSELS_QUARANTINED).set(held as f64);
        metrics::gauge!(crate::server::metrics::COVERAGE_H)
            .set(evaluation.as_ref().map_or(0.0, |e| e.h));
    }

    /// The fleet of the `live` vessels, in that order; `None` when there
    /// are none.
    pub(super) fn fleet(&self, live: &[String]) -> Option<Fleet> {
        if live.is_empty() {
            return None;
        }
        let vessels = live
            .iter()
            .map(|id| {
                let e = &self.vessels[id];
                let p = e.pose.as_ref().expect("live vessels have a pose");
                Vessel {
                    position: Point { x: p.x, y: p.y },
                    k: e.actuator.k,
                    beta: e.actuator.beta,
                }
            })
            .collect();
        Fleet::new(vessels).ok()
    }

    pub(super) fn evaluate_live(&self, live: &[String]) -> Option<Evaluation> {
        let fleet = self.fleet(live)?;
        Some(evaluate(
            self.mission.region(),
            covered(&self.learning, &self.mission),
            &fleet,
            &Options {
                parallel: true,
                ..Options::default()
            },
        ))
    }

    pub(super) fn publish(&mut self, time: f64, live: &[String], evaluation: Option<&Evaluation>) {
        let h = evaluation.map_or(0.0, |e| e.h);
        let coverage = match evaluation {
            Some(e) => {
                let doc = evaluation_document(self.mission.region(), live, e);
                CoverageDocument {
                    tick: self.tick,
                    time,
                    h,
                    cells: doc.cells,
                }
            }
            None => CoverageDocument {
                tick: self.tick,
                time,
                h,
                cells: Vec::new(),
            },
        };
        // An index rather than a search per vessel, which made publishing
        // quadratic: milliseconds of a 1000-vessel tick, holding a worker
        // thread while the links were sending that tick's commands.
        let cells: std::collections::HashMap<&str, &crate::protocol::CellDocument> =
            coverage.cells.iter().map(|c| (c.id.as_str(), c)).collect();
        let vessels = self
            .vessels
            .iter()
            .map(|(id, e)| {
                let cell = cells.get(id.as_str()).copied();
                VesselStatusDocument {
                    id: id.clone(),
                    connected: e.link.is_some(),
                    live: cell.is_some(),
                    controlled: e.pose.as_ref().and_then(|p| p.controlled).unwrap_or(true),
                    pose: e.pose.clone(),
                    actuator: e.actuator,
                    polygon: cell.and_then(|c| c.polygon.clone()),
                    edges: cell.map_or_else(Vec::new, |c| c.edges.clone()),
                    mass: cell.map_or(0.0, |c| c.mass),
                    centroid: cell.map(|c| c.centroid),
                    last_command: e.last_command.clone(),
                    last_seen: e.last_seen_tick.map(|t| t as f64 / self.mission.tick_hz()),
                    neighbours: e.neighbours,
                    quarantine: e.standing.quarantine(),
                }
            })
            .collect();
        let snapshot = crate::protocol::Snapshot {
            document: SnapshotDocument {
                tick: self.tick,
                time,
                h,
                mission: self.mission.document(),
                vessels,
            },
            coverage,
        };
        let snapshot = Arc::new(snapshot);
        if self.recorder.is_on() {
            self.recorder.record(RecorderEntry::Tick(snapshot.clone()));
        }
        self.history.push(self.tick, time, h);
        self.snapshot.send_replace(Arc::new(Snapshot {
            state: snapshot,
            history: self.history.document(),
        }));
    }
}
