//! The docs cannot drift from the compiler: `docs/language.md` embeds
//! `grammar/shade.pest` verbatim, and every ```shd example of `docs/*.md`
//! and `README.md` checks without errors or warnings and lowers to the IR
//! without errors (issue 16, item 7).

const DOC: &str = include_str!("../docs/language.md");
const GRAMMAR: &str = include_str!("../grammar/shade.pest");

/// `UPDATE_DOCS=1 cargo test --test suite docs::` rewrites the grammar section.
#[test]
fn the_reference_embeds_the_grammar_verbatim() {
    let section = format!("```pest\n{GRAMMAR}```");
    if DOC.contains(&section) {
        return;
    }
    if std::env::var_os("UPDATE_DOCS").is_some() {
        let start = DOC.find("```pest\n").expect("docs/language.md has a ```pest block");
        let end = start + DOC[start..].find("\n```").expect("the block is closed") + 4;
        let updated = format!("{}{section}{}", &DOC[..start], &DOC[end..]);
        std::fs::write(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/language.md"), updated).unwrap();
        return;
    }
    panic!("docs/language.md does not embed grammar/shade.pest as it is now; run `UPDATE_DOCS=1 cargo test --test suite docs::`");
}

/// Every ```` ```shd ```` block of `docs/*.md` and `README.md`: the file,
/// the 1-based line of its first source line, and its text preceded by as
/// many empty lines as precede it in the file.
fn shd_blocks() -> Vec<(String, usize, String)> {
    let root = env!("CARGO_MANIFEST_DIR");
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(format!("{root}/docs"))
        .expect("docs/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    files.sort();
    files.push(format!("{root}/README.md").into());
    let mut blocks = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let name = path.strip_prefix(root).unwrap().display().to_string();
        let mut open: Option<(usize, String)> = None;
        for (i, line) in text.lines().enumerate() {
            match &mut open {
                // Blank lines first, so a diagnostic's line is the file's.
                None if line.trim_end() == "```shd" => open = Some((i + 2, "\n".repeat(i + 1))),
                None => {}
                Some(_) if line.starts_with("```") => {
                    let (at, body) = open.take().unwrap();
                    blocks.push((name.clone(), at, body));
                }
                Some((_, body)) => {
                    body.push_str(line);
                    body.push('\n');
                }
            }
        }
        assert!(open.is_none(), "{name}: a ```shd block is not closed");
    }
    blocks
}

#[test]
fn every_example_in_the_docs_checks_and_lowers() {
    let blocks = shd_blocks();
    let in_reference = blocks.iter().filter(|(f, ..)| f == "docs/language.md").count();
    assert!(in_reference >= 11, "one example per construct in docs/language.md, found {in_reference}");
    let mut failures = Vec::new();
    for (file, line, block) in &blocks {
        let (program, mut diagnostics) = shadec::parser::check(block);
        // The front end's warnings too (unused names): an example shows clean code.
        let front_clean = diagnostics.is_empty();
        if front_clean {
            diagnostics.extend(shadec::ir::lower(&program).1.into_iter().filter(|d| d.is_error()));
        }
        if !diagnostics.is_empty() {
            let source =
                shadec::diag::SourceFile::new(format!("{file} (the block at line {line})"), block.as_str());
            failures.push(source.render(&diagnostics, false));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} ```shd blocks do not check:\n{}",
        failures.len(),
        blocks.len(),
        failures.join("\n")
    );
}

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The text of `path` (relative to the repository).
fn read(path: &str) -> String {
    std::fs::read_to_string(format!("{ROOT}/{path}")).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The fenced blocks of `text` whose info string is `lang`, in order.
fn fenced<'a>(text: &'a str, lang: &str) -> Vec<&'a str> {
    let open = format!("```{lang}\n");
    let mut blocks = Vec::new();
    let mut rest = text;
    while let Some(start) = rest.find(&open) {
        let body = &rest[start + open.len()..];
        let end = body.find("```").expect("a fenced block is closed");
        blocks.push(&body[..end]);
        rest = &body[end..][3..];
    }
    blocks
}

/// `docs/*.md` and `README.md`, each with its text.
fn user_docs() -> Vec<(String, String)> {
    let mut files: Vec<String> = std::fs::read_dir(format!("{ROOT}/docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    files.sort();
    files.push("README.md".into());
    files.push("examples/README.md".into());
    files.into_iter().map(|f| (f.clone(), read(&f))).collect()
}

/// Where `text` says `seeds/` or "issue N" (a number after it), as
/// `what:line: text` lines.
fn internal_references(what: &str, text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        let lower = line.to_lowercase();
        let issue = lower
            .match_indices("issue ")
            .any(|(at, m)| lower[at + m.len()..].chars().next().is_some_and(|c| c.is_ascii_digit()));
        // "issue" at the end of a line, its number at the start of the next.
        let next =
            lines.get(i + 1).map_or("", |l| l.trim_start().trim_start_matches(['/', '!', '#', '-', ' ']));
        let split = (lower.ends_with(" issue") || lower.ends_with("(issue"))
            && next.starts_with(|c: char| c.is_ascii_digit());
        let issue = issue || split;
        if lower.contains("seeds/") || issue {
            found.push(format!("{what}:{}: {line}", i + 1));
        }
    }
    found
}

/// Users see the papers by author and year (docs/references.md), not the
/// project's file names, and no issue numbers: not in the README, not in
/// any page of docs/ but the bibliography, not in any command's help.
#[test]
fn user_facing_text_cites_papers_not_seed_files_or_issues() {
    let mut found = Vec::new();
    for (file, text) in user_docs() {
        if file != "docs/references.md" {
            found.extend(internal_references(&file, &text));
        }
    }
    let commands = ["check", "compile", "fmt", "emulate", "render", "bench", "translate", "lsp"];
    for args in std::iter::once(vec!["--help"]).chain(commands.iter().map(|c| vec![*c, "--help"])) {
        let r = crate::common::shadec(&args);
        assert_eq!(r.code, 0, "shadec {args:?}: {}", r.stderr);
        assert!(r.stdout.len() > 200, "shadec {args:?} prints its help");
        found.extend(internal_references(&format!("shadec {}", args.join(" ")), &r.stdout));
    }
    // The bibliography maps every seed file to its paper.
    let refs = read("docs/references.md");
    for seed in ["000_", "001_", "002_", "003_", "004_"] {
        assert!(refs.contains(&format!("seeds/{seed}")), "docs/references.md does not list seeds/{seed}");
    }
    assert!(
        found.is_empty(),
        "{} user-facing lines cite seed files or issues:\n{}",
        found.len(),
        found.join("\n")
    );
}

/// Every relative link and every `docs/…`/`examples/…`/`scenes/…` path the
/// user documents name exists: no dangling or machine-local reference.
#[test]
fn documents_name_only_files_that_exist() {
    let mut missing = Vec::new();
    for (file, text) in user_docs() {
        let dir = std::path::Path::new(ROOT).join(&file).parent().unwrap().to_path_buf();
        for (at, _) in text.match_indices("](") {
            let target = &text[at + 2..];
            let target = &target[..target.find(')').unwrap_or(0)];
            let target = target.split('#').next().unwrap();
            if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            if !dir.join(target).exists() {
                missing.push(format!("{file}: link to {target}"));
            }
        }
        if text.contains("/work/") || text.contains("/home/") {
            missing.push(format!("{file}: a machine-local path"));
        }
    }
    let cargo = read("Cargo.toml");
    for word in cargo.split(|c: char| c.is_whitespace() || "(),;:`'\"".contains(c)) {
        if word.ends_with(".md") && !std::path::Path::new(ROOT).join(word).exists() {
            missing.push(format!("Cargo.toml: {word}"));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// The README's first screen: the two set-up commands, alone in the first
/// code block, then the install line, then the tutorial.
#[test]
fn the_readme_opens_with_two_commands_install_and_tutorial() {
    let readme = read("README.md");
    let first = fenced(&readme, "sh")[0];
    assert_eq!(first, "cargo run --release -- render\n./.ci/run\n");
    let at = |needle: &str| readme.find(needle).unwrap_or_else(|| panic!("README.md lacks {needle:?}"));
    assert!(at(first) < at("cargo install --path .") && at("cargo install --path .") < at("## Five minutes"));
    assert!(at("## Five minutes") < at("## Status"));
    // The status table is short: history lives in CHANGELOG.md.
    let status = &readme[at("## Status")..];
    let status = &status[..status[3..].find("\n## ").unwrap_or(status.len() - 3) + 3];
    for row in status.lines().filter(|l| l.starts_with('|')) {
        for cell in row.split('|') {
            assert!(
                cell.chars().count() <= 200,
                "a status cell of {} characters: {cell}",
                cell.chars().count()
            );
        }
    }
}

/// The tutorial works as written: its program is saved as the file it
/// names, and every `shadec` command of its ```sh blocks runs in that
/// folder and succeeds, writing what it says (the built binary stands in
/// for the installed one).
#[test]
fn the_readme_tutorial_runs() {
    let readme = read("README.md");
    let start = readme.find("## Five minutes").expect("the tutorial");
    let tutorial = &readme[start..start + readme[start..].find("\n## Status").expect("then the status")];
    let program = fenced(tutorial, "shd")[0];
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("hello.shd"), program).unwrap();
    let mut ran = 0;
    for block in fenced(tutorial, "sh") {
        for line in block.lines().filter(|l| l.starts_with("shadec ")) {
            let args: Vec<&str> = line.split_whitespace().skip(1).collect();
            let r = crate::common::shadec_in(dir.path(), &args);
            assert_eq!(r.code, 0, "`{line}` failed:\n{}\n{}", r.stdout, r.stderr);
            if let Some(i) = args.iter().position(|a| *a == "-o") {
                let out = dir.path().join(args[i + 1]);
                assert!(
                    std::fs::metadata(&out).is_ok_and(|m| m.len() > 0),
                    "`{line}` wrote no {}",
                    args[i + 1]
                );
            }
            ran += 1;
        }
    }
    assert!(ran >= 6, "the tutorial has {ran} shadec commands");
    // What the text says the commands show.
    let r = crate::common::shadec_in(dir.path(), &["check", "--target", "geforce256", "hello.shd"]);
    assert!(r.stderr.contains("needs 3 texture units; it has 2"), "{}", r.stderr);
    let r = crate::common::shadec_in(
        dir.path(),
        &["render", "--shader", "hello.shd", "--target", "geforce256", "-o", "x.png"],
    );
    assert!(r.stdout.contains("4 passes on geforce256"), "{}", r.stdout);
    let typo = program.replace("max(0, Nn·Ln)", "max(0, Nn·Lm)");
    std::fs::write(dir.path().join("typo.shd"), typo).unwrap();
    let r = crate::common::shadec_in(dir.path(), &["check", "typo.shd"]);
    assert_eq!(r.code, 1);
    assert!(r.stderr.contains("typo.shd:16:") && r.stderr.contains("help: did you mean"), "{}", r.stderr);
}

/// The scene of docs/scenes.md parses, builds and renders with the
/// program beside it, as the page says: one pass per light, the scene's
/// textures in place of the program's.
#[test]
fn the_scene_in_docs_scenes_renders() {
    let page = read("docs/scenes.md");
    let scene = fenced(&page, "ron")[0];
    let program = fenced(&page, "shd")[0];
    let parsed = shadec::scene::Scene::parse(scene, std::path::Path::new("scenes/my_scene.ron"))
        .unwrap_or_else(|e| panic!("docs/scenes.md's scene: {e}"));
    let assets = parsed.build().unwrap();
    assert_eq!((parsed.lights.len(), assets.meshes.len()), (3, 2));
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scenes")).unwrap();
    std::fs::write(dir.path().join("scenes/my_scene.ron"), scene).unwrap();
    std::fs::write(dir.path().join("my_program.shd"), program).unwrap();
    let command = fenced(&page, "sh")[0].trim();
    let args: Vec<&str> = command.split_whitespace().skip_while(|a| *a != "--").skip(1).collect();
    let mut args = args;
    args.extend(["--size", "80x60"]);
    let r = crate::common::shadec_in(dir.path(), &args);
    assert_eq!(r.code, 0, "{command}:\n{}\n{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("3 passes"), "one pass per light:\n{}", r.stdout);
    assert!(!r.stdout.contains("not found"), "the scene's textures replace the program's:\n{}", r.stdout);
    let img = image::open(dir.path().join("my_scene.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (80, 60));
    let lit = img.pixels().filter(|p| p.0.iter().any(|&c| c > 60)).count();
    assert!(lit > 80 * 60 / 10, "{lit} lit pixels");
}

/// The same for what users read beyond the documents: rustdoc (`///`,
/// `//!`) and every line of code in `src/` (diagnostics, help, emitted
/// headers are string literals there), and the files users open — the
/// examples, the scenes and the profiles. Plain `//` comments in `src/` are
/// for the project's developers and may cite its files.
#[test]
fn rustdoc_messages_and_examples_cite_papers_not_seed_files_or_issues() {
    fn walk(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    for dir in ["src", "examples", "scenes", "profiles"] {
        walk(&std::path::Path::new(ROOT).join(dir), &mut files);
    }
    files.sort();
    let mut found = Vec::new();
    for path in files {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !["rs", "shd", "ron", "md"].contains(&ext) {
            continue;
        }
        let name = path.strip_prefix(ROOT).unwrap().display().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let user_facing: String = text
            .lines()
            .map(|line| {
                let t = line.trim_start();
                let developer_comment =
                    ext == "rs" && t.starts_with("//") && !t.starts_with("///") && !t.starts_with("//!");
                if developer_comment {
                    ""
                } else {
                    line
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        found.extend(internal_references(&name, &user_facing));
    }
    assert!(found.is_empty(), "{} lines cite seed files or issues:\n{}", found.len(), found.join("\n"));
}
