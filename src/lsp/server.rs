//! The server loop over stdio.
//!
//! Four threads: one reads standard input in chunks, one frames them into
//! messages (`transport.rs`, which survives any byte sequence), one analyses
//! documents, and this one — the loop — owns the open documents, answers
//! requests and writes every reply, flushed, to standard output.
//!
//! **Work follows the typist.** The loop takes every message that has
//! arrived before it acts, applies each document's changes to its text in
//! order (full or incremental sync), and hands the analyser only the newest
//! version; a version still queued when a newer one comes is replaced, and
//! one being analysed when a newer one is queued stops after the front end
//! (the planner is skipped). A burst of edits costs at most one analysis
//! in flight plus one of the last version. Diagnostics are published only
//! for the current version, so the last version's come last.
//!
//! **Answers do not wait for analysis when they need not.** Hover,
//! completion, semantic tokens, inlay hints and document symbols are
//! answered at once from the last analysis of the document, even when a
//! newer version is being analysed (their positions are read against the
//! text that analysis saw). Requests whose answer edits or points into the
//! text — definition, references, rename, formatting, code actions — and
//! any request on a document not yet analysed wait for the current
//! version's analysis; `$/cancelRequest` answers a waiting one with
//! RequestCancelled (-32800).
//!
//! **Lifecycle (LSP 3.17).** Before `initialize`, requests are answered
//! ServerNotInitialized (-32002) and notifications other than `exit`
//! dropped; messages between the `initialize` reply and `initialized` are
//! served (clients race there); after `shutdown`, requests are refused
//! until `exit`. The exit status is 0 after `shutdown`, 1 otherwise
//! (`exit` without `shutdown`, or the input ending).
//!
//! Every request runs under `catch_unwind`: a panic answers that request
//! with an InternalError and the server goes on.

use std::collections::{HashMap, VecDeque};
use std::io::Write as _;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc::{channel, sync_channel, Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex};

use lsp_server::ErrorCode;
use lsp_types::notification::{self as notif, Notification as _};
use lsp_types::*;
use serde_json::{json, Value};

use super::documents::{analyze_version, apply_change, offset_of, Document, Drift};
use super::transport::{Incoming, Reader};
use super::{
    code_actions, completion, diagnostics, formatting, hover, inlay_hints, navigation, semantic_tokens,
    symbols,
};
use crate::parser::print::Style;

/// Requests under this method panic on purpose when the environment
/// variable `SHADEC_LSP_TEST_HOOKS` is `1`: how the tests check that a
/// panic does not kill the server.
pub const PANIC_FOR_TEST: &str = "shadec/panicForTest";

/// What the server answers `initialize` with.
pub fn capabilities() -> ServerCapabilities {
    ServerCapabilities {
        text_document_sync: Some(TextDocumentSyncCapability::Options(TextDocumentSyncOptions {
            open_close: Some(true),
            change: Some(TextDocumentSyncKind::INCREMENTAL),
            save: Some(TextDocumentSyncSaveOptions::SaveOptions(SaveOptions { include_text: Some(true) })),
            ..Default::default()
        })),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        definition_provider: Some(OneOf::Left(true)),
        references_provider: Some(OneOf::Left(true)),
        rename_provider: Some(OneOf::Right(RenameOptions {
            prepare_provider: Some(true),
            work_done_progress_options: Default::default(),
        })),
        document_symbol_provider: Some(OneOf::Left(true)),
        document_formatting_provider: Some(OneOf::Left(true)),
        semantic_tokens_provider: Some(SemanticTokensServerCapabilities::SemanticTokensOptions(
            SemanticTokensOptions {
                legend: semantic_tokens::legend(),
                full: Some(SemanticTokensFullOptions::Bool(true)),
                range: None,
                work_done_progress_options: Default::default(),
            },
        )),
        inlay_hint_provider: Some(OneOf::Left(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec!["\\".into(), "-".into(), ")".into()]),
            ..Default::default()
        }),
        code_action_provider: Some(CodeActionProviderCapability::Options(CodeActionOptions {
            code_action_kinds: Some(vec![CodeActionKind::QUICKFIX, CodeActionKind::new("source.convert")]),
            ..Default::default()
        })),
        ..Default::default()
    }
}

/// `shadec.target` from initializationOptions or settings: `{"target": T}`
/// or `{"shadec": {"target": T}}`.
pub fn configured_target(options: &Value) -> Option<String> {
    let t = options.get("shadec").and_then(|s| s.get("target")).or_else(|| options.get("target"))?;
    t.as_str().map(str::to_string)
}

/// Runs the server on stdin/stdout until `exit` (or the end of input).
/// Whether it was shut down in order (`shutdown` before `exit`); `Err`
/// when standard output cannot be written (the client is gone).
pub fn run() -> anyhow::Result<bool> {
    let (events, inbox) = channel();
    // Standard input in chunks, a bounded queue of them: a client that
    // writes faster than the server frames waits, memory stays flat.
    let (chunks_in, chunks) = sync_channel::<Vec<u8>>(64);
    std::thread::spawn(move || {
        use std::io::Read as _;
        let mut stdin = std::io::stdin().lock();
        let mut buf = vec![0u8; 1 << 16];
        loop {
            match stdin.read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => {
                    if chunks_in.send(buf[..n].to_vec()).is_err() {
                        break;
                    }
                }
            }
        }
    });
    let framer = events.clone();
    std::thread::spawn(move || {
        let mut reader = Reader::new(chunks);
        while let Some(incoming) = reader.next_message() {
            if framer.send(Event::Incoming(incoming)).is_err() {
                return;
            }
        }
        let _ = framer.send(Event::InputEnded);
    });
    let jobs = Arc::new(Jobs::default());
    {
        let (jobs, events) = (jobs.clone(), events.clone());
        std::thread::spawn(move || analyser(&jobs, &events));
    }
    let mut out = std::io::stdout().lock();
    let mut server = Server::new(jobs);
    let result = server.serve(&inbox, &mut |v: &Value| write_message(&mut out, v));
    let _ = out.flush();
    result
}

/// One framed message on `out`, flushed (the reply to `initialize` was
/// sometimes lost when the process ended before `lsp-server`'s writer
/// thread wrote it).
fn write_message(out: &mut impl std::io::Write, v: &Value) -> std::io::Result<()> {
    let body = serde_json::to_vec(v).map_err(std::io::Error::other)?;
    write!(out, "Content-Length: {}\r\n\r\n", body.len())?;
    out.write_all(&body)?;
    out.flush()
}

/// What the loop waits for.
pub enum Event {
    Incoming(Incoming),
    InputEnded,
    /// The analyser's result for a document's version (`None`: it stopped
    /// because a newer one was waiting).
    Analysed {
        uri: String,
        generation: u64,
        document: Option<Box<Document>>,
    },
}

/// One document version to analyse.
struct Job {
    generation: u64,
    version: i32,
    text: Arc<str>,
    client_target: Option<String>,
}

/// The analyser's queue: at most one job per document, the newest (a
/// newer version replaces a queued one in place).
#[derive(Default)]
struct Jobs {
    queue: Mutex<(VecDeque<String>, HashMap<String, Job>)>,
    ready: Condvar,
}

impl Jobs {
    fn submit(&self, uri: &str, job: Job) {
        let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
        if q.1.insert(uri.to_string(), job).is_none() {
            q.0.push_back(uri.to_string());
        }
        self.ready.notify_one();
    }

    fn has_newer(&self, uri: &str) -> bool {
        self.queue.lock().unwrap_or_else(|e| e.into_inner()).1.contains_key(uri)
    }
}

fn analyser(jobs: &Jobs, events: &Sender<Event>) {
    loop {
        let (uri, job) = {
            let mut q = jobs.queue.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if let Some(uri) = q.0.pop_front() {
                    // A queued uri has its job (`submit` inserts both); one
                    // without is skipped rather than ending the server.
                    if let Some(job) = q.1.remove(&uri) {
                        break (uri, job);
                    }
                    continue;
                }
                q = jobs.ready.wait(q).unwrap_or_else(|e| e.into_inner());
            }
        };
        let superseded = || jobs.has_newer(&uri);
        let document =
            analyze_version(&uri, job.version, &job.text, job.client_target.as_deref(), &superseded);
        let event = Event::Analysed { uri, generation: job.generation, document: document.map(Box::new) };
        if events.send(event).is_err() {
            return;
        }
    }
}

/// An open document: the text as the client has it now, and the last
/// analysis that finished.
struct Open {
    version: i32,
    text: String,
    /// The generation of the job for the current text.
    wanted: u64,
    /// The generation of the first job of this opening: results of an
    /// earlier opening of the same URI are not this one's.
    opened: u64,
    analysed: Option<(u64, Arc<Document>)>,
    /// Changed since the last job was submitted.
    dirty: bool,
    /// Requests waiting for the current version's analysis.
    waiting: Vec<(Value, String, Value)>,
}

impl Open {
    fn fresh(&self) -> Option<&Arc<Document>> {
        self.analysed.as_ref().filter(|(g, _)| *g == self.wanted && !self.dirty).map(|(_, d)| d)
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// No `initialize` yet.
    Uninitialized,
    Running,
    /// `shutdown` answered: only `exit` is left.
    ShuttingDown,
}

struct Server {
    phase: Phase,
    docs: HashMap<String, Open>,
    client_target: Option<String>,
    jobs: Arc<Jobs>,
    generation: u64,
}

type Writer<'w> = dyn FnMut(&Value) -> std::io::Result<()> + 'w;

impl Server {
    fn new(jobs: Arc<Jobs>) -> Server {
        Server { phase: Phase::Uninitialized, docs: HashMap::new(), client_target: None, jobs, generation: 0 }
    }

    /// The session: until `exit` or the end of input; whether `shutdown`
    /// came first.
    fn serve(&mut self, inbox: &Receiver<Event>, out: &mut Writer) -> anyhow::Result<bool> {
        loop {
            // Everything that has arrived, then act: a burst of changes is
            // one job per document.
            let Ok(first) = inbox.recv() else { return Ok(self.phase == Phase::ShuttingDown) };
            let batch: Vec<Event> = std::iter::once(first).chain(inbox.try_iter()).collect();
            for event in batch {
                match event {
                    Event::InputEnded => return Ok(self.phase == Phase::ShuttingDown),
                    Event::Incoming(Incoming::Notification { method, .. }) if method == "exit" => {
                        return Ok(self.phase == Phase::ShuttingDown)
                    }
                    Event::Incoming(incoming) => self.incoming(incoming, out)?,
                    Event::Analysed { uri, generation, document } => {
                        self.analysed(&uri, generation, document, out)?
                    }
                }
            }
            self.submit_dirty();
        }
    }

    fn submit_dirty(&mut self) {
        let mut dirty: Vec<&String> = self.docs.iter().filter(|(_, d)| d.dirty).map(|(u, _)| u).collect();
        dirty.sort();
        let dirty: Vec<String> = dirty.into_iter().cloned().collect();
        for uri in dirty {
            self.generation += 1;
            let Some(d) = self.docs.get_mut(&uri) else { continue };
            d.dirty = false;
            d.wanted = self.generation;
            let job = Job {
                generation: self.generation,
                version: d.version,
                text: Arc::from(d.text.as_str()),
                client_target: self.client_target.clone(),
            };
            self.jobs.submit(&uri, job);
        }
    }

    fn analysed(
        &mut self,
        uri: &str,
        generation: u64,
        document: Option<Box<Document>>,
        out: &mut Writer,
    ) -> std::io::Result<()> {
        let (Some(d), Some(document)) = (self.docs.get_mut(uri), document) else { return Ok(()) };
        if generation < d.opened || d.analysed.as_ref().is_some_and(|(g, _)| *g > generation) {
            return Ok(());
        }
        d.analysed = Some((generation, Arc::new(*document)));
        let Some(fresh) = d.fresh().cloned() else { return Ok(()) };
        let waiting = std::mem::take(&mut d.waiting);
        let Ok(u) = uri.parse::<Uri>() else { return Ok(()) };
        let published = diagnostics::publish(&fresh, &u);
        out(&notification(notif::PublishDiagnostics::METHOD, published))?;
        for (id, method, params) in waiting {
            out(&answer(id, method, params, &fresh))?;
        }
        Ok(())
    }

    fn incoming(&mut self, incoming: Incoming, out: &mut Writer) -> std::io::Result<()> {
        match incoming {
            Incoming::Response => Ok(()),
            Incoming::Invalid { id, code, message } => out(&error_response(id, code, &message)),
            Incoming::Notification { method, params } => {
                if self.phase == Phase::Running {
                    self.notification(&method, params, out)?;
                }
                // Before `initialize` and after `shutdown` notifications
                // are dropped (LSP 3.17); `exit` was handled by the loop.
                Ok(())
            }
            Incoming::Request { id, method, params } => self.request(id, method, params, out),
        }
    }

    fn request(&mut self, id: Value, method: String, params: Value, out: &mut Writer) -> std::io::Result<()> {
        match (self.phase, method.as_str()) {
            (Phase::Uninitialized, "initialize") => {
                let options = params.get("initializationOptions").cloned().unwrap_or(Value::Null);
                self.client_target = configured_target(&options);
                self.phase = Phase::Running;
                let result = InitializeResult {
                    capabilities: capabilities(),
                    server_info: Some(ServerInfo {
                        name: "shadec".into(),
                        version: Some(env!("CARGO_PKG_VERSION").into()),
                    }),
                };
                out(&json!({"jsonrpc": "2.0", "id": id, "result": result}))
            }
            (Phase::Uninitialized, _) => out(&error_response(
                id,
                -32002,
                &format!("the server is not initialized: send `initialize` before `{}`", escape(&method)),
            )),
            (Phase::ShuttingDown, _) => {
                out(&error_response(id, ErrorCode::InvalidRequest as i32, "the server is shutting down"))
            }
            (Phase::Running, "initialize") => out(&error_response(
                id,
                ErrorCode::InvalidRequest as i32,
                "the server is already initialized (`initialize` comes once)",
            )),
            (Phase::Running, "shutdown") => {
                self.phase = Phase::ShuttingDown;
                // Waiting requests will not be answered by an analysis now.
                let waiting: Vec<Value> = self
                    .docs
                    .values_mut()
                    .flat_map(|d| std::mem::take(&mut d.waiting))
                    .map(|w| w.0)
                    .collect();
                for id in waiting {
                    out(&error_response(
                        id,
                        ErrorCode::InvalidRequest as i32,
                        "the server is shutting down",
                    ))?;
                }
                out(&json!({"jsonrpc": "2.0", "id": id, "result": null}))
            }
            (Phase::Running, _) => {
                let uri = params.pointer("/textDocument/uri").and_then(Value::as_str).map(str::to_string);
                let Some(d) = uri.as_ref().and_then(|u| self.docs.get_mut(u)) else {
                    // No document (or not an open one): answered at once.
                    return out(&answer_without_document(id, method, params));
                };
                let current = d.fresh().cloned();
                let last = d.analysed.as_ref().map(|(_, doc)| doc.clone());
                match (current, last) {
                    (Some(doc), _) => out(&answer(id, method, params, &doc)),
                    (None, Some(doc)) if answers_from_last_analysis(&method) => {
                        out(&answer_from_older(id, method, params, &doc, &d.text))
                    }
                    _ => {
                        d.waiting.push((id, method, params));
                        Ok(())
                    }
                }
            }
        }
    }

    fn notification(&mut self, method: &str, params: Value, out: &mut Writer) -> std::io::Result<()> {
        match method {
            notif::DidOpenTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidOpenTextDocumentParams>(params) else {
                    return Ok(());
                };
                let uri = p.text_document.uri.as_str().to_string();
                if let Some(old) = self.docs.remove(&uri) {
                    cancel_waiting(old.waiting, out, "the document was opened again")?;
                }
                let open = Open {
                    version: p.text_document.version,
                    text: p.text_document.text,
                    wanted: 0,
                    opened: self.generation + 1,
                    analysed: None,
                    dirty: true,
                    waiting: Vec::new(),
                };
                self.docs.insert(uri, open);
            }
            notif::DidChangeTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidChangeTextDocumentParams>(params) else {
                    return Ok(());
                };
                let Some(d) = self.docs.get_mut(p.text_document.uri.as_str()) else { return Ok(()) };
                for change in p.content_changes {
                    apply_change(&mut d.text, change.range, &change.text);
                }
                d.version = p.text_document.version;
                d.dirty = true;
            }
            notif::DidSaveTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidSaveTextDocumentParams>(params) else {
                    return Ok(());
                };
                if let (Some(text), Some(d)) = (p.text, self.docs.get_mut(p.text_document.uri.as_str())) {
                    if text != d.text {
                        d.text = text;
                        d.dirty = true;
                    }
                }
            }
            notif::DidCloseTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidCloseTextDocumentParams>(params) else {
                    return Ok(());
                };
                if let Some(old) = self.docs.remove(p.text_document.uri.as_str()) {
                    cancel_waiting(old.waiting, out, "the document was closed")?;
                }
                let cleared =
                    PublishDiagnosticsParams { uri: p.text_document.uri, diagnostics: vec![], version: None };
                out(&notification(notif::PublishDiagnostics::METHOD, cleared))?;
            }
            notif::DidChangeConfiguration::METHOD => {
                let Ok(p) = serde_json::from_value::<DidChangeConfigurationParams>(params) else {
                    return Ok(());
                };
                self.client_target = configured_target(&p.settings);
                self.docs.values_mut().for_each(|d| d.dirty = true);
            }
            notif::Cancel::METHOD => {
                let Some(id) = params.get("id") else { return Ok(()) };
                for d in self.docs.values_mut() {
                    if let Some(i) = d.waiting.iter().position(|w| w.0 == *id) {
                        let (id, _, _) = d.waiting.remove(i);
                        out(&error_response(id, -32800, "the request was cancelled"))?;
                        break;
                    }
                }
            }
            _ => {}
        }
        Ok(())
    }
}

/// Whether a request may be answered from an analysis of an older version
/// while the current one is analysed: those that only show (their answer
/// is replaced by the next), not those whose answer edits the text or
/// sends the editor somewhere.
fn answers_from_last_analysis(method: &str) -> bool {
    use lsp_types::request::{self as r, Request as _};
    [
        r::HoverRequest::METHOD,
        r::Completion::METHOD,
        r::SemanticTokensFullRequest::METHOD,
        r::InlayHintRequest::METHOD,
        r::DocumentSymbolRequest::METHOD,
    ]
    .contains(&method)
}

fn cancel_waiting(waiting: Vec<(Value, String, Value)>, out: &mut Writer, why: &str) -> std::io::Result<()> {
    for (id, _, _) in waiting {
        // ContentModified: the document the request was about changed.
        out(&error_response(id, -32801, why))?;
    }
    Ok(())
}

fn notification(method: &str, params: impl serde::Serialize) -> Value {
    json!({"jsonrpc": "2.0", "method": method, "params": params})
}

fn error_response(id: Value, code: i32, message: &str) -> Value {
    json!({"jsonrpc": "2.0", "id": id, "error": {"code": code, "message": message}})
}

/// A request's answer on a document, under `catch_unwind`.
fn answer(id: Value, method: String, params: Value, doc: &Document) -> Value {
    respond(id, catch_unwind(AssertUnwindSafe(|| handle_request(Some(doc), &method, params))))
}

/// A request answered from the analysis of an older version of the text
/// (`current` is the client's): a hover's or a completion's position is
/// read through the [`Drift`] between the two texts, and the ranges of the
/// answer back, so the answer is about the characters under the client's
/// cursor; where the older analysis has not seen them (inside the edited
/// region), there is no hover and no completion yet.
fn answer_from_older(id: Value, method: String, mut params: Value, doc: &Document, current: &str) -> Value {
    use lsp_types::request::{self as r, Request as _};
    let position = match method.as_str() {
        r::HoverRequest::METHOD | r::Completion::METHOD => "/position",
        _ => return answer(id, method, params, doc),
    };
    if doc.text() == current {
        return answer(id, method, params, doc);
    }
    let drift = Drift::between(doc.text(), current);
    let at = params.pointer(position).and_then(|p| serde_json::from_value::<Position>(p.clone()).ok());
    let older = at.and_then(|p| drift.to_old(offset_of(current, p)));
    let (Some(older), Some(slot)) = (older, params.pointer_mut(position)) else {
        let empty = if method == r::HoverRequest::METHOD { Value::Null } else { json!([]) };
        return json!({"jsonrpc": "2.0", "id": id, "result": empty});
    };
    *slot = json!(doc.range(crate::span::Span::new(older, older)).start);
    let mut reply = answer(id, method, params, doc);
    let index = crate::span::LineIndex::new(current);
    let remap = |range: &mut Value| {
        let Ok(r) = serde_json::from_value::<Range>(range.clone()) else { return false };
        let newer =
            |p: Position| drift.to_new(offset_of(doc.text(), p)).map(|o| index.lsp_position(current, o));
        match (newer(r.start), newer(r.end)) {
            (Some(a), Some(b)) => {
                *range =
                    json!({"start": {"line": a.0, "character": a.1}, "end": {"line": b.0, "character": b.1}});
                true
            }
            _ => false,
        }
    };
    if let Some(result) = reply.get_mut("result") {
        if let Some(range) = result.get_mut("range") {
            if !remap(range) {
                if let Some(o) = result.as_object_mut() {
                    o.remove("range");
                }
            }
        }
        for item in result.as_array_mut().into_iter().flatten() {
            let ok = item.pointer_mut("/textEdit/range").is_some_and(&remap);
            if let (false, Some(o)) = (ok, item.as_object_mut()) {
                o.remove("textEdit");
            }
        }
    }
    reply
}

/// A request that names no open document.
fn answer_without_document(id: Value, method: String, params: Value) -> Value {
    respond(id, catch_unwind(AssertUnwindSafe(|| handle_request(None, &method, params))))
}

fn respond(id: Value, result: std::thread::Result<Answer>) -> Value {
    match result {
        Ok(Ok(value)) => json!({"jsonrpc": "2.0", "id": id, "result": value}),
        Ok(Err((code, message))) => error_response(id, code as i32, &message),
        Err(panic) => error_response(
            id,
            ErrorCode::InternalError as i32,
            &format!("shadec lsp: this request panicked ({}); the server goes on", panic_text(&panic)),
        ),
    }
}

/// A method name from the client, safe to quote.
fn escape(s: &str) -> String {
    s.chars().take(80).flat_map(char::escape_debug).collect()
}

pub(super) fn panic_text(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into())
}

type Answer = Result<Value, (ErrorCode, String)>;

fn params<P: serde::de::DeserializeOwned>(raw: Value) -> Result<P, (ErrorCode, String)> {
    serde_json::from_value(raw).map_err(|e| (ErrorCode::InvalidParams, format!("invalid parameters: {e}")))
}

fn json<T: serde::Serialize>(v: T) -> Answer {
    serde_json::to_value(v)
        .map_err(|e| (ErrorCode::InternalError, format!("the answer does not serialize: {e}")))
}

/// The request's document: the one the loop found for its URI, if open.
fn doc<'d>(docs: Option<&'d Document>, uri: &Uri) -> Result<&'d Document, (ErrorCode, String)> {
    docs.ok_or((ErrorCode::InvalidParams, format!("{} is not open", uri.as_str())))
}

/// `textDocument/hover`: the hover text of the name under the cursor.
fn hover_request(docs: Option<&Document>, raw: Value) -> Answer {
    let p: HoverParams = params(raw)?;
    let (uri, pos) =
        (p.text_document_position_params.text_document.uri, p.text_document_position_params.position);
    let d = doc(docs, &uri)?;
    json(hover::hover(d, d.offset(pos)).map(|(text, span)| Hover {
        contents: HoverContents::Markup(MarkupContent { kind: MarkupKind::Markdown, value: text }),
        range: Some(d.range(span)),
    }))
}

/// `textDocument/formatting`: the canonical printing as one edit of the
/// whole document, or no edit when it is printed so already.
fn formatting_request(docs: Option<&Document>, raw: Value) -> Answer {
    let p: DocumentFormattingParams = params(raw)?;
    let d = doc(docs, &p.text_document.uri)?;
    let out =
        formatting::print_document(d.text(), Style::Unicode).map_err(|e| (ErrorCode::RequestFailed, e))?;
    let whole = d.range(crate::span::Span::new(0, d.text().len()));
    json(if out == d.text() { vec![] } else { vec![TextEdit { range: whole, new_text: out }] })
}

fn handle_request(docs: Option<&Document>, method: &str, raw: Value) -> Answer {
    use lsp_types::request::{self as r, Request as _};
    match method {
        r::HoverRequest::METHOD => hover_request(docs, raw),
        r::GotoDefinition::METHOD => {
            let p: GotoDefinitionParams = params(raw)?;
            let (uri, pos) =
                (p.text_document_position_params.text_document.uri, p.text_document_position_params.position);
            let d = doc(docs, &uri)?;
            json(navigation::definition(d, &uri, d.offset(pos)).map(GotoDefinitionResponse::Scalar))
        }
        r::References::METHOD => {
            let p: ReferenceParams = params(raw)?;
            let (uri, pos) = (p.text_document_position.text_document.uri, p.text_document_position.position);
            let d = doc(docs, &uri)?;
            json(navigation::references(d, &uri, d.offset(pos), p.context.include_declaration))
        }
        r::PrepareRenameRequest::METHOD => {
            let p: TextDocumentPositionParams = params(raw)?;
            let d = doc(docs, &p.text_document.uri)?;
            navigation::prepare_rename(d, d.offset(p.position))
                .map_err(|e| (ErrorCode::RequestFailed, e))
                .and_then(json)
        }
        r::Rename::METHOD => {
            let p: RenameParams = params(raw)?;
            let (uri, pos) = (p.text_document_position.text_document.uri, p.text_document_position.position);
            let d = doc(docs, &uri)?;
            navigation::rename(d, &uri, d.offset(pos), &p.new_name)
                .map_err(|e| (ErrorCode::RequestFailed, e))
                .and_then(json)
        }
        r::DocumentSymbolRequest::METHOD => {
            let p: DocumentSymbolParams = params(raw)?;
            json(DocumentSymbolResponse::Nested(symbols::document_symbols(doc(docs, &p.text_document.uri)?)))
        }
        r::Formatting::METHOD => formatting_request(docs, raw),
        r::SemanticTokensFullRequest::METHOD => {
            let p: SemanticTokensParams = params(raw)?;
            let d = doc(docs, &p.text_document.uri)?;
            let data = semantic_tokens::encode(d, &semantic_tokens::tokens(d));
            json(SemanticTokensResult::Tokens(SemanticTokens { result_id: None, data }))
        }
        r::InlayHintRequest::METHOD => {
            let p: InlayHintParams = params(raw)?;
            let d = doc(docs, &p.text_document.uri)?;
            json(inlay_hints::inlay_hints(d, d.offset(p.range.start), d.offset(p.range.end)))
        }
        r::Completion::METHOD => {
            let p: CompletionParams = params(raw)?;
            let (uri, pos) = (p.text_document_position.text_document.uri, p.text_document_position.position);
            let d = doc(docs, &uri)?;
            json(CompletionResponse::Array(completion::complete(d, d.offset(pos))))
        }
        r::CodeActionRequest::METHOD => {
            let p: CodeActionParams = params(raw)?;
            let d = doc(docs, &p.text_document.uri)?;
            let actions = code_actions::code_actions(d, &p.text_document.uri, p.range);
            json(actions.into_iter().map(CodeActionOrCommand::CodeAction).collect::<Vec<_>>())
        }
        PANIC_FOR_TEST if std::env::var("SHADEC_LSP_TEST_HOOKS").as_deref() == Ok("1") => {
            panic!("the test hook {PANIC_FOR_TEST} panics on purpose")
        }
        other => Err((ErrorCode::MethodNotFound, format!("shadec lsp does not handle `{other}`"))),
    }
}
