//! Lights with the OpenGL 1.x model that the papers assume (Kilgard 2000
//! Section 5.1 handles positional and directional lights; Adaptive Sample Shading, Section 3
//! culls by spot cut-off and volume of influence): directional, point, and
//! spot lights with a cut-off angle and exponent, and distance attenuation
//! 1/(c + l·d + q·d²).

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Constant, linear and quadratic attenuation coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Attenuation {
    pub constant: f32,
    pub linear: f32,
    pub quadratic: f32,
}

impl Default for Attenuation {
    fn default() -> Attenuation {
        Attenuation { constant: 1.0, linear: 0.0, quadratic: 0.0 }
    }
}

impl Attenuation {
    /// GL's distance attenuation 1/(c + l·d + q·d²); 0 where the denominator
    /// is not positive.
    pub fn factor(&self, distance: f32) -> f32 {
        let d = self.constant + self.linear * distance + self.quadratic * distance * distance;
        if d > 0.0 {
            1.0 / d
        } else {
            0.0
        }
    }
}

/// A scene light, as GL's fixed-function lights.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Light {
    /// Light from direction `direction` (pointing *from* the light, as it travels).
    Directional { direction: Vec3, color: Vec3 },
    Point {
        position: Vec3,
        color: Vec3,
        #[serde(default)]
        attenuation: Attenuation,
    },
    /// GL spot: zero outside the cone `cutoff_deg` around `direction`, inside
    /// (cos angle)^exponent.
    Spot {
        position: Vec3,
        direction: Vec3,
        cutoff_deg: f32,
        #[serde(default)]
        exponent: f32,
        color: Vec3,
        #[serde(default)]
        attenuation: Attenuation,
    },
}

/// What a light delivers at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incidence {
    /// Unit vector from the point towards the light (L).
    pub to_light: Vec3,
    /// Colour times attenuation times spot factor.
    pub intensity: Vec3,
}

impl Light {
    /// The light's colour (before attenuation and spot factor).
    pub fn color(&self) -> Vec3 {
        match *self {
            Light::Directional { color, .. } | Light::Point { color, .. } | Light::Spot { color, .. } => {
                color
            }
        }
    }

    /// The light arriving at world point `p`; zero intensity outside a spot cone.
    pub fn incidence(&self, p: Vec3) -> Incidence {
        match *self {
            Light::Directional { direction, color } => {
                Incidence { to_light: (-direction).normalize_or_zero(), intensity: color }
            }
            Light::Point { position, color, attenuation } => {
                let d = position - p;
                Incidence {
                    to_light: d.normalize_or_zero(),
                    intensity: color * attenuation.factor(d.length()),
                }
            }
            Light::Spot { position, direction, cutoff_deg, exponent, color, attenuation } => {
                let d = position - p;
                let l = d.normalize_or_zero();
                Incidence {
                    to_light: l,
                    intensity: color
                        * attenuation.factor(d.length())
                        * spot_factor(l, direction, cutoff_deg, exponent),
                }
            }
        }
    }

    /// Why this light cannot be used, if it cannot.
    pub fn problem(&self) -> Option<String> {
        match *self {
            Light::Directional { direction, color } => {
                if !direction.is_finite() || direction.length_squared() == 0.0 || !color.is_finite() {
                    return Some(
                        "directional light needs a finite, non-zero direction and a finite colour".into(),
                    );
                }
            }
            Light::Point { position, color, attenuation } => {
                if !position.is_finite()
                    || !color.is_finite()
                    || attenuation.factor(0.0) == 0.0
                        && attenuation.linear == 0.0
                        && attenuation.quadratic == 0.0
                {
                    return Some(
                        "point light needs finite values and attenuation coefficients not all zero".into(),
                    );
                }
            }
            Light::Spot { position, direction, cutoff_deg, exponent, color, .. } => {
                if !position.is_finite()
                    || !color.is_finite()
                    || !direction.is_finite()
                    || direction.length_squared() == 0.0
                {
                    return Some("spot light needs finite values and a non-zero direction".into());
                }
                if !(0.0..=90.0).contains(&cutoff_deg) {
                    return Some(
                        "spot cutoff_deg must be in [0, 90] (GL also allows 180 = point light; use Point)"
                            .into(),
                    );
                }
                if !(0.0..=128.0).contains(&exponent) {
                    return Some("spot exponent must be in [0, 128], as in GL".into());
                }
            }
        }
        None
    }
}

/// GL spot factor: with s = (−L)·D̂, zero if s < cos(cutoff), else s^exponent.
pub fn spot_factor(to_light: Vec3, direction: Vec3, cutoff_deg: f32, exponent: f32) -> f32 {
    let s = (-to_light).dot(direction.normalize_or_zero());
    if s < cutoff_deg.to_radians().cos() {
        0.0
    } else {
        s.max(0.0).powf(exponent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_cut_off_and_exponent() {
        let spot = Light::Spot {
            position: Vec3::new(0.0, 2.0, 0.0),
            direction: Vec3::NEG_Y,
            cutoff_deg: 30.0,
            exponent: 2.0,
            color: Vec3::ONE,
            attenuation: Attenuation { constant: 0.0, linear: 0.0, quadratic: 1.0 },
        };
        let below = spot.incidence(Vec3::ZERO);
        assert!((below.intensity - Vec3::splat(0.25)).length() < 1e-6);
        assert_eq!(below.to_light, Vec3::Y);
        // 45° off axis: outside the 30° cone.
        assert_eq!(spot.incidence(Vec3::new(2.0, 0.0, 0.0)).intensity, Vec3::ZERO);
        // 20° off axis: inside, cos²(20°)/d².
        let p = Vec3::new(2.0 * 20f32.to_radians().tan(), 0.0, 0.0);
        let expected = 20f32.to_radians().cos().powi(2) / (Vec3::new(0.0, 2.0, 0.0) - p).length_squared();
        assert!((spot.incidence(p).intensity.x - expected).abs() < 1e-5);
        assert!(spot.problem().is_none());
    }

    #[test]
    fn directional_light_points_back_along_its_direction() {
        let l = Light::Directional { direction: Vec3::new(0.0, -2.0, 0.0), color: Vec3::ONE };
        assert_eq!(l.incidence(Vec3::new(9.0, 9.0, 9.0)).to_light, Vec3::Y);
    }
}
