//! `shadec emulate`: run a register-combiner setup (`!!RC1.0` or RON) on
//! images with the CPU emulator (Kilgard 2000, Section 4.2), as a user porting
//! legacy content would.
//!
//! Exit codes: 0 ok, 1 the config is malformed or invalid, 2 usage or I/O
//! errors (missing file, images of different sizes, unwritable output).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use shadec::backends::combiners::emulator::{emulate, Inputs};
use shadec::backends::combiners::ts1::{self, TextureShader};
use shadec::backends::combiners::{rc1, validate, Color, CombinerConfig, CombinerLimits};
use shadec::diag::SourceFile;
use shadec::numerics::Precision;

/// The combiner limits of a profile (built-in name or `.ron` file): a
/// setup is checked against the machine the user names, never a copy of
/// its numbers (limits come only from profiles).
pub(super) fn profile_limits(name: &str) -> Result<CombinerLimits, Failure> {
    let profile = shadec::profile::Profile::resolve(name).map_err(|e| Failure::Io(e.to_string()))?;
    profile.combiner_limits().ok_or_else(|| {
        Failure::Io(format!(
            "profile `{}` has no register combiners; give `geforce256`, `geforce3` or a `.ron` profile whose fragment stage is `Combiners`",
            profile.name
        ))
    })
}

// The arguments of `shadec emulate` (its help is the variant's, in args.rs).
#[derive(Clone, Debug, clap::Args)]
pub struct EmulateArgs {
    /// The combiner setup: an nvparse `!!RC1.0` program, or `.ron` for a CombinerConfig.
    pub config: PathBuf,
    /// Texture unit 0 (RGBA8 PNG): the texture register per pixel, or, with a
    /// texture shader, the unit's texture image (a cube map: six square
    /// faces stacked +X −X +Y −Y +Z −Z; a 3-D texture: square slices stacked).
    #[arg(long, value_name = "PNG")]
    pub tex0: Option<PathBuf>,
    /// Texture unit 1 (RGBA8 PNG), as --tex0.
    #[arg(long, value_name = "PNG")]
    pub tex1: Option<PathBuf>,
    /// Texture unit 2 (RGBA8 PNG), as --tex0 (geforce3: four units).
    #[arg(long, value_name = "PNG")]
    pub tex2: Option<PathBuf>,
    /// Texture unit 3 (RGBA8 PNG), as --tex0 (geforce3: four units).
    #[arg(long, value_name = "PNG")]
    pub tex3: Option<PathBuf>,
    /// Interpolated primary (diffuse) colour per pixel (RGBA8 PNG).
    #[arg(long, value_name = "PNG")]
    pub primary: Option<PathBuf>,
    /// Interpolated secondary (specular) colour per pixel (RGBA8 PNG).
    #[arg(long, value_name = "PNG")]
    pub secondary: Option<PathBuf>,
    /// Constant colour 0 as r,g,b,a in [0, 1] (the program's own `const0` wins).
    #[arg(long, value_name = "R,G,B,A", value_parser = parse_color)]
    pub const0: Option<Color>,
    /// Constant colour 1 as r,g,b,a in [0, 1] (the program's own `const1` wins).
    #[arg(long, value_name = "R,G,B,A", value_parser = parse_color)]
    pub const1: Option<Color>,
    /// Fog colour (r,g,b) and fog factor (a), each in [0, 1].
    #[arg(long, value_name = "R,G,B,A", value_parser = parse_color)]
    pub fog: Option<Color>,
    /// The combiners' arithmetic: `fixed9` (8 bits + sign, as the hardware
    /// did), `f32`, or `exact` (f64).
    #[arg(long, value_enum, default_value_t = Precision::Fixed9)]
    pub precision: Precision,
    /// The profile whose combiner limits the setup must fit (built-in name
    /// or `.ron` file).
    #[arg(long, value_name = "PROFILE", default_value = "geforce3")]
    pub profile: String,
    /// A `!!TS1.0` texture-shader program computing texture0..3 (instead of
    /// one in front of the `!!RC1.0` program). With a texture shader,
    /// --tex0..--tex3 are texture images of any size (docs/combiners.md).
    #[arg(long, value_name = "TS_FILE")]
    pub texture_shader: Option<PathBuf>,
    /// Texture coordinates (s, t, r, q) of unit 0 per pixel, RGBA8 PNG of the
    /// output's size (default: pixel centres; encoding in docs/combiners.md).
    #[arg(long, value_name = "PNG")]
    pub coord0: Option<PathBuf>,
    /// Texture coordinates of unit 1 per pixel, as --coord0.
    #[arg(long, value_name = "PNG")]
    pub coord1: Option<PathBuf>,
    /// Texture coordinates of unit 2 per pixel, as --coord0.
    #[arg(long, value_name = "PNG")]
    pub coord2: Option<PathBuf>,
    /// Texture coordinates of unit 3 per pixel, as --coord0.
    #[arg(long, value_name = "PNG")]
    pub coord3: Option<PathBuf>,
    /// Accept what NV2A (the Xbox GPU) runs beyond NV_register_combiners:
    /// dot products in the alpha portion, computed as the product of the two
    /// alpha inputs (docs/combiners.md). Off by default.
    #[arg(long)]
    pub permissive: bool,
    /// The output image (RGBA8 PNG, written atomically): the final
    /// combiner's RGBA. `--out` is an older name.
    #[arg(short, long, alias = "out", value_name = "OUT.png")]
    pub output: PathBuf,
}

fn parse_color(s: &str) -> Result<Color, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        return Err(format!("expected four numbers r,g,b,a, found {}", parts.len()));
    }
    let mut c = [0.0; 4];
    for (slot, p) in c.iter_mut().zip(&parts) {
        *slot = p.parse::<f32>().map_err(|_| format!("`{p}` is not a number"))?;
        if !slot.is_finite() {
            return Err(format!("`{p}` is not a finite number"));
        }
    }
    Ok(c)
}

pub(super) enum Failure {
    /// Bad config (exit 1); the message is complete.
    Config(String),
    /// Usage or I/O (exit 2).
    Io(String),
}

/// `shadec emulate`: a combiner setup (and texture shader) run on input
/// images, the result written as a PNG.
pub fn run(args: &EmulateArgs) -> ExitCode {
    match run_inner(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Config(message)) => {
            eprint!("{message}");
            if !message.ends_with('\n') {
                eprintln!();
            }
            ExitCode::from(1)
        }
        Err(Failure::Io(message)) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}

fn run_inner(args: &EmulateArgs) -> Result<(), Failure> {
    let limits = profile_limits(&args.profile)?;
    let limits = if args.permissive { limits.permissive() } else { limits };
    let mut config = load_config(&args.config, &limits)?;
    let program = texture_shader(args.texture_shader.as_deref(), &mut config, &args.config)?;
    let coords = [&args.coord0, &args.coord1, &args.coord2, &args.coord3];
    if program.is_none() {
        if let Some(path) = coords.iter().find_map(|c| c.as_ref()) {
            return Err(Failure::Io(format!(
                "{}: coordinates are read only by a texture shader: give a `!!TS1.0` program (in front of `!!RC1.0` or with --texture-shader)",
                path.display()
            )));
        }
    }
    let load = |path: &Option<PathBuf>| -> Result<Option<(PathBuf, image::RgbaImage)>, Failure> {
        path.as_ref().map(|p| Ok((p.clone(), load_png(p)?))).transpose()
    };
    let textures = [load(&args.tex0)?, load(&args.tex1)?, load(&args.tex2)?, load(&args.tex3)?];
    let per_pixel = [load(&args.primary)?, load(&args.secondary)?];
    let coord_images = [load(coords[0])?, load(coords[1])?, load(coords[2])?, load(coords[3])?];
    // With a texture shader, textures are images of any size; the per-pixel
    // inputs (colours, coordinates) set the output size, else the first texture.
    let sized: Vec<&(PathBuf, image::RgbaImage)> = match program {
        Some(_) => per_pixel.iter().chain(&coord_images).flatten().collect(),
        None => textures.iter().chain(&per_pixel).flatten().collect(),
    };
    let (width, height) = match one_size(&sized)? {
        Some(size) => size,
        None => match textures.iter().flatten().next() {
            Some((_, img)) if program.is_some() => img.dimensions(),
            _ => return Err(Failure::Io("no input image: give at least one of --tex0..--tex3, --primary, --secondary (they set the output size)".into())),
        },
    };
    let inputs = Inputs {
        width: width as usize,
        height: height as usize,
        textures: [raw(&textures[0]), raw(&textures[1]), raw(&textures[2]), raw(&textures[3])],
        primary: raw(&per_pixel[0]),
        secondary: raw(&per_pixel[1]),
        fog: args.fog.unwrap_or([0.0; 4]),
        constant0: args.const0.unwrap_or([0.0; 4]),
        constant1: args.const1.unwrap_or([0.0; 4]),
    };
    let precision = args.precision;
    let pixels = match &program {
        None => emulate(&config, &inputs, precision).map_err(|e| Failure::Config(format!("error: {e}")))?,
        Some(program) => {
            let texture_inputs = ts1::emulate::TextureInputs {
                width: width as usize,
                height: height as usize,
                textures: [
                    image(&textures[0]),
                    image(&textures[1]),
                    image(&textures[2]),
                    image(&textures[3]),
                ],
                coords: [
                    raw(&coord_images[0]),
                    raw(&coord_images[1]),
                    raw(&coord_images[2]),
                    raw(&coord_images[3]),
                ],
            };
            ts1::emulate::emulate(&config, program, &inputs, &texture_inputs, precision)
                .map_err(|e| Failure::Config(format!("error: {e}")))?
        }
    };
    write_png(&args.output, &pixels, width, height)
}

/// An input image, with the path it was read from.
type Loaded = Option<(PathBuf, image::RgbaImage)>;

/// An input image's RGBA8 bytes.
fn raw(img: &Loaded) -> Option<&[u8]> {
    img.as_ref().map(|(_, i)| i.as_raw().as_slice())
}

/// An input image as a texture shader's texture.
fn image(img: &Loaded) -> Option<ts1::emulate::Image<'_>> {
    img.as_ref().map(|(_, i)| ts1::emulate::Image { width: i.width(), height: i.height(), rgba: i.as_raw() })
}

/// Writes RGBA8 pixels as a PNG file, atomically.
fn write_png(path: &Path, pixels: &[u8], width: u32, height: u32) -> Result<(), Failure> {
    let mut png = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut png);
    image::ImageEncoder::write_image(encoder, pixels, width, height, image::ExtendedColorType::Rgba8)
        .map_err(|e| Failure::Io(format!("{}: cannot encode PNG: {e}", path.display())))?;
    shadec::io::write_atomic(path, &png).map_err(|e| Failure::Io(e.to_string()))
}

/// The one size all `images` share (an error naming two that differ).
fn one_size(images: &[&(PathBuf, image::RgbaImage)]) -> Result<Option<(u32, u32)>, Failure> {
    let Some((first, img)) = images.first() else { return Ok(None) };
    let (w, h) = img.dimensions();
    for (path, other) in &images[1..] {
        if other.dimensions() != (w, h) {
            return Err(Failure::Io(format!(
                "input images differ in size: {} is {w}x{h} but {} is {}x{}; all per-pixel inputs must have one size",
                first.display(),
                path.display(),
                other.width(),
                other.height()
            )));
        }
    }
    Ok(Some((w, h)))
}

/// The texture-shader program: from `--texture-shader`, or the `!!TS1.0`
/// block in front of the combiners (not both).
pub(super) fn texture_shader(
    path: Option<&Path>,
    config: &mut CombinerConfig,
    config_path: &Path,
) -> Result<Option<TextureShader>, Failure> {
    let Some(path) = path else { return Ok(config.texture_shader.clone()) };
    if config.texture_shader.is_some() {
        return Err(Failure::Io(format!(
            "{} already starts with a `!!TS1.0` program; --texture-shader {} would be a second one: give one of them",
            config_path.display(),
            path.display()
        )));
    }
    let text = shadec::io::read_text(path).map_err(|e| Failure::Io(e.to_string()))?;
    let program = ts1::parse_file(&text).map_err(|diagnostics| {
        let file = SourceFile::new(path.display().to_string(), text.clone());
        Failure::Config(file.render(&diagnostics, false))
    })?;
    config.texture_shader = Some(program.clone());
    Ok(Some(program))
}

pub(super) fn load_config(path: &Path, limits: &CombinerLimits) -> Result<CombinerConfig, Failure> {
    let text = shadec::io::read_text(path).map_err(|e| Failure::Io(e.to_string()))?;
    let name = path.display().to_string();
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron")) {
        let config = CombinerConfig::from_ron(&text).map_err(|e| {
            Failure::Config(format!(
                "{name}:{}:{}: error[ron]: {}\n  = help: a CombinerConfig in RON is laid out as docs/combiners.md, \"Translated shaders\", shows (or write the setup as `!!RC1.0` text)\n",
                e.span.start.line, e.span.start.col, e.code
            ))
        })?;
        if let Err(errors) = validate(&config, limits) {
            let mut out = String::new();
            for e in errors {
                out.push_str(&format!("{name}: error[{}]: {e}\n  = help: {}\n", e.code, e.help));
            }
            return Err(Failure::Config(out));
        }
        Ok(config)
    } else {
        rc1::parse_and_validate(&text, limits).map_err(|diagnostics| {
            let file = SourceFile::new(name, text.clone());
            Failure::Config(file.render(&diagnostics, false))
        })
    }
}

fn load_png(path: &Path) -> Result<image::RgbaImage, Failure> {
    let bytes =
        std::fs::read(path).map_err(|e| Failure::Io(format!("{}: cannot read: {e}", path.display())))?;
    let img = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
        .map_err(|e| Failure::Io(format!("{}: not a readable PNG image: {e}", path.display())))?;
    Ok(img.to_rgba8())
}
