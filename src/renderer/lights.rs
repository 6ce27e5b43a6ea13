//! Native multi-light Phong shading over a scene's lights — the "full per
//! pixel shading" reference of Adaptive Sample Shading — and the per-polygon light
//! relevance of Adaptive Sample Shading, Section 2.2 that lets it skip light terms.
//!
//! **Shading** (Adaptive Sample Shading, Section 3.3: the OpenGL 1.2 equation with the
//! (m·l) model instead of (n·h)). Per pixel, with N the normalized
//! interpolated normal, V the unit vector to the viewer, L the unit vector
//! to light i and M = 2(N·V)N − V the reflected eye vector:
//!
//! ```text
//! c = ka·A + Σ_i [N·L > 0] · I_i · (kd·(N·L) + ks·max(M·L, 0)^n)
//! ```
//!
//! where I_i is the light's colour times its distance attenuation
//! 1/(c + l·d + q·d²) times the GL spot factor (zero beyond the cut-off,
//! else cos^exponent), A the scene's ambient light. Colours are clamped to
//! [0, 1].
//!
//! **Relevance** (Section 2.2). For each triangle, with Pm the centroid and
//! r_max the radius of the sphere around Pm holding the triangle:
//!
//! - the *normal cone*: axis n_a = normalize(Σ n_j), half-angle θn = the
//!   largest angle to a vertex normal (every interpolated normal lies in it);
//! - the *view cone*: v_a = normalize(E − Pm), θv = asin(r_max/|E − Pm|)
//!   (0 for an infinite viewer);
//! - the *bounding cone of reflected eye vectors* (Section 2.2.2): axis
//!   m_a = 2(n_a·v_a)n_a − v_a. The paper's half-angle is the largest angle
//!   to the vertices' m_j, widened by Δφ; we use θm = 2θn + θv, which is
//!   provably enough (reflecting v about n is a rotation by π about n, so
//!   turning n by φ turns M by at most 2φ, and changing v turns M by the
//!   same angle): every M of every pixel lies in this cone;
//! - the *light cone*: l_a = normalize(L − Pm), θl = asin(r_max/|L − Pm|)
//!   (0 for a directional light; the polygon's bounding sphere enlarges the
//!   volume of influence as in Section 2.2.3, Fig. 4);
//! - the *volume of influence* (Section 2.2.3): the largest intensity is
//!   I_max = colour · attenuation(max(0, |L − Pm| − r_max)) · spot, where the
//!   spot factor is 0 if the angle between the spot axis and Pm − L, less
//!   θl, exceeds the cut-off (the polygon lies outside the cone of
//!   influence, R_m > r_max + R_inf), else cos^exponent of that angle.
//!
//! Then max N·L ≤ cos(max(0, ∠(n_a, l_a) − θn − θl)) and
//! max M·L ≤ cos(max(0, ∠(m_a, l_a) − θm − θl)). A term is skipped when its
//! bound is below `tol = tolerance / (2·#lights)`: the diffuse term when
//! max_c(kd·I_max)·max N·L < tol, the specular one when
//! max_c(ks·I_max)·(max M·L)^n < tol — that is, when the light lies outside
//! the cone m_a widened by the shininess cut-off angle
//! cos α_cutoff = (tol / (ks·I_max))^(1/n) (Section 2.2.3's
//! cos α = threshold^(1/n), with the light and material scale). Since every
//! skipped term is below tol everywhere on its triangle, the culled image
//! differs from the full one by less than `tolerance` in every channel.
//!
//! The per-triangle mask of relevant terms reaches the fragment stage as a
//! flat varying (the mesh is drawn de-indexed); culling is applied to at
//! most [`MAX_CULLED_LIGHTS`] lights, more lights are always evaluated.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Mat3, Mat4, Vec3};

use super::{CullMode, DepthState, Fragment, FragmentResult, FragmentStage, Pass, RenderState, VertexStage};
use crate::scene::relevance::{angle, light_reach, sphere_angle, Cone};
use crate::scene::{Camera, Light, Material, Scene, SceneAssets, Viewer};

/// Lights beyond this many are never culled (the term mask travels as an
/// f32 varying and must stay exact under interpolation).
pub const MAX_CULLED_LIGHTS: usize = 8;

/// World-space positions and normals of one object, de-indexed, with a
/// per-triangle mask of relevant light terms. Varyings: position (3),
/// normal (3), term mask (1).
pub struct LitVertices {
    view_projection: Mat4,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    /// One per triangle: bit 2i = diffuse of light i, bit 2i+1 = specular.
    masks: Vec<u32>,
    triangles: Vec<[u32; 3]>,
}

impl VertexStage for LitVertices {
    fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    fn n_varyings(&self) -> usize {
        7
    }
    fn shade_vertex(&self, index: u32, varyings: &mut [f32]) -> [f32; 4] {
        let i = index as usize;
        let (p, n) = (self.positions[i], self.normals[i]);
        varyings[..3].copy_from_slice(&p.to_array());
        varyings[3..6].copy_from_slice(&n.to_array());
        varyings[6] = self.masks[i / 3] as f32;
        (self.view_projection * p.extend(1.0)).to_array()
    }
}

/// The Phong fragment stage of one material (see the module docs).
pub struct PhongStage {
    lights: Vec<Light>,
    material: Material,
    ambient: Vec3,
    camera: Camera,
    /// Light terms evaluated / skipped by relevance, over all shaded pixels.
    evaluated: AtomicU64,
    skipped: AtomicU64,
}

impl PhongStage {
    /// Shades world point `p` with unit normal `n`, evaluating only the
    /// terms in `mask` (bit 2i diffuse, 2i+1 specular of light i).
    pub fn shade_point(&self, p: Vec3, n: Vec3, mask: u32) -> Vec3 {
        let v = self.camera.view_vector(p);
        let m = 2.0 * n.dot(v) * n - v;
        let mat = &self.material;
        let mut c = mat.ambient * self.ambient;
        for (i, light) in self.lights.iter().enumerate() {
            let bits = term_bits(mask, i);
            if bits == 0 {
                continue;
            }
            let inc = light.incidence(p);
            let ndl = n.dot(inc.to_light);
            if ndl <= 0.0 || inc.intensity == Vec3::ZERO {
                continue;
            }
            if bits & 1 != 0 {
                c += mat.diffuse * inc.intensity * ndl;
            }
            if bits & 2 != 0 {
                let mdl = m.dot(inc.to_light);
                if mdl > 0.0 {
                    c += mat.specular * inc.intensity * mdl.powf(mat.shininess);
                }
            }
        }
        c.clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// The diffuse (bit 0) and specular (bit 1) bits of light `i`; lights past
/// [`MAX_CULLED_LIGHTS`] are always relevant.
fn term_bits(mask: u32, i: usize) -> u32 {
    if i >= MAX_CULLED_LIGHTS {
        3
    } else {
        (mask >> (2 * i)) & 3
    }
}

impl FragmentStage for PhongStage {
    /// Every fragment is lit.
    fn may_discard(&self) -> bool {
        false
    }

    fn shade(&self, _: &Fragment, varyings: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        let p = Vec3::new(varyings[0], varyings[1], varyings[2]);
        let n = Vec3::new(varyings[3], varyings[4], varyings[5]).normalize_or_zero();
        let mask = varyings[6].round() as u32;
        let n_culled = self.lights.len().min(MAX_CULLED_LIGHTS);
        let all = if n_culled == 0 { 0 } else { (1u32 << (2 * n_culled)) - 1 };
        let relevant = (mask & all).count_ones() as u64;
        self.evaluated.fetch_add(relevant + 2 * (self.lights.len() - n_culled) as u64, Ordering::Relaxed);
        self.skipped.fetch_add(2 * n_culled as u64 - relevant, Ordering::Relaxed);
        let c = self.shade_point(p, n, mask);
        *out = [c.x, c.y, c.z, 1.0];
        FragmentResult::Keep
    }
}

/// Per-triangle relevance counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RelevanceStats {
    pub triangles: u64,
    /// Light terms (diffuse and specular per light) over all triangles.
    pub terms: u64,
    /// Terms found irrelevant.
    pub skipped: u64,
}

/// Per-pixel term counts of the draws since the last [`LitScene::take_term_counts`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TermCounts {
    pub evaluated: u64,
    pub skipped: u64,
}

/// A scene ready to draw with [`PhongStage`]s: one pass per object.
pub struct LitScene {
    objects: Vec<(LitVertices, PhongStage)>,
    pub relevance: RelevanceStats,
}

impl LitScene {
    /// Builds every object; with `cull_tolerance = Some(t)`, light terms
    /// whose contribution to a triangle is below t/(2·#lights) everywhere
    /// are skipped (the whole image changes by less than t per channel).
    pub fn new(scene: &Scene, assets: &SceneAssets, cull_tolerance: Option<f32>) -> LitScene {
        let (w, h) = scene.resolution;
        let view_projection = scene.camera.view_projection(w as f32 / h as f32);
        let mut relevance = RelevanceStats::default();
        let mut objects = Vec::with_capacity(scene.objects.len());
        for (object, (mesh, model)) in scene.objects.iter().zip(&assets.meshes) {
            let material = scene.materials.get(&object.material).cloned().unwrap_or(Material {
                ambient: Vec3::splat(0.2),
                diffuse: Vec3::splat(0.8),
                specular: Vec3::ZERO,
                shininess: 1.0,
                textures: Default::default(),
            });
            let normal_matrix = Mat3::from_mat4(*model).inverse().transpose();
            let mut positions = Vec::with_capacity(mesh.triangles.len() * 3);
            let mut normals = Vec::with_capacity(mesh.triangles.len() * 3);
            let mut masks = Vec::with_capacity(mesh.triangles.len());
            for tri in &mesh.triangles {
                let p = tri.map(|i| model.transform_point3(mesh.positions[i as usize]));
                let n = tri.map(|i| (normal_matrix * mesh.normals[i as usize]).normalize_or_zero());
                positions.extend_from_slice(&p);
                normals.extend_from_slice(&n);
                let mask = match cull_tolerance {
                    Some(t) => triangle_relevance(&p, &n, &scene.lights, &material, &scene.camera, t),
                    None => u32::MAX,
                };
                let n_culled = scene.lights.len().min(MAX_CULLED_LIGHTS);
                let all = if n_culled == 0 { 0 } else { (1u32 << (2 * n_culled)) - 1 };
                relevance.triangles += 1;
                relevance.terms += 2 * scene.lights.len() as u64;
                relevance.skipped += (all & !mask).count_ones() as u64;
                masks.push(mask & all);
            }
            let triangles = (0..masks.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
            let vertices = LitVertices { view_projection, positions, normals, masks, triangles };
            let stage = PhongStage {
                lights: scene.lights.clone(),
                material,
                ambient: scene.ambient,
                camera: scene.camera,
                evaluated: AtomicU64::new(0),
                skipped: AtomicU64::new(0),
            };
            objects.push((vertices, stage));
        }
        LitScene { objects, relevance }
    }

    /// One opaque pass per object: back-face culling, depth `Less` with write.
    pub fn passes(&self) -> Vec<Pass<'_>> {
        self.objects
            .iter()
            .map(|(v, f)| Pass {
                triangles: &v.triangles,
                vertex: v,
                fragment: f,
                state: RenderState {
                    cull: CullMode::Back,
                    depth: DepthState::LESS_WRITE,
                    ..RenderState::default()
                },
            })
            .collect()
    }

    /// Full per-pixel shading: every pass through [`super::draw`].
    pub fn draw_full(&self, target: &mut super::Framebuffer) -> Result<super::DrawStats, super::RenderError> {
        let mut total = super::DrawStats::default();
        for pass in self.passes() {
            let s = super::draw(target, &pass)?;
            total.fragments += s.fragments;
            total.shaded += s.shaded;
            total.written += s.written;
        }
        Ok(total)
    }

    /// Adaptive sample shading of all passes (see [`super::adaptive`]).
    pub fn draw_adaptive(
        &self,
        target: &mut super::Framebuffer,
        settings: &super::AdaptiveSettings,
    ) -> Result<super::AdaptiveStats, super::RenderError> {
        super::draw_adaptive(target, &self.passes(), settings)
    }

    /// Per-pixel light-term counts since the last call, and resets them.
    pub fn take_term_counts(&self) -> TermCounts {
        let mut c = TermCounts::default();
        for (_, stage) in &self.objects {
            c.evaluated += stage.evaluated.swap(0, Ordering::Relaxed);
            c.skipped += stage.skipped.swap(0, Ordering::Relaxed);
        }
        c
    }
}

/// The mask of relevant terms of one triangle (module docs, Section 2.2);
/// the cones and the volume of influence are [`crate::scene::relevance`]'s.
pub fn triangle_relevance(
    p: &[Vec3; 3],
    n: &[Vec3; 3],
    lights: &[Light],
    mat: &Material,
    camera: &Camera,
    tolerance: f32,
) -> u32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let pm = (p[0] + p[1] + p[2]) / 3.0;
    let r_max = p.iter().map(|q| (*q - pm).length()).fold(0.0f32, f32::max) * (1.0 + 1e-5) + 1e-6;
    let n_sum = n[0] + n[1] + n[2];
    let (n_a, theta_n) = match n_sum.try_normalize() {
        Some(a) => {
            let t = n.iter().map(|q| angle(a, *q)).fold(0.0f32, f32::max);
            (a, if t < FRAC_PI_2 { t } else { PI })
        }
        None => (Vec3::Z, PI),
    };
    let (v_a, theta_v) = match camera.viewer {
        Viewer::Local => {
            let d = camera.eye - pm;
            (d.normalize_or_zero(), sphere_angle(r_max, d.length()))
        }
        Viewer::Infinite => ((camera.eye - camera.target).normalize_or_zero(), 0.0),
    };
    let m_a = (2.0 * n_a.dot(v_a) * n_a - v_a).normalize_or_zero();
    let theta_m = (2.0 * theta_n + theta_v).min(PI);
    let normals = Cone { axis: n_a, half_angle: theta_n };
    let reflected = Cone { axis: m_a, half_angle: theta_m };
    let tol = tolerance / (2.0 * lights.len().max(1) as f32);
    let mut mask = 0u32;
    for (i, light) in lights.iter().enumerate().take(MAX_CULLED_LIGHTS) {
        let reach = light_reach(light, pm, r_max);
        let max_ndl = normals.max_cos(reach.to_light).max(0.0);
        let max_mdl = reflected.max_cos(reach.to_light).max(0.0);
        let diffuse = (mat.diffuse * reach.max_intensity).max_element() * max_ndl;
        let specular = if max_ndl > 0.0 {
            (mat.specular * reach.max_intensity).max_element() * max_mdl.powf(mat.shininess)
        } else {
            0.0
        };
        // NaN counts as relevant: only a bound known to be small culls.
        if diffuse.is_nan() || diffuse >= tol {
            mask |= 1 << (2 * i);
        }
        if specular.is_nan() || specular >= tol {
            mask |= 2 << (2 * i);
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Attenuation;

    fn camera() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 40.0,
            near: 0.1,
            far: 50.0,
            viewer: Viewer::Local,
        }
    }

    fn shiny() -> Material {
        Material {
            ambient: Vec3::ZERO,
            diffuse: Vec3::splat(0.5),
            specular: Vec3::splat(0.5),
            shininess: 50.0,
            textures: Default::default(),
        }
    }

    #[test]
    fn spot_pointing_away_is_irrelevant_and_one_above_is_relevant() {
        let p = [Vec3::new(-0.1, -0.1, 0.0), Vec3::new(0.1, -0.1, 0.0), Vec3::new(0.0, 0.1, 0.0)];
        let n = [Vec3::Z; 3];
        let spot = |dir: Vec3| Light::Spot {
            position: Vec3::new(0.0, 0.0, 2.0),
            direction: dir,
            cutoff_deg: 20.0,
            exponent: 2.0,
            color: Vec3::ONE,
            attenuation: Attenuation::default(),
        };
        let away = triangle_relevance(&p, &n, &[spot(Vec3::Z)], &shiny(), &camera(), 0.01);
        assert_eq!(away, 0);
        let at = triangle_relevance(&p, &n, &[spot(Vec3::NEG_Z)], &shiny(), &camera(), 0.01);
        assert_eq!(at, 3, "diffuse and specular: the light is right above, the eye too");
    }

    #[test]
    fn light_behind_the_polygon_is_irrelevant() {
        let p = [Vec3::new(-0.1, -0.1, 0.0), Vec3::new(0.1, -0.1, 0.0), Vec3::new(0.0, 0.1, 0.0)];
        let n = [Vec3::Z; 3];
        let l = Light::Directional { direction: Vec3::Z, color: Vec3::ONE };
        assert_eq!(triangle_relevance(&p, &n, &[l], &shiny(), &camera(), 0.01), 0);
        // Grazing from the side: diffuse relevant, the highlight (towards the eye) is not.
        let l = Light::Directional { direction: Vec3::new(-1.0, 0.0, -0.3), color: Vec3::ONE };
        assert_eq!(triangle_relevance(&p, &n, &[l], &shiny(), &camera(), 0.01), 1);
    }
}
