//! Does the mesh fit the points? The check a user's dataset passes before its mesh becomes a
//! ground truth.
//!
//! A ground truth rendered from a mesh the points are not on scores nothing: with the mesh
//! scaled ten times every point is off the surface, the reference sees none of them, and a
//! method that calls every point visible scores F1 1. So before a user's mesh is used, each
//! point's distance to it is measured (at the position whose visibility is its truth: a
//! degraded cloud's clean source position; added outliers are left out, being off the surface
//! on purpose) and the dataset is refused when more than [`MAX_FAR_SHARE`] of the points lie
//! farther than [`FAR_SPACINGS`] density spacings from the mesh (or than the surface tolerance
//! the user gave, when larger). The refusal gives the share, the median distance and the
//! likely cause: part of the points when most lie on the mesh (outliers, or surfaces the mesh
//! lacks), else what the two bounding boxes say ([`likely_cause`]: scale or units, an offset,
//! or another surface). `--allow-off-surface` (or `allow_off_surface = true` in a
//! manifest entry) lets a user who knows go on; their rows are then marked `off-surface`
//! ([`MeshFit::mark`]).
//!
//! Built-in datasets are samples of their own meshes and are not checked.

use anyhow::{Result, bail};
use cloud::Aabb;
use cloud::glam::DVec3;

use super::Dataset;

/// The largest share of a cloud's points that may lie farther than [`FAR_SPACINGS`] from its
/// mesh: a scan registered to its mesh has a few stray points, a mesh that does not fit has
/// most of them off.
pub const MAX_FAR_SHARE: f64 = 0.01;

/// The distance, in density spacings (`cloud::spacing::density_spacing`, k = 8), beyond which
/// a point counts as far from the mesh.
pub const FAR_SPACINGS: f64 = 3.0;

/// How far a dataset's points lie from its mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFit {
    /// Points measured (every point but added outliers).
    pub points: usize,
    /// The share of them farther than [`MeshFit::limit`] from the mesh.
    pub far_share: f64,
    /// The median distance to the mesh, world units.
    pub median_distance: f64,
    /// The distance counted as far, world units: [`FAR_SPACINGS`] density spacings, or the
    /// surface tolerance given when larger.
    pub limit: f64,
    /// What the bounding boxes suggest went wrong ([`likely_cause`]).
    pub cause: String,
    /// True when the user let a mesh that does not fit be used (`--allow-off-surface`).
    pub allowed: bool,
}

impl MeshFit {
    /// True when no more than [`MAX_FAR_SHARE`] of the points are far from the mesh.
    pub fn fits(&self) -> bool {
        self.far_share <= MAX_FAR_SHARE
    }

    /// The mark of rows scored against this mesh: `ok`, or `off-surface` when it does not fit
    /// and the user went on.
    pub fn mark(&self) -> &'static str {
        if self.fits() { "ok" } else { "off-surface" }
    }

    /// `P % of the points lie farther than L from it (more than the 1 % allowed), median
    /// distance M; likely cause: C`.
    pub fn text(&self) -> String {
        format!(
            "{:.1} % of the points lie farther than {} from it ({} density spacings; more than \
             the {} % allowed), median distance {}; likely cause: {}",
            100.0 * self.far_share,
            num(self.limit),
            FAR_SPACINGS,
            100.0 * MAX_FAR_SHARE,
            num(self.median_distance),
            self.cause
        )
    }
}

/// Measures how far `ds`'s points lie from its mesh (`None` without a mesh, or with too few
/// points for a density spacing).
pub fn measure(ds: &Dataset) -> Result<Option<MeshFit>> {
    let Some(mesh) = &ds.mesh else {
        return Ok(None);
    };
    if ds.cloud.len() <= 8 {
        return Ok(None);
    }
    let spacing = cloud::spacing::density_spacing(&ds.cloud.positions, 8, 20_000, 1)?;
    let limit = match ds.surface_tolerance {
        Some(t) => t.max(FAR_SPACINGS * spacing),
        None => FAR_SPACINGS * spacing,
    };
    let outlier = |i: usize| ds.outliers.as_ref().is_some_and(|o| o[i]);
    let points: Vec<DVec3> = ds
        .truth_points()
        .iter()
        .enumerate()
        .filter(|&(i, _)| !outlier(i))
        .map(|(_, p)| *p)
        .collect();
    if points.is_empty() {
        return Ok(None);
    }
    let mut d = truth::ExactVisibility::new(mesh)?.distances(&points)?;
    let far = d.iter().filter(|&&x| x > limit).count();
    let median = cloud::spacing::median_of(&mut d).unwrap_or(f64::NAN);
    // Distances in the dataset's frame (recentred, perhaps rescaled exactly) back to world units.
    let world = 1.0 / (ds.scale.0 * ds.scale.1);
    let (Some(cloud_box), Some(mesh_box)) = (Aabb::from_points(&points), mesh.bbox()) else {
        return Ok(None);
    };
    Ok(Some(MeshFit {
        points: points.len(),
        far_share: far as f64 / points.len() as f64,
        median_distance: median * world,
        limit: limit * world,
        cause: if median <= limit {
            format!(
                "part of the points: most lie on the mesh (median distance {}), the far ones \
                 are stray points or outliers of a scan, or points of surfaces the mesh lacks",
                num(median * world)
            )
        } else {
            likely_cause(&cloud_box, &mesh_box, world)
        },
        allowed: false,
    }))
}

/// Measures `ds`'s mesh against its points ([`measure`]) and records the result in
/// [`Dataset::mesh_fit`]; fails when the mesh does not fit unless `allow` (the refusal says
/// how to go on). `mesh` names the mesh file for the message, when known.
pub fn check(ds: &mut Dataset, allow: bool, mesh: Option<&std::path::Path>) -> Result<()> {
    let Some(mut fit) = measure(ds)? else {
        return Ok(());
    };
    if !fit.fits() {
        if !allow {
            let mesh = mesh.map_or_else(
                || "its mesh".to_owned(),
                |m| format!("the mesh {}", m.display()),
            );
            bail!(
                "dataset {}: {mesh} does not fit the points: {}. A ground truth \
                 rendered from it would score every method against a surface the points are \
                 not on. Check the mesh (`--mesh`, or `mesh =` in the manifest) and the cloud, \
                 or pass --allow-off-surface (or `allow_off_surface = true` in the manifest \
                 entry) to score against it anyway: the rows are then marked \
                 mesh_fit=off-surface",
                ds.name,
                fit.text()
            );
        }
        fit.allowed = true;
    }
    ds.mesh_fit = Some(fit);
    Ok(())
}

/// The likely cause of a mesh that does not fit, from the points' and the mesh's bounding
/// boxes (`world` converts their lengths to world units): their sizes differ by more than a
/// quarter (scale, or units when the factor is a usual one: 10, 100, 1000, 25.4, 12, 3.28),
/// else their centres lie more than a twentieth of the size apart (an offset), else the
/// points are not on this surface (another mesh, or a rotation).
pub fn likely_cause(points: &Aabb, mesh: &Aabb, world: f64) -> String {
    let (dp, dm) = (points.diagonal(), mesh.diagonal());
    if !(dp > 0.0 && dm > 0.0) {
        return "the points or the mesh are flat or a single position".into();
    }
    let ratio = dm / dp;
    if !(0.8..=1.25).contains(&ratio) {
        let (big, which) = if ratio > 1.0 {
            (ratio, "the mesh is")
        } else {
            (1.0 / ratio, "the points are")
        };
        const UNITS: [(f64, &str); 6] = [
            (1000.0, "millimetres against metres"),
            (100.0, "centimetres against metres"),
            (10.0, "millimetres against centimetres"),
            (25.4, "millimetres against inches"),
            (12.0, "inches against feet"),
            (3.2808, "feet against metres"),
        ];
        let unit = UNITS
            .iter()
            .find(|(f, _)| (big / f - 1.0).abs() < 0.05)
            .map_or(String::new(), |(f, u)| {
                format!(" (a factor of {f}: units, {u}?)")
            });
        return format!(
            "scale: {which} {} times as large as the other{unit}",
            num(big)
        );
    }
    let offset = (points.center() - mesh.center()) * world;
    if offset.length() > 0.05 * dp.max(dm) * world {
        return format!(
            "offset: the points' bounding box is shifted by ({}, {}, {}) from the mesh's \
             (another origin, or the cloud in georeferenced coordinates and the mesh in local \
             ones?)",
            num(offset.x),
            num(offset.y),
            num(offset.z)
        );
    }
    "another mesh: the bounding boxes agree in size and place, but the points are not on this \
     surface (a different object or version of it, or the points rotated or mirrored against \
     it?)"
        .into()
}

/// A length with four significant digits.
fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.digits$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxed(min: [f64; 3], max: [f64; 3]) -> Aabb {
        Aabb::from_points(&[DVec3::from_array(min), DVec3::from_array(max)]).unwrap()
    }

    #[test]
    fn the_likely_cause_reads_the_boxes() {
        let unit = boxed([-1.0; 3], [1.0; 3]);
        let tenfold = boxed([-10.0; 3], [10.0; 3]);
        let cause = likely_cause(&unit, &tenfold, 1.0);
        assert!(
            cause.starts_with("scale: the mesh is 10.00 times") && cause.contains("units"),
            "{cause}"
        );
        let cause = likely_cause(&tenfold, &unit, 1.0);
        assert!(cause.starts_with("scale: the points are 10.00"), "{cause}");
        let cause = likely_cause(&unit, &boxed([-3.0; 3], [3.0; 3]), 1.0);
        assert!(
            cause.starts_with("scale") && !cause.contains("units"),
            "{cause}"
        );
        let shifted = boxed([4.0, -1.0, -1.0], [6.0, 1.0, 1.0]);
        let cause = likely_cause(&shifted, &unit, 1.0);
        assert!(
            cause.starts_with("offset: ") && cause.contains("(5.000, 0, 0)"),
            "{cause}"
        );
        assert!(likely_cause(&unit, &unit, 1.0).starts_with("another mesh"));
    }
}
