//! `shadec lsp` driven over stdio as an editor drives it (issue 21): every
//! feature, through the real binary and JSON-RPC framing.

use crate::common_lsp;

use common_lsp::{pos, Client};
use serde_json::{json, Value};

const URI: &str = "file:///tmp/shadec-lsp/bump.shd";

/// A program with a texture, a shader, a `let` and one statement.
const PROGRAM: &str = "\
// target: geforce3
vector N : normal;
vector L : light(0);
const kd : rgb = (0.8, 0.6, 0.4);
texture T : 2d rgba8 = image(\"brick.png\");
let base = T δu x;
shader p : s → c {
    let diffuse = max(0, N·L);
    kd * diffuse
}
C δπx ← base ⊕ (δ p s x);
";

fn client() -> Client {
    Client::start(Value::Null, &[])
}

fn text_doc(uri: &str) -> Value {
    json!({"uri": uri})
}

fn at(uri: &str, text: &str, needle: &str, n: usize, extra: usize) -> Value {
    json!({"textDocument": text_doc(uri), "position": pos(text, needle, n, extra)})
}

fn messages(published: &Value) -> Vec<String> {
    published["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["message"].as_str().unwrap().to_string())
        .collect()
}

fn whole(uri: &str) -> Value {
    json!({"textDocument": text_doc(uri), "range": {"start": {"line": 0, "character": 0}, "end": {"line": 999, "character": 0}}, "context": {"diagnostics": []}})
}

/// Applies LSP text edits (UTF-16 positions) to a text, as an editor does.
fn apply(text: &str, edits: &[Value]) -> String {
    let offset = |p: &Value| {
        let line_start: usize =
            text.split_inclusive('\n').take(p["line"].as_u64().unwrap() as usize).map(str::len).sum();
        let mut units = 0;
        for (i, ch) in text[line_start..].char_indices() {
            if units == p["character"].as_u64().unwrap() as usize {
                return line_start + i;
            }
            units += ch.len_utf16();
        }
        text.len()
    };
    let mut spans: Vec<(usize, usize, &str)> = edits
        .iter()
        .map(|e| (offset(&e["range"]["start"]), offset(&e["range"]["end"]), e["newText"].as_str().unwrap()))
        .collect();
    spans.sort();
    let mut out = text.to_string();
    for (a, b, new) in spans.into_iter().rev() {
        out.replace_range(a..b, new);
    }
    out
}

#[test]
fn diagnostics_follow_edits_that_introduce_and_fix_errors() {
    let mut c = client();
    let clean = c.open(URI, PROGRAM);
    assert_eq!(clean["version"], 1);
    assert_eq!(messages(&clean), Vec::<String>::new(), "{clean}");

    // A typo with a transposition, then a missing `;` on two lines.
    let typo = PROGRAM.replace("max(0, N·L)", "max(0, N·Ligth)").replace("vector L :", "vector Light :");
    let d = c.change(URI, 2, &typo);
    assert_eq!(d["version"], 2);
    // One mistake, one diagnostic: `Light`, meant by the typo, is not also "never used".
    assert_eq!(messages(&d), ["unknown name `Ligth`\nhelp: did you mean `Light`?"], "{d}");
    assert_eq!(d["diagnostics"][0]["code"], "unknown-name");
    assert_eq!(d["diagnostics"][0]["range"]["start"], pos(&typo, "Ligth", 0, 0));

    let unterminated = PROGRAM
        .replace("vector N : normal;", "vector N : normal")
        .replace("(0.8, 0.6, 0.4);", "(0.8, 0.6, 0.4)");
    let d = c.change(URI, 3, &unterminated);
    assert_eq!(d["version"], 3);
    let want = "expected `;` at the end of this line\nhelp: end every statement and declaration with `;`; the next line starts a new one";
    assert_eq!(messages(&d), [want, want], "{d}");
    assert_eq!(d["diagnostics"][0]["range"]["start"], pos(&unterminated, "\nvector L", 0, 0));

    // Fixed again; a save with the text re-checks too.
    assert_eq!(messages(&c.change(URI, 4, PROGRAM)), Vec::<String>::new());
    c.notify("textDocument/didSave", json!({"textDocument": text_doc(URI), "text": unterminated}));
    let d = c.diagnostics(URI);
    assert_eq!(d["version"], 4);
    assert_eq!(messages(&d).len(), 2);
    c.notify("textDocument/didClose", json!({"textDocument": text_doc(URI)}));
    assert_eq!(messages(&c.diagnostics(URI)), Vec::<String>::new());
    assert!(c.shutdown().success());
}

#[test]
fn related_spans_are_related_information_with_encoded_uris() {
    let mut c = client();
    let uri = "file:///tmp/a%20b/%C3%A4.shd";
    let text = format!("{PROGRAM}const kd = 1;\n");
    let d = c.open(uri, &text);
    assert_eq!(d["uri"], uri);
    let dup = &d["diagnostics"][0];
    assert_eq!(dup["code"], "duplicate-name", "{d}");
    let related = dup["relatedInformation"].as_array().unwrap();
    assert_eq!(related.len(), 1, "one related span, not repeated: {dup}");
    assert_eq!(related[0]["location"]["uri"], uri);
    assert_eq!(related[0]["location"]["range"]["start"], pos(&text, "kd", 0, 0));
    assert_eq!(related[0]["message"], "first declared here as a constant");
    assert!(c.shutdown().success());
}

#[test]
fn hover_tells_type_frequency_range_and_where_it_lands() {
    let mut c = client();
    c.open(URI, PROGRAM);
    let hover = |c: &mut Client, needle: &str, n: usize| -> String {
        let h = c.result("textDocument/hover", at(URI, PROGRAM, needle, n, 0));
        h["contents"]["value"].as_str().unwrap().to_string()
    };
    // The let in the shader block: per vertex (no δ yet), in [0, 1].
    let h = hover(&mut c, "diffuse", 1);
    assert!(h.starts_with("**`diffuse`** — `let` binding (declared at line 8:9)"), "{h}");
    assert!(
        h.contains("`max(0, N·L)`\n\n- type: scalar\n- frequency: per-vertex\n- value range: [0, 1]\n"),
        "{h}"
    );
    assert!(h.contains("- geforce3, pass 1: per vertex (interpolated into the combiners)"), "{h}");
    // The lookup: per fragment, texture unit 0 of pass 1.
    let h = hover(&mut c, "T δu x;", 0);
    assert!(h.contains("- type: rgba\n- frequency: per-fragment\n- value range: [0, 1]\n"), "{h}");
    assert!(h.contains("- geforce3, pass 1: texture unit 0 (`T`): register combiners, "), "{h}");
    // δ interpolates: the same shader's value is per fragment after it.
    let h = hover(&mut c, "δ p s x", 0);
    assert!(h.contains("- frequency: per-fragment\n- value range: [0, 0.8]"), "{h}");
    // On wgsl (the default), the same document lands in WGSL.
    let uri = "file:///tmp/shadec-lsp/wgsl.shd";
    let text = PROGRAM.replace("// target: geforce3\n", "");
    c.open(uri, &text);
    let h = c.result("textDocument/hover", at(uri, &text, "T δu x;", 0, 0));
    assert!(
        h["contents"]["value"]
            .as_str()
            .unwrap()
            .contains("- wgsl, pass 1: texture unit 0 (`T`): WGSL fragment shader"),
        "{h}"
    );
    // Nothing under the cursor: null.
    let h = c.result(
        "textDocument/hover",
        json!({"textDocument": text_doc(uri), "position": {"line": 0, "character": 0}}),
    );
    assert!(h.is_null(), "{h}");
    assert!(c.shutdown().success());
}

#[test]
fn the_target_comes_from_the_document_or_the_client() {
    let text = PROGRAM.replace("// target: geforce3\n", "");
    let hint = |c: &mut Client, uri: &str| -> String {
        let r = c.result("textDocument/inlayHint", whole(uri));
        r.as_array().unwrap().last().unwrap()["label"].as_str().unwrap().to_string()
    };
    let mut c = Client::start(json!({"shadec": {"target": "geforce256"}}), &[]);
    c.open(URI, &text);
    assert_eq!(hint(&mut c, URI), "pass 1 (geforce256)");
    c.notify("workspace/didChangeConfiguration", json!({"settings": {"shadec": {"target": "multitexture"}}}));
    assert!(c.diagnostics(URI)["diagnostics"].as_array().unwrap().iter().all(|d| d["severity"] != 1));
    assert_eq!(hint(&mut c, URI), "pass 1 (multitexture)");
    // A comment beats the client; the program's declaration beats both.
    let commented = format!("// target: geforce3\n{text}");
    c.change(URI, 2, &commented);
    assert_eq!(hint(&mut c, URI), "pass 1 (geforce3)");
    let declared = format!("target wgsl;\n{commented}");
    c.change(URI, 3, &declared);
    assert_eq!(hint(&mut c, URI), "pass 1 (wgsl)");
    // An unknown profile in the comment is a located error.
    let wrong = format!("// target: geforce9\n{text}");
    let d = c.change(URI, 4, &wrong);
    assert_eq!(d["diagnostics"][0]["code"], "unknown-profile", "{d}");
    assert_eq!(d["diagnostics"][0]["range"]["start"], pos(&wrong, "geforce9", 0, 0));
    assert!(c.shutdown().success());
}

#[test]
fn inlay_hints_show_frequencies_and_passes() {
    let mut c = client();
    c.open(URI, PROGRAM);
    let r = c.result("textDocument/inlayHint", whole(URI));
    let hints: Vec<(Value, &str)> =
        r.as_array().unwrap().iter().map(|h| (h["position"].clone(), h["label"].as_str().unwrap())).collect();
    assert_eq!(
        hints,
        [
            (pos(PROGRAM, "T δu x;", 0, 7), ": per-fragment"),
            (pos(PROGRAM, "N·L)", 0, 4), ": per-vertex"),
            (pos(PROGRAM, "(δ p s x);", 0, 10), "pass 1 (geforce3)"),
        ]
    );
    // A statement that needs two passes on geforce256 but one on geforce3.
    let uri = "file:///tmp/shadec-lsp/two.shd";
    let text =
        "target geforce256;\ntexture A, B, D : 2d = image(\"a.png\");\nC δπx ← A δu x * B δu x * D δu x;\n";
    let d = c.open(uri, text);
    assert_eq!(d["diagnostics"][0]["code"], "does-not-fit", "{d}");
    let r = c.result("textDocument/inlayHint", whole(uri));
    assert_eq!(r.as_array().unwrap().last().unwrap()["label"], "passes 1–2 (geforce256)");
    // Two lookups land in one pass, the third in the other (two units per pass).
    let mut in_pass = [0, 0];
    for t in ["A δu x", "B δu x", "D δu x"] {
        let h = c.result("textDocument/hover", at(uri, text, t, 0, 0));
        let h = h["contents"]["value"].as_str().unwrap().to_string();
        let k = (1..=2).find(|k| h.contains(&format!("- geforce256, pass {k}: texture unit "))).expect(&h);
        in_pass[k - 1] += 1;
    }
    in_pass.sort();
    assert_eq!(in_pass, [1, 2]);
    assert!(c.shutdown().success());
}

#[test]
fn definition_references_and_rename() {
    let mut c = client();
    c.open(URI, PROGRAM);
    let def = c.result("textDocument/definition", at(URI, PROGRAM, "kd", 1, 1));
    assert_eq!(def["uri"], URI);
    assert_eq!(def["range"]["start"], pos(PROGRAM, "kd", 0, 0));
    // The shader-block `let` resolves to its own declaration.
    let def = c.result("textDocument/definition", at(URI, PROGRAM, "diffuse", 1, 0));
    assert_eq!(def["range"]["start"], pos(PROGRAM, "diffuse", 0, 0));
    let mut params = at(URI, PROGRAM, "T", 1, 0);
    params["context"] = json!({"includeDeclaration": true});
    let refs = c.result("textDocument/references", params.clone());
    let starts: Vec<Value> = refs.as_array().unwrap().iter().map(|l| l["range"]["start"].clone()).collect();
    assert_eq!(starts, [pos(PROGRAM, "T :", 0, 0), pos(PROGRAM, "T δu", 0, 0)]);
    params["context"] = json!({"includeDeclaration": false});
    assert_eq!(c.result("textDocument/references", params).as_array().unwrap().len(), 1);

    let prep = c.result("textDocument/prepareRename", at(URI, PROGRAM, "base", 1, 2));
    assert_eq!(prep["placeholder"], "base");
    assert_eq!(prep["range"]["start"], pos(PROGRAM, "base", 1, 0));
    // The paper's families and built-ins are not renamed.
    let e = c.request("textDocument/prepareRename", at(URI, PROGRAM, "x", 1, 0));
    assert_eq!(
        e["error"]["message"],
        "`x` is a vertex of the language, not a declared name: it cannot be renamed"
    );
    let e = c.request("textDocument/prepareRename", at(URI, PROGRAM, "max", 0, 0));
    assert!(e["error"]["message"].as_str().unwrap().starts_with("`max` is a built-in function"), "{e}");

    let mut params = at(URI, PROGRAM, "base", 0, 0);
    params["newName"] = json!("albedo");
    let edit = c.result("textDocument/rename", params.clone());
    let edits = edit["changes"][URI].as_array().unwrap();
    assert_eq!(edits.len(), 2);
    let renamed = apply(PROGRAM, edits);
    assert_eq!(renamed, PROGRAM.replace("base", "albedo"));
    // The renamed program checks: the edit is applied as an editor would.
    assert_eq!(messages(&c.change(URI, 2, &renamed)), Vec::<String>::new());
    for (bad, why) in [
        ("kd", "`kd` is already declared"),
        ("let", "`let` is a keyword of the language"),
        ("2x", "`2x` is not a name: use letters, digits and `_`, then primes `'` if you like"),
    ] {
        let mut p = at(URI, &renamed, "albedo", 0, 0);
        p["newName"] = json!(bad);
        assert_eq!(c.request("textDocument/rename", p)["error"]["message"], why);
    }
    assert!(c.shutdown().success());
}

#[test]
fn document_symbols_outline_declarations_and_statements() {
    let mut c = client();
    c.open(URI, PROGRAM);
    let r = c.result("textDocument/documentSymbol", json!({"textDocument": text_doc(URI)}));
    let names: Vec<(&str, &str)> = r
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["name"].as_str().unwrap(), s["detail"].as_str().unwrap()))
        .collect();
    assert_eq!(
        names,
        [
            ("N", "vector"),
            ("L", "vector"),
            ("kd", "const"),
            ("T", "texture"),
            ("base", "let"),
            ("p", "shader"),
            ("C δπx ←", "statement")
        ]
    );
    let shader = &r[5];
    assert_eq!(shader["children"][0]["name"], "diffuse");
    assert_eq!(shader["range"]["end"]["line"], 9, "the block's closing brace");
    assert!(c.shutdown().success());
}

#[test]
fn formatting_prints_canonically_and_keeps_comments() {
    let mut c = client();
    let ascii = "// lead comment\nvector N : normal;   # why\nvector L : light(0);\nshader p : s -> c = max(0, N (.) L);\n/* block */\nC delta pi x <- delta p s x;  // (4)\n";
    c.open(URI, ascii);
    let options = json!({"tabSize": 4, "insertSpaces": true});
    let r = c.result("textDocument/formatting", json!({"textDocument": text_doc(URI), "options": options}));
    let out = r[0]["newText"].as_str().unwrap();
    assert_eq!(
        out,
        "// lead comment\nvector N : normal;  # why\nvector L : light(0);\nshader p : s → c = max(0, N·L);\n/* block */\nC δπx ← δ p s x;  // (4)\n"
    );
    // Formatting what is canonical changes nothing.
    c.change(URI, 2, out);
    assert_eq!(
        c.result("textDocument/formatting", json!({"textDocument": text_doc(URI), "options": options})),
        json!([])
    );
    // A document with syntax errors is refused, with the reason.
    c.change(URI, 3, "C δπx ← ;\n");
    let e = c.request("textDocument/formatting", json!({"textDocument": text_doc(URI), "options": options}));
    assert!(e["error"]["message"].as_str().unwrap().starts_with("the document has syntax errors"), "{e}");
    assert!(c.shutdown().success());
}

/// Decodes semantic tokens into (line, character, length, type, modifiers).
fn decode(data: &Value) -> Vec<(u64, u64, u64, String, u64)> {
    let legend = [
        "texture",
        "framebuffer",
        "vector",
        "shader",
        "constant",
        "uniform",
        "variable",
        "parameter",
        "function",
        "keyword",
        "number",
        "string",
        "comment",
        "operator",
    ];
    let v: Vec<u64> = data.as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect();
    let (mut line, mut ch) = (0, 0);
    v.chunks(5)
        .map(|t| {
            line += t[0];
            ch = if t[0] == 0 { ch + t[1] } else { t[1] };
            (line, ch, t[2], legend[t[3] as usize].to_string(), t[4])
        })
        .collect()
}

#[test]
fn semantic_tokens_classify_names_operators_and_keywords() {
    let mut c = client();
    let init = c.request("initialize", json!({})); // a second initialize is an error, not a crash
    assert!(init.get("error").is_some());
    c.open(URI, PROGRAM);
    let r = c.result("textDocument/semanticTokens/full", json!({"textDocument": text_doc(URI)}));
    let tokens = decode(&r["data"]);
    let find = |needle: &str, n: usize| {
        let p = pos(PROGRAM, needle, n, 0);
        tokens
            .iter()
            .find(|t| t.0 == p["line"].as_u64().unwrap() && t.1 == p["character"].as_u64().unwrap())
            .map(|t| (t.2, t.3.as_str(), t.4))
    };
    assert_eq!(find("// target", 0), Some((19, "comment", 0)));
    assert_eq!(find("vector", 0), Some((6, "keyword", 0)));
    assert_eq!(find("T :", 0), Some((1, "texture", 1)), "a declaration");
    assert_eq!(find("T δu", 0), Some((1, "texture", 0)));
    assert_eq!(find("kd", 1), Some((2, "constant", 0)));
    assert_eq!(find("p :", 0), Some((1, "shader", 1)));
    assert_eq!(find("max", 0), Some((3, "function", 2)), "built-ins are defaultLibrary");
    assert_eq!(find("C δπx", 0), Some((1, "framebuffer", 2)), "the paper's C");
    assert_eq!(find("δπx", 0), Some((1, "operator", 0)));
    assert_eq!(find("πx", 0), Some((1, "operator", 0)));
    assert_eq!(find("←", 0), Some((1, "operator", 0)));
    assert_eq!(find("⊕", 0), Some((1, "operator", 0)));
    assert_eq!(find("0.8", 0), Some((3, "number", 0)));
    assert_eq!(find("\"brick.png\"", 0), Some((11, "string", 0)));
    // ASCII spellings are operators too.
    let uri = "file:///tmp/shadec-lsp/ascii.shd";
    let text = "texture T : 2d = image(\"a.png\");\nC delta pi x <- T delta u x (+) T delta u x;\n";
    c.open(uri, text);
    let tokens =
        decode(&c.result("textDocument/semanticTokens/full", json!({"textDocument": text_doc(uri)}))["data"]);
    let ops: Vec<u64> = tokens.iter().filter(|t| t.3 == "operator").map(|t| t.2).collect();
    assert_eq!(ops, [5, 2, 2, 5, 3, 5], "delta pi <- delta (+) delta: {tokens:?}");
    assert!(c.shutdown().success());
}

fn labels(r: &Value) -> Vec<String> {
    r.as_array().unwrap().iter().map(|i| i["label"].as_str().unwrap().to_string()).collect()
}

#[test]
fn completion_offers_names_builtins_and_symbols_from_ascii() {
    let mut c = client();
    let text = "vector Normal : normal;\nC δπx ← nor";
    c.open(URI, text);
    let complete = |c: &mut Client, text: &str, version: i32| {
        c.change(URI, version, text);
        let end =
            pos(text, text.lines().last().unwrap(), 0, text.lines().last().unwrap().encode_utf16().count());
        c.result("textDocument/completion", json!({"textDocument": text_doc(URI), "position": end}))
    };
    let r = complete(&mut c, "vector Normal : normal;\nC δπx ← Nor", 2);
    assert_eq!(labels(&r), ["Normal"]);
    let r = complete(&mut c, "vector Normal : normal;\nC δπx ← nor", 3);
    assert_eq!(labels(&r), ["normalize", "normalize_cube", "normal_map"]);
    for (typed, symbol) in
        [("\\del", "δ"), ("delta", "δ"), ("<-", "←"), ("(+)", "⊕"), ("(+", "⊕"), ("\\pi", "π")]
    {
        let text = format!("vector Normal : normal;\nC {typed}");
        let r = complete(&mut c, &text, 4);
        let first = &r[0];
        assert_eq!(first["label"], symbol, "{typed}: {r}");
        let edit = &first["textEdit"];
        assert_eq!(edit["newText"], symbol);
        assert_eq!(edit["range"]["start"], pos(&text, typed, 0, 0), "{typed}: replaces what was typed");
    }
    assert!(c.shutdown().success());
}

#[test]
fn code_actions_apply_suggestions_insert_semicolons_and_convert() {
    let mut c = client();
    let typo = PROGRAM.replace("kd * diffuse", "kd * difuse");
    let d = c.open(URI, &typo);
    let diag = d["diagnostics"][0].clone();
    let r = c.result(
        "textDocument/codeAction",
        json!({"textDocument": text_doc(URI), "range": diag["range"], "context": {"diagnostics": [diag]}}),
    );
    assert_eq!(r[0]["title"], "Replace with `diffuse`");
    assert_eq!(r[0]["kind"], "quickfix");
    let e = &r[0]["edit"]["changes"][URI][0];
    assert_eq!(e["newText"], "diffuse");
    assert_eq!(e["range"]["start"], pos(&typo, "difuse", 0, 0));
    // No conversion is offered for a document that does not parse? It parses: names are checked later.
    assert!(
        labels_of(&r).contains(&"Convert the document to ASCII spellings (delta, pi, <-, (+))".to_string())
    );

    let missing = PROGRAM.replace("vector L : light(0);", "vector L : light(0)");
    let d = c.change(URI, 2, &missing);
    let diag = d["diagnostics"][0].clone();
    let r = c.result(
        "textDocument/codeAction",
        json!({"textDocument": text_doc(URI), "range": diag["range"], "context": {"diagnostics": [diag]}}),
    );
    assert_eq!(r[0]["title"], "Insert `;`");
    let e = &r[0]["edit"]["changes"][URI][0];
    assert_eq!(e["newText"], ";");
    assert_eq!(e["range"]["start"], pos(&missing, "\nconst kd", 0, 0));
    assert_eq!(r.as_array().unwrap().len(), 1, "no conversion of a document with syntax errors: {r}");

    // ASCII → Unicode and back; the converted text checks clean.
    c.change(URI, 3, PROGRAM);
    let r = c.result("textDocument/codeAction", whole(URI));
    let ascii = r
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["kind"] == "source.convert" && a["title"].as_str().unwrap().contains("ASCII"))
        .unwrap();
    let text = ascii["edit"]["changes"][URI][0]["newText"].as_str().unwrap().to_string();
    assert!(text.contains("C delta pi x <- base (+) delta p s x;"), "{text}");
    assert!(!text.contains('δ') && text.starts_with("// target: geforce3\n"));
    assert_eq!(messages(&c.change(URI, 4, &text)), Vec::<String>::new());
    let r = c.result("textDocument/codeAction", whole(URI));
    let unicode =
        r.as_array().unwrap().iter().find(|a| a["title"].as_str().unwrap().contains("Unicode")).unwrap();
    let back = unicode["edit"]["changes"][URI][0]["newText"].as_str().unwrap();
    assert!(back.contains("C δπx ← base ⊕ δ p s x;"), "{back}");
    assert!(c.shutdown().success());
}

fn labels_of(r: &Value) -> Vec<String> {
    r.as_array().unwrap().iter().map(|a| a["title"].as_str().unwrap().to_string()).collect()
}

#[test]
fn a_panicking_request_answers_an_error_and_the_server_goes_on() {
    let mut c = Client::start(Value::Null, &[("SHADEC_LSP_TEST_HOOKS", "1")]);
    c.open(URI, PROGRAM);
    let e = c.request("shadec/panicForTest", json!({}));
    assert_eq!(e["error"]["code"], -32603, "{e}");
    assert_eq!(
        e["error"]["message"],
        "shadec lsp: this request panicked (the test hook shadec/panicForTest panics on purpose); the server goes on"
    );
    let h = c.result("textDocument/hover", at(URI, PROGRAM, "kd", 1, 0));
    assert!(h["contents"]["value"].as_str().unwrap().starts_with("**`kd`** — constant"));
    let d = c.change(URI, 2, "C δπx ← Q;\n");
    assert_eq!(d["diagnostics"][0]["code"], "unknown-name");
    // Without the hook the method does not exist.
    let mut plain = client();
    assert_eq!(plain.request("shadec/panicForTest", json!({}))["error"]["code"], -32601);
    assert!(plain.shutdown().success());
    assert!(c.shutdown().success());
}

#[test]
fn requests_on_unopened_documents_and_unknown_methods_are_errors() {
    let mut c = client();
    let e = c.request("textDocument/hover", at("file:///nowhere.shd", "x", "x", 0, 0));
    assert_eq!(e["error"]["message"], "file:///nowhere.shd is not open");
    let e = c.request("textDocument/hover", json!({"bogus": 1}));
    assert_eq!(e["error"]["code"], -32602);
    assert_eq!(c.request("workspace/symbol", json!({"query": ""}))["error"]["code"], -32601);
    assert!(c.shutdown().success());
}

#[test]
fn check_json_writes_percent_encoded_uris() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("a b");
    std::fs::create_dir(&sub).unwrap();
    let file = sub.join("ä.shd");
    std::fs::write(&file, "C δπx ← Q;\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shadec"))
        .args(["check", "--format", "json"])
        .arg(&file)
        .output()
        .unwrap();
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let uri = report["files"][0]["uri"].as_str().unwrap();
    assert!(uri.ends_with("/a%20b/%C3%A4.shd"), "{uri}");
    assert!(uri.parse::<lsp_types::Uri>().is_ok(), "{uri}");
    assert_eq!(shadec::lsp::uri::to_path(uri).unwrap(), std::fs::canonicalize(&file).unwrap());
}

#[test]
fn the_textmate_grammar_knows_every_builtin_and_keyword() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/editors/shadec.tmLanguage.json");
    let grammar: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    assert_eq!(grammar["scopeName"], "source.shadec");
    let builtins = grammar["repository"]["builtins"]["match"].as_str().unwrap();
    let listed = |pattern: &str, word: &str| {
        pattern.contains(&format!("|{word}|"))
            || pattern.contains(&format!("({word}|"))
            || pattern.contains(&format!("|{word})"))
    };
    for f in shadec::parser::resolve::FUNCTIONS.iter().chain(shadec::parser::resolve::GENERATORS) {
        assert!(listed(builtins, f), "`{f}` is missing from the grammar's built-ins");
    }
    let decls = grammar["repository"]["declarations"].to_string();
    for k in shadec::lsp::navigation::KEYWORDS {
        let in_ops = grammar["repository"]["operators"].to_string().contains(&format!("\\\\b{k}\\\\b"));
        assert!(
            listed(&decls, k) || in_ops || ["depth", "stencil"].contains(k),
            "keyword `{k}` is missing from the grammar"
        );
    }
    // The VS Code extension points at it.
    let package: Value = serde_json::from_str(include_str!("../editors/vscode/package.json")).unwrap();
    assert_eq!(package["contributes"]["grammars"][0]["path"], "../shadec.tmLanguage.json");
}

mod robustness {
    use super::*;
    use proptest::prelude::*;

    /// Text made of the language's pieces, often malformed.
    fn program_text() -> impl Strategy<Value = String> {
        let pieces = prop::sample::select(vec![
            "C",
            "δ",
            "π",
            "x",
            "u",
            "s",
            "xs",
            "←",
            "<-",
            "⊕",
            "(+)",
            "·",
            "T",
            "N",
            "L",
            "kd",
            "p",
            "(",
            ")",
            "{",
            "}",
            ";",
            "\n",
            " ",
            "=",
            "→",
            "1",
            "0.5",
            "texture T : 2d = image(\"a.png\");",
            "vector N : normal;",
            "vector L : light(0);",
            "shader p : s → c = max(0, N·L);",
            "let a = ",
            "// c\n",
            "α",
            "′",
            "ä",
            "𝑇",
            "p(16)",
            "target geforce3;",
            "// target: geforce256\n",
            "¬",
            "Å",
            "\"",
            "/*",
        ]);
        prop::collection::vec(pieces, 0..40).prop_map(|v| v.concat())
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

        /// Whatever the text, every request is answered, none with an
        /// internal error, and the server is alive for the next.
        #[test]
        fn any_text_gets_answers_and_never_kills_the_server(text in program_text(), line in 0u32..4, character in 0u32..12) {
            let mut c = client();
            c.open(URI, &text);
            let position = json!({"line": line, "character": character});
            let at = json!({"textDocument": text_doc(URI), "position": position});
            let mut rename = at.clone();
            rename["newName"] = json!("renamed");
            for (method, params) in [
                ("textDocument/hover", at.clone()),
                ("textDocument/definition", at.clone()),
                ("textDocument/prepareRename", at.clone()),
                ("textDocument/rename", rename),
                ("textDocument/completion", at.clone()),
                ("textDocument/documentSymbol", json!({"textDocument": text_doc(URI)})),
                ("textDocument/semanticTokens/full", json!({"textDocument": text_doc(URI)})),
                ("textDocument/inlayHint", whole(URI)),
                ("textDocument/codeAction", whole(URI)),
                ("textDocument/formatting", json!({"textDocument": text_doc(URI), "options": {"tabSize": 4, "insertSpaces": true}})),
            ] {
                let r = c.request(method, params);
                prop_assert!(r["error"]["code"] != json!(-32603), "{method} on {text:?}: {r}");
            }
            let d = c.change(URI, 2, &format!("{text}\n"));
            prop_assert!(d["diagnostics"].as_array().unwrap().iter().all(|d| d["code"] != "internal-error"), "{d}");
            prop_assert!(c.shutdown().success());
        }
    }
}

/// LSP 3.17 "shutdown" and "exit": after `shutdown` requests are refused
/// (Neovim 0.7 sends a second `shutdown`), `exit` then ends with status 0;
/// `exit` without `shutdown` ends with status 1.
#[test]
fn shutdown_refuses_later_requests_and_exit_reports_order() {
    let mut c = client();
    c.open(URI, PROGRAM);
    assert_eq!(c.request("shutdown", Value::Null)["result"], Value::Null);
    let again = c.request("shutdown", Value::Null);
    assert_eq!(again["error"]["code"], -32600, "{again}");
    let hover = c.request("textDocument/hover", at(URI, PROGRAM, "kd", 1, 0));
    assert_eq!(hover["error"]["message"], "the server is shutting down");
    assert!(c.exit().success());
    assert_eq!(client().exit().code(), Some(1));
}

/// Found by the property test: an unterminated string ran its token past
/// the line's end, and the token length underflowed (a panic answered as
/// InternalError). It ends at the line's end now.
#[test]
fn an_unterminated_string_is_a_token_of_its_line() {
    let mut c = client();
    c.open(URI, "C\"ab\nx");
    let r = c.result("textDocument/semanticTokens/full", json!({"textDocument": text_doc(URI)}));
    let strings: Vec<_> = decode(&r["data"]).into_iter().filter(|t| t.3 == "string").collect();
    assert_eq!(strings, [(0, 1, 3, "string".to_string(), 0)]);
    assert!(c.shutdown().success());
}

/// seeds/001 (1) pasted from the PDF's Symbol font, `C d p x ¬ d p s x`:
/// applying the server's quick fixes one at a time, as a user would, gives a
/// program that checks.
#[test]
fn quick_fixes_turn_symbol_font_text_into_a_program_that_checks() {
    let mut c = client();
    let mut text =
        "vector N : normal;\nvector L : light(0);\nshader q : s → c = max(0, N·L);\nC d p x ¬ d q s x;\n"
            .to_string();
    let mut d = c.open(URI, &text);
    let mut version = 1;
    let mut applied = Vec::new();
    while let Some(diag) = d["diagnostics"].as_array().unwrap().iter().find(|d| d["severity"] == 1).cloned() {
        assert!(applied.len() < 10, "no progress: {applied:?} {d}");
        let r = c.result("textDocument/codeAction", json!({"textDocument": text_doc(URI), "range": diag["range"], "context": {"diagnostics": [diag]}}));
        let fix = r
            .as_array()
            .unwrap()
            .iter()
            .find(|a| a["kind"] == "quickfix")
            .unwrap_or_else(|| panic!("no fix for {diag}"));
        applied.push(fix["title"].as_str().unwrap().to_string());
        text = apply(&text, fix["edit"]["changes"][URI].as_array().unwrap());
        version += 1;
        d = c.change(URI, version, &text);
    }
    assert_eq!(applied, ["Replace with `←`", "Replace with `δ`", "Replace with `π`", "Replace with `δ`"]);
    assert!(text.ends_with("C δ π x ← δ q s x;\n"), "{text}");
    assert_eq!(messages(&d), Vec::<String>::new());
    assert!(c.shutdown().success());
}

/// "Every error of the document, as `check` finds them": for every example
/// program, what the server publishes equals what `shadec check --target T
/// --format json` writes (T: the program's own `target`, else the client's
/// geforce3).
#[test]
fn the_server_reports_what_check_reports_on_every_example() {
    let mut c = Client::start(json!({"shadec": {"target": "geforce3"}}), &[]);
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    files.sort();
    assert!(files.len() >= 20);
    let mut with_diagnostics = 0;
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let uri = shadec::lsp::uri::from_path(&path);
        let published = c.open(&uri, &text);
        let declared = shadec::parser::parse(&text).0.items.iter().find_map(|i| match &i.kind {
            shadec::parser::ast::ItemKind::Target(t) => Some(t.profile.value.clone()),
            _ => None,
        });
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_shadec"))
            .args(["check", "--format", "json", "--target", declared.as_deref().unwrap_or("geforce3")])
            .arg(&path)
            .output()
            .unwrap();
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        let expected = &report["files"][0];
        assert_eq!(expected["uri"], uri.as_str());
        let key = |d: &Value| (d["range"].to_string(), d["code"].to_string(), d["message"].to_string());
        let got: Vec<_> = published["diagnostics"].as_array().unwrap().iter().map(key).collect();
        let want: Vec<_> = expected["diagnostics"].as_array().unwrap().iter().map(key).collect();
        assert_eq!(got, want, "{}", path.display());
        with_diagnostics += usize::from(!want.is_empty());
    }
    assert!(
        with_diagnostics > 0,
        "some example has a diagnostic on geforce3, so the comparison compares something"
    );
    assert!(c.shutdown().success());
}

/// Hover names the combiner that computes a value and the error of an
/// approximation the lowering applied to it (issue 21's hover list).
#[test]
fn hover_tells_the_combiner_stage_and_the_approximation_error() {
    let mut c = client();
    let text = "// target: geforce256\ntexture A, B : 2d rgb8 = image(\"a.png\");\nconst kd : rgb = (0.8, 0.6, 0.4);\n\
        C δπx ← max(0, expand(A δu x)·expand(B δu x)) * kd;\n";
    let uri = "file:///tmp/shadec-lsp/stage.shd";
    c.open(uri, text);
    let hover = |c: &mut Client, uri: &str, text: &str, needle: &str| -> String {
        let h = c.result("textDocument/hover", at(uri, text, needle, 0, 0));
        h["contents"]["value"].as_str().unwrap_or("").to_string()
    };
    // The dot product is general combiner 0's RGB portion (seeds/003 §4.2).
    let h = hover(&mut c, uri, text, "·");
    assert!(
        h.contains("1 general stage and the final combiner; computed in general combiner 0 (RGB portion)"),
        "{h}"
    );
    let h = hover(&mut c, uri, text, "B δu x");
    assert!(
        h.contains("texture unit 1 (`B`)")
            && h.contains("read from its texture register by general combiner 0"),
        "{h}"
    );
    // The product with the constant colour is the final combiner's.
    let h = hover(&mut c, uri, text, "* kd");
    assert!(h.contains("no general combiner computes it: an input mapping or the final combiner"), "{h}");
    // Lowered for geforce256: the rule, its error bound, and what that
    // becomes at the output. (`fragment_lighting.shd` is no longer the
    // example: measured on the built-in torus, its per-vertex fall-back is
    // more accurate there than the cube maps, so that is the plan.)
    let text = "// target: geforce256\ntexture A : 2d rgb8 = image(\"a.png\");\nvector L : light(0);\n\
        C δπx ← max(0, expand(A δu x)·normalize(L δ s x));\n";
    let uri = "file:///tmp/shadec-lsp/lighting.shd";
    c.open(uri, text);
    let h = hover(&mut c, uri, text, "normalize(L");
    assert!(h.contains("- approximated by `normalization_cube_map`: `normalize` per fragment is a lookup in an 8-bit normalization cube map"), "{h}");
    assert!(h.contains("(error ≤ 0.004 here, ≤ 0.0119 at the output)"), "{h}");
    assert!(c.shutdown().success());
}
