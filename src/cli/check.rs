//! `shadec check FILE|DIR…`: every diagnostic of every file, then a summary.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde::Serialize;
use shadec::diag::{LspDiagnostic, Severity, SourceFile};

use super::args::{CheckArgs, Format};
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

/// The JSON document `--format json` prints: one per run.
#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Report {
    files: Vec<FileReport>,
    io_errors: Vec<String>,
    summary: Summary,
}

#[derive(Serialize)]
struct FileReport {
    uri: String,
    path: String,
    diagnostics: Vec<LspDiagnostic>,
}

#[derive(Serialize, Default)]
struct Summary {
    files: usize,
    clean: usize,
    errors: usize,
    warnings: usize,
}

/// Whether diagnostics on standard error are coloured: a terminal, and
/// `NO_COLOR` unset.
pub fn color_stderr() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none()
}

/// `shadec check`: every file's diagnostics, then a summary.
pub fn run(args: &CheckArgs) -> ExitCode {
    let mut io_errors = Vec::new();
    let files = collect_files(&args.paths, &mut io_errors);
    let mut report = Report { files: Vec::new(), io_errors: Vec::new(), summary: Summary::default() };
    let color = color_stderr();
    // Standard output's part of the report: printed as it comes, or with
    // -o gathered and written at the end.
    let mut out = Out { gathered: args.output.is_some().then(String::new) };
    let on = match load_scene(args.scene.as_deref()) {
        Ok(on) => on,
        Err(code) => return code,
    };
    for path in &files {
        let text = match shadec::io::read_text(path) {
            Ok(t) => t,
            Err(e) => {
                io_errors.push(e.to_string());
                continue;
            }
        };
        // The scene, its program's images looked for beside this program first.
        let dir = path.parent().unwrap_or(Path::new(""));
        let scene = on
            .as_ref()
            .map(|(s, _)| shadec::scene::Scene { program_dir: Some(dir.to_path_buf()), ..s.clone() });
        let for_scene =
            scene.as_ref().zip(on.as_ref()).map(|(s, (_, a))| shadec::driver::ForScene::specialized(s, a));
        let front = check_one(path, &text, args, for_scene);
        let shadec::driver::Front { program, mut diagnostics, .. } = match front {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(EXIT_USAGE_OR_IO);
            }
        };
        // Cube maps from images that cannot be made, read where `render`
        // reads them: beside the program (then beside the scene).
        diagnostics.extend(shadec::driver::cube_image_errors(&program, dir, scene.as_ref()));
        diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
        let file = SourceFile::new(path.display().to_string(), text);
        let n_errors = diagnostics.iter().filter(|d| d.severity == Severity::Error).count();
        let n_warnings = diagnostics.iter().filter(|d| d.severity == Severity::Warning).count();
        report.summary.files += 1;
        report.summary.errors += n_errors;
        report.summary.warnings += n_warnings;
        if n_errors == 0 && (n_warnings == 0 || !args.deny_warnings) {
            report.summary.clean += 1;
        }
        match args.format {
            Format::Human => {
                eprint!("{}", file.render(&diagnostics, color));
                let status = match (n_errors, n_warnings) {
                    (0, 0) => "ok".to_string(),
                    (0, w) => format!("ok, {w} warning{}", plural(w)),
                    (e, w) => format!("{e} error{}, {w} warning{}", plural(e), plural(w)),
                };
                out.line(format!("{:<48} {status:<22} {} items", path.display(), program.items.len()));
            }
            Format::Short => out.text(file.render_short(&diagnostics)),
            Format::Json => report.files.push(FileReport {
                uri: file_uri(path),
                path: path.display().to_string(),
                diagnostics: file.to_lsp(&file_uri(path), &diagnostics),
            }),
        }
    }
    print_summary(args, &mut report, &io_errors, &mut out);
    let s = &report.summary;
    if let (Some(path), Some(text)) = (&args.output, out.gathered) {
        if super::write_output(Some(path), &text) != ExitCode::SUCCESS {
            return ExitCode::from(EXIT_USAGE_OR_IO);
        }
    }
    if !io_errors.is_empty() {
        ExitCode::from(EXIT_USAGE_OR_IO)
    } else if s.errors > 0 || (args.deny_warnings && s.warnings > 0) {
        ExitCode::from(EXIT_SOURCE_ERRORS)
    } else {
        ExitCode::SUCCESS
    }
}

/// The end of the report: the JSON document (with the I/O errors), or the
/// I/O errors and a one-line summary.
fn print_summary(args: &CheckArgs, report: &mut Report, io_errors: &[String], out: &mut Out) {
    match args.format {
        Format::Json => {
            report.io_errors = io_errors.to_vec();
            #[allow(clippy::expect_used, reason = "the report is strings and numbers: JSON writes it")]
            let text = serde_json::to_string_pretty(&*report).expect("the report serializes");
            out.line(text);
        }
        _ => {
            let s = &report.summary;
            for e in io_errors {
                eprintln!("error: {e}");
            }
            out.line(format!(
                "checked {} file{}: {} clean, {} error{}, {} warning{}",
                s.files,
                plural(s.files),
                s.clean,
                s.errors,
                plural(s.errors),
                s.warnings,
                plural(s.warnings)
            ));
        }
    }
}

/// `--scene`: the scene and its meshes, loaded once for every file; a
/// scene that does not load or build is reported with `render`'s exit
/// code (2 for a missing file, else 1).
fn load_scene(
    path: Option<&Path>,
) -> Result<Option<(shadec::scene::Scene, shadec::scene::SceneAssets)>, ExitCode> {
    let Some(path) = path else { return Ok(None) };
    let scene = shadec::scene::Scene::load(path).map_err(super::scene_failed)?;
    let assets = scene.build().map_err(super::scene_failed)?;
    Ok(Some((scene, assets)))
}

/// One file's diagnostics: the driver's `check`, with the flags `compile`
/// and `render` take, on the scene when one is given, and image files
/// looked for next to the program (then the scene).
fn check_one(
    path: &Path,
    text: &str,
    args: &CheckArgs,
    scene: Option<shadec::driver::ForScene>,
) -> Result<shadec::driver::Front, shadec::profile::ProfileError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let judging = shadec::verdict::Judging {
        plan: shadec::driver::PlanOptions { scene, lowering: args.quality.lowering(), ..Default::default() },
        images: Some(dir),
        stand_ins: args.quality.stand_ins,
        rendered_on: None,
    };
    shadec::verdict::check_with(text, args.target.as_deref(), &judging)
}

/// Standard output's part of the report, or (with `-o`) its text gathered.
struct Out {
    gathered: Option<String>,
}

impl Out {
    fn text(&mut self, s: String) {
        match &mut self.gathered {
            Some(all) => all.push_str(&s),
            None => print!("{s}"),
        }
    }
    fn line(&mut self, s: String) {
        self.text(s + "\n");
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// The `.shd` files named, folders searched recursively, in sorted order.
fn collect_files(paths: &[PathBuf], io_errors: &mut Vec<String>) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for path in paths {
        if path.is_dir() {
            let before = files.len();
            walk(path, &mut files, io_errors);
            if files.len() == before {
                io_errors.push(format!("{}: no `.shd` files in this folder", path.display()));
            }
        } else if path.exists() {
            files.push(path.clone());
        } else {
            io_errors.push(format!("{}: no such file or folder", path.display()));
        }
    }
    files
}

fn walk(dir: &Path, files: &mut Vec<PathBuf>, io_errors: &mut Vec<String>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) => {
            io_errors.push(format!("{}: cannot read folder: {e}", dir.display()));
            return;
        }
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            walk(&p, files, io_errors);
        } else if p.extension().is_some_and(|e| e == "shd") {
            files.push(p);
        }
    }
}

/// The file's URI, percent-encoded (a raw space or `ä` is rejected by strict clients).
fn file_uri(path: &Path) -> String {
    shadec::lsp::uri::from_path(path)
}
