//! The visibility form of an external method: its setting read into the JSON object of the
//! keys its manifest declares (an undeclared key is refused), and per preparation one program
//! ([`Session`]) told the points, then asked view by view.

use std::sync::Mutex;

use cloud::Camera;

use super::manifest::{ExternalMethod, external_error};
use super::session::Session;
use crate::error::{Error, Result};
use crate::params::Reader;
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// An external visibility method.
pub(super) struct Visibility(pub(super) &'static ExternalMethod);

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
            method: self.0,
            params: params_json(self.0, r)?,
        }))
    }
}

/// Its setting.
struct Args {
    method: &'static ExternalMethod,
    params: serde_json::Value,
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let m = self.method;
        m.check().map_err(|why| external_error(m.name, why))?;
        Ok(Box::new(Prep {
            session: m.session(input.cloud, None, self.params.clone(), None)?,
            cameras: m.cameras.clone(),
            views: Mutex::new(0),
        }))
    }
}

struct Prep {
    session: Session,
    cameras: Vec<String>,
    /// Views asked through [`Prepared::visible`], which does not know the view's index.
    views: Mutex<usize>,
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
        let request = format!("{{\"view\":{view},\"camera\":{}}}", camera.to_json());
        let answer = Mutex::new(None);
        let wall = self
            .session
            .ask(&format!("view {view}"), Some(&request), &|line| {
                let v = Session::json(line)?;
                let seconds = self.session.seconds(&v)?;
                let visible = self.session.indices(&v)?;
                *answer.lock().map_err(|_| "lock")? = Some((visible, seconds));
                Ok(())
            })?;
        let (visible, seconds) = answer
            .into_inner()
            .ok()
            .flatten()
            .ok_or_else(|| external_error(self.session.method, "no answer"))?;
        Ok(Output {
            visible,
            reported_seconds: Some(seconds.unwrap_or(wall)),
            ..Output::default()
        })
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

    fn reported_build_seconds(&self) -> Option<f64> {
        self.session.built.lock().ok()?.as_ref()?.0
    }
}
