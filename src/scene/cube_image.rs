//! Cube maps from images, as a program declares them and a scene gives them:
//! `texture Env : cube … = image(…)` with
//!
//! - `image("env.png")`: one image, its layout deduced from its shape
//!   (a horizontal or vertical cross, a strip of six faces, an
//!   equirectangular panorama; [`crate::textures::cube_image`]);
//! - `image("env.png", "hcross")`: the layout named (`hcross`, `vcross`,
//!   `hstrip`, `vstrip`, `equirect`), checked against the shape;
//! - `image("env_{face}.png")`: six face files, `{face}` standing for
//!   `px nx py ny pz nz`; or the six file names, in GL order
//!   (+X −X +Y −Y +Z −Z).
//!
//! What cannot be rendered — an unreadable file, a shape that is no
//! layout, faces not square or not of one size — is a located error of
//! `check` and `compile` ([`diagnose`]); a missing file renders with a
//! stand-in, the procedural sky, with a note ([`cube_image_texture`]).

use std::path::{Path, PathBuf};

use super::bind::{BindError, TextureDecl};
use super::Scene;
use crate::diag::Diagnostic;
use crate::ir::declared::{DeclaredSource, DeclaredTexture, TextureKind};
use crate::span::Span;
use crate::textures::cube_image::{self, CubeImageError, CubeLayout, FACE_NAMES};
use crate::textures::{generators, TexelFormat, Texture, TextureCube};

/// Where a cube map's texels come from.
#[derive(Clone, Debug, PartialEq)]
pub enum CubeImageSource {
    /// One image, in the layout named or the one its shape has.
    File { file: String, layout: Option<CubeLayout> },
    /// Six face files in GL order (+X −X +Y −Y +Z −Z).
    Faces(Vec<String>),
}

/// An `image(…)` a cube declaration cannot use, located.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceProblem {
    pub span: Span,
    pub message: String,
    pub label: String,
    pub help: String,
}

/// The size of the stand-in sky's faces, for a missing image.
pub const STAND_IN_FACE: u32 = 64;

const LAYOUT_HELP: &str = "write one of `hcross` (4:3), `vcross` (3:4), `hstrip` (6:1), `vstrip` (1:6) or `equirect` (2:1), or leave the layout out to deduce it from the image's shape";

/// Whether a declaration's `source` is a call of `image(…)`.
pub fn is_image_call(source: &DeclaredSource) -> bool {
    matches!(source, DeclaredSource::Generator { name, .. } if name == "image")
}

/// Reads the arguments of a cube declaration's `image(…)` call `source`.
pub fn read_source(source: &DeclaredSource) -> Result<CubeImageSource, SourceProblem> {
    let DeclaredSource::Generator { args: items, args_span, .. } = source else {
        return Err(problem(
            source.span(),
            "a cube map's source is not `image(…)`",
            "not image(…)",
            "write `image(\"env.png\")`",
        ));
    };
    let mut files = Vec::with_capacity(items.len());
    for item in items {
        match item.text() {
            Some(s) => files.push(s.to_string()),
            None => {
                return Err(problem(
                    item.span,
                    "an argument of `image` is not a file name in quotes",
                    "not a string",
                    "write the file name in double quotes, such as `image(\"env.png\")`",
                ))
            }
        }
    }
    let pattern = |f: &String| f.contains("{face}");
    match files.as_slice() {
        [file] if pattern(file) => {
            Ok(CubeImageSource::Faces(FACE_NAMES.iter().map(|n| file.replace("{face}", n)).collect()))
        }
        [file] => Ok(CubeImageSource::File { file: file.clone(), layout: None }),
        [file, _] if pattern(file) => Err(problem(items[1].span, "six face files (`{face}`) have no layout", "a layout", "leave the layout out: `image(\"env_{face}.png\")` reads env_px.png … env_nz.png")),
        [file, layout] => match CubeLayout::from_name(layout) {
            Some(l) => Ok(CubeImageSource::File { file: file.clone(), layout: Some(l) }),
            None => Err(problem(items[1].span, format!("`{layout}` is not a cube-map layout"), "unknown layout", LAYOUT_HELP)),
        },
        six if six.len() == 6 => Ok(CubeImageSource::Faces(six.to_vec())),
        _ => Err(problem(*args_span, format!("`image` of a cube map takes one image, an image and its layout, or six face files, not {} arguments", items.len()), "image(file[, layout]) or six files", "write `image(\"env.png\")`, `image(\"env.png\", \"hcross\")`, `image(\"env_{face}.png\")` or six file names in the order +X −X +Y −Y +Z −Z")),
    }
}

fn problem(span: Span, message: impl Into<String>, label: &str, help: &str) -> SourceProblem {
    SourceProblem { span, message: message.into(), label: label.into(), help: help.into() }
}

/// Loads the cube map of `source`, paths resolved by `resolve`.
pub fn load(
    source: &CubeImageSource,
    format: TexelFormat,
    resolve: &dyn Fn(&str) -> PathBuf,
) -> Result<TextureCube, CubeImageError> {
    match source {
        CubeImageSource::File { file, layout } => {
            cube_image::load_cube_image(&resolve(file), *layout, format)
        }
        CubeImageSource::Faces(files) => {
            let paths: Vec<PathBuf> = files.iter().map(|f| resolve(f)).collect();
            let refs: [&Path; 6] = std::array::from_fn(|i| paths[i].as_path());
            cube_image::load_cube_faces(&refs, format)
        }
    }
}

/// The cube map of a declaration `image(…)` (its arguments read into
/// `source`), paths relative to the scene's folder; a missing file
/// becomes the procedural sky ([`generators::sky_cube`]) with a note.
pub fn cube_image_texture(
    d: &TextureDecl,
    scene: &Scene,
    source: &Result<CubeImageSource, String>,
    format: TexelFormat,
    notes: &mut Vec<String>,
) -> Result<Texture, BindError> {
    let error = |message: String| BindError::Texture { name: d.name.clone(), message };
    let source = source.as_ref().map_err(|m| error(m.clone()))?;
    match load(source, format, &|f| scene.resolve_program_file(f)) {
        Ok(cube) => Ok(Texture::Cube(cube)),
        Err(CubeImageError::NotFound { path }) => {
            notes.push(format!(
                "texture `{}`: {path} not found; using a procedural sky stand-in (a cube map of {STAND_IN_FACE}² faces)",
                d.name
            ));
            Ok(Texture::Cube(generators::sky_cube(STAND_IN_FACE, format, generators::STAND_IN_SUN)))
        }
        Err(e) => Err(error(format!("{e}; {}", e.help()))),
    }
}

/// A scene's `File(…)` texture given to a `cube` declaration: the image
/// read as a cube map, its layout deduced from its shape.
pub fn scene_file_as_cube(scene: &Scene, file: &str, format: TexelFormat) -> Result<Texture, String> {
    let source = CubeImageSource::File { file: file.into(), layout: None };
    load(&source, format, &|f| scene.resolve(f)).map(Texture::Cube).map_err(|e| format!("{e}; {}", e.help()))
}

/// The located errors of the cube-map images of the `declared` textures, files
/// found by `resolve`, each at its declaration: arguments `image` cannot
/// take, and images that are there but cannot make a cube map (unreadable,
/// a shape that is no layout, faces not square or not of one size). A
/// missing file is no error here (it renders with a stand-in); a
/// declaration whose every name `replaced` says a scene texture replaces is
/// not read.
pub fn diagnose(
    declared: &[DeclaredTexture],
    resolve: &dyn Fn(&str) -> PathBuf,
    replaced: &dyn Fn(&str) -> bool,
) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    for t in declared {
        let Some(e) = t.source.as_ref().filter(|e| t.kind == TextureKind::Cube && is_image_call(e)) else {
            continue;
        };
        if !t.names.is_empty() && t.names.iter().all(|(n, _)| replaced(n)) {
            continue;
        }
        let declared = t.names.first().map_or(t.kind_span, |(_, span)| *span);
        let source = match read_source(e) {
            Ok(s) => s,
            Err(p) => {
                out.push(
                    Diagnostic::error("bad-generator", p.message, p.span, p.label)
                        .with_label(declared, "this cube map")
                        .with_help(p.help),
                );
                continue;
            }
        };
        match load(&source, TexelFormat::F32, resolve) {
            Ok(_) | Err(CubeImageError::NotFound { .. }) => {}
            Err(err) => out.push(
                Diagnostic::error(
                    "bad-image",
                    format!("this cube map cannot be made: {err}"),
                    e.span(),
                    "the cube map's images",
                )
                .with_label(declared, "declared here")
                .with_help(err.help()),
            ),
        }
    }
    out
}

/// The source a scene's `CubeImage(…)` or `CubeFaces(…)` texture names.
fn scene_source(desc: &super::TextureDesc) -> Result<CubeImageSource, String> {
    match desc {
        super::TextureDesc::CubeImage { path, layout, .. } if path.contains("{face}") => {
            if layout.is_some() {
                return Err("six face files (`{face}` in the path) have no layout; leave `layout` out".into());
            }
            Ok(CubeImageSource::Faces(FACE_NAMES.iter().map(|n| path.replace("{face}", n)).collect()))
        }
        super::TextureDesc::CubeImage { path, layout, .. } => {
            Ok(CubeImageSource::File { file: path.clone(), layout: *layout })
        }
        super::TextureDesc::CubeFaces { faces, .. } if faces.len() == 6 => {
            Ok(CubeImageSource::Faces(faces.clone()))
        }
        super::TextureDesc::CubeFaces { faces, .. } => {
            Err(format!("{} face files; give six, in the order +X −X +Y −Y +Z −Z", faces.len()))
        }
        _ => Err("not a cube map image".into()),
    }
}

/// The files a scene's cube map texture reads (for the scene's check that
/// they exist).
pub fn scene_files(desc: &super::TextureDesc) -> Result<Vec<String>, String> {
    Ok(match scene_source(desc)? {
        CubeImageSource::File { file, .. } => vec![file],
        CubeImageSource::Faces(files) => files,
    })
}

/// A scene's `CubeImage(…)` or `CubeFaces(…)` texture, built.
pub fn scene_cube(scene: &Scene, desc: &super::TextureDesc, format: TexelFormat) -> Result<Texture, String> {
    let source = scene_source(desc)?;
    load(&source, format, &|f| scene.resolve(f)).map(Texture::Cube).map_err(|e| format!("{e}; {}", e.help()))
}
