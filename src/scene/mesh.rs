//! Triangle meshes with per-vertex positions, normals, tangents and texture
//! coordinates: procedural sphere, torus, plane and cube at a chosen
//! tessellation, and Wavefront OBJ files (tobj). Procedural surfaces take
//! their tangents from the parameterization; other meshes derive them from
//! the texture coordinates (Kilgard 2000, Section 5.1), orthonormalized against
//! the normal, with the binormal B = N × T and a handedness sign in `w`.

use std::f32::consts::{PI, TAU};
use std::path::Path;

use glam::{Vec2, Vec3, Vec4};
use thiserror::Error;

/// Why a mesh could not be loaded.
#[derive(Debug, Error)]
pub enum MeshError {
    #[error("{path}: OBJ file not found; check the path (relative paths are relative to the scene file)")]
    NotFound { path: String },
    #[error("{path}: cannot load OBJ: {message}")]
    Obj { path: String, message: String },
    #[error("{path}: the OBJ file has no triangles")]
    Empty { path: String },
    #[error("{what}: tessellation {value} is out of range; use {min}..={max}")]
    Tessellation { what: &'static str, value: u32, min: u32, max: u32 },
}

/// A triangle mesh. All per-vertex arrays have the same length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Unit tangent in xyz (orthogonal to the normal); w = ±1 so that the
    /// binormal is B = w · (N × T).
    pub tangents: Vec<Vec4>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
}

fn check(what: &'static str, value: u32, min: u32, max: u32) -> Result<(), MeshError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(MeshError::Tessellation { what, value, min, max })
    }
}

/// Index of grid vertex (i, j) in a (n+1)-wide grid.
fn grid_triangles(nu: u32, nv: u32, tris: &mut Vec<[u32; 3]>, base: u32) {
    for j in 0..nv {
        for i in 0..nu {
            let a = base + j * (nu + 1) + i;
            let b = a + nu + 1;
            // Counter-clockwise seen from outside when u runs with the tangent and v with the binormal.
            tris.push([a, a + 1, b + 1]);
            tris.push([a, b + 1, b]);
        }
    }
}

impl Mesh {
    /// UV sphere: u around the y axis, v from the south pole to the north pole.
    pub fn sphere(radius: f32, slices: u32, stacks: u32) -> Result<Mesh, MeshError> {
        check("sphere slices", slices, 3, 4096)?;
        check("sphere stacks", stacks, 2, 4096)?;
        let mut m = Mesh::default();
        for j in 0..=stacks {
            let v = j as f32 / stacks as f32;
            let phi = PI * (v - 0.5); // latitude
            for i in 0..=slices {
                let u = i as f32 / slices as f32;
                let theta = TAU * u;
                let n = Vec3::new(phi.cos() * theta.cos(), phi.sin(), -phi.cos() * theta.sin());
                m.positions.push(n * radius);
                m.normals.push(n);
                // ∂P/∂θ direction; at the poles use the limit.
                m.tangents.push(Vec3::new(-theta.sin(), 0.0, -theta.cos()).extend(1.0));
                m.uvs.push(Vec2::new(u, v));
            }
        }
        grid_triangles(slices, stacks, &mut m.triangles, 0);
        m.drop_degenerate();
        Ok(m)
    }

    /// Torus around the y axis: ring radius `major`, tube radius `minor`.
    /// u runs around the ring (`rings` segments), v around the tube (`sides`).
    pub fn torus(major: f32, minor: f32, rings: u32, sides: u32) -> Result<Mesh, MeshError> {
        check("torus rings", rings, 3, 4096)?;
        check("torus sides", sides, 3, 4096)?;
        let mut m = Mesh::default();
        for j in 0..=sides {
            let v = j as f32 / sides as f32;
            let phi = TAU * v;
            for i in 0..=rings {
                let u = i as f32 / rings as f32;
                let theta = TAU * u;
                let ring = Vec3::new(theta.cos(), 0.0, -theta.sin());
                let n = ring * phi.cos() + Vec3::Y * phi.sin();
                m.positions.push(ring * major + n * minor);
                m.normals.push(n);
                m.tangents.push(Vec3::new(-theta.sin(), 0.0, -theta.cos()).extend(1.0));
                m.uvs.push(Vec2::new(u, v));
            }
        }
        grid_triangles(rings, sides, &mut m.triangles, 0);
        Ok(m)
    }

    /// A square in the xz plane facing +y, `size` wide, `subdivisions`² quads.
    pub fn plane(size: f32, subdivisions: u32) -> Result<Mesh, MeshError> {
        check("plane subdivisions", subdivisions, 1, 4096)?;
        let mut m = Mesh::default();
        m.add_face(Vec3::Y, Vec3::X, Vec3::NEG_Z, size, subdivisions);
        Ok(m)
    }

    /// An axis-aligned cube of edge `size`, each face `subdivisions`² quads,
    /// with flat normals (24+ vertices: faces do not share vertices).
    pub fn cube(size: f32, subdivisions: u32) -> Result<Mesh, MeshError> {
        check("cube subdivisions", subdivisions, 1, 1024)?;
        let mut m = Mesh::default();
        for (n, t) in [
            (Vec3::X, Vec3::NEG_Z),
            (Vec3::NEG_X, Vec3::Z),
            (Vec3::Y, Vec3::X),
            (Vec3::NEG_Y, Vec3::X),
            (Vec3::Z, Vec3::X),
            (Vec3::NEG_Z, Vec3::NEG_X),
        ] {
            let b = n.cross(t);
            let base = m.positions.len();
            m.add_face(n, t, b, size, subdivisions);
            for p in &mut m.positions[base..] {
                *p += n * size * 0.5;
            }
        }
        Ok(m)
    }

    /// A square grid centred at the origin spanned by t (u) and b (v), facing n = t × b.
    fn add_face(&mut self, n: Vec3, t: Vec3, b: Vec3, size: f32, k: u32) {
        let base = self.positions.len() as u32;
        for j in 0..=k {
            for i in 0..=k {
                let (u, v) = (i as f32 / k as f32, j as f32 / k as f32);
                self.positions.push(t * (u - 0.5) * size + b * (v - 0.5) * size);
                self.normals.push(n);
                self.tangents.push(t.extend(1.0));
                self.uvs.push(Vec2::new(u, v));
            }
        }
        grid_triangles(k, k, &mut self.triangles, base);
    }

    /// Loads every model of an OBJ file into one mesh (triangulated, single
    /// index). Missing normals are computed (area-weighted), missing texture
    /// coordinates are zero, and tangents are derived from the UVs.
    pub fn load_obj(path: &Path) -> Result<Mesh, MeshError> {
        let display = path.display().to_string();
        if !path.is_file() {
            return Err(MeshError::NotFound { path: display });
        }
        let options = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
        let (models, _) = tobj::load_obj(path, &options)
            .map_err(|e| MeshError::Obj { path: display.clone(), message: e.to_string() })?;
        let mut m = Mesh::default();
        let mut have_normals = true;
        for model in &models {
            let mesh = &model.mesh;
            let base = m.positions.len() as u32;
            let n = mesh.positions.len() / 3;
            for k in 0..n {
                m.positions.push(Vec3::from_slice(&mesh.positions[3 * k..3 * k + 3]));
                if mesh.normals.len() == mesh.positions.len() {
                    m.normals.push(Vec3::from_slice(&mesh.normals[3 * k..3 * k + 3]).normalize_or_zero());
                } else {
                    have_normals = false;
                    m.normals.push(Vec3::ZERO);
                }
                m.uvs.push(if mesh.texcoords.len() >= 2 * n {
                    Vec2::from_slice(&mesh.texcoords[2 * k..2 * k + 2])
                } else {
                    Vec2::ZERO
                });
            }
            for tri in mesh.indices.chunks_exact(3) {
                if tri.iter().all(|&i| (i as usize) < n) {
                    m.triangles.push([base + tri[0], base + tri[1], base + tri[2]]);
                }
            }
        }
        if m.triangles.is_empty() {
            return Err(MeshError::Empty { path: display });
        }
        if !have_normals {
            m.compute_normals();
        }
        m.compute_tangents();
        Ok(m)
    }

    /// Removes triangles of (nearly) zero area, such as those touching the
    /// collapsed pole rows of a UV sphere.
    fn drop_degenerate(&mut self) {
        let positions = &self.positions;
        self.triangles.retain(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let longest =
                (b - a).length_squared().max((c - a).length_squared()).max((c - b).length_squared());
            (b - a).cross(c - a).length_squared() > 1e-8 * longest * longest
        });
    }

    /// Area-weighted vertex normals; vertices of zero-area triangles only get +z.
    pub fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            if n.is_finite() {
                for &i in t {
                    acc[i as usize] += n;
                }
            }
        }
        self.normals = acc.into_iter().map(|n| n.try_normalize().unwrap_or(Vec3::Z)).collect();
    }

    /// Tangents from texture coordinates (Kilgard 2000, Section 5.1): per triangle
    /// T = ∂P/∂u and B_uv = ∂P/∂v from the UV gradients, summed per vertex,
    /// then Gram-Schmidt against N; w is the sign of (N × T)·B_uv. Where the UVs
    /// are degenerate, any unit vector orthogonal to N is used.
    pub fn compute_tangents(&mut self) {
        let n_vertices = self.positions.len();
        let mut tan = vec![Vec3::ZERO; n_vertices];
        let mut bin = vec![Vec3::ZERO; n_vertices];
        for t in &self.triangles {
            let [i0, i1, i2] = t.map(|i| i as usize);
            let (e1, e2) = (self.positions[i1] - self.positions[i0], self.positions[i2] - self.positions[i0]);
            let (d1, d2) = (self.uvs[i1] - self.uvs[i0], self.uvs[i2] - self.uvs[i0]);
            let det = d1.x * d2.y - d2.x * d1.y;
            if det.abs() < 1e-12 || !det.is_finite() {
                continue;
            }
            let r = 1.0 / det;
            let sdir = (e1 * d2.y - e2 * d1.y) * r;
            let tdir = (e2 * d1.x - e1 * d2.x) * r;
            if !(sdir.is_finite() && tdir.is_finite()) {
                continue;
            }
            for i in [i0, i1, i2] {
                tan[i] += sdir;
                bin[i] += tdir;
            }
        }
        self.tangents = (0..n_vertices)
            .map(|i| {
                let n = self.normals[i].try_normalize().unwrap_or(Vec3::Z);
                let t = tan[i] - n * n.dot(tan[i]);
                let t = t.try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
                let w = if n.cross(t).dot(bin[i]) < 0.0 { -1.0 } else { 1.0 };
                t.extend(w)
            })
            .collect();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_frames_orthonormal(m: &Mesh) {
        assert_eq!(m.positions.len(), m.normals.len());
        assert_eq!(m.positions.len(), m.tangents.len());
        for (n, t) in m.normals.iter().zip(&m.tangents) {
            let t3 = t.truncate();
            assert!((n.length() - 1.0).abs() < 1e-4, "normal {n}");
            assert!((t3.length() - 1.0).abs() < 1e-4, "tangent {t}");
            assert!(n.dot(t3).abs() < 1e-4, "N·T = {}", n.dot(t3));
            assert!(t.w == 1.0 || t.w == -1.0);
        }
    }

    #[test]
    fn procedural_meshes_have_orthonormal_frames_and_outward_ccw_faces() {
        for m in [
            Mesh::sphere(1.0, 16, 8).unwrap(),
            Mesh::torus(1.0, 0.3, 24, 12).unwrap(),
            Mesh::plane(2.0, 4).unwrap(),
            Mesh::cube(2.0, 2).unwrap(),
        ] {
            assert_frames_orthonormal(&m);
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let face = (b - a).cross(c - a);
                let n = m.normals[t[0] as usize] + m.normals[t[1] as usize] + m.normals[t[2] as usize];
                assert!(face.dot(n) > 0.0, "triangle {t:?} winds against its normals");
            }
        }
        assert_eq!(Mesh::cube(1.0, 1).unwrap().triangles.len(), 12);
    }

    #[test]
    fn tangents_from_uvs_follow_the_u_direction() {
        for mut m in [
            Mesh::torus(1.0, 0.3, 24, 12).unwrap(),
            Mesh::sphere(1.0, 16, 8).unwrap(),
            Mesh::cube(1.0, 1).unwrap(),
        ] {
            let analytic = m.tangents.clone();
            m.compute_tangents();
            assert_frames_orthonormal(&m);
            // Away from poles and seams, the UV tangent matches the parametric one.
            let agree = analytic
                .iter()
                .zip(&m.tangents)
                .filter(|(a, b)| a.truncate().dot(b.truncate()) > 0.95)
                .count();
            assert!(agree as f32 > 0.8 * analytic.len() as f32, "{agree} of {}", analytic.len());
        }
    }

    #[test]
    fn bad_tessellation_is_an_error() {
        assert!(matches!(Mesh::sphere(1.0, 2, 8), Err(MeshError::Tessellation { .. })));
        assert!(Mesh::torus(1.0, 0.2, 100_000, 3).is_err());
    }

    #[test]
    fn obj_loading_computes_normals_and_tangents() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("quad.obj");
        std::fs::write(
            &path,
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
        )
        .unwrap();
        let m = Mesh::load_obj(&path).unwrap();
        assert_eq!(m.triangles.len(), 2);
        assert_frames_orthonormal(&m);
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
        assert!(m.tangents.iter().all(|t| (t.truncate() - Vec3::X).length() < 1e-6 && t.w == 1.0));
        let err = Mesh::load_obj(&dir.path().join("missing.obj")).unwrap_err();
        assert!(err.to_string().contains("missing.obj"));
        let empty = dir.path().join("empty.obj");
        std::fs::write(&empty, "# nothing\n").unwrap();
        assert!(Mesh::load_obj(&empty).is_err());
    }
}
