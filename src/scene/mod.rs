//! Scenes for the renderer, written in RON: meshes
//! (procedural or OBJ) with transforms and materials, a perspective camera
//! with a local or infinite viewer, lights (directional, point, spot with
//! cut-off, exponent and attenuation), named constants of the shading
//! program, and textures — image files or the generators of the papers
//! (Kilgard 2000, Appendices D-F, Heidrich & Seidel 1999, Sections 3.1 and 4.1-4.2, GeForce3 Phong
//! Section 5.2; see [`crate::textures::generators`]).
//!
//! The format, field by field, with a scene to start from, is the
//! repository's `docs/scenes.md`.
//!
//! [`Scene::load`] parses and checks a scene (RON errors carry the path and
//! line:col; references to unknown materials/textures and missing files are
//! named); [`Scene::build`] then creates meshes and textures.

pub mod bind;
pub mod camera;
pub mod cube_image;
pub mod light;
pub mod mesh;
pub mod relevance;
pub mod shadow_volume;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use camera::{Camera, Viewer};
pub use light::{Attenuation, Light};
pub use mesh::{Mesh, MeshError};

use crate::textures::{
    self, generators, CubeBits, NormalMapFormat, TexelFormat, Texture, TextureError, Wrap,
};

/// Why a scene file could not be loaded: each names the file and what to fix.
#[derive(Debug, Error)]
pub enum SceneError {
    #[error("{0}")]
    Io(#[from] crate::io::IoError),
    #[error("{path}:{line}:{col}: {message}\n  help: check the RON syntax and the field names against docs/scenes.md")]
    Syntax { path: String, line: usize, col: usize, message: String },
    #[error("{path}{at}: {what} '{name}' is not defined; {help}")]
    Unknown { path: String, at: String, what: &'static str, name: String, help: String },
    #[error("{path}: {what} refers to '{file}', which does not exist (looked for {resolved}); fix the path, relative to the scene file")]
    MissingFile { path: String, what: String, file: String, resolved: String },
    #[error("{path}: {what}: {message}")]
    Invalid { path: String, what: String, message: String },
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(transparent)]
    Texture(#[from] TextureError),
}

/// A scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Output size in pixels.
    #[serde(default = "default_resolution")]
    pub resolution: (u32, u32),
    pub camera: Camera,
    #[serde(default)]
    pub lights: Vec<Light>,
    #[serde(default)]
    pub ambient: Vec3,
    pub objects: Vec<Object>,
    #[serde(default)]
    pub materials: BTreeMap<String, Material>,
    #[serde(default)]
    pub textures: BTreeMap<String, TextureDesc>,
    /// Values of the program's named constants (1 to 4 components).
    #[serde(default)]
    pub constants: BTreeMap<String, Vec<f32>>,
    /// Where the scene was loaded from (relative paths resolve against its folder).
    #[serde(skip)]
    pub path: PathBuf,
    /// The folder of the program rendered on the scene, when it is a file:
    /// the program's own `image(…)` and `height(…)` files are looked up
    /// there first, then beside the scene ([`Scene::resolve_program_file`]).
    #[serde(skip)]
    pub program_dir: Option<PathBuf>,
}

fn default_resolution() -> (u32, u32) {
    (512, 512)
}

/// A scene object: a mesh, where it is, and its material's name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Object {
    pub mesh: MeshDesc,
    #[serde(default)]
    pub transform: Transform,
    pub material: String,
}

/// Scale, then rotate (Euler XYZ, degrees), then translate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transform {
    #[serde(default)]
    pub translate: Vec3,
    #[serde(default)]
    pub rotate_deg: Vec3,
    #[serde(default = "one")]
    pub scale: Vec3,
}

fn one() -> Vec3 {
    Vec3::ONE
}

impl Default for Transform {
    fn default() -> Transform {
        Transform { translate: Vec3::ZERO, rotate_deg: Vec3::ZERO, scale: Vec3::ONE }
    }
}

impl Transform {
    /// The model matrix: scale, then rotate (Euler XYZ), then translate.
    pub fn matrix(&self) -> Mat4 {
        let r = self.rotate_deg * (std::f32::consts::PI / 180.0);
        Mat4::from_scale_rotation_translation(
            self.scale,
            Quat::from_euler(glam::EulerRot::XYZ, r.x, r.y, r.z),
            self.translate,
        )
    }
}

/// An object's mesh: a built-in shape or an OBJ file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum MeshDesc {
    /// Tessellation by default: 32 slices, 16 stacks.
    Sphere {
        radius: f32,
        #[serde(default = "default_slices")]
        slices: u32,
        #[serde(default = "default_stacks")]
        stacks: u32,
    },
    /// Tessellation by default: 48 rings, 24 sides.
    Torus {
        major: f32,
        minor: f32,
        #[serde(default = "default_rings")]
        rings: u32,
        #[serde(default = "default_sides")]
        sides: u32,
    },
    /// 8 × 8 quads by default (per-vertex terms need vertices).
    Plane {
        size: f32,
        #[serde(default = "default_plane_subdivisions")]
        subdivisions: u32,
    },
    /// 4 × 4 quads a face by default.
    Cube {
        size: f32,
        #[serde(default = "default_cube_subdivisions")]
        subdivisions: u32,
    },
    Obj(String),
}

fn default_slices() -> u32 {
    32
}

fn default_stacks() -> u32 {
    16
}

fn default_rings() -> u32 {
    48
}

fn default_sides() -> u32 {
    24
}

fn default_plane_subdivisions() -> u32 {
    8
}

fn default_cube_subdivisions() -> u32 {
    4
}

/// Material parameters; `textures` binds texture names to roles (e.g.
/// `"normal_map": "bumps"`) that the shading program refers to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    #[serde(default)]
    pub ambient: Vec3,
    #[serde(default)]
    pub diffuse: Vec3,
    #[serde(default)]
    pub specular: Vec3,
    #[serde(default = "default_shininess")]
    pub shininess: f32,
    #[serde(default)]
    pub textures: BTreeMap<String, String>,
}

fn default_shininess() -> f32 {
    32.0
}

/// Where a height field comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum HeightDesc {
    /// A grayscale image.
    File(String),
    /// Procedural golf-ball dimples: `cells` pits per side.
    Dimples { size: u32, cells: u32 },
}

/// A scene texture: a file, or one of the papers' generated tables.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum TextureDesc {
    /// PNG, JPEG or Radiance HDR.
    File {
        path: String,
        #[serde(default = "default_format")]
        format: TexelFormat,
        #[serde(default = "default_wrap")]
        wrap: Wrap,
        #[serde(default)]
        mipmaps: bool,
    },
    /// A cube map from one image: a cross, a strip of six faces or an
    /// equirectangular panorama (`layout`, else deduced from the shape), or
    /// six files where `path` has `{face}` (px nx py ny pz nz); see
    /// [`textures::cube_image`].
    CubeImage {
        path: String,
        #[serde(default)]
        layout: Option<textures::CubeLayout>,
        #[serde(default = "default_format")]
        format: TexelFormat,
    },
    /// A cube map from six face files, in GL order (+X −X +Y −Y +Z −Z).
    CubeFaces {
        faces: Vec<String>,
        #[serde(default = "default_format")]
        format: TexelFormat,
    },
    /// Kilgard 2000, Appendix D.
    NormalizeCube { size: u32, bits: CubeBits },
    /// Kilgard 2000, Appendices E-F.
    NormalMap {
        height: HeightDesc,
        scale: f32,
        #[serde(default = "default_nm_format")]
        format: NormalMapFormat,
    },
    /// Heidrich & Seidel 1999, Section 4.1-4.2, of a procedural sky with a sun in direction `sun`.
    DualParaboloid {
        size: u32,
        sun: Vec3,
        #[serde(default = "default_format")]
        format: TexelFormat,
    },
    /// Heidrich & Seidel 1999, Section 3.1: F(cos θ)·D(cos δ).
    HsFresnelDistribution {
        size: u32,
        roughness: f32,
        index: f32,
        #[serde(default = "default_format")]
        format: TexelFormat,
    },
    /// Heidrich & Seidel 1999, Section 3.1: G(cos α, cos β)/(π cos β), stored divided by `scale`.
    HsGeometry {
        size: u32,
        roughness: f32,
        scale: f32,
        #[serde(default = "default_format")]
        format: TexelFormat,
    },
    /// GeForce3 Phong, Section 5.2: x^exponent.
    ExponentLut {
        size: u32,
        exponent: f32,
        #[serde(default = "default_format")]
        format: TexelFormat,
    },
}

fn default_format() -> TexelFormat {
    TexelFormat::Rgba8
}
fn default_wrap() -> Wrap {
    Wrap::Repeat
}
fn default_nm_format() -> NormalMapFormat {
    NormalMapFormat::Rgba8
}

/// Meshes (in object space, with their object → world matrices) and textures of a scene.
#[derive(Clone, Debug)]
pub struct SceneAssets {
    pub meshes: Vec<(Mesh, Mat4)>,
    pub textures: BTreeMap<String, Texture>,
}

use crate::textures::generators::{MAX_CUBE_FACE, MAX_TABLE_SIDE};

impl SceneAssets {
    /// The centre and radius of the world-space bounding sphere of all
    /// meshes: where light projections aim (Pipeline Grammar's `πl`) and what light
    /// relevance bounds against.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for (mesh, model) in &self.meshes {
            for p in &mesh.positions {
                let w = model.transform_point3(*p);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        if !lo.is_finite() || !hi.is_finite() {
            return (Vec3::ZERO, 1.0);
        }
        ((lo + hi) * 0.5, ((hi - lo) * 0.5).length().max(1e-3))
    }
}

impl Scene {
    /// Reads, parses and checks a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text = crate::io::read_text(path)?;
        Scene::parse(&text, path)
    }

    /// Parses and checks scene text; `path` names it in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
        let display = path.display().to_string();
        let mut scene: Scene = ron::from_str(text).map_err(|e| SceneError::Syntax {
            path: display.clone(),
            line: e.span.start.line,
            col: e.span.start.col,
            message: e.code.to_string(),
        })?;
        scene.path = path.to_path_buf();
        scene.check().map_err(|e| match e {
            SceneError::Unknown { path, what, name, help, .. } => {
                SceneError::Unknown { at: locate_use(text, &name), path, what, name, help }
            }
            other => other,
        })?;
        Ok(scene)
    }

    fn base_dir(&self) -> PathBuf {
        self.path.parent().map(Path::to_path_buf).unwrap_or_default()
    }

    /// A file a program's texture declaration names (`image("brick.png")`),
    /// resolved as an include is: beside the program ([`Scene::program_dir`])
    /// when it is there, else beside the scene. A file in neither is named
    /// beside the program, where a user puts it.
    pub fn resolve_program_file(&self, file: &str) -> PathBuf {
        match &self.program_dir {
            Some(dir) if !Path::new(file).is_absolute() => {
                let beside_program = dir.join(file);
                let beside_scene = self.resolve(file);
                if beside_program.is_file() || !beside_scene.is_file() {
                    beside_program
                } else {
                    beside_scene
                }
            }
            _ => self.resolve(file),
        }
    }

    /// A path in the scene, resolved against the scene's folder.
    pub fn resolve(&self, file: &str) -> PathBuf {
        let p = Path::new(file);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir().join(p)
        }
    }

    fn check(&self) -> Result<(), SceneError> {
        let (w, h) = self.resolution;
        if w == 0 || h == 0 || w > 16384 || h > 16384 {
            return Err(
                self.invalid("resolution".into(), format!("{w}x{h} is not usable; use 1..=16384 per side"))
            );
        }
        if let Some(problem) = self.camera.problem() {
            return Err(self.invalid("camera".into(), problem));
        }
        for (i, light) in self.lights.iter().enumerate() {
            if let Some(problem) = light.problem() {
                return Err(self.invalid(format!("light {i}"), problem));
            }
        }
        self.check_objects()?;
        self.check_materials()?;
        for (name, texture) in &self.textures {
            self.check_texture(name, texture)?;
        }
        for (name, value) in &self.constants {
            if value.is_empty() || value.len() > 4 || value.iter().any(|v| !v.is_finite()) {
                return Err(self.invalid(format!("constant '{name}'"), "needs 1 to 4 finite numbers".into()));
            }
        }
        Ok(())
    }

    /// `what` of this scene file is invalid: `message` says why.
    fn invalid(&self, what: String, message: String) -> SceneError {
        SceneError::Invalid { path: self.path.display().to_string(), what, message }
    }

    /// `file`, named by `what`, exists (relative to the scene file).
    fn file_exists(&self, what: String, file: &str) -> Result<(), SceneError> {
        let resolved = self.resolve(file);
        if resolved.is_file() {
            Ok(())
        } else {
            Err(SceneError::MissingFile {
                path: self.path.display().to_string(),
                what,
                file: file.into(),
                resolved: resolved.display().to_string(),
            })
        }
    }

    /// Every object names a defined material, its mesh file exists and its
    /// transform is finite.
    fn check_objects(&self) -> Result<(), SceneError> {
        for (i, object) in self.objects.iter().enumerate() {
            if !self.materials.contains_key(&object.material) {
                return Err(SceneError::Unknown {
                    path: self.path.display().to_string(),
                    at: String::new(),
                    what: "material",
                    name: object.material.clone(),
                    help: format!(
                        "object {i} uses it; defined materials: [{}]",
                        names(self.materials.keys().collect())
                    ),
                });
            }
            if let MeshDesc::Obj(file) = &object.mesh {
                self.file_exists(format!("object {i}"), file)?;
            }
            let t = &object.transform;
            if !(t.translate.is_finite() && t.rotate_deg.is_finite() && t.scale.is_finite()) {
                return Err(self.invalid(format!("object {i}"), "transform values must be finite".into()));
            }
        }
        Ok(())
    }

    /// Every texture a material binds is defined.
    fn check_materials(&self) -> Result<(), SceneError> {
        for (name, material) in &self.materials {
            for (role, texture) in &material.textures {
                if !self.textures.contains_key(texture) {
                    return Err(SceneError::Unknown {
                        path: self.path.display().to_string(),
                        at: String::new(),
                        what: "texture",
                        name: texture.clone(),
                        help: format!(
                            "material '{name}' binds it as '{role}'; defined textures: [{}]",
                            names(self.textures.keys().collect())
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// A texture's files exist and its generated size is in range.
    fn check_texture(&self, name: &str, texture: &TextureDesc) -> Result<(), SceneError> {
        let what = format!("texture '{name}'");
        let max =
            if matches!(texture, TextureDesc::NormalizeCube { .. }) { MAX_CUBE_FACE } else { MAX_TABLE_SIDE };
        let size_ok = |size: u32| {
            if (1..=max).contains(&size) {
                Ok(())
            } else {
                Err(self.invalid(what.clone(), format!("size {size} is out of range; use 1..={max}")))
            }
        };
        match texture {
            TextureDesc::File { path: file, .. } => self.file_exists(what.clone(), file)?,
            TextureDesc::CubeImage { .. } | TextureDesc::CubeFaces { .. } => {
                for file in cube_image::scene_files(texture).map_err(|m| self.invalid(what.clone(), m))? {
                    self.file_exists(what.clone(), &file)?;
                }
            }
            TextureDesc::NormalMap { height: HeightDesc::File(file), .. } => {
                self.file_exists(what.clone(), file)?
            }
            TextureDesc::NormalMap { height: HeightDesc::Dimples { size, .. }, .. } => size_ok(*size)?,
            TextureDesc::NormalizeCube { size, .. }
            | TextureDesc::DualParaboloid { size, .. }
            | TextureDesc::HsFresnelDistribution { size, .. }
            | TextureDesc::HsGeometry { size, .. }
            | TextureDesc::ExponentLut { size, .. } => size_ok(*size)?,
        }
        Ok(())
    }

    /// Builds the meshes and generates or loads the textures.
    pub fn build(&self) -> Result<SceneAssets, SceneError> {
        let mut meshes = Vec::with_capacity(self.objects.len());
        for object in &self.objects {
            let mesh = match &object.mesh {
                MeshDesc::Sphere { radius, slices, stacks } => Mesh::sphere(*radius, *slices, *stacks)?,
                MeshDesc::Torus { major, minor, rings, sides } => {
                    Mesh::torus(*major, *minor, *rings, *sides)?
                }
                MeshDesc::Plane { size, subdivisions } => Mesh::plane(*size, *subdivisions)?,
                MeshDesc::Cube { size, subdivisions } => Mesh::cube(*size, *subdivisions)?,
                MeshDesc::Obj(file) => Mesh::load_obj(&self.resolve(file))?,
            };
            meshes.push((mesh, object.transform.matrix()));
        }
        let mut built = BTreeMap::new();
        for (name, desc) in &self.textures {
            let texture = match desc {
                TextureDesc::File { path, format, wrap, mipmaps } => {
                    let t = textures::load_image(&self.resolve(path), *format, *wrap)?;
                    Texture::Flat(if *mipmaps { t.with_box_mipmaps() } else { t })
                }
                TextureDesc::CubeImage { format, .. } | TextureDesc::CubeFaces { format, .. } => {
                    cube_image::scene_cube(self, desc, *format).map_err(|message| SceneError::Invalid {
                        path: self.path.display().to_string(),
                        what: format!("texture '{name}'"),
                        message,
                    })?
                }
                TextureDesc::NormalizeCube { size, bits } => {
                    Texture::Cube(generators::normalize_cube(*size, *bits))
                }
                TextureDesc::NormalMap { height, scale, format } => {
                    let hf = match height {
                        HeightDesc::File(file) => textures::load_height_field(&self.resolve(file))?,
                        HeightDesc::Dimples { size, cells } => {
                            generators::HeightField::dimples(*size, *cells)
                        }
                    };
                    Texture::Flat(generators::normal_map(&hf, *scale, *format))
                }
                TextureDesc::DualParaboloid { size, sun, format } => {
                    let sun = sun.to_array();
                    Texture::DualParaboloid(generators::dual_paraboloid(*size, *format, &|d| {
                        generators::sky(d, sun)
                    }))
                }
                TextureDesc::HsFresnelDistribution { size, roughness, index, format } => {
                    Texture::Flat(generators::hs_fresnel_distribution(*size, *roughness, *index, *format))
                }
                TextureDesc::HsGeometry { size, roughness, scale, format } => {
                    Texture::Flat(generators::hs_geometry(*size, *roughness, *scale, *format))
                }
                TextureDesc::ExponentLut { size, exponent, format } => {
                    Texture::Flat(generators::exponent_lut(*size, *exponent, *format))
                }
            };
            built.insert(name.clone(), texture);
        }
        Ok(SceneAssets { meshes, textures: built })
    }
}

/// Defined names, comma-separated, for a help line.
fn names(map: Vec<&String>) -> String {
    map.into_iter().cloned().collect::<Vec<_>>().join(", ")
}

/// `:line:col` of the first use of the undefined `name` in the scene's
/// text: `"name"` not followed by `:` (a use, not a map key); empty when
/// it is not found.
fn locate_use(text: &str, name: &str) -> String {
    let quoted = format!("\"{name}\"");
    let Some((start, _)) =
        text.match_indices(&quoted).find(|(i, q)| !text[i + q.len()..].trim_start().starts_with(':'))
    else {
        return String::new();
    };
    let line = text[..start].matches('\n').count() + 1;
    let col = text[..start].rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!(":{line}:{col}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> String {
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bump_torus.ron")).unwrap()
    }

    /// A misspelt field (`colour`) is a located error naming the fields
    /// the place takes; it was ignored, and the error was the missing
    /// `color` at the end of the light. A sphere's tessellation may be
    /// left out.
    #[test]
    fn an_unknown_field_is_located_and_tessellation_has_defaults() {
        let text = "(camera: (eye: (0, 0, 3), target: (0, 0, 0), up: (0, 1, 0), fov_y_deg: 45),\n lights: [Point(position: (1, 1, 1), colour: (1, 1, 1))])";
        let Err(SceneError::Syntax { line, col, message, .. }) = Scene::parse(text, Path::new("s.ron"))
        else {
            panic!("a misspelt field is an error")
        };
        assert_eq!((line, col), (2, 38), "{message}");
        assert!(message.contains("`colour`") && message.contains("`color`"), "{message}");
        let text = text.replace("colour", "color").replace(
            "])",
            "], objects: [(mesh: Sphere(radius: 0.6), material: \"m\")], materials: {\"m\": ()})",
        );
        let scene = Scene::parse(&text, Path::new("s.ron")).unwrap();
        assert_eq!(scene.objects[0].mesh, MeshDesc::Sphere { radius: 0.6, slices: 32, stacks: 16 });
        // An undefined material is located at its use.
        let text = text.replace("material: \"m\"", "material: \"matte\"");
        let e = Scene::parse(&text, Path::new("s.ron")).unwrap_err().to_string();
        assert!(e.starts_with("s.ron:2:106: material 'matte' is not defined"), "{e}");
    }

    #[test]
    fn example_scene_loads_and_builds() {
        let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bump_torus.ron"));
        let scene = Scene::load(path).unwrap();
        assert_eq!(scene.lights.len(), 1);
        let assets = scene.build().unwrap();
        assert_eq!(assets.meshes.len(), 1);
        let Some(Texture::Flat(nm)) = assets.textures.get("bumps") else { panic!("normal map missing") };
        assert!(nm.levels.len() > 1);
    }

    #[test]
    fn syntax_errors_name_path_line_and_column() {
        let text = example().replacen("camera:", "camera::", 1);
        let err = Scene::parse(&text, Path::new("scenes/x.ron")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("scenes/x.ron:"), "{msg}");
        let SceneError::Syntax { line, col, .. } = err else { panic!("{msg}") };
        assert!(line > 1 && col > 1, "{msg}");
    }

    #[test]
    fn unknown_references_and_missing_files_are_named() {
        let text = example().replacen("material: \"bumpy\"", "material: \"shiny\"", 1);
        let err = Scene::parse(&text, Path::new("s.ron")).unwrap_err().to_string();
        assert!(err.contains("material 'shiny' is not defined") && err.contains("bumpy"), "{err}");

        let text = example().replacen("Torus(", "Obj(\"nowhere/teapot.obj\"), _unused: Torus(", 1);
        let err = Scene::parse(&text, Path::new("s.ron")).unwrap_err().to_string();
        assert!(!err.is_empty());

        let text = example().replacen(
            "mesh: Torus(major: 1.0, minor: 0.35, rings: 64, sides: 32)",
            "mesh: Obj(\"nowhere/teapot.obj\")",
            1,
        );
        let err = Scene::parse(&text, Path::new("/tmp/s.ron")).unwrap_err().to_string();
        assert!(err.contains("nowhere/teapot.obj") && err.contains("/tmp/nowhere/teapot.obj"), "{err}");

        let err = Scene::load(Path::new("/nonexistent/scene.ron")).unwrap_err().to_string();
        assert!(err.contains("/nonexistent/scene.ron"), "{err}");
    }

    #[test]
    fn bad_values_are_errors_not_panics() {
        let text = example().replacen("rings: 64", "rings: 1", 1);
        let scene = Scene::parse(&text, Path::new("s.ron")).unwrap();
        let err = scene.build().unwrap_err().to_string();
        assert!(err.contains("torus rings"), "{err}");
        let text = example().replacen("fov_y_deg: 40.0", "fov_y_deg: 0.0", 1);
        assert!(Scene::parse(&text, Path::new("s.ron")).unwrap_err().to_string().contains("fov_y_deg"));
        assert!(Scene::parse("", Path::new("s.ron")).is_err());
        assert!(Scene::parse("(((((", Path::new("s.ron")).is_err());
    }

    /// Generated textures are bounded before they are built: a cube face by MAX_CUBE_FACE, a 2-D table side by MAX_TABLE_SIDE.
    #[test]
    fn generator_sizes_are_bounded() {
        let text = example().replacen("NormalizeCube(size: 32", "NormalizeCube(size: 100000", 1);
        let err = Scene::parse(&text, Path::new("s.ron")).unwrap_err().to_string();
        assert_eq!(err, "s.ron: texture 'norm_cube': size 100000 is out of range; use 1..=1024");
        let text =
            example().replacen("NormalizeCube(size: 32", &format!("NormalizeCube(size: {MAX_CUBE_FACE}"), 1);
        Scene::parse(&text, Path::new("s.ron")).expect("the limit itself is allowed");
        let text = example().replacen("Dimples(size: 256", "Dimples(size: 4097", 1);
        let err = Scene::parse(&text, Path::new("s.ron")).unwrap_err().to_string();
        assert!(err.ends_with("size 4097 is out of range; use 1..=4096"), "{err}");
    }
}
