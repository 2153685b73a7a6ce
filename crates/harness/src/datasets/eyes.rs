//! Eyes inside the object or among its points: views that are legal (no eye on a point,
//! `Dataset::check_views`) but that most methods were not made for, found so that a command
//! can say so once, in plain words, before it measures.
//!
//! Two cases, for pinhole cameras (a spherical scanner inside a room is what it is for, and an
//! orthographic camera has no eye):
//! - the eye **inside the mesh**: most of seven rays from it cross the mesh an odd number of
//!   times (`truth::ExactVisibility::is_inside`: each ray of a closed mesh does; an open surface,
//!   such as a floor under a ball, leaves most rays even). The ground truth then sees the surface
//!   from inside; HPR and the robust operator, made for an object seen from outside, answer
//!   poorly or refuse;
//! - the eye **among the points**: nearer a point than [`registry::scoring::pixels`]'s footprint
//!   radius (the ray cast's automatic radius, 1.5 density spacings), the splat a point is drawn
//!   as. That point then covers the whole image, which a pinhole view of a sampled surface
//!   cannot show: the eye is closer to the cloud than its spacing allows.

use anyhow::Result;
use cloud::Model;

use super::Dataset;

/// What [`find`] found: the views whose eye is inside the mesh, and those whose eye is among
/// the points with the nearest point's distance.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Eyes {
    /// Views whose eye is inside the mesh.
    pub inside: Vec<usize>,
    /// Views whose eye is nearer a point than the footprint radius: (view, distance).
    pub among: Vec<(usize, f64)>,
    /// The footprint radius (world units).
    pub footprint: f64,
}

impl Eyes {
    /// True when no view is inside or among the points.
    pub fn is_empty(&self) -> bool {
        self.inside.is_empty() && self.among.is_empty()
    }

    /// What to tell the user, one line per case, naming dataset `name` and the views (`n`
    /// views in all).
    pub fn lines(&self, name: &str, n: usize) -> Vec<String> {
        let mut out = Vec::new();
        if !self.inside.is_empty() {
            out.push(format!(
                "note: dataset {name}: {} inside the mesh, so it sees the surface from inside (a room, or an eye placed inside the object by mistake?). The \
                 ground truth and the methods that trace rays or draw the points (raycast, \
                 splat) see what such an eye sees; HPR and the robust operator are made for an \
                 object seen from outside and answer poorly or refuse there.",
                views(&self.inside, n)
            ));
        }
        if !self.among.is_empty() {
            let nearest = self
                .among
                .iter()
                .map(|&(_, d)| d)
                .fold(f64::INFINITY, f64::min);
            let v: Vec<usize> = self.among.iter().map(|&(v, _)| v).collect();
            out.push(format!(
                "note: dataset {name}: {} among the points ({nearest:.4} from the nearest, within {:.4}, 1.5 times their spacing): from there a point's splat \
                 covers the whole image, so no method can show a surface; move the eye away \
                 from the points.",
                views(&v, n),
                self.footprint
            ));
        }
        out
    }
}

/// `the eye of view 3 is`, `the eyes of views 0, 4 and 7 are`, `the eyes of every view (16)
/// are`, or `the eye is` (of a dataset with one view).
fn views(v: &[usize], n: usize) -> String {
    match v {
        [one] if n > 1 => format!("the eye of view {one} is"),
        [_] => "the eye is".to_owned(),
        _ if v.len() == n => format!("the eyes of every view ({n}) are"),
        _ => {
            let list: Vec<String> = v.iter().map(ToString::to_string).collect();
            let (last, rest) = list.split_last().map_or(("", &[][..]), |(l, r)| (l, r));
            format!("the eyes of views {} and {last} are", rest.join(", "))
        }
    }
}

/// The pinhole views of `ds` whose eye is inside its mesh or among its points ([`Eyes`]).
pub fn find(ds: &Dataset) -> Result<Eyes> {
    let pinhole: Vec<usize> = (0..ds.views.len())
        .filter(|&k| matches!(ds.views[k].model(), Model::Pinhole { .. }))
        .collect();
    let mut eyes = Eyes::default();
    if pinhole.is_empty() || ds.cloud.len() <= 8 {
        return Ok(eyes);
    }
    if let Some(mesh) = &ds.mesh {
        let exact = truth::ExactVisibility::new(mesh)?;
        eyes.inside = pinhole
            .iter()
            .copied()
            .filter(|&k| exact.is_inside(ds.views[k].eye))
            .collect();
    }
    use rayon::prelude::*;
    let nearest: Vec<(usize, f64)> = pinhole
        .iter()
        .map(|&k| {
            let eye = ds.views[k].eye;
            let d = ds
                .cloud
                .positions
                .par_iter()
                .map(|p| (*p - eye).length())
                .reduce(|| f64::INFINITY, f64::min);
            (k, d)
        })
        .collect();
    // The spacing (a neighbour search over a sample) only when some eye may be that near:
    // 1.5 spacings exceed a tenth of the bounding box's diagonal only for clouds of a few
    // hundred points.
    let diagonal = ds.cloud.bbox().map_or(0.0, |b| b.diagonal());
    if ds.cloud.len() > 1_000 && nearest.iter().all(|&(_, d)| d >= 0.1 * diagonal) {
        return Ok(eyes);
    }
    let footprint = registry::scoring::pixels::footprint_radius(&ds.cloud.positions)?;
    let world = 1.0 / (ds.scale.0 * ds.scale.1);
    eyes.footprint = footprint * world;
    eyes.among = nearest
        .into_iter()
        .filter(|&(_, d)| d < footprint)
        .map(|(k, d)| (k, d * world))
        .collect();
    Ok(eyes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lines_name_the_views() {
        assert_eq!(views(&[3], 16), "the eye of view 3 is");
        assert_eq!(views(&[0], 1), "the eye is");
        assert_eq!(views(&[0, 4, 7], 16), "the eyes of views 0, 4 and 7 are");
        assert_eq!(views(&[0, 1], 2), "the eyes of every view (2) are");
        let eyes = Eyes {
            inside: vec![2],
            among: vec![(5, 0.001), (6, 0.0005)],
            footprint: 0.01,
        };
        let lines = eyes.lines("d", 8);
        assert_eq!(lines.len(), 2);
        assert!(
            lines[0].contains("view 2 is inside the mesh"),
            "{}",
            lines[0]
        );
        assert!(
            lines[1].contains("views 5 and 6 are among") && lines[1].contains("0.0005 from"),
            "{}",
            lines[1]
        );
    }
}
