//! Protocol 3's warm program: one program per external method and cloud, serving every
//! setting, so that a peer imports its library and reads the points once per cloud rather
//! than once per setting. The method's [`WarmSlot`] (its visibility form's) holds the program of the last cloud it
//! was prepared on, known by the cloud's [`fingerprint`] (what the points file carries:
//! positions, normals, colours, texture coordinates); a preparation on another cloud ends
//! that program (its input closed, then its group killed) and starts one on the new cloud.
//! A preparation still answering keeps its program alive until it is done. The catalogue
//! ends every warm program when its run is over (`Catalogue::end_programs`); a signal to
//! pointsight kills them through `cloud::scratch`, as every program.

use std::hash::Hasher;
use std::sync::{Arc, Mutex};

use super::manifest::{ExternalMethod, external_error};
use super::session::Session;
use crate::error::Result;

/// What identifies a cloud's points file: its point count and a 64-bit hash of what it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Fingerprint {
    points: usize,
    hash: u64,
}

/// The fingerprint of what the points file carries of `cloud`.
pub(super) fn fingerprint(cloud: &cloud::PointCloud) -> Fingerprint {
    let mut h = std::hash::DefaultHasher::new();
    for p in &cloud.positions {
        for c in p.to_array() {
            h.write_u64(c.to_bits());
        }
    }
    match &cloud.normals {
        Some(normals) => {
            h.write_u8(1);
            for n in normals {
                for c in n.to_array() {
                    h.write_u32(c.to_bits());
                }
            }
        }
        None => h.write_u8(0),
    }
    match &cloud.colors {
        Some(colors) => {
            h.write_u8(1);
            for c in colors {
                h.write(c);
            }
        }
        None => h.write_u8(0),
    }
    match &cloud.uvs {
        Some(uvs) => {
            h.write_u8(1);
            for uv in uvs {
                h.write_u32(uv.x.to_bits());
                h.write_u32(uv.y.to_bits());
            }
        }
        None => h.write_u8(0),
    }
    Fingerprint {
        points: cloud.len(),
        hash: h.finish(),
    }
}

/// A method's warm program, if one runs: the cloud it was started on and its session.
#[derive(Default)]
pub(crate) struct WarmSlot(Mutex<Option<(Fingerprint, Arc<Session>)>>);

impl std::fmt::Debug for WarmSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let on = self
            .0
            .lock()
            .ok()
            .and_then(|slot| slot.as_ref().map(|(print, _)| print.points));
        f.debug_tuple("WarmSlot").field(&on).finish()
    }
}

impl WarmSlot {
    /// The program serving `method` on `cloud`: the warm one when it was started on the same
    /// points, else a new session (its points written; the program starts at the first
    /// request), which replaces the old one.
    pub(super) fn session(
        &self,
        method: &ExternalMethod,
        cloud: &cloud::PointCloud,
    ) -> Result<Arc<Session>> {
        let print = fingerprint(cloud);
        let mut slot = self
            .0
            .lock()
            .map_err(|_| external_error(method.name, "warm program lock poisoned"))?;
        if let Some((on, session)) = slot.as_ref()
            && *on == print
        {
            return Ok(Arc::clone(session));
        }
        // The old program ends here (unless a preparation still holds it), before the new
        // one's points are written.
        drop(slot.take());
        let session = Arc::new(method.session(
            cloud,
            None,
            serde_json::Value::Object(serde_json::Map::new()),
            None,
        )?);
        *slot = Some((print, Arc::clone(&session)));
        Ok(session)
    }

    /// Ends the warm program, if one runs (once no preparation holds it).
    pub(super) fn end(&self) {
        let old = self.0.lock().ok().and_then(|mut slot| slot.take());
        drop(old);
    }
}
