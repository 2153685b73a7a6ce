//! Degradations: what real scanners do to a cloud, as seeded, composable transforms of a clean
//! sample, keeping per point where it came from so that the ground truth still comes from the
//! mesh.
//!
//! Models (lengths in [`Unit`]s of the *clean* cloud, measured once before the first step):
//! - [`Degradation::Noise`]: Gaussian displacement, isotropic (σ per axis) or along the
//!   point's normal (σ along it; normals required).
//! - [`Degradation::Jitter`]: uniform displacement along the point's normal, in
//!   [−margin, margin] (normals required): the noise model of Mehra et al., "Visibility of noisy
//!   point cloud data", 2010 ("uniform random perturbations in the normal direction", the
//!   margin in bounding-box diagonals).
//! - [`Degradation::FallOff`]: density falling off with distance d from a point: each point is
//!   kept with probability `ratio^(-(d − d_min)/(d_max − d_min))`, so the nearest points keep
//!   their density and the farthest `1/ratio` of it (the density ratio is `ratio`).
//! - [`Degradation::DensityField`]: a smooth field over space, s(x) ∈ [0, 1], the normalised
//!   sum of three plane waves of the given wavelength with seeded directions and phases; each
//!   point is kept with probability `ratio^(-s(x))` (density ratio `ratio` between the field's
//!   extremes).
//! - [`Degradation::Holes`]: `count` patches removed: every point within `radius` of a
//!   centre drawn from the cloud.
//! - [`Degradation::Outliers`]: `fraction × n` points added (n: points before this step),
//!   uniform in the bounding box grown by 5 % (`near_surface: None`), or clustered near the
//!   surface: a random point moved along a uniform random direction by a distance uniform in
//!   (1, `near_surface`] units (so never within one unit of where it was taken).
//!
//! [`Degraded::source`] gives, per output point, the index of the clean point it came from, or
//! [`OUTLIER`]: scoring takes a point's truth from its clean source (a noisy sample of a
//! visible surface point is a visible point) and sets outliers apart. Every random choice is
//! drawn from `seed` and the step's position in the list (`rng::seeded`).

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};
use crate::points::PointCloud;
use crate::rng::{RngExt, gaussian, seeded};

/// `source` of a point that no clean point produced.
pub const OUTLIER: u32 = u32::MAX;

/// The unit of a degradation's lengths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// The clean cloud's density spacing, 1/sqrt(points per unit area)
    /// (`spacing::density_spacing`, k = 8).
    Spacing,
    /// The clean cloud's bounding-box diagonal.
    Diagonal,
}

/// One degradation step.
#[derive(Debug, Clone, PartialEq)]
pub enum Degradation {
    /// Gaussian noise of standard deviation `sigma` units.
    Noise {
        /// Standard deviation.
        sigma: f64,
        /// Its unit.
        unit: Unit,
        /// Along each point's normal instead of isotropic.
        along_normal: bool,
    },
    /// Uniform displacement along each point's normal, in [−margin, margin] units.
    Jitter {
        /// Half width of the displacement.
        margin: f64,
        /// Its unit.
        unit: Unit,
    },
    /// Density falling off with distance from `from`, by `ratio` from nearest to farthest.
    FallOff {
        /// The point the distance is measured from (a scanner).
        from: DVec3,
        /// Density of the nearest points over that of the farthest (≥ 1).
        ratio: f64,
    },
    /// A smooth density field with extremes `ratio` apart.
    DensityField {
        /// Highest density over lowest (≥ 1).
        ratio: f64,
        /// Wavelength of the field, in bounding-box diagonals.
        wavelength: f64,
    },
    /// Patches removed.
    Holes {
        /// Number of patches.
        count: usize,
        /// Patch radius.
        radius: f64,
        /// Its unit.
        unit: Unit,
    },
    /// Outliers added.
    Outliers {
        /// Added points over points present.
        fraction: f64,
        /// `None`: uniform in the bounding box; `Some(m)`: within `m` units of the surface.
        near_surface: Option<f64>,
        /// The unit of `near_surface`.
        unit: Unit,
    },
}

impl Degradation {
    /// A short name with the parameters, for tables (`noise-0.5sp`, `outliers-0.05`, ...).
    pub fn label(&self) -> String {
        let u = |unit: &Unit| match unit {
            Unit::Spacing => "sp",
            Unit::Diagonal => "diag",
        };
        match self {
            Degradation::Noise {
                sigma,
                unit,
                along_normal,
            } => format!(
                "noise{}-{sigma}{}",
                if *along_normal { "-normal" } else { "" },
                u(unit)
            ),
            Degradation::Jitter { margin, unit } => format!("jitter-{margin}{}", u(unit)),
            Degradation::FallOff { ratio, .. } => format!("falloff-{ratio}"),
            Degradation::DensityField { ratio, .. } => format!("density-{ratio}"),
            Degradation::Holes {
                count,
                radius,
                unit,
                ..
            } => format!("holes-{count}x{radius}{}", u(unit)),
            Degradation::Outliers {
                fraction,
                near_surface,
                ..
            } => match near_surface {
                None => format!("outliers-{fraction}"),
                Some(m) => format!("outliers-near{m}-{fraction}"),
            },
        }
    }
}

impl std::str::FromStr for Degradation {
    type Err = Error;

    /// `KIND:key=value,key=value`, the form manifests use:
    /// `noise:sigma=0.5[,unit=spacing|diagonal][,along=normal]`, `jitter:margin=0.01[,unit=...]`,
    /// `falloff:ratio=4,from=X;Y;Z`, `density:ratio=4[,wavelength=0.5]`,
    /// `holes:count=5,radius=10[,unit=...]`, `outliers:fraction=0.01[,near=5][,unit=...]`.
    fn from_str(text: &str) -> Result<Self> {
        let bad = |reason: String| invalid("degrade", format!("{text:?}: {reason}"));
        let (kind, rest) = text.split_once(':').unwrap_or((text, ""));
        let mut pairs = std::collections::BTreeMap::new();
        for pair in rest.split(',').filter(|p| !p.trim().is_empty()) {
            let (k, v) = pair
                .split_once('=')
                .ok_or_else(|| bad(format!("expected key=value, got {pair:?}")))?;
            pairs.insert(k.trim().to_owned(), v.trim().to_owned());
        }
        let mut take = |key: &str| pairs.remove(key);
        let number = |v: Option<String>, key: &str| -> Result<Option<f64>> {
            v.map(|v| {
                v.parse::<f64>()
                    .map_err(|_| bad(format!("{key} is not a number: {v:?}")))
            })
            .transpose()
        };
        let unit = match take("unit").as_deref() {
            None | Some("spacing") => Unit::Spacing,
            Some("diagonal") => Unit::Diagonal,
            Some(other) => return Err(bad(format!("unit {other:?}: spacing or diagonal"))),
        };
        let need = |v: Option<f64>, key: &str| v.ok_or_else(|| bad(format!("needs {key}=")));
        let step = match kind.trim() {
            "noise" => Degradation::Noise {
                sigma: need(number(take("sigma"), "sigma")?, "sigma")?,
                unit,
                along_normal: match take("along").as_deref() {
                    None | Some("isotropic") => false,
                    Some("normal") => true,
                    Some(other) => return Err(bad(format!("along={other}: normal or isotropic"))),
                },
            },
            "jitter" => Degradation::Jitter {
                margin: need(number(take("margin"), "margin")?, "margin")?,
                unit,
            },
            "falloff" => {
                let from = take("from").ok_or_else(|| bad("needs from=X;Y;Z".into()))?;
                let c: Vec<f64> = from
                    .split(';')
                    .map(|c| c.trim().parse::<f64>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| bad(format!("from={from}: three numbers X;Y;Z")))?;
                let [x, y, z] = c[..] else {
                    return Err(bad(format!("from={from}: three numbers X;Y;Z")));
                };
                Degradation::FallOff {
                    from: DVec3::new(x, y, z),
                    ratio: need(number(take("ratio"), "ratio")?, "ratio")?,
                }
            }
            "density" => Degradation::DensityField {
                ratio: need(number(take("ratio"), "ratio")?, "ratio")?,
                wavelength: number(take("wavelength"), "wavelength")?.unwrap_or(0.5),
            },
            "holes" => Degradation::Holes {
                count: need(number(take("count"), "count")?, "count")? as usize,
                radius: need(number(take("radius"), "radius")?, "radius")?,
                unit,
            },
            "outliers" => Degradation::Outliers {
                fraction: need(number(take("fraction"), "fraction")?, "fraction")?,
                near_surface: number(take("near"), "near")?,
                unit,
            },
            other => {
                return Err(bad(format!(
                    "unknown degradation {other:?}: noise, jitter, falloff, density, holes or outliers"
                )));
            }
        };
        if let Some(key) = pairs.keys().next() {
            return Err(bad(format!("unknown key {key:?}")));
        }
        Ok(step)
    }
}

/// A degraded cloud.
#[derive(Debug, Clone, PartialEq)]
pub struct Degraded {
    /// The points (with whatever attributes the clean cloud had, for the points it gave).
    pub cloud: PointCloud,
    /// Per point: the clean point it came from, or [`OUTLIER`].
    pub source: Vec<u32>,
    /// The clean cloud's density spacing (the unit `Unit::Spacing` stood for).
    pub spacing: f64,
    /// The clean cloud's bounding-box diagonal.
    pub diagonal: f64,
}

impl Degraded {
    /// Per point: is it an outlier?
    pub fn outliers(&self) -> Vec<bool> {
        self.source.iter().map(|&s| s == OUTLIER).collect()
    }

    /// Per point, where it truly lies: its clean source's position in `clean` (the cloud
    /// [`apply`] was given), or its own position for an outlier.
    pub fn truth_positions(&self, clean: &[DVec3]) -> Vec<DVec3> {
        self.source
            .iter()
            .zip(&self.cloud.positions)
            .map(|(&s, &p)| clean.get(s as usize).copied().unwrap_or(p))
            .collect()
    }

    /// Per point, the clean truth of its source (`false` for outliers).
    pub fn truth_of(&self, clean: &[bool]) -> Vec<bool> {
        self.source
            .iter()
            .map(|&s| s != OUTLIER && clean.get(s as usize).copied().unwrap_or(false))
            .collect()
    }
}

fn invalid(name: &'static str, reason: String) -> Error {
    Error::InvalidParameter { name, reason }
}

/// A uniform direction on the unit sphere.
fn direction(rng: &mut crate::rng::Rng) -> DVec3 {
    let z = 2.0 * rng.random::<f64>() - 1.0;
    let phi = std::f64::consts::TAU * rng.random::<f64>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Applies `steps` in order to `clean`.
pub fn apply(clean: &PointCloud, steps: &[Degradation], seed: u64) -> Result<Degraded> {
    clean.validate()?;
    let bbox = clean.bbox().ok_or(Error::EmptyCloud)?;
    let diagonal = bbox.diagonal();
    let spacing = crate::spacing::density_spacing(&clean.positions, 8, 20_000, seed)?;
    let length = |v: f64, unit: Unit| match unit {
        Unit::Spacing => v * spacing,
        Unit::Diagonal => v * diagonal,
    };
    let mut cloud = clean.clone();
    let mut source: Vec<u32> = (0..clean.len() as u32).collect();
    for (k, step) in steps.iter().enumerate() {
        let mut rng = seeded(seed, &format!("degrade-{k}"));
        match *step {
            Degradation::Noise {
                sigma,
                unit,
                along_normal,
            } => {
                if !(sigma >= 0.0 && sigma.is_finite()) {
                    return Err(invalid("sigma", format!("must be >= 0, got {sigma}")));
                }
                let s = length(sigma, unit);
                let normals: Option<Vec<Vec3>> = if along_normal {
                    Some(cloud.normals.clone().ok_or_else(|| {
                        invalid(
                            "along_normal",
                            "noise along the normal needs normals".into(),
                        )
                    })?)
                } else {
                    None
                };
                for (i, p) in cloud.positions.iter_mut().enumerate() {
                    let d = match &normals {
                        Some(n) => n[i].as_dvec3().normalize_or_zero() * (s * gaussian(&mut rng)),
                        None => {
                            let (x, y, z) =
                                (gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng));
                            DVec3::new(x, y, z) * s
                        }
                    };
                    *p += d;
                }
            }
            Degradation::Jitter { margin, unit } => {
                if !(margin >= 0.0 && margin.is_finite()) {
                    return Err(invalid("margin", format!("must be >= 0, got {margin}")));
                }
                let m = length(margin, unit);
                let normals = cloud.normals.clone().ok_or_else(|| {
                    invalid("jitter", "noise along the normal needs normals".into())
                })?;
                for (p, n) in cloud.positions.iter_mut().zip(&normals) {
                    let t: f64 = rng.random::<f64>() * 2.0 - 1.0;
                    *p += n.as_dvec3().normalize_or_zero() * (m * t);
                }
            }
            Degradation::FallOff { from, ratio } => {
                if !(ratio >= 1.0 && ratio.is_finite() && from.is_finite()) {
                    return Err(invalid("ratio", format!("must be >= 1, got {ratio}")));
                }
                let d: Vec<f64> = cloud
                    .positions
                    .iter()
                    .map(|p| (*p - from).length())
                    .collect();
                let (lo, hi) = d
                    .iter()
                    .fold((f64::MAX, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                let span = (hi - lo).max(f64::MIN_POSITIVE);
                let keep: Vec<u32> = (0..cloud.len())
                    .filter(|&i| rng.random::<f64>() < ratio.powf(-(d[i] - lo) / span))
                    .map(|i| i as u32)
                    .collect();
                (cloud, source) = subset(&cloud, &source, &keep);
            }
            Degradation::DensityField { ratio, wavelength } => {
                if !(ratio >= 1.0 && ratio.is_finite() && wavelength > 0.0) {
                    return Err(invalid(
                        "ratio/wavelength",
                        format!("need ratio >= 1 and wavelength > 0, got {ratio}, {wavelength}"),
                    ));
                }
                let waves: Vec<(DVec3, f64)> = (0..3)
                    .map(|_| {
                        let k =
                            direction(&mut rng) * (std::f64::consts::TAU / (wavelength * diagonal));
                        (k, std::f64::consts::TAU * rng.random::<f64>())
                    })
                    .collect();
                let field = |p: DVec3| {
                    let sum: f64 = waves.iter().map(|(k, ph)| (k.dot(p) + ph).sin()).sum();
                    (sum / 3.0 + 1.0) / 2.0
                };
                let keep: Vec<u32> = (0..cloud.len())
                    .filter(|&i| rng.random::<f64>() < ratio.powf(-field(cloud.positions[i])))
                    .map(|i| i as u32)
                    .collect();
                (cloud, source) = subset(&cloud, &source, &keep);
            }
            Degradation::Holes {
                count,
                radius,
                unit,
            } => {
                let r = length(radius, unit);
                if !(r >= 0.0 && r.is_finite()) {
                    return Err(invalid("radius", format!("must be >= 0, got {radius}")));
                }
                // Centres are drawn from the points: more holes than points is a mistake (and
                // a count from a manifest must not size an allocation unchecked).
                if count > cloud.len() {
                    return Err(invalid(
                        "count",
                        format!("{count} holes for {} points", cloud.len()),
                    ));
                }
                let centres: Vec<DVec3> = (0..count)
                    .map(|_| cloud.positions[rng.random_range(0..cloud.len())])
                    .collect();
                let keep: Vec<u32> = (0..cloud.len())
                    .filter(|&i| {
                        centres
                            .iter()
                            .all(|c| (cloud.positions[i] - *c).length_squared() > r * r)
                    })
                    .map(|i| i as u32)
                    .collect();
                (cloud, source) = subset(&cloud, &source, &keep);
            }
            Degradation::Outliers {
                fraction,
                near_surface,
                unit,
            } => {
                if !(0.0..=10.0).contains(&fraction) {
                    return Err(invalid(
                        "fraction",
                        format!("must be in [0, 10], got {fraction}"),
                    ));
                }
                let n = cloud.len();
                let added = (fraction * n as f64).round() as usize;
                // The cloud grows by `added` points with their attributes (at most ~64 bytes).
                crate::memory::ensure(
                    64 * (n + added) as u128,
                    &format!("{added} outliers added to {n} points"),
                )?;
                let grown = (bbox.max - bbox.min) * 0.05;
                let (lo, size) = (bbox.min - grown, bbox.max - bbox.min + 2.0 * grown);
                let new: Vec<DVec3> = (0..added)
                    .map(|_| match near_surface {
                        None => {
                            lo + size
                                * DVec3::new(
                                    rng.random::<f64>(),
                                    rng.random::<f64>(),
                                    rng.random::<f64>(),
                                )
                        }
                        Some(m) => {
                            let (unit_len, max) = (length(1.0, unit), length(m, unit));
                            let d =
                                unit_len + (max - unit_len).max(0.0) * (1.0 - rng.random::<f64>());
                            cloud.positions[rng.random_range(0..n)] + direction(&mut rng) * d
                        }
                    })
                    .collect();
                cloud = with_points(&cloud, &new);
                source.extend(std::iter::repeat_n(OUTLIER, added));
            }
        }
    }
    if cloud.is_empty() {
        return Err(Error::EmptyCloud);
    }
    Ok(Degraded {
        cloud,
        source,
        spacing,
        diagonal,
    })
}

fn subset(cloud: &PointCloud, source: &[u32], keep: &[u32]) -> (PointCloud, Vec<u32>) {
    (
        cloud.select(keep),
        keep.iter().map(|&i| source[i as usize]).collect(),
    )
}

/// `cloud` with `extra` points appended (their attributes zero; no surface sample).
fn with_points(cloud: &PointCloud, extra: &[DVec3]) -> PointCloud {
    let mut out = cloud.clone();
    out.positions.extend_from_slice(extra);
    let n = extra.len();
    if let Some(v) = out.normals.as_mut() {
        v.extend(std::iter::repeat_n(Vec3::ZERO, n));
    }
    if let Some(v) = out.colors.as_mut() {
        v.extend(std::iter::repeat_n([0; 3], n));
    }
    if let Some(v) = out.uvs.as_mut() {
        v.extend(std::iter::repeat_n(glam::Vec2::ZERO, n));
    }
    if let Some(v) = out.intensity.as_mut() {
        v.extend(std::iter::repeat_n(0, n));
    }
    if let Some(v) = out.classification.as_mut() {
        v.extend(std::iter::repeat_n(0, n));
    }
    if let Some(v) = out.scan.as_mut() {
        v.extend(std::iter::repeat_n(u16::MAX, n));
    }
    // Surface samples say where on the mesh a point lies; an outlier lies nowhere.
    out.samples = None;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::sphere_scene;

    fn clean() -> PointCloud {
        sphere_scene(40_000).cloud
    }

    #[test]
    fn isotropic_noise_has_the_asked_sigma() {
        let c = clean();
        let d = apply(
            &c,
            &[Degradation::Noise {
                sigma: 0.5,
                unit: Unit::Spacing,
                along_normal: false,
            }],
            7,
        )
        .unwrap();
        assert_eq!(d.cloud.len(), c.len());
        let sigma = 0.5 * d.spacing;
        // Per-axis standard deviation of the displacement.
        let n = c.len() as f64;
        for axis in 0..3 {
            let (mut s, mut s2) = (0.0, 0.0);
            for (p, q) in d.cloud.positions.iter().zip(&c.positions) {
                let x = (*p - *q)[axis];
                s += x;
                s2 += x * x;
            }
            let measured = (s2 / n - (s / n).powi(2)).sqrt();
            assert!(
                (measured / sigma - 1.0).abs() < 0.02,
                "axis {axis}: {measured} vs {sigma}"
            );
            assert!((s / n).abs() < 0.02 * sigma, "mean {}", s / n);
        }
    }

    #[test]
    fn jitter_is_uniform_along_the_normal_within_its_margin() {
        let c = clean();
        let step: Degradation = "jitter:margin=0.01,unit=diagonal".parse().unwrap();
        assert_eq!(step.label(), "jitter-0.01diag");
        let d = apply(&c, &[step], 3).unwrap();
        let m = 0.01 * c.bbox().unwrap().diagonal();
        let normals = c.normals.as_ref().unwrap();
        let mut t = Vec::new();
        for ((p, q), n) in d.cloud.positions.iter().zip(&c.positions).zip(normals) {
            let disp = *p - *q;
            let n = n.as_dvec3().normalize();
            assert!((disp - n * disp.dot(n)).length() < 1e-12, "off the normal");
            t.push(disp.dot(n) / m);
        }
        // Uniform on [-1, 1]: inside it, mean 0, variance 1/3, and both ends reached.
        assert!(t.iter().all(|x| x.abs() <= 1.0 + 1e-9));
        let n = t.len() as f64;
        let mean = t.iter().sum::<f64>() / n;
        let var = t.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((var * 3.0 - 1.0).abs() < 0.05, "variance {var}");
        assert!(t.iter().any(|&x| x > 0.95) && t.iter().any(|&x| x < -0.95));
        let bare = PointCloud {
            normals: None,
            ..c.clone()
        };
        assert!(
            apply(
                &bare,
                &[Degradation::Jitter {
                    margin: 0.01,
                    unit: Unit::Diagonal
                }],
                3
            )
            .is_err()
        );
        assert!(
            "jitter:margin=-1"
                .parse::<Degradation>()
                .is_ok_and(|s| apply(&c, &[s], 3).is_err())
        );
    }

    #[test]
    fn noise_along_the_normal_stays_on_the_normal() {
        let c = clean();
        let d = apply(
            &c,
            &[Degradation::Noise {
                sigma: 0.01,
                unit: Unit::Diagonal,
                along_normal: true,
            }],
            1,
        )
        .unwrap();
        let normals = c.normals.as_ref().unwrap();
        let mut s2 = 0.0;
        for ((p, q), n) in d.cloud.positions.iter().zip(&c.positions).zip(normals) {
            let disp = *p - *q;
            let n = n.as_dvec3().normalize();
            assert!((disp - n * disp.dot(n)).length() < 1e-12);
            s2 += disp.length_squared();
        }
        let measured = (s2 / c.len() as f64).sqrt();
        let sigma = 0.01 * d.diagonal;
        assert!(
            (measured / sigma - 1.0).abs() < 0.02,
            "{measured} vs {sigma}"
        );
    }

    #[test]
    fn outlier_fraction_and_flags_are_as_asked() {
        let c = clean();
        for near in [None, Some(5.0)] {
            let d = apply(
                &c,
                &[Degradation::Outliers {
                    fraction: 0.05,
                    near_surface: near,
                    unit: Unit::Spacing,
                }],
                3,
            )
            .unwrap();
            let outliers = d.outliers().iter().filter(|&&o| o).count();
            assert_eq!(outliers, 2_000);
            assert_eq!(d.cloud.len(), 42_000);
            assert!(
                d.source[..40_000]
                    .iter()
                    .enumerate()
                    .all(|(i, &s)| s == i as u32)
            );
            if let Some(m) = near {
                // Every near-surface outlier lies between 1 and m spacings from the surface
                // it was taken from (the unit sphere: |‖p‖ − 1| at most the offset).
                for p in &d.cloud.positions[40_000..] {
                    assert!((p.length() - 1.0).abs() <= m * d.spacing + 1e-12);
                }
            }
        }
    }

    #[test]
    fn fall_off_gives_the_asked_density_ratio() {
        let c = clean();
        let from = DVec3::new(0.0, 0.0, 3.0);
        let d = apply(&c, &[Degradation::FallOff { from, ratio: 4.0 }], 5).unwrap();
        // Kept fraction among the nearest and the farthest tenth of the distance range.
        let dist: Vec<f64> = c.positions.iter().map(|p| (*p - from).length()).collect();
        let (lo, hi) = (2.0, 4.0);
        let band = |a: f64, b: f64, pts: &mut dyn Iterator<Item = f64>| {
            pts.filter(|&x| x >= lo + a * (hi - lo) && x < lo + b * (hi - lo))
                .count() as f64
        };
        let near_before = band(0.0, 0.1, &mut dist.iter().copied());
        let far_before = band(0.9, 1.0, &mut dist.iter().copied());
        let kept: Vec<f64> = d.source.iter().map(|&s| dist[s as usize]).collect();
        let near_after = band(0.0, 0.1, &mut kept.iter().copied());
        let far_after = band(0.9, 1.0, &mut kept.iter().copied());
        let ratio = (near_after / near_before) / (far_after / far_before);
        // Expected: 4^(0.95 - 0.05) = 3.48 between the bands' centres.
        assert!((ratio / 4f64.powf(0.9) - 1.0).abs() < 0.15, "{ratio}");
    }

    #[test]
    fn density_field_and_holes_remove_and_keep_sources() {
        let c = clean();
        let steps = [
            Degradation::DensityField {
                ratio: 8.0,
                wavelength: 0.5,
            },
            Degradation::Holes {
                count: 5,
                radius: 10.0,
                unit: Unit::Spacing,
            },
        ];
        let d = apply(&c, &steps, 9).unwrap();
        assert!(d.cloud.len() < c.len() / 2, "{}", d.cloud.len());
        assert!(d.cloud.len() > c.len() / 10, "{}", d.cloud.len());
        for (p, &s) in d.cloud.positions.iter().zip(&d.source) {
            assert_eq!(*p, c.positions[s as usize]);
        }
        assert_eq!(d.truth_positions(&c.positions), d.cloud.positions);
        // The same seed gives the same cloud.
        assert_eq!(apply(&c, &steps, 9).unwrap(), d);
    }

    #[test]
    fn steps_parse_from_their_manifest_form() {
        let parsed: Degradation = "noise:sigma=0.5,along=normal".parse().unwrap();
        assert_eq!(
            parsed,
            Degradation::Noise {
                sigma: 0.5,
                unit: Unit::Spacing,
                along_normal: true
            }
        );
        let parsed: Degradation = "falloff:ratio=4,from=1;2;3".parse().unwrap();
        assert_eq!(
            parsed,
            Degradation::FallOff {
                from: DVec3::new(1.0, 2.0, 3.0),
                ratio: 4.0
            }
        );
        let parsed: Degradation = "outliers:fraction=0.01,near=5,unit=diagonal"
            .parse()
            .unwrap();
        assert_eq!(
            parsed,
            Degradation::Outliers {
                fraction: 0.01,
                near_surface: Some(5.0),
                unit: Unit::Diagonal
            }
        );
        for bad in [
            "blur:sigma=1",
            "noise",
            "noise:sigma=x",
            "noise:sigma=1,color=red",
            "falloff:ratio=2,from=1;2",
        ] {
            assert!(bad.parse::<Degradation>().is_err(), "{bad}");
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let c = clean();
        assert!(
            apply(
                &c,
                &[Degradation::FallOff {
                    from: DVec3::ZERO,
                    ratio: 0.5
                }],
                1
            )
            .is_err()
        );
        assert!(
            apply(
                &c,
                &[Degradation::Noise {
                    sigma: f64::NAN,
                    unit: Unit::Spacing,
                    along_normal: false
                }],
                1
            )
            .is_err()
        );
        let holes: Degradation = "holes:count=1e15,radius=1".parse().unwrap();
        assert!(apply(&c, &[holes], 1).is_err());
        let bare = PointCloud::from_positions(c.positions.clone()).unwrap();
        assert!(
            apply(
                &bare,
                &[Degradation::Noise {
                    sigma: 1.0,
                    unit: Unit::Spacing,
                    along_normal: true
                }],
                1
            )
            .is_err()
        );
    }
}
