//! Area-weighted, seeded surface sampling of a triangle mesh.
//!
//! A triangle is drawn with probability proportional to its area (binary search in the prefix
//! sums of the areas), then a uniform point in it with the square-root warp of Osada et al.
//! ("Shape distributions", ACM TOG 2002, §4.2): with `r1, r2` uniform in [0, 1),
//! `p = (1 − √r1)·a + √r1(1 − r2)·b + √r1·r2·c`. Each sample keeps its triangle id and
//! barycentric weights ([`SurfaceSample`]), its normal is the triangle's geometric normal, and
//! texture coordinates are interpolated when the mesh has them. Coordinates are the mesh's own:
//! no recentring, no scaling.

use glam::{DVec3, Vec2};

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::points::{PointCloud, SurfaceSample};
use crate::rng::{RngExt, seeded};

/// Samples `n` points on the surface of `mesh`, area-weighted, reproducibly from `seed`.
///
/// The cloud is held in memory: a sample larger than the memory available is refused with
/// [`Error::OutOfMemory`] before anything is allocated ([`SurfaceSampler`] streams instead).
pub fn sample_surface(mesh: &TriMesh, n: usize, seed: u64) -> Result<PointCloud> {
    let per_point = size_of::<DVec3>()
        + size_of::<glam::Vec3>()
        + size_of::<SurfaceSample>()
        + mesh.uvs.as_ref().map_or(0, |_| size_of::<Vec2>());
    crate::memory::ensure(
        n as u128 * per_point as u128,
        &format!("sampling {n} points of a mesh"),
    )?;
    let mut sampler = SurfaceSampler::new(mesh, seed)?;
    let mut positions = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    let mut samples = Vec::with_capacity(n);
    let mut uvs = mesh.uvs.as_ref().map(|_| Vec::with_capacity(n));
    for _ in 0..n {
        let sample = sampler.draw();
        let (t, w) = (sample.triangle as usize, sample.barycentric);
        positions.push(sample_position(mesh, &sample));
        normals.push(mesh.face_normal(t).as_vec3());
        samples.push(sample);
        if let (Some(out), Some(mesh_uvs)) = (uvs.as_mut(), mesh.uvs.as_ref()) {
            let [ia, ib, ic] = mesh.triangles[t];
            let uv = mesh_uvs[ia as usize] * w[0] as f32
                + mesh_uvs[ib as usize] * w[1] as f32
                + mesh_uvs[ic as usize] * w[2] as f32;
            out.push(uv);
        }
    }
    Ok(PointCloud {
        positions,
        normals: Some(normals),
        colors: None,
        uvs,
        samples: Some(samples),
        ..PointCloud::default()
    })
}

/// The draws of [`sample_surface`] one at a time, for clouds streamed rather than held: the
/// `k`-th draw of a sampler made with `seed` is the `k`-th point of `sample_surface(mesh, n,
/// seed)` for every `n` > `k`.
pub struct SurfaceSampler<'a> {
    mesh: &'a TriMesh,
    cumulative: Vec<f64>,
    total: f64,
    rng: crate::rng::Rng,
}

impl<'a> SurfaceSampler<'a> {
    /// A sampler of `mesh` (validated; an error when its area is zero).
    pub fn new(mesh: &'a TriMesh, seed: u64) -> Result<Self> {
        mesh.validate()?;
        let mut cumulative = Vec::with_capacity(mesh.triangles.len());
        let mut total = 0.0;
        for t in 0..mesh.triangles.len() {
            total += mesh.area(t);
            cumulative.push(total);
        }
        if !(total > 0.0) {
            return Err(Error::EmptyMesh);
        }
        Ok(Self {
            mesh,
            cumulative,
            total,
            rng: seeded(seed, "sample-surface"),
        })
    }

    /// The next sample: its triangle and barycentric weights.
    pub fn draw(&mut self) -> SurfaceSample {
        let target = self.rng.random::<f64>() * self.total;
        // First triangle whose cumulative area exceeds the target; zero-area triangles are
        // never chosen because their cumulative value equals their predecessor's.
        let t = self
            .cumulative
            .partition_point(|&c| c <= target)
            .min(self.cumulative.len() - 1);
        let r1: f64 = self.rng.random();
        let r2: f64 = self.rng.random();
        let s = r1.sqrt();
        SurfaceSample {
            triangle: t as u32,
            barycentric: [1.0 - s, s * (1.0 - r2), s * r2],
        }
    }

    /// Appends the positions of the next `count` samples to `out`.
    pub fn positions_into(&mut self, count: usize, out: &mut Vec<DVec3>) {
        out.reserve(count);
        for _ in 0..count {
            let sample = self.draw();
            out.push(sample_position(self.mesh, &sample));
        }
    }
}

/// Position of a sample on its mesh (recomputed from the provenance).
pub fn sample_position(mesh: &TriMesh, sample: &SurfaceSample) -> DVec3 {
    let [a, b, c] = mesh.corners(sample.triangle as usize);
    let w = sample.barycentric;
    w[0] * a + w[1] * b + w[2] * c
}

/// Texture coordinate of a sample, if the mesh has texture coordinates.
pub fn sample_uv(mesh: &TriMesh, sample: &SurfaceSample) -> Option<Vec2> {
    let uvs = mesh.uvs.as_ref()?;
    let [a, b, c] = mesh.triangles[sample.triangle as usize];
    let w = sample.barycentric;
    Some(
        uvs[a as usize] * w[0] as f32
            + uvs[b as usize] * w[1] as f32
            + uvs[c as usize] * w[2] as f32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_triangles() -> TriMesh {
        // Triangle 0 has area 0.5, triangle 1 has area 1.5.
        TriMesh::new(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(10.0, 0.0, 0.0),
                DVec3::new(13.0, 0.0, 0.0),
                DVec3::new(10.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        )
        .unwrap()
    }

    #[test]
    fn same_seed_same_points_and_attributes_consistent() {
        let mesh = two_triangles();
        let a = sample_surface(&mesh, 1000, 42).unwrap();
        let b = sample_surface(&mesh, 1000, 42).unwrap();
        let c = sample_surface(&mesh, 1000, 43).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.positions, c.positions);
        a.validate().unwrap();
        for (p, s) in a.positions.iter().zip(a.samples.as_ref().unwrap()) {
            assert!((sample_position(&mesh, s) - *p).length() < 1e-12);
            assert!((s.barycentric.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(s.barycentric.iter().all(|&w| (0.0..=1.0).contains(&w)));
        }
    }

    #[test]
    fn the_sampler_streams_the_same_points() {
        let mesh = two_triangles();
        let whole = sample_surface(&mesh, 1000, 7).unwrap();
        let mut sampler = SurfaceSampler::new(&mesh, 7).unwrap();
        let mut streamed = Vec::new();
        for count in [1, 300, 699] {
            sampler.positions_into(count, &mut streamed);
        }
        assert_eq!(streamed, whole.positions);
        let flat = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], vec![[0, 1, 2]]);
        if let Ok(flat) = flat {
            assert!(SurfaceSampler::new(&flat, 7).is_err());
        }
    }

    #[test]
    fn area_weighting() {
        let mesh = two_triangles();
        let cloud = sample_surface(&mesh, 40_000, 1).unwrap();
        let on_big = cloud
            .samples
            .unwrap()
            .iter()
            .filter(|s| s.triangle == 1)
            .count() as f64
            / 40_000.0;
        // Expected 0.75; the binomial standard deviation is about 0.002.
        assert!((on_big - 0.75).abs() < 0.01, "{on_big}");
    }

    #[test]
    fn zero_area_mesh_is_an_error() {
        let mesh =
            TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], vec![[0, 1, 2]]).unwrap();
        assert!(matches!(
            sample_surface(&mesh, 10, 0),
            Err(Error::EmptyMesh)
        ));
        let empty = TriMesh::default();
        assert!(matches!(
            sample_surface(&empty, 10, 0),
            Err(Error::EmptyMesh)
        ));
    }

    #[test]
    fn a_sample_larger_than_memory_is_refused_before_allocating() {
        let mesh = crate::synth::icosphere(1);
        // 2^44 points of 68 bytes: more than any machine, and than the 2^47 bytes assumed
        // where the limits cannot be read.
        let e = sample_surface(&mesh, 1 << 44, 0).unwrap_err();
        assert!(
            matches!(&e, Error::OutOfMemory { what, .. } if what.contains("17592186044416 points")),
            "{e}"
        );
    }
}
