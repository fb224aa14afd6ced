//! The mission's durable home: one redb file, `mission.redb`, under the data
//! directory (`--data-dir`, default `./seacover-data`).
//!
//! Invariants:
//! - every write is one redb transaction committed with
//!   [`Durability::Immediate`], i.e. fsynced before [`Store::apply`] returns;
//!   the coordinator answers a write only after that, so an acknowledged
//!   change survives `kill -9` at any later moment, and an unacknowledged one
//!   is either wholly there or wholly absent (redb's commit is atomic);
//! - the store holds documents already validated by
//!   [`Mission::changed`](crate::mission::Mission::changed); what is loaded is
//!   validated again anyway, so a file edited by hand cannot start a server
//!   with an invalid mission;
//! - risk objects keep their insertion order across restarts (each carries a
//!   sequence number), so `GET /api/v1/risk-objects` answers the same list
//!   before and after.
//!
//! Values are the wire documents as JSON: the file is readable with any redb
//! tool and needs no migration when a field is added with a default.

use std::path::{Path, PathBuf};

use redb::{Database, Durability, ReadableDatabase, ReadableTable, TableDefinition};

use crate::mission::{ChangeResult, MissionChange};
use crate::protocol::{
    ActuatorDocument, GuidanceDocument, MissionDocument, RegionDocument, RiskDocument,
    RiskObjectDocument,
};

/// Mission-wide values by name: `origin`, `region`, `base`, `actuator`,
/// `guidance`, `tick_hz`, `safety`, `next_seq`.
const META: TableDefinition<&str, &str> = TableDefinition::new("meta");
/// Risk objects by id: (insertion sequence, object JSON).
const OBJECTS: TableDefinition<&str, (u64, &str)> = TableDefinition::new("objects");

/// The file inside the data directory.
pub(super) const FILE_NAME: &str = "mission.redb";

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("creating the data directory {path}")]
    Directory {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("opening the store {path}")]
    Open {
        path: PathBuf,
        source: Box<redb::DatabaseError>,
    },
    #[error("the store")]
    Redb(#[from] Box<redb::Error>),
    #[error("the store: a stored {what} does not parse")]
    Corrupt {
        what: String,
        source: serde_json::Error,
    },
}

fn redb_err(e: impl Into<redb::Error>) -> StoreError {
    StoreError::Redb(Box::new(e.into()))
}

/// An open store. Owned by the tick task; blocking calls (a commit fsyncs).
pub(super) struct Store {
    db: Database,
    path: PathBuf,
}

impl std::fmt::Debug for Store {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Store").field("path", &self.path).finish()
    }
}

fn json<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_string(value).expect("wire documents serialize")
}

fn parse<T: serde::de::DeserializeOwned>(what: &str, text: &str) -> Result<T, StoreError> {
    serde_json::from_str(text).map_err(|source| StoreError::Corrupt {
        what: what.to_string(),
        source,
    })
}

impl Store {
    /// Opens (creating when needed) the store under `dir`.
    pub(super) fn open(dir: &Path) -> Result<Store, StoreError> {
        std::fs::create_dir_all(dir).map_err(|source| StoreError::Directory {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = dir.join(FILE_NAME);
        let db = Database::create(&path).map_err(|source| StoreError::Open {
            path: path.clone(),
            source: Box::new(source),
        })?;
        Ok(Store { db, path })
    }

    pub(super) fn path(&self) -> &Path {
        &self.path
    }

    /// The stored mission, or `None` when the store is new.
    pub(super) fn load(&self) -> Result<Option<MissionDocument>, StoreError> {
        let read = self.db.begin_read().map_err(redb_err)?;
        let meta = match read.open_table(META) {
            Ok(t) => t,
            Err(redb::TableError::TableDoesNotExist(_)) => return Ok(None),
            Err(e) => return Err(redb_err(e)),
        };
        let get = |key: &str| -> Result<Option<String>, StoreError> {
            Ok(meta
                .get(key)
                .map_err(redb_err)?
                .map(|v| v.value().to_string()))
        };
        let (Some(region), Some(base), Some(actuator), Some(guidance), Some(tick_hz)) = (
            get("region")?,
            get("base")?,
            get("actuator")?,
            get("guidance")?,
            get("tick_hz")?,
        ) else {
            return Ok(None);
        };
        let mut objects: Vec<(u64, RiskObjectDocument)> = Vec::new();
        if let Ok(table) = read.open_table(OBJECTS) {
            for row in table.iter().map_err(redb_err)? {
                let (id, value) = row.map_err(redb_err)?;
                let (seq, text) = value.value();
                let mut object: RiskObjectDocument = parse("risk object", text)?;
                object.id = Some(id.value().to_string());
                objects.push((seq, object));
            }
        }
        objects.sort_by_key(|(seq, _)| *seq);
        Ok(Some(MissionDocument {
            // Stores written before geo-referencing have no origin.
            origin: match get("origin")? {
                Some(text) => parse("origin", &text)?,
                None => None,
            },
            region: parse::<RegionDocument>("region", &region)?,
            risk: RiskDocument {
                base: parse("base", &base)?,
                objects: objects.into_iter().map(|(_, o)| o).collect(),
            },
            actuator: parse::<ActuatorDocument>("actuator", &actuator)?,
            guidance: parse::<GuidanceDocument>("guidance", &guidance)?,
            tick_hz: parse("tick_hz", &tick_hz)?,
            // Stores written before safety existed have none: defaults.
            safety: match get("safety")? {
                Some(text) => parse("safety", &text)?,
                None => Default::default(),
            },
        }))
    }

    /// Replaces whatever is stored with `mission`, in one transaction.
    pub(super) fn save(&self, mission: &MissionDocument) -> Result<(), StoreError> {
        self.write(|meta, objects| {
            meta.insert("origin", json(&mission.origin).as_str())?;
            meta.insert("region", json(&mission.region).as_str())?;
            meta.insert("base", json(&mission.risk.base).as_str())?;
            meta.insert("actuator", json(&mission.actuator).as_str())?;
            meta.insert("guidance", json(&mission.guidance).as_str())?;
            meta.insert("tick_hz", json(&mission.tick_hz).as_str())?;
            meta.insert("safety", json(&mission.safety).as_str())?;
            objects.retain(|_, _| false)?;
            let mut seq = 0u64;
            for object in &mission.risk.objects {
                let id = object.id.as_deref().expect("mission objects have ids");
                objects.insert(id, (seq, json(&without_id(object)).as_str()))?;
                seq += 1;
            }
            meta.insert("next_seq", json(&seq).as_str())?;
            Ok(())
        })
    }

    /// Makes one accepted change durable. `result` is what
    /// [`Mission::changed`](crate::mission::Mission::changed) answered, which
    /// carries the id a new object was given.
    pub(super) fn apply(
        &self,
        change: &MissionChange,
        result: &ChangeResult,
    ) -> Result<(), StoreError> {
        if let (MissionChange::Adopt(_) | MissionChange::Risk(_), ChangeResult::Mission(mission)) =
            (change, result)
        {
            return self.save(mission);
        }
        self.write(|meta, objects| {
            match (change, result) {
                (MissionChange::Origin(origin), _) => {
                    meta.insert("origin", json(&Some(origin)).as_str())?;
                }
                // The region as placed in the plane, not as given.
                (MissionChange::Region(_), ChangeResult::Mission(mission)) => {
                    meta.insert("region", json(&mission.region).as_str())?;
                }
                (MissionChange::Base(base), _) => {
                    meta.insert("base", json(base).as_str())?;
                }
                (MissionChange::AddObject(_), ChangeResult::Object(object)) => {
                    let seq: u64 = match meta.get("next_seq")? {
                        Some(v) => serde_json::from_str(v.value()).unwrap_or(0),
                        None => 0,
                    };
                    let id = object.id.as_deref().expect("added objects have ids");
                    objects.insert(id, (seq, json(&without_id(object)).as_str()))?;
                    meta.insert("next_seq", json(&(seq + 1)).as_str())?;
                }
                (MissionChange::PutObject(id, _), ChangeResult::Object(object)) => {
                    let seq = objects
                        .get(id.as_str())?
                        .map(|v| v.value().0)
                        .unwrap_or(u64::MAX);
                    objects.insert(id.as_str(), (seq, json(&without_id(object)).as_str()))?;
                }
                (MissionChange::DeleteObject(id), _) => {
                    objects.remove(id.as_str())?;
                }
                (change, result) => {
                    unreachable!("change {change:?} cannot answer {result:?}")
                }
            }
            Ok(())
        })
    }

    fn write(
        &self,
        body: impl FnOnce(
            &mut redb::Table<&str, &str>,
            &mut redb::Table<&str, (u64, &str)>,
        ) -> Result<(), redb::StorageError>,
    ) -> Result<(), StoreError> {
        let mut txn = self.db.begin_write().map_err(redb_err)?;
        txn.set_durability(Durability::Immediate)
            .map_err(|e| redb_err(redb::Error::from(e)))?;
        {
            let mut meta = txn.open_table(META).map_err(redb_err)?;
            let mut objects = txn.open_table(OBJECTS).map_err(redb_err)?;
            body(&mut meta, &mut objects).map_err(redb_err)?;
        }
        txn.commit().map_err(redb_err)
    }
}

/// The id is the key; keeping it out of the value leaves one truth.
fn without_id(object: &RiskObjectDocument) -> RiskObjectDocument {
    RiskObjectDocument {
        id: None,
        ..object.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::Mission;

    #[test]
    fn a_saved_mission_and_its_changes_load_back_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let mission = Mission::paper();
        {
            let store = Store::open(dir.path()).unwrap();
            assert_eq!(store.load().unwrap(), None);
            store.save(&mission.document()).unwrap();
        }
        let store = Store::open(dir.path()).unwrap();
        assert_eq!(store.load().unwrap(), Some(mission.document()));

        let mut current = mission;
        let changes = [
            MissionChange::AddObject(
                RiskObjectDocument {
                    id: Some("zeta".into()),
                    x: 10.0,
                    y: 20.0,
                    alpha: 3.0,
                    sigma: 4.0,
                }
                .into(),
            ),
            MissionChange::AddObject(
                RiskObjectDocument {
                    id: None,
                    x: 11.0,
                    y: 21.0,
                    alpha: 1.0,
                    sigma: 2.0,
                }
                .into(),
            ),
            MissionChange::PutObject(
                "object-1".into(),
                RiskObjectDocument {
                    id: None,
                    x: 50.0,
                    y: 50.0,
                    alpha: 9.0,
                    sigma: 9.0,
                }
                .into(),
            ),
            MissionChange::DeleteObject("object-2".into()),
            MissionChange::Base(0.25),
            MissionChange::Origin(crate::protocol::OriginDocument {
                lat: 60.39,
                lon: 5.32,
            }),
            // Stored as placed in the plane, not as given.
            MissionChange::Region(
                serde_json::from_value(serde_json::json!({"type": "Polygon", "coordinates": [[
                    [5.32, 60.39], [5.322, 60.39], [5.322, 60.391], [5.32, 60.391], [5.32, 60.39]
                ]]}))
                .unwrap(),
            ),
        ];
        for change in &changes {
            let (next, result) = current.changed(change).unwrap();
            store.apply(change, &result).unwrap();
            current = next;
        }
        drop(store);
        let loaded = Store::open(dir.path()).unwrap().load().unwrap().unwrap();
        assert_eq!(loaded, current.document());
        assert_eq!(loaded.region.polygon[0], [0.0, 0.0]);
        assert!(loaded.origin.is_some());
    }
}
