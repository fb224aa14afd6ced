//! `seacover sim --record FILE.mcap`: a finished run as the coordinator
//! would have recorded it — the mission, each tick's poses, commands and
//! coverage — plus what only a simulator knows: each vessel's true state,
//! its disturbance and the observer's estimate
//! ([`crate::recorder::messages::SIM_VESSEL`]).
//!
//! Written after the run from its ticks, re-evaluating each tick's
//! partition (the run keeps H and centroids, not every cell): evaluation
//! is deterministic, so the cells are the run's. Publish times are the log
//! times and the writer blocks instead of dropping, so the same seed gives
//! the same messages.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::learn::{Cover, LearnLog};
use super::run::fleet_at;
use super::{Config, Run, SimError, Tick, VesselSample};
use crate::coverage::{Options, RiskField, evaluate};
use crate::geometry::Point;
use crate::learning::{FADE, LearnSettings};
use crate::mission::scenario::{LocalScenario, evaluation_document};
use crate::mission::{guidance_document, safety_document};
use crate::protocol::{
    ActuatorDocument, BeliefDocument, CellDocument, CommandDocument, CoverageDocument,
    MissionDocument, PoseDocument, RiskDocument, SampleDocument, Snapshot, SnapshotDocument,
    VesselStatusDocument,
};
use crate::recorder::messages::SimVesselRecord;
use crate::recorder::{Entry, Recorder, RecorderConfig, Target};

/// Records `run` of `config` (from the scenario document `doc`) into a new
/// file in `dir` (named by its UTC start, as every recording is); returns
/// the file.
pub fn record(
    dir: &Path,
    config: &Config,
    doc: &LocalScenario,
    run: &Run,
) -> Result<PathBuf, SimError> {
    std::fs::create_dir_all(dir).map_err(|e| SimError::Io(format!("{}: {e}", dir.display())))?;
    let path = crate::recorder::writer::new_file(dir);
    let path = path.as_path();
    // Opened here first, so that an unwritable path is this command's
    // error rather than a line in the log.
    std::fs::File::create(path).map_err(|e| SimError::Io(format!("{}: {e}", path.display())))?;
    let (recorder, thread) = Recorder::start(
        RecorderConfig {
            target: Target::File(path.to_path_buf()),
            wall_clock: false,
        },
        true,
    );
    let mission = mission_of(config, doc);
    recorder.mission(0.0, mission.clone());
    let mut learned = LearnReplay::new(config, run);
    for (k, tick) in run.ticks.iter().enumerate() {
        learned.record_until(&recorder, config, tick.t);
        if let Some(snapshot) = record_tick(&recorder, config, &mission, k, tick, &learned.cover) {
            recorder.record(Entry::Tick(Arc::new(snapshot)));
        }
    }
    recorder.finish();
    thread.join();
    Ok(path.to_path_buf())
}

/// The mission a coordinator would have recorded for `config`.
fn mission_of(config: &Config, doc: &LocalScenario) -> MissionDocument {
    let first = config.scenario.fleet.vessels()[0];
    let mut risk = doc.risk.clone().unwrap_or(RiskDocument {
        base: 0.0,
        objects: Vec::new(),
    });
    for (i, o) in risk.objects.iter_mut().enumerate() {
        o.id.get_or_insert_with(|| format!("object-{}", i + 1));
    }
    MissionDocument {
        // A geo-referenced scenario gives Foxglove's map channels too.
        origin: doc.origin,
        region: doc
            .region
            .clone()
            .expect("a simulated scenario has a region"),
        risk,
        actuator: ActuatorDocument {
            k: first.k,
            beta: first.beta,
        },
        guidance: guidance_document(&config.guidance),
        tick_hz: config.tick_hz,
        safety: safety_document(&config.safety),
    }
}

/// Records tick `k`'s poses and simulator truths, and returns its
/// snapshot (the partition evaluated again); `None` for a fleet that
/// cannot be evaluated.
fn record_tick(
    recorder: &Recorder,
    config: &Config,
    mission: &MissionDocument,
    k: usize,
    tick: &Tick,
    risk: &RiskField,
) -> Option<Snapshot> {
    let ids = &config.scenario.ids;
    let positions = tick.vessels.iter().map(|v| Point {
        x: v.state.x,
        y: v.state.y,
    });
    let fleet = fleet_at(config, positions)?;
    let evaluation = evaluate(&config.scenario.region, risk, &fleet, &Options::default());
    let cells = evaluation_document(&config.scenario.region, ids, &evaluation).cells;
    let mut vessels = Vec::with_capacity(ids.len());
    for (((id, v), cell), own) in ids
        .iter()
        .zip(&tick.vessels)
        .zip(&cells)
        .zip(fleet.vessels())
    {
        let s = v.state;
        let pose = PoseDocument {
            t: tick.t,
            x: s.x,
            y: s.y,
            psi: s.psi,
            u: s.vel.x,
            v: s.vel.y,
            r: s.vel.z,
            controlled: None,
            telemetry: None,
            fix: None,
        };
        recorder.record(Entry::Pose {
            vessel: Arc::from(id.as_str()),
            time: tick.t,
            pose: Box::new(pose.clone()),
        });
        recorder.record(Entry::SimVessel(Box::new(SimVesselRecord {
            vessel: id.clone(),
            time: tick.t,
            truth: [s.x, s.y, s.psi, s.vel.x, s.vel.y, s.vel.z],
            disturbance: [v.tau_d.x, v.tau_d.y, v.tau_d.z],
            estimate: [v.estimate.x, v.estimate.y, v.estimate.z],
        })));
        // Each vessel's own actuator: a mixed fleet's β differ.
        let actuator = ActuatorDocument {
            k: own.k,
            beta: own.beta,
        };
        vessels.push(status(id, k, v, pose, actuator, cell));
    }
    Some(Snapshot {
        document: SnapshotDocument {
            tick: k as u64,
            time: tick.t,
            h: tick.h,
            mission: mission.clone(),
            vessels,
        },
        coverage: CoverageDocument {
            tick: k as u64,
            time: tick.t,
            h: tick.h,
            cells,
        },
    })
}

/// A simulated vessel's status at tick `k`, as a coordinator shows it.
fn status(
    id: &str,
    k: usize,
    v: &VesselSample,
    pose: PoseDocument,
    actuator: ActuatorDocument,
    cell: &CellDocument,
) -> VesselStatusDocument {
    let c = v.command;
    VesselStatusDocument {
        id: id.to_string(),
        connected: true,
        live: true,
        controlled: true,
        last_seen: Some(pose.t),
        pose: Some(pose),
        actuator,
        polygon: cell.polygon.clone(),
        edges: cell.edges.clone(),
        mass: cell.mass,
        centroid: Some(cell.centroid),
        last_command: Some(CommandDocument {
            tick: k as u64,
            u_d: c.u_d,
            r_d: c.r_d,
            u_d_dot: c.u_d_dot,
            r_d_dot: c.r_d_dot,
            centroid: [v.centroid.x, v.centroid.y],
            e: c.e,
            psi_e: c.psi_e,
            hold: None,
            station: None,
        }),
        neighbours: None,
        quarantine: None,
    }
}

/// A learning run's samples and beliefs, handed to the recorder in time
/// order between the ticks, and the density covered at each tick (what
/// its cells are of).
struct LearnReplay<'a> {
    log: Option<&'a LearnLog>,
    cover: RiskField,
    /// The optimism (κ at first, its fade), for each belief's document.
    optimism: LearnSettings,
    next_sample: usize,
    next_belief: usize,
}

impl<'a> LearnReplay<'a> {
    fn new(config: &Config, run: &'a Run) -> LearnReplay<'a> {
        let learning = config.learning.as_ref();
        let cover = match learning.map(|l| l.cover) {
            Some(Cover::Truth) => learning.map(|l| l.truth.clone()),
            _ => None,
        };
        LearnReplay {
            log: run.learn_log.as_ref(),
            cover: cover.unwrap_or_else(|| config.scenario.risk.clone()),
            optimism: LearnSettings {
                kappa: learning.map_or(0.0, |l| l.kappa),
                fade: learning.map_or(FADE, |l| l.fade),
                ..LearnSettings::default()
            },
            next_sample: 0,
            next_belief: 0,
        }
    }

    /// Records the samples and beliefs up to mission time `t`.
    fn record_until(&mut self, recorder: &Recorder, config: &Config, t: f64) {
        let Some(log) = self.log else { return };
        while let Some(s) = log.samples.get(self.next_sample)
            && s.t <= t
        {
            let sample = SampleDocument {
                vessel: config.scenario.ids[s.vessel].clone(),
                t: s.t,
                x: s.at.x,
                y: s.at.y,
                value: s.value,
                sd: s.sd,
            };
            recorder.sample(s.t, &sample, "accepted");
            self.next_sample += 1;
        }
        while let Some((at, density, grid)) = log.beliefs.get(self.next_belief)
            && *at <= t
        {
            self.next_belief += 1;
            self.cover = density.clone();
            let samples = log.samples.iter().take_while(|s| s.t <= *at).count();
            recorder.belief(
                *at,
                BeliefDocument {
                    source: "learned".to_string(),
                    risk: crate::mission::belief::risk_document(density),
                    samples: samples as u64,
                    fits: self.next_belief as u64,
                    fitted_at: Some(*at),
                    kappa: self.optimism.kappa_at(*at),
                    learning: true,
                    uncertainty: Some(grid.clone()),
                },
            );
        }
    }
}
