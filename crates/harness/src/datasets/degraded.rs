//! A cloud degraded by `cloud::degrade` with the bookkeeping its scoring needs: where each
//! point truly lies (its clean source's position; an outlier's own) and which points are
//! added outliers. The one place that does this, for built-in, manifest and experiment clouds.

use anyhow::Result;
use cloud::PointCloud;
use cloud::degrade::Degradation;
use cloud::glam::DVec3;

/// A degraded cloud and, per point, its truth position and outlier flag.
#[derive(Debug, Clone)]
pub struct Degraded {
    /// The points methods see.
    pub cloud: PointCloud,
    /// Per point, the position whose visibility is its ground truth: the clean point it came
    /// from (an outlier: itself).
    pub truth_positions: Vec<DVec3>,
    /// Per point, whether it is an added outlier (scored apart).
    pub outliers: Vec<bool>,
}

/// Applies `steps` to `clean` in order (`cloud::degrade::apply`, seeded with `seed`) and maps
/// every resulting point back to the clean cloud.
pub fn degrade(clean: &PointCloud, steps: &[Degradation], seed: u64) -> Result<Degraded> {
    let d = cloud::degrade::apply(clean, steps, seed)?;
    let truth_positions = d.truth_positions(&clean.positions);
    let outliers = d.outliers();
    Ok(Degraded {
        cloud: d.cloud,
        truth_positions,
        outliers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloud::degrade::Unit;

    #[test]
    fn outliers_are_flagged_and_surface_points_keep_their_source() {
        let clean = cloud::synth::sphere_scene(2_000).cloud;
        let d = degrade(
            &clean,
            &[
                Degradation::Noise {
                    sigma: 0.5,
                    unit: Unit::Spacing,
                    along_normal: false,
                },
                Degradation::Outliers {
                    fraction: 0.1,
                    near_surface: None,
                    unit: Unit::Spacing,
                },
            ],
            7,
        )
        .unwrap();
        assert_eq!(d.cloud.len(), 2_200);
        assert_eq!(d.truth_positions.len(), d.cloud.len());
        assert_eq!(d.outliers.iter().filter(|&&o| o).count(), 200);
        // Noisy surface points moved; their truth is a clean point.
        for i in (0..d.cloud.len()).filter(|&i| !d.outliers[i]) {
            assert!(clean.positions.contains(&d.truth_positions[i]));
            assert_ne!(d.cloud.positions[i], d.truth_positions[i]);
        }
        assert!(
            degrade(&clean, &[], 7)
                .unwrap()
                .outliers
                .iter()
                .all(|&o| !o)
        );
    }
}
