//! The camera: a perspective projection with GL conventions (clip z in
//! [−w, w], right-handed eye space looking down −z) and the viewer model of
//! Kilgard 2000, Section 5.1: a local viewer (V from the eye position per vertex)
//! or an infinite viewer (one constant V).

use glam::{Mat4, Vec3, Vec4};
use serde::{Deserialize, Serialize};

/// How the view vector V is computed for lighting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Viewer {
    /// V = normalize(eye − p) at every point.
    #[default]
    Local,
    /// V = −(viewing direction), the same everywhere (GL's default light model).
    Infinite,
}

/// A perspective camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Vertical field of view in degrees.
    #[serde(default = "default_fov")]
    pub fov_y_deg: f32,
    #[serde(default = "default_near")]
    pub near: f32,
    #[serde(default = "default_far")]
    pub far: f32,
    #[serde(default)]
    pub viewer: Viewer,
}

fn default_up() -> Vec3 {
    Vec3::Y
}
fn default_fov() -> f32 {
    45.0
}
fn default_near() -> f32 {
    0.1
}
fn default_far() -> f32 {
    100.0
}

impl Camera {
    /// The view matrix (`gluLookAt`).
    pub fn view(&self) -> Mat4 {
        look_at(self.eye, self.target, self.up)
    }
    /// The projection matrix (`gluPerspective`, GL's clip z in [−1, 1]).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        perspective_gl(self.fov_y_deg.to_radians(), aspect, self.near, self.far)
    }
    /// projection · view.
    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }
    /// The unit vector from world point `p` towards the viewer.
    pub fn view_vector(&self, p: Vec3) -> Vec3 {
        match self.viewer {
            Viewer::Local => (self.eye - p).normalize_or_zero(),
            Viewer::Infinite => (self.eye - self.target).normalize_or_zero(),
        }
    }
    /// Why this camera cannot be used, if it cannot.
    pub fn problem(&self) -> Option<String> {
        let finite = self.eye.is_finite() && self.target.is_finite() && self.up.is_finite();
        if !finite || !self.fov_y_deg.is_finite() || !self.near.is_finite() || !self.far.is_finite() {
            return Some("camera values must be finite numbers".into());
        }
        if (self.target - self.eye).length_squared() == 0.0 {
            return Some("camera eye and target coincide; move the target".into());
        }
        if (self.target - self.eye).cross(self.up).length_squared() < 1e-12 {
            return Some("camera up is parallel to the viewing direction; choose another up".into());
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return Some("fov_y_deg must be between 0 and 180".into());
        }
        if !(self.near > 0.0 && self.far > self.near) {
            return Some("need 0 < near < far".into());
        }
        None
    }
}

/// gluPerspective: maps eye z ∈ [−near, −far] to NDC z ∈ [−1, 1].
pub fn perspective_gl(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    Mat4::from_cols(
        Vec4::new(f / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, (far + near) / (near - far), -1.0),
        Vec4::new(0.0, 0.0, 2.0 * far * near / (near - far), 0.0),
    )
}

/// gluLookAt: right-handed view matrix.
pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let f = (target - eye).normalize_or_zero();
    let s = f.cross(up).normalize_or_zero();
    let u = s.cross(f);
    Mat4::from_cols(
        Vec4::new(s.x, u.x, -f.x, 0.0),
        Vec4::new(s.y, u.y, -f.y, 0.0),
        Vec4::new(s.z, u.z, -f.z, 0.0),
        Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_maps_near_and_far_planes() {
        let p = perspective_gl(1.0, 1.5, 0.5, 20.0);
        let near = p * Vec4::new(0.0, 0.0, -0.5, 1.0);
        let far = p * Vec4::new(0.0, 0.0, -20.0, 1.0);
        assert!((near.z / near.w + 1.0).abs() < 1e-6);
        assert!((far.z / far.w - 1.0).abs() < 1e-5);
        let v = look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, 2.0, -5.0), Vec3::Y);
        let q = v * Vec4::new(1.0, 2.0, -1.0, 1.0);
        assert!((q - Vec4::new(0.0, 0.0, -4.0, 1.0)).length() < 1e-6);
    }

    #[test]
    fn viewer_models() {
        let mut c = Camera {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 45.0,
            near: 0.1,
            far: 10.0,
            viewer: Viewer::Local,
        };
        assert!(
            (c.view_vector(Vec3::new(5.0, 0.0, 0.0)) - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6
        );
        c.viewer = Viewer::Infinite;
        assert_eq!(c.view_vector(Vec3::new(5.0, 0.0, 0.0)), Vec3::Z);
        assert!(c.problem().is_none());
        c.up = Vec3::Z;
        assert!(c.problem().unwrap().contains("parallel"));
    }
}
