//! The server loop over stdio (JSON-RPC with `Content-Length` framing, by
//! `lsp-server`): initialize, then one message at a time. Every request
//! runs under `catch_unwind`: a panic answers that request with an
//! InternalError and the server goes on.

use std::panic::{catch_unwind, AssertUnwindSafe};

use lsp_server::{Connection, ErrorCode, Message, Notification, Request, Response};
use lsp_types::notification::{self as notif, Notification as _};
use lsp_types::*;
use serde_json::Value;

use super::documents::Documents;
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
            change: Some(TextDocumentSyncKind::FULL),
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
/// Whether it was shut down in order (`shutdown` before `exit`).
pub fn run() -> anyhow::Result<bool> {
    let (connection, io) = Connection::stdio();
    let orderly = serve(&connection)?;
    drop(connection);
    io.join()?;
    Ok(orderly)
}

/// The whole session on a connection: initialize, messages, shutdown,
/// exit. Whether `shutdown` came before the end (the protocol asks for exit
/// status 1 when it did not); `Err` when the connection breaks.
pub fn serve(connection: &Connection) -> anyhow::Result<bool> {
    let (id, params) = connection.initialize_start()?;
    let params: InitializeParams = serde_json::from_value(params)?;
    let mut docs = Documents::default();
    docs.client_target = params.initialization_options.as_ref().and_then(configured_target);
    let result = InitializeResult {
        capabilities: capabilities(),
        server_info: Some(ServerInfo {
            name: "shadec".into(),
            version: Some(env!("CARGO_PKG_VERSION").into()),
        }),
    };
    connection.initialize_finish(id, serde_json::to_value(result)?)?;
    // LSP 3.17 "shutdown": after it, requests are refused until `exit`
    // (Neovim 0.7 sends `shutdown` twice when a stopped client's editor
    // quits; lsp-server's `handle_shutdown` would fail on the second).
    let mut shutting_down = false;
    for msg in &connection.receiver {
        match msg {
            Message::Request(req) if req.method == "shutdown" || shutting_down => {
                let response = if shutting_down {
                    Response::new_err(
                        req.id,
                        ErrorCode::InvalidRequest as i32,
                        "the server is shutting down".into(),
                    )
                } else {
                    Response::new_ok(req.id, ())
                };
                shutting_down = true;
                connection.sender.send(Message::Response(response))?;
            }
            Message::Notification(n) if n.method == "exit" => {
                return Ok(shutting_down);
            }
            Message::Request(req) => {
                let id = req.id.clone();
                let response = match catch_unwind(AssertUnwindSafe(|| handle_request(&docs, req))) {
                    Ok(Ok(value)) => Response::new_ok(id, value),
                    Ok(Err((code, message))) => Response::new_err(id, code as i32, message),
                    Err(panic) => Response::new_err(
                        id,
                        ErrorCode::InternalError as i32,
                        format!(
                            "shadec lsp: this request panicked ({}); the server goes on",
                            panic_text(&panic)
                        ),
                    ),
                };
                connection.sender.send(Message::Response(response))?;
            }
            Message::Notification(n) => {
                for published in handle_notification(&mut docs, n) {
                    let n = Notification::new(notif::PublishDiagnostics::METHOD.into(), published);
                    connection.sender.send(Message::Notification(n))?;
                }
            }
            Message::Response(_) => {}
        }
    }
    Ok(shutting_down)
}

pub(super) fn panic_text(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into())
}

fn uri_of(u: &Uri) -> String {
    u.as_str().to_string()
}

/// The open/change/save/close/configuration notifications; returns the
/// diagnostics to publish.
fn handle_notification(docs: &mut Documents, n: Notification) -> Vec<PublishDiagnosticsParams> {
    let publish = |docs: &Documents, uri: &Uri| docs.get(uri.as_str()).map(|d| diagnostics::publish(d, uri));
    match n.method.as_str() {
        notif::DidOpenTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<DidOpenTextDocumentParams>(n.params) else { return vec![] };
            docs.update(&uri_of(&p.text_document.uri), p.text_document.version, p.text_document.text);
            publish(docs, &p.text_document.uri).into_iter().collect()
        }
        notif::DidChangeTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<DidChangeTextDocumentParams>(n.params) else {
                return vec![];
            };
            // Full sync: the last change holds the whole text.
            let Some(change) = p.content_changes.into_iter().last() else { return vec![] };
            docs.update(&uri_of(&p.text_document.uri), p.text_document.version, change.text);
            publish(docs, &p.text_document.uri).into_iter().collect()
        }
        notif::DidSaveTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<DidSaveTextDocumentParams>(n.params) else { return vec![] };
            let key = uri_of(&p.text_document.uri);
            if let (Some(text), Some(version)) = (p.text, docs.get(&key).map(|d| d.version)) {
                docs.update(&key, version, text);
            }
            publish(docs, &p.text_document.uri).into_iter().collect()
        }
        notif::DidCloseTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<DidCloseTextDocumentParams>(n.params) else { return vec![] };
            docs.close(p.text_document.uri.as_str());
            vec![PublishDiagnosticsParams { uri: p.text_document.uri, diagnostics: vec![], version: None }]
        }
        notif::DidChangeConfiguration::METHOD => {
            let Ok(p) = serde_json::from_value::<DidChangeConfigurationParams>(n.params) else {
                return vec![];
            };
            docs.client_target = configured_target(&p.settings);
            let uris = docs.reanalyze_all();
            uris.iter().filter_map(|u| u.parse::<Uri>().ok()).filter_map(|u| publish(docs, &u)).collect()
        }
        _ => vec![],
    }
}

type Answer = Result<Value, (ErrorCode, String)>;

fn params<P: serde::de::DeserializeOwned>(req: Request) -> Result<P, (ErrorCode, String)> {
    serde_json::from_value(req.params)
        .map_err(|e| (ErrorCode::InvalidParams, format!("invalid parameters: {e}")))
}

fn json<T: serde::Serialize>(v: T) -> Answer {
    Ok(serde_json::to_value(v).expect("protocol types serialize"))
}

fn doc<'d>(docs: &'d Documents, uri: &Uri) -> Result<&'d super::documents::Document, (ErrorCode, String)> {
    docs.get(uri.as_str()).ok_or((ErrorCode::InvalidParams, format!("{} is not open", uri.as_str())))
}

fn handle_request(docs: &Documents, req: Request) -> Answer {
    use lsp_types::request::{self as r, Request as _};
    match req.method.as_str() {
        r::HoverRequest::METHOD => {
            let p: HoverParams = params(req)?;
            let (uri, pos) =
                (p.text_document_position_params.text_document.uri, p.text_document_position_params.position);
            let d = doc(docs, &uri)?;
            json(hover::hover(d, d.offset(pos)).map(|(text, span)| Hover {
                contents: HoverContents::Markup(MarkupContent { kind: MarkupKind::Markdown, value: text }),
                range: Some(d.range(span)),
            }))
        }
        r::GotoDefinition::METHOD => {
            let p: GotoDefinitionParams = params(req)?;
            let (uri, pos) =
                (p.text_document_position_params.text_document.uri, p.text_document_position_params.position);
            let d = doc(docs, &uri)?;
            json(navigation::definition(d, &uri, d.offset(pos)).map(GotoDefinitionResponse::Scalar))
        }
        r::References::METHOD => {
            let p: ReferenceParams = params(req)?;
            let (uri, pos) = (p.text_document_position.text_document.uri, p.text_document_position.position);
            let d = doc(docs, &uri)?;
            json(navigation::references(d, &uri, d.offset(pos), p.context.include_declaration))
        }
        r::PrepareRenameRequest::METHOD => {
            let p: TextDocumentPositionParams = params(req)?;
            let d = doc(docs, &p.text_document.uri)?;
            navigation::prepare_rename(d, d.offset(p.position))
                .map_err(|e| (ErrorCode::RequestFailed, e))
                .and_then(json)
        }
        r::Rename::METHOD => {
            let p: RenameParams = params(req)?;
            let (uri, pos) = (p.text_document_position.text_document.uri, p.text_document_position.position);
            let d = doc(docs, &uri)?;
            navigation::rename(d, &uri, d.offset(pos), &p.new_name)
                .map_err(|e| (ErrorCode::RequestFailed, e))
                .and_then(json)
        }
        r::DocumentSymbolRequest::METHOD => {
            let p: DocumentSymbolParams = params(req)?;
            json(DocumentSymbolResponse::Nested(symbols::document_symbols(doc(docs, &p.text_document.uri)?)))
        }
        r::Formatting::METHOD => {
            let p: DocumentFormattingParams = params(req)?;
            let d = doc(docs, &p.text_document.uri)?;
            let out = formatting::print_document(d.text(), Style::Unicode)
                .map_err(|e| (ErrorCode::RequestFailed, e))?;
            let whole = d.range(crate::span::Span::new(0, d.text().len()));
            json(if out == d.text() { vec![] } else { vec![TextEdit { range: whole, new_text: out }] })
        }
        r::SemanticTokensFullRequest::METHOD => {
            let p: SemanticTokensParams = params(req)?;
            let d = doc(docs, &p.text_document.uri)?;
            let data = semantic_tokens::encode(d, &semantic_tokens::tokens(d));
            json(SemanticTokensResult::Tokens(SemanticTokens { result_id: None, data }))
        }
        r::InlayHintRequest::METHOD => {
            let p: InlayHintParams = params(req)?;
            let d = doc(docs, &p.text_document.uri)?;
            json(inlay_hints::inlay_hints(d, d.offset(p.range.start), d.offset(p.range.end)))
        }
        r::Completion::METHOD => {
            let p: CompletionParams = params(req)?;
            let (uri, pos) = (p.text_document_position.text_document.uri, p.text_document_position.position);
            let d = doc(docs, &uri)?;
            json(CompletionResponse::Array(completion::complete(d, d.offset(pos))))
        }
        r::CodeActionRequest::METHOD => {
            let p: CodeActionParams = params(req)?;
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
