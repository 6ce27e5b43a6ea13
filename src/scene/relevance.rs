//! Light relevance geometry shared by the renderer's native Phong stage
//! (`renderer::lights`, per polygon) and the planner's light culling of
//! compiled plans (`planner::relevance`, per object): Adaptive Sample Shading, Section 2.2.
//!
//! - [`Cone`]: a bounding cone of unit directions — Section 2.2.2's
//!   "bounding cone": the axis is the normalized average of the vectors,
//!   the half-angle the largest angle to one of them. Every direction
//!   interpolated between vectors of a cone narrower than a hemisphere lies
//!   in it (a convex combination of vectors in a convex cone stays in it).
//! - [`Cone::max_cos`] / [`Cone::min_cos`]: the extreme dot products of two
//!   unit vectors from two cones (the condition of Section 2.2.2:
//!   cos(θ_cone) against the angle between the axes).
//! - [`light_reach`]: the volume of influence of a light (Section 2.2.3,
//!   Fig. 4) seen from a bounding sphere (centre Pm, radius r_max): the cone
//!   of directions from the sphere to the light (enlarged by the sphere, as
//!   the paper enlarges the volume by the polygon's bounding sphere) and the
//!   largest intensity reaching any point of the sphere — colour ·
//!   attenuation(max(0, |L − Pm| − r_max)) · spot factor, the spot factor
//!   zero when the sphere lies outside the cone of influence
//!   (R_m > r_max + R_inf).
//! - [`shininess_cutoff`]: the implicit cut-off angle of a highlight,
//!   cos α = threshold^(1/n) (Section 2.2.3).

use glam::Vec3;

use super::Light;

/// Angle between two unit vectors.
pub fn angle(a: Vec3, b: Vec3) -> f32 {
    a.dot(b).clamp(-1.0, 1.0).acos()
}

/// Half-angle of the cone of directions from a point at distance `d` to a
/// sphere of radius `r` around it (π when the point is inside).
pub fn sphere_angle(r: f32, d: f32) -> f32 {
    if d <= r {
        std::f32::consts::PI
    } else {
        (r / d).asin()
    }
}

/// A cone of unit directions: `axis` and `half_angle` in radians (π: every
/// direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// The unit direction at the cone's centre.
    pub axis: Vec3,
    /// The angle from the axis to the cone's edge, in radians.
    pub half_angle: f32,
}

impl Cone {
    /// Every direction.
    pub const ALL: Cone = Cone { axis: Vec3::Z, half_angle: std::f32::consts::PI };

    /// One direction.
    pub fn ray(axis: Vec3) -> Cone {
        match axis.try_normalize() {
            Some(a) => Cone { axis: a, half_angle: 0.0 },
            None => Cone::ALL,
        }
    }

    /// The bounding cone of unit directions (Section 2.2.2): axis the
    /// normalized sum, half-angle the largest angle to a direction; a cone
    /// as wide as a hemisphere or wider bounds nothing under interpolation,
    /// so it becomes [`Cone::ALL`].
    pub fn of_directions(dirs: impl IntoIterator<Item = Vec3> + Clone) -> Cone {
        let sum: Vec3 = dirs.clone().into_iter().fold(Vec3::ZERO, |s, d| s + d);
        let Some(axis) = sum.try_normalize() else { return Cone::ALL };
        let theta = dirs.into_iter().map(|d| angle(axis, d.normalize_or_zero())).fold(0.0f32, f32::max);
        if theta < std::f32::consts::FRAC_PI_2 {
            // A little slack for the f32 rounding of the vectors themselves.
            Cone { axis, half_angle: (theta + 1e-4).min(std::f32::consts::PI) }
        } else {
            Cone::ALL
        }
    }

    /// The cone widened by `by` radians.
    pub fn widened(self, by: f32) -> Cone {
        Cone { axis: self.axis, half_angle: (self.half_angle + by).min(std::f32::consts::PI) }
    }

    /// The largest a·b of unit a in `self`, b in `other`:
    /// cos(max(0, ∠(axes) − θa − θb)).
    pub fn max_cos(self, other: Cone) -> f32 {
        (angle(self.axis, other.axis) - self.half_angle - other.half_angle).max(0.0).cos()
    }

    /// The smallest a·b: cos(min(π, ∠(axes) + θa + θb)).
    pub fn min_cos(self, other: Cone) -> f32 {
        (angle(self.axis, other.axis) + self.half_angle + other.half_angle).min(std::f32::consts::PI).cos()
    }
}

/// Why a light's volume of influence misses a sphere (Section 2.2.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outside {
    /// The sphere lies outside the spot's cone of influence.
    SpotCone {
        /// The spot's cut-off angle, in degrees.
        cutoff_deg: f32,
    },
    /// The light's colour is black.
    Black,
}

/// A light seen from a bounding sphere (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reach {
    /// Directions from points of the sphere towards the light.
    pub to_light: Cone,
    /// The largest intensity (colour · attenuation · spot) at any point of the sphere.
    pub max_intensity: Vec3,
    /// The smallest distance from the sphere to the light (0 for a directional light).
    pub min_distance: f32,
    /// Set when the volume of influence misses the sphere entirely.
    pub outside: Option<Outside>,
}

/// The volume of influence of `light` against the sphere (`center`, `radius`).
pub fn light_reach(light: &Light, center: Vec3, radius: f32) -> Reach {
    match *light {
        Light::Directional { direction, color } => Reach {
            to_light: Cone::ray(-direction),
            max_intensity: color,
            min_distance: 0.0,
            outside: (color.max_element() <= 0.0).then_some(Outside::Black),
        },
        Light::Point { position, color, attenuation } => {
            let d = position - center;
            let dist = d.length();
            let min_distance = (dist - radius).max(0.0);
            Reach {
                to_light: Cone { axis: d.normalize_or(Vec3::Z), half_angle: sphere_angle(radius, dist) },
                max_intensity: color * attenuation.factor(min_distance),
                min_distance,
                outside: (color.max_element() <= 0.0).then_some(Outside::Black),
            }
        }
        Light::Spot { position, direction, cutoff_deg, exponent, color, attenuation } => {
            let d = position - center;
            let dist = d.length();
            let theta_l = sphere_angle(radius, dist);
            // Smallest angle between the spot axis and a ray to the sphere.
            let gamma = (angle(direction.normalize_or_zero(), -d.normalize_or_zero()) - theta_l).max(0.0);
            let outside_cone = gamma > cutoff_deg.to_radians();
            let spot = if outside_cone { 0.0 } else { gamma.cos().max(0.0).powf(exponent) };
            let min_distance = (dist - radius).max(0.0);
            Reach {
                to_light: Cone { axis: d.normalize_or(Vec3::Z), half_angle: theta_l },
                max_intensity: color * attenuation.factor(min_distance) * spot,
                min_distance,
                outside: if outside_cone {
                    Some(Outside::SpotCone { cutoff_deg })
                } else {
                    (color.max_element() <= 0.0).then_some(Outside::Black)
                },
            }
        }
    }
}

/// The implicit cut-off angle of a highlight x^n (Section 2.2.3):
/// cos α = (threshold / scale)^(1/n) — beyond α from the highlight's
/// centre, `scale · cos^n` is below `threshold`. `None` when the highlight
/// never falls below it (scale ≤ threshold) or n ≤ 0.
pub fn shininess_cutoff(threshold: f32, scale: f32, n: f32) -> Option<f32> {
    let defined = n > 0.0 && scale > threshold && threshold > 0.0;
    if !defined {
        return None;
    }
    Some((threshold / scale).powf(1.0 / n).clamp(-1.0, 1.0).acos())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Attenuation;

    #[test]
    fn cone_of_directions_holds_them_and_bounds_dots() {
        let dirs = [Vec3::new(0.1, 0.0, 1.0).normalize(), Vec3::new(-0.1, 0.1, 1.0).normalize(), Vec3::Z];
        let c = Cone::of_directions(dirs);
        for d in dirs {
            assert!(angle(c.axis, d) <= c.half_angle);
        }
        let l = Cone::ray(Vec3::new(1.0, 0.0, 1.0));
        for d in dirs {
            let x = d.dot(l.axis);
            assert!(x <= c.max_cos(l) + 1e-6 && x >= c.min_cos(l) - 1e-6);
        }
        // A hemisphere or more bounds nothing.
        assert_eq!(Cone::of_directions([Vec3::X, Vec3::NEG_X, Vec3::Y]).half_angle, std::f32::consts::PI);
    }

    #[test]
    fn spot_volume_of_influence_and_attenuation() {
        let spot = |dir: Vec3| Light::Spot {
            position: Vec3::new(0.0, 2.0, 0.0),
            direction: dir,
            cutoff_deg: 20.0,
            exponent: 0.0,
            color: Vec3::ONE,
            attenuation: Attenuation { constant: 0.0, linear: 0.0, quadratic: 1.0 },
        };
        let away = light_reach(&spot(Vec3::Y), Vec3::ZERO, 0.5);
        assert_eq!(away.outside, Some(Outside::SpotCone { cutoff_deg: 20.0 }));
        assert_eq!(away.max_intensity, Vec3::ZERO);
        let at = light_reach(&spot(Vec3::NEG_Y), Vec3::ZERO, 0.5);
        assert_eq!(at.outside, None);
        assert!((at.max_intensity.x - 1.0 / (1.5 * 1.5)).abs() < 1e-5, "{at:?}");
    }

    #[test]
    fn shininess_cutoff_is_threshold_to_the_one_over_n() {
        let a = shininess_cutoff(0.01, 1.0, 32.0).unwrap();
        assert!((a.cos() - 0.01f32.powf(1.0 / 32.0)).abs() < 1e-6);
        assert!(shininess_cutoff(0.5, 0.25, 8.0).is_none());
    }
}
