//! `shadec emulate`: run a register-combiner setup (`!!RC1.0` or RON) on
//! images with the CPU emulator (seeds/003 Section 4.2), as a user porting
//! legacy content would.
//!
//! Exit codes: 0 ok, 1 the config is malformed or invalid, 2 usage or I/O
//! errors (missing file, images of different sizes, unwritable output).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use shadec::backends::combiners::emulator::{emulate, Inputs};
use shadec::backends::combiners::{rc1, validate, Color, CombinerConfig, CombinerLimits};
use shadec::diag::SourceFile;
use shadec::numerics::Precision;

/// The combiner limits of a profile (built-in name or `.ron` file): a
/// setup is checked against the machine the user names, never a copy of
/// its numbers (issue 17: limits come only from profiles).
pub(super) fn profile_limits(name: &str) -> Result<CombinerLimits, Failure> {
    let profile = shadec::profile::Profile::resolve(name).map_err(|e| Failure::Io(e.to_string()))?;
    profile.combiner_limits().ok_or_else(|| {
        Failure::Io(format!(
            "profile `{}` has no register combiners; give `geforce256`, `geforce3` or a `.ron` profile whose fragment stage is `Combiners`",
            profile.name
        ))
    })
}

/// Run a register-combiner setup on images.
#[derive(Clone, Debug, clap::Args)]
pub struct EmulateArgs {
    /// The combiner setup: an nvparse `!!RC1.0` program, or `.ron` for a CombinerConfig.
    pub config: PathBuf,
    /// Texture unit 0 (RGBA8 PNG).
    #[arg(long)]
    pub tex0: Option<PathBuf>,
    #[arg(long)]
    pub tex1: Option<PathBuf>,
    #[arg(long)]
    pub tex2: Option<PathBuf>,
    #[arg(long)]
    pub tex3: Option<PathBuf>,
    /// Interpolated primary (diffuse) colour per pixel.
    #[arg(long)]
    pub primary: Option<PathBuf>,
    /// Interpolated secondary (specular) colour per pixel.
    #[arg(long)]
    pub secondary: Option<PathBuf>,
    /// Constant colour 0 as r,g,b,a in [0, 1] (the program's own `const0` wins).
    #[arg(long, value_parser = parse_color)]
    pub const0: Option<Color>,
    /// Constant colour 1 as r,g,b,a in [0, 1] (the program's own `const1` wins).
    #[arg(long, value_parser = parse_color)]
    pub const1: Option<Color>,
    /// Fog colour (r,g,b) and fog factor (a).
    #[arg(long, value_parser = parse_color)]
    pub fog: Option<Color>,
    /// The combiners' arithmetic: `fixed9` (8 bits + sign, as the hardware
    /// did), `f32`, or `exact` (f64).
    #[arg(long, value_enum, default_value_t = Precision::Fixed9)]
    pub precision: Precision,
    /// The profile whose combiner limits the setup must fit (built-in name
    /// or `.ron` file).
    #[arg(long, value_name = "PROFILE", default_value = "geforce3")]
    pub profile: String,
    /// The output image (RGBA8 PNG): the final combiner's RGBA.
    #[arg(long)]
    pub out: PathBuf,
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
    let config = load_config(&args.config, &limits)?;

    let named = [
        ("--tex0", &args.tex0),
        ("--tex1", &args.tex1),
        ("--tex2", &args.tex2),
        ("--tex3", &args.tex3),
        ("--primary", &args.primary),
        ("--secondary", &args.secondary),
    ];
    let mut images: Vec<Option<(PathBuf, image::RgbaImage)>> = Vec::new();
    for (_, path) in named {
        images.push(match path {
            Some(path) => Some((path.clone(), load_png(path)?)),
            None => None,
        });
    }
    let mut size: Option<(&Path, u32, u32)> = None;
    for (path, img) in images.iter().flatten() {
        match size {
            None => size = Some((path, img.width(), img.height())),
            Some((first, w, h)) if (w, h) != img.dimensions() => {
                return Err(Failure::Io(format!(
                "input images differ in size: {} is {w}x{h} but {} is {}x{}; all inputs must have one size",
                first.display(),
                path.display(),
                img.width(),
                img.height()
            )))
            }
            _ => {}
        }
    }
    let Some((_, width, height)) = size else {
        return Err(Failure::Io("no input image: give at least one of --tex0..--tex3, --primary, --secondary (they set the output size)".into()));
    };
    let raw = |i: usize| images[i].as_ref().map(|(_, img)| img.as_raw().as_slice());
    let inputs = Inputs {
        width: width as usize,
        height: height as usize,
        textures: [raw(0), raw(1), raw(2), raw(3)],
        primary: raw(4),
        secondary: raw(5),
        fog: args.fog.unwrap_or([0.0; 4]),
        constant0: args.const0.unwrap_or([0.0; 4]),
        constant1: args.const1.unwrap_or([0.0; 4]),
    };
    let pixels =
        emulate(&config, &inputs, args.precision).map_err(|e| Failure::Config(format!("error: {e}")))?;
    let mut png = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut png);
    image::ImageEncoder::write_image(encoder, &pixels, width, height, image::ExtendedColorType::Rgba8)
        .map_err(|e| Failure::Io(format!("{}: cannot encode PNG: {e}", args.out.display())))?;
    shadec::io::write_atomic(&args.out, &png).map_err(|e| Failure::Io(e.to_string()))?;
    Ok(())
}

pub(super) fn load_config(path: &Path, limits: &CombinerLimits) -> Result<CombinerConfig, Failure> {
    let text = shadec::io::read_text(path).map_err(|e| Failure::Io(e.to_string()))?;
    let name = path.display().to_string();
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron")) {
        let config = CombinerConfig::from_ron(&text).map_err(|e| {
            Failure::Config(format!(
                "{name}:{}:{}: error[ron]: {}\n  = help: see tests/data/combiners/*.ron for the CombinerConfig layout\n",
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
