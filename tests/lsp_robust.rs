//! `shadec lsp` driven by a careless client (issue 40): malformed frames
//! and messages, requests out of order, incremental edits and bursts of
//! them. The server must answer what it can, report what it cannot as
//! JSON-RPC says, and never exit before `exit`.

use crate::common_lsp;

use common_lsp::{pos, Client};
use serde_json::{json, Value};

const URI: &str = "file:///tmp/shadec-lsp/robust.shd";

const PROGRAM: &str = "\
vector N : normal;
vector L : light(0);
const kd : rgb = (0.8, 0.6, 0.4);
C δπx ← kd * max(0, N·L);
";

fn frame(body: &[u8]) -> Vec<u8> {
    let mut f = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
    f.extend_from_slice(body);
    f
}

fn hover_params() -> Value {
    json!({"textDocument": {"uri": URI}, "position": pos(PROGRAM, "kd", 1, 0)})
}

fn hover_body(id: i64) -> String {
    json!({"jsonrpc": "2.0", "id": id, "method": "textDocument/hover", "params": hover_params()}).to_string()
}

/// The hover on `kd` is answered, as a hover.
fn assert_hover_answered(c: &mut Client, what: &str) {
    let h = c.request("textDocument/hover", hover_params());
    let text = h["result"]["contents"]["value"].as_str().unwrap_or_else(|| panic!("after {what}: {h}"));
    assert!(text.starts_with("**`kd`**"), "after {what}: {h}");
    assert!(c.alive(), "the server exited after {what}");
}

fn change_text(version: i32, text_json: &str) -> Vec<u8> {
    frame(
        format!(
            r#"{{"jsonrpc":"2.0","method":"textDocument/didChange","params":{{"textDocument":{{"uri":"{URI}","version":{version}}},"contentChanges":[{{"text":{text_json}}}]}}}}"#
        )
        .as_bytes(),
    )
}

/// Every malformed input of issue 40, each followed by a hover that must
/// be answered; the errors that JSON-RPC asks for come back with id null;
/// the server is alive at the end and exits 0 after `shutdown`.
#[test]
fn no_byte_sequence_stops_the_server() {
    let mut c = Client::start(Value::Null, &[]);
    c.open(URI, PROGRAM);
    let hover = hover_body(9001);
    let deep = format!(
        r#"{{"jsonrpc":"2.0","id":9100,"method":"textDocument/hover","params":{}{}}}"#,
        "[".repeat(300),
        "]".repeat(300)
    );
    // (what, bytes, the error code answered with id null, if one is)
    let mut cases: Vec<(&str, Vec<u8>, Option<i64>)> = vec![
        ("invalid JSON", frame(b"{\"jsonrpc\": \"2.0\", \"id\": 1, \"method\": "), Some(-32700)),
        ("a length 3 bytes short", {
            let mut f = format!("Content-Length: {}\r\n\r\n", hover.len() - 3).into_bytes();
            f.extend_from_slice(hover.as_bytes());
            f
        }, Some(-32700)),
        ("a header without Content-Length", format!("Content-Type: application/json\r\n\r\n{hover}").into_bytes(), Some(-32700)),
        ("a length that is not a number", b"Content-Length: twelve\r\n\r\n{}".to_vec(), Some(-32700)),
        ("noise between frames", b"\x00\x01garbage\xff\xfe\r\n".to_vec(), Some(-32700)),
        ("params nested 300 deep", frame(deep.as_bytes()), Some(-32700)),
        ("a batch", frame(format!("[{hover}]").as_bytes()), Some(-32600)),
        ("an empty batch", frame(b"[]"), Some(-32600)),
        ("a string", frame(b"\"hello\""), Some(-32600)),
        ("no jsonrpc member", frame(br#"{"id":5,"method":"textDocument/hover"}"#), None),
        ("an object as id", frame(br#"{"jsonrpc":"2.0","id":{"a":1},"method":"x"}"#), Some(-32600)),
        ("a number as method", frame(br#"{"jsonrpc":"2.0","method":5}"#), Some(-32600)),
        ("neither method nor result", frame(br#"{"jsonrpc":"2.0"}"#), Some(-32600)),
        ("a response to nothing", frame(br#"{"jsonrpc":"2.0","id":77,"result":null}"#), None),
        ("an unknown notification", frame(br#"{"jsonrpc":"2.0","method":"$/whatever","params":{}}"#), None),
        ("didOpen with params of the wrong shape", frame(br#"{"jsonrpc":"2.0","method":"textDocument/didOpen","params":5}"#), None),
        ("a change to a document that is not open", frame(br#"{"jsonrpc":"2.0","method":"textDocument/didChange","params":{"textDocument":{"uri":"file:///none.shd","version":3},"contentChanges":[{"text":"x"}]}}"#), None),
        ("a cancel of an unknown request", frame(br#"{"jsonrpc":"2.0","method":"$/cancelRequest","params":{"id":123456}}"#), None),
    ];
    // A length a few bytes long: the message and the next one both read.
    let mut long = format!("Content-Length: {}\r\n\r\n{hover}", hover.len() + 4).into_bytes();
    long.extend(frame(hover_body(9002).as_bytes()));
    cases.push(("a length 4 bytes long", long, None));
    for (what, bytes, code) in cases {
        c.raw(&bytes);
        assert_hover_answered(&mut c, what);
        if let Some(code) = code {
            let e = c.response(&Value::Null);
            assert_eq!(e["error"]["code"], code, "{what}: {e}");
            assert!(!e["error"]["message"].as_str().unwrap().is_empty(), "{what}: {e}");
        }
    }
    // The long frame's own request, and the one it swallowed the header of.
    for id in [9001, 9002] {
        let r = c.response(&json!(id));
        assert!(r["result"]["contents"]["value"].as_str().is_some(), "{r}");
    }
    // A request without `jsonrpc` is answered with its id.
    assert_eq!(c.response(&json!(5))["error"]["code"], -32600);

    // Text that is not Unicode: a lone surrogate (valid JSON) and bytes
    // that are not UTF-8 in a document's text.
    let mut bad_utf8 = change_text(
        2,
        r#""C δπx ← kd;\n// \ud800 lone\nvector N : normal;\nvector L : light(0);\nconst kd : rgb = (0.8, 0.6, 0.4);\n""#,
    );
    let at = bad_utf8.windows(4).position(|w| w == b"lone").unwrap();
    bad_utf8[at] = 0xff;
    c.raw(&bad_utf8);
    let d = c.diagnostics(URI);
    let fffd: Vec<&Value> = d["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d["code"] == "replacement-character")
        .collect();
    assert_eq!(fffd.len(), 2, "{d}");
    assert_eq!(fffd[0]["range"]["start"], json!({"line": 1, "character": 3}), "{d}");
    assert_eq!(fffd[1]["range"]["start"], json!({"line": 1, "character": 5}), "{d}");
    assert!(fffd[0]["message"].as_str().unwrap().contains("lone UTF-16 surrogate"), "{d}");
    c.change(URI, 3, PROGRAM);

    // Requests the protocol answers with errors, and positions out of range.
    assert_eq!(c.request("initialize", json!({"capabilities": {}}))["error"]["code"], -32600);
    assert_eq!(c.request("no/suchMethod", json!({}))["error"]["code"], -32601);
    let far = json!({"textDocument": {"uri": URI}, "position": {"line": 1_000_000, "character": 4_000_000}});
    let r = c.request("textDocument/hover", far.clone());
    assert!(r.get("error").is_none(), "{r}");
    let r = c.request("textDocument/definition", far);
    assert!(r.get("error").is_none(), "{r}");
    assert_hover_answered(&mut c, "everything");
    assert!(c.shutdown().success());
}

/// Before `initialize`, requests get ServerNotInitialized and
/// notifications are dropped; a request or `didOpen` between the
/// `initialize` reply and `initialized` is served (clients race there).
#[test]
fn requests_before_initialize_and_before_initialized() {
    let mut c = Client::spawn(&[]);
    let e = c.request("textDocument/hover", hover_params());
    assert_eq!(e["error"]["code"], -32002, "{e}");
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": URI, "languageId": "shadec", "version": 1, "text": PROGRAM}}),
    );
    let r = c.request("initialize", json!({"processId": null, "capabilities": {}}));
    assert_eq!(r["result"]["capabilities"]["textDocumentSync"]["change"], 2, "{r}");
    // The didOpen before initialize was dropped: the document is not open.
    let e = c.request("textDocument/hover", hover_params());
    assert_eq!(e["error"]["message"], format!("{URI} is not open"), "{e}");
    // `initialized` not sent yet: open and ask anyway.
    c.open(URI, PROGRAM);
    assert_hover_answered(&mut c, "a request before `initialized`");
    c.notify("initialized", json!({}));
    assert_hover_answered(&mut c, "`initialized`");
    assert!(c.shutdown().success());
}

/// `exit` before `initialize` ends with status 1 (LSP 3.17 `exit`), and
/// the `initialize` reply is written before the process ends even when
/// `exit` follows at once.
#[test]
fn exit_codes_and_the_initialize_reply_is_flushed() {
    let c = Client::spawn(&[]);
    assert_eq!(c.exit().code(), Some(1));
    for _ in 0..3 {
        let mut c = Client::spawn(&[]);
        let mut bytes =
            frame(br#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"capabilities":{}}}"#);
        bytes.extend(frame(br#"{"jsonrpc":"2.0","method":"exit"}"#));
        c.raw(&bytes);
        let r = c.response(&json!(1));
        assert!(r["result"]["capabilities"].is_object(), "{r}");
        assert_eq!(c.wait().code(), Some(1));
    }
    // The input ending without `exit`: status 1 as well.
    let c = Client::start(Value::Null, &[]);
    assert_eq!(c.wait().code(), Some(1));
}

/// Incremental changes (ranges in UTF-16 units, across lines and
/// astral characters) give the diagnostics that the whole text gives.
#[test]
fn incremental_changes_give_the_diagnostics_of_the_full_text() {
    let mut c = Client::start(Value::Null, &[]);
    c.open(URI, PROGRAM);
    let range = |l0: u32, c0: u32, l1: u32, c1: u32| json!({"start": {"line": l0, "character": c0}, "end": {"line": l1, "character": c1}});
    // Rename kd to 𝑘 in the declaration (line 2, characters 6-8), then
    // break the statement's use, then add a line.
    let changes = json!([
        {"range": range(2, 6, 2, 8), "text": "𝑘"},
        {"range": range(3, 8, 3, 10), "text": "kdd"},
        {"range": range(3, 0, 3, 0), "text": "// 𝑇𝑇 note\n"},
        {"range": range(0, 0, 1, 0), "text": ""},
    ]);
    c.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": URI, "version": 2}, "contentChanges": changes}),
    );
    let incremental = c.diagnostics(URI);
    let expected_text = "\
vector L : light(0);
const 𝑘 : rgb = (0.8, 0.6, 0.4);
// 𝑇𝑇 note
C δπx ← kdd * max(0, N·L);
";
    let other = "file:///tmp/shadec-lsp/full.shd";
    let full = c.open(other, expected_text);
    assert_eq!(incremental["diagnostics"], full["diagnostics"]);
    assert_eq!(incremental["version"], 2);
    assert!(!full["diagnostics"].as_array().unwrap().is_empty());
    let format = |c: &mut Client, uri: &str| {
        let r = c.request(
            "textDocument/formatting",
            json!({"textDocument": {"uri": uri}, "options": {"tabSize": 4, "insertSpaces": true}}),
        );
        (r["result"].clone(), r["error"].clone())
    };
    assert_eq!(format(&mut c, URI), format(&mut c, other));
    assert!(c.shutdown().success());
}

/// A large program: `n` declarations and statements.
fn large_program(n: usize, misspelled: bool) -> String {
    let mut s = String::from("vector N : normal;\nvector L : light(0);\n");
    for i in 0..n {
        s.push_str(&format!("const k_{i:05} = 0.5;\n"));
    }
    for i in 0..n {
        let name = if misspelled && i % 2 == 0 { format!("kk_{i:05}") } else { format!("k_{i:05}") };
        s.push_str(&format!("C δπx ← {name} * max(0, N·L);\n"));
    }
    s
}

/// A burst of changes: the last version's diagnostics come last, versions
/// never go back, fewer analyses than changes are published, and a hover
/// sent in the burst is answered (from the last analysis).
#[test]
fn a_burst_of_changes_publishes_the_last_version_last() {
    let mut c = Client::start(Value::Null, &[]);
    let base = large_program(3000, false);
    c.open(URI, &base);
    let changes = 30;
    for v in 2..2 + changes {
        let text = large_program(3000, v % 2 == 1);
        c.notify(
            "textDocument/didChange",
            json!({"textDocument": {"uri": URI, "version": v}, "contentChanges": [{"text": text}]}),
        );
    }
    let h = c.request(
        "textDocument/hover",
        json!({"textDocument": {"uri": URI}, "position": {"line": 2, "character": 7}}),
    );
    assert!(h["result"]["contents"]["value"].as_str().is_some_and(|t| t.contains("k_00000")), "{h}");
    // Definition waits for the current version's analysis: its answer
    // comes after that version's diagnostics.
    let last = 1 + changes;
    let d = c.request(
        "textDocument/definition",
        json!({"textDocument": {"uri": URI}, "position": {"line": 3002, "character": 9}}),
    );
    assert!(d.get("error").is_none(), "{d}");
    let published: Vec<i64> = c
        .take_pending()
        .into_iter()
        .filter(|v| v["method"] == "textDocument/publishDiagnostics")
        .map(|v| v["params"]["version"].as_i64().unwrap())
        .collect();
    assert_eq!(published.last(), Some(&(last as i64)), "{published:?}");
    assert!(published.windows(2).all(|w| w[0] < w[1]), "{published:?}");
    assert!(published.len() < changes as usize, "every change was analysed and published: {published:?}");
    assert!(c.shutdown().success());
}

/// A request waiting for an analysis that `$/cancelRequest` names is
/// answered RequestCancelled, or with its result if the analysis won.
#[test]
fn a_waiting_request_can_be_cancelled() {
    let mut c = Client::start(Value::Null, &[]);
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": URI, "languageId": "shadec", "version": 1, "text": large_program(4000, true)}}),
    );
    let id = c.send_request(
        "textDocument/definition",
        json!({"textDocument": {"uri": URI}, "position": {"line": 4003, "character": 9}}),
    );
    c.notify("$/cancelRequest", json!({"id": id}));
    let r = c.response(&json!(id));
    assert!(r["error"]["code"] == -32800 || r.get("result").is_some(), "{r}");
    assert!(c.shutdown().success());
}

/// A hover sent while the server analyses a newer version is answered from
/// the last analysis, at the characters under the client's cursor: lines
/// inserted above the position move it, and the answer follows (it used to
/// read the new position against the old text, one constant off per line
/// inserted). The hover's range is in the client's text too.
#[test]
fn a_hover_answered_from_an_older_analysis_follows_the_edit() {
    let mut c = Client::start(Value::Null, &[]);
    let base = large_program(3000, false);
    c.open(URI, &base);
    // Three declarations inserted at the top (an incremental change), then
    // at once a hover on `k_00100`'s declaration, five lines lower now.
    let inserted = "const a1 = 0.1;\nconst a2 = 0.2;\nconst a3 = 0.3;\n";
    c.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": URI, "version": 2}, "contentChanges": [
            {"range": {"start": {"line": 0, "character": 0}, "end": {"line": 0, "character": 0}}, "text": inserted}
        ]}),
    );
    let line = 2 + 3 + 100;
    let h = c.request(
        "textDocument/hover",
        json!({"textDocument": {"uri": URI}, "position": {"line": line, "character": 8}}),
    );
    let text = h["result"]["contents"]["value"].as_str().unwrap_or_else(|| panic!("no hover: {h}"));
    assert!(text.contains("k_00100"), "the hover is about another line: {h}");
    assert_eq!(h["result"]["range"]["start"]["line"], json!(line), "{h}");
    assert!(c.shutdown().success());
}
