//! The level-of-detail form of an external method (`kind = "lod"`, protocol 2 or 3): one program
//! per cloud builds its structure and says so on its first line; then per view and setting it
//! is asked for the splats (indices and radii), its setting the JSON object of the keys its
//! manifest declares.

use std::sync::Mutex;

use cloud::Camera;
use splat::render::Splat;

use super::manifest::{ExternalMethod, external_error};
use super::session::Session;
use super::visibility::params_json;
use crate::error::Result;
use crate::lod::{LodArgs, LodBuilt, LodInput, LodMethod, LodSelector, LodSize, Reads, args_of};
use crate::params::Reader;

/// An external level-of-detail method.
pub(super) struct Lod(pub(super) &'static ExternalMethod);

/// Its setting: the JSON object of the keys given.
struct Args(String);

impl LodMethod for Lod {
    fn parse(&self, r: &mut Reader<'_>) -> Result<LodArgs> {
        Ok(Box::new(Args(params_json(self.0, r)?.to_string())))
    }

    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let m = self.0;
        m.check().map_err(|why| external_error(m.name, why))?;
        if input.normals.len() != input.cloud.len() {
            return Err(external_error(
                m.name,
                format!(
                    "{} normals for {} points",
                    input.normals.len(),
                    input.cloud.len()
                ),
            ));
        }
        let session = m.session(
            input.cloud,
            Some(input.normals),
            serde_json::Value::Object(serde_json::Map::new()),
            Some(input.radius),
        )?;
        // Start it now: the build is this call.
        session.ask("build", None, &|_| Ok(()))?;
        let (seconds, size) = session
            .built
            .lock()
            .ok()
            .and_then(|b| *b)
            .ok_or_else(|| external_error(m.name, "no build line"))?;
        Ok(Box::new(ExternalLodBuilt {
            session,
            build_seconds: seconds,
            size,
            name: m.name,
            views: Mutex::new(0),
        }))
    }
}

struct ExternalLodBuilt {
    session: Session,
    build_seconds: Option<f64>,
    size: LodSize,
    name: &'static str,
    views: Mutex<usize>,
}

impl LodBuilt for ExternalLodBuilt {
    fn size(&self) -> LodSize {
        self.size
    }

    fn reported_build_seconds(&self) -> Option<f64> {
        self.build_seconds
    }

    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(ExternalLodSel {
            built: self,
            input,
            params: &args_of::<Args>(args, self.name)?.0,
            last: Vec::new(),
            seconds: None,
            bytes_read: None,
        }))
    }
}

struct ExternalLodSel<'s> {
    built: &'s ExternalLodBuilt,
    input: &'s LodInput<'s>,
    params: &'s str,
    last: Vec<(u32, f64)>,
    seconds: Option<f64>,
    /// The last answer's `bytes_read`: the bytes its selection read from the program's own file.
    bytes_read: Option<u64>,
}

impl ExternalLodSel<'_> {
    fn ask(&mut self, view: usize, camera: &Camera) -> Result<()> {
        let session = &self.built.session;
        let request = format!(
            "{{\"view\":{view},\"camera\":{},\"params\":{}}}",
            camera.to_json(),
            self.params
        );
        let answer = Mutex::new(None);
        let wall = session
            .ask(&format!("view {view}"), Some(&request), &|v| {
                let visible = session.indices(v)?;
                let radii: Vec<f64> = match v.get("radius") {
                    Some(serde_json::Value::Array(list)) => {
                        if list.len() != visible.len() {
                            return Err(format!(
                                "{} radii for {} indices",
                                list.len(),
                                visible.len()
                            ));
                        }
                        // The radii follow the answer's order; the indices were sorted, so
                        // re-read the pairs in the answer's order.
                        let order = answer_order(v, session)?;
                        let mut pairs: Vec<(u32, f64)> = order
                            .into_iter()
                            .zip(list)
                            .map(|(i, r)| r.as_f64().map(|r| (i, r)).ok_or("radius not a number"))
                            .collect::<std::result::Result<_, _>>()?;
                        pairs.sort_unstable_by_key(|p| p.0);
                        pairs.into_iter().map(|p| p.1).collect()
                    }
                    Some(r) => {
                        let r = r.as_f64().ok_or("\"radius\" is not a number")?;
                        vec![r; visible.len()]
                    }
                    None => return Err("answer has no \"radius\"".into()),
                };
                if let Some(r) = radii.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
                    return Err(format!("splat radius {r} is not a positive number"));
                }
                let seconds = session.seconds(v)?;
                let bytes_read = match v.get("bytes_read") {
                    None => None,
                    Some(b) => Some(b.as_u64().ok_or_else(|| {
                        format!("\"bytes_read\" {b} is not a whole number of bytes")
                    })?),
                };
                *answer.lock().map_err(|_| "lock")? = Some((
                    visible.into_iter().zip(radii).collect::<Vec<_>>(),
                    seconds,
                    bytes_read,
                ));
                Ok(())
            })?
            .wall;
        let (last, seconds, bytes_read) = answer
            .into_inner()
            .ok()
            .flatten()
            .ok_or_else(|| external_error(session.method, "no answer"))?;
        self.last = last;
        self.seconds = Some(seconds.unwrap_or(wall));
        self.bytes_read = bytes_read;
        Ok(())
    }
}

/// The answer's `visible` list in its own order (checked already by [`Session::indices`]).
fn answer_order(v: &serde_json::Value, session: &Session) -> std::result::Result<Vec<u32>, String> {
    match v.get("visible").and_then(serde_json::Value::as_array) {
        Some(list) => Ok(list
            .iter()
            .filter_map(serde_json::Value::as_u64)
            .map(|i| i as u32)
            .collect()),
        None => Err(format!(
            "external method {}: per-index radii need the \"visible\" list (not a file)",
            session.method
        )),
    }
}

impl LodSelector for ExternalLodSel<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let view = {
            let mut v = self
                .built
                .views
                .lock()
                .map_err(|_| external_error(self.built.name, "lock"))?;
            *v += 1;
            *v - 1
        };
        self.ask(view, camera)
    }

    fn select_at(&mut self, view: usize, camera: &Camera) -> Result<()> {
        self.ask(view, camera)
    }

    fn reported_seconds(&self) -> Option<f64> {
        self.seconds
    }

    fn reads(&self) -> Option<Reads> {
        // The program's own file, read as it says; it keeps no cache pointsight knows of.
        self.bytes_read.map(|bytes_read| Reads {
            bytes_read,
            cache_bytes: 0,
            selection_bytes: (self.last.len() * size_of::<Splat>()) as u64,
        })
    }

    fn splats(&self) -> Vec<Splat> {
        self.last
            .iter()
            .map(|&(i, r)| self.input.point_splat(i as usize, r))
            .collect()
    }
}
