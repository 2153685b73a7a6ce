//! The visibility form of an external method: its setting read into the JSON object of the
//! keys its manifest declares (an undeclared key is refused), and the program ([`Session`])
//! told the points, then asked view by view: with protocols 1 and 2 one program per
//! preparation (per setting and cloud), with protocol 3 the method's warm program for the
//! cloud ([`super::warm`]), each request carrying the setting.

use std::sync::{Arc, Mutex};

use cloud::Camera;

use super::manifest::{ExternalMethod, external_error};
use super::session::{Cold, Session};
use super::warm::WarmSlot;
use crate::error::{Error, Result};
use crate::params::Reader;
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// An external visibility method, and with protocol 3 its program kept running for the last
/// cloud, serving every setting.
pub(super) struct Visibility {
    method: &'static ExternalMethod,
    warm: &'static WarmSlot,
}

impl Visibility {
    pub(super) fn new(method: &'static ExternalMethod) -> Self {
        Self {
            method,
            // Lives as the card does (for the process).
            warm: Box::leak(Box::default()),
        }
    }
}

/// The keys `method`'s manifest declares, each given or at the method's default setting (a key
/// outside it, not given, is left to the program's own rule), as a JSON object of strings.
pub(super) fn params_json(
    method: &ExternalMethod,
    r: &mut Reader<'_>,
) -> Result<serde_json::Value> {
    let mut pairs = serde_json::Map::new();
    for p in method.params {
        if let Some(v) = r.text(p)? {
            pairs.insert(p.key.to_owned(), serde_json::Value::String(v));
        }
    }
    Ok(serde_json::Value::Object(pairs))
}

impl Method for Visibility {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        Ok(Box::new(Args {
            method: self.method,
            warm: self.warm,
            params: params_json(self.method, r)?,
        }))
    }

    fn end(&self) {
        self.warm.end();
    }
}

/// Its setting.
struct Args {
    method: &'static ExternalMethod,
    warm: &'static WarmSlot,
    params: serde_json::Value,
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let m = self.method;
        m.check().map_err(|why| external_error(m.name, why))?;
        let session = if m.protocol >= 3 {
            self.warm.session(m, input.cloud)?
        } else {
            Arc::new(m.session(input.cloud, None, self.params.clone(), None)?)
        };
        Ok(Box::new(Prep {
            session,
            params: (m.protocol >= 3).then(|| self.params.to_string()),
            cameras: m.cameras.clone(),
            views: Mutex::new(0),
            cold: Mutex::new(None),
            built: Mutex::new(None),
        }))
    }
}

struct Prep {
    session: Arc<Session>,
    /// Protocol 3: the setting every request carries.
    params: Option<String>,
    cameras: Vec<String>,
    /// Views asked through [`Prepared::visible`], which does not know the view's index.
    views: Mutex<usize>,
    /// The cold call of a program this preparation's requests started (the last one).
    cold: Mutex<Option<Cold>>,
    /// Protocol 3: the first `built_seconds` an answer to these views gave (the set-up this
    /// setting needed in a program already running: a BVH for its radius).
    built: Mutex<Option<f64>>,
}

impl Prep {
    fn ask(&self, view: usize, camera: &Camera) -> Result<Output> {
        if !self.cameras.iter().any(|m| m == camera.model().name()) {
            return Err(Error::Unsupported(format!(
                "external method {} does not support {} cameras (it supports: {})",
                self.session.method,
                camera.model().name(),
                self.cameras.join(", ")
            )));
        }
        let request = match &self.params {
            Some(params) => format!(
                "{{\"view\":{view},\"camera\":{},\"params\":{params}}}",
                camera.to_json()
            ),
            None => format!("{{\"view\":{view},\"camera\":{}}}", camera.to_json()),
        };
        let answer = Mutex::new(None);
        let asked = self
            .session
            .ask(&format!("view {view}"), Some(&request), &|v| {
                let seconds = self.session.seconds(v)?;
                let built = self.session.seconds_at(v, "built_seconds")?;
                let visible = self.session.indices(v)?;
                *answer.lock().map_err(|_| "lock")? = Some((visible, seconds, built));
                Ok(())
            })?;
        if let Some(cold) = asked.cold {
            *self
                .cold
                .lock()
                .map_err(|_| external_error(self.session.method, "lock"))? = Some(cold);
        }
        let (visible, seconds, built) = answer
            .into_inner()
            .ok()
            .flatten()
            .ok_or_else(|| external_error(self.session.method, "no answer"))?;
        if let Some(built) = built
            && let Ok(mut first) = self.built.lock()
        {
            first.get_or_insert(built);
        }
        Ok(Output {
            visible,
            reported_seconds: Some(seconds.unwrap_or(asked.wall)),
            ..Output::default()
        })
    }

    fn cold(&self) -> Option<Cold> {
        *self.cold.lock().ok()?
    }
}

impl Prepared for Prep {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let view = {
            let mut v = self
                .views
                .lock()
                .map_err(|_| external_error(self.session.method, "lock"))?;
            *v += 1;
            *v - 1
        };
        self.ask(view, camera)
    }

    fn visible_at(&self, view: usize, camera: &Camera) -> Result<Output> {
        self.ask(view, camera)
    }

    /// The build line of a program these views started (a warm program started by an
    /// earlier setting's views reports none here: its build was that setting's), plus the
    /// set-up this setting needed in it (protocol 3's `built_seconds`).
    fn reported_build_seconds(&self) -> Option<f64> {
        let line = self.cold().and_then(|c| c.built);
        let setting = self.built.lock().ok().and_then(|b| *b);
        match (line, setting) {
            (None, None) => None,
            (a, b) => Some(a.unwrap_or(0.0) + b.unwrap_or(0.0)),
        }
    }

    fn cold_call_seconds(&self) -> Option<f64> {
        Some(self.cold()?.seconds)
    }
}
