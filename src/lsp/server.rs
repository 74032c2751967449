//! The server's state (open documents, their analyses and lint results) and the message loop.

use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender, select};
use lsp_server::{Connection, ErrorCode, Message, Notification, Request, RequestId, Response};
use lsp_types::notification::Notification as _;
use lsp_types::request::Request as _;
use lsp_types::{
    CodeActionProviderCapability, CompletionOptions, Hover, HoverContents, HoverProviderCapability, InitializeParams,
    Location, MarkupContent, MarkupKind, OneOf, Position, PositionEncodingKind, PublishDiagnosticsParams, SaveOptions,
    SemanticTokens, SemanticTokensFullOptions, SemanticTokensOptions, SemanticTokensResult,
    SemanticTokensServerCapabilities, ServerCapabilities, TextDocumentSyncCapability, TextDocumentSyncKind,
    TextDocumentSyncOptions, TextDocumentSyncSaveOptions, TextEdit, Url, notification as notif, request as req,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

use super::Options;
use super::analysis::{Analysis, Files, name_of};
use super::text::{Encoding, LineIndex};
use crate::diag::Diagnostic;

pub fn serve(conn: &Connection, options: Options) -> Result<(), String> {
    let proto = |e: lsp_server::ProtocolError| format!("protocol error: {e}");
    let (id, params) = conn.initialize_start().map_err(proto)?;
    let init: InitializeParams =
        serde_json::from_value(params).map_err(|e| format!("invalid `initialize` parameters: {e}"))?;
    let enc = negotiate(&init);
    let mut lint_delay = options.lint_delay;
    if let Some(ms) = init.initialization_options.as_ref().and_then(|o| o.get("lintDelayMs")).and_then(|v| v.as_u64()) {
        lint_delay = Duration::from_millis(ms);
    }
    let result = serde_json::json!({
        "capabilities": capabilities(enc),
        "serverInfo": { "name": "revelio", "version": env!("CARGO_PKG_VERSION") },
    });
    conn.initialize_finish(id, result).map_err(proto)?;
    let (lint_tx, lint_rx) = crossbeam_channel::unbounded();
    let mut server = Server {
        enc,
        files: Files::new(options.cache),
        docs: HashMap::new(),
        lint_delay,
        lint_tx,
        lint_rx,
        published: HashMap::new(),
        fresh: Default::default(),
        generation: 0,
    };
    server.run(conn)
}

/// UTF-8 when the client offers it (no conversion), else UTF-32, else LSP's default UTF-16.
fn negotiate(init: &InitializeParams) -> Encoding {
    let offered = init.capabilities.general.as_ref().and_then(|g| g.position_encodings.clone()).unwrap_or_default();
    if offered.contains(&PositionEncodingKind::UTF8) {
        Encoding::Utf8
    } else if offered.contains(&PositionEncodingKind::UTF32) {
        Encoding::Utf32
    } else {
        Encoding::Utf16
    }
}

fn capabilities(enc: Encoding) -> ServerCapabilities {
    ServerCapabilities {
        position_encoding: Some(match enc {
            Encoding::Utf8 => PositionEncodingKind::UTF8,
            Encoding::Utf16 => PositionEncodingKind::UTF16,
            Encoding::Utf32 => PositionEncodingKind::UTF32,
        }),
        text_document_sync: Some(TextDocumentSyncCapability::Options(TextDocumentSyncOptions {
            open_close: Some(true),
            change: Some(TextDocumentSyncKind::FULL),
            save: Some(TextDocumentSyncSaveOptions::SaveOptions(SaveOptions { include_text: Some(false) })),
            ..TextDocumentSyncOptions::default()
        })),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        definition_provider: Some(OneOf::Left(true)),
        references_provider: Some(OneOf::Left(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec![".".into(), ":".into(), "|".into()]),
            ..CompletionOptions::default()
        }),
        code_action_provider: Some(CodeActionProviderCapability::Simple(true)),
        document_symbol_provider: Some(OneOf::Left(true)),
        document_formatting_provider: Some(OneOf::Left(true)),
        semantic_tokens_provider: Some(SemanticTokensServerCapabilities::SemanticTokensOptions(
            SemanticTokensOptions {
                legend: super::tokens::legend(),
                full: Some(SemanticTokensFullOptions::Bool(true)),
                range: None,
                ..SemanticTokensOptions::default()
            },
        )),
        ..ServerCapabilities::default()
    }
}

/// An open document.
struct Doc {
    name: String,
    text: String,
    version: i32,
    lines: LineIndex,
    analysis: Analysis,
    /// Which analysis this is (lint results name the one they were computed for).
    generation: u64,
    /// Lattice lints of this analysis, once computed.
    lints: Vec<Diagnostic>,
    lint_due: Option<Instant>,
    linting: bool,
}

struct LintDone {
    uri: Url,
    generation: u64,
    diagnostics: Vec<Diagnostic>,
}

struct Server {
    enc: Encoding,
    files: Files,
    docs: HashMap<Url, Doc>,
    lint_delay: Duration,
    lint_tx: Sender<LintDone>,
    lint_rx: Receiver<LintDone>,
    /// What was last published per URI, so unchanged lists are not sent again.
    published: HashMap<Url, Vec<lsp_types::Diagnostic>>,
    /// Documents whose diagnostics are sent at the next publish even if unchanged: the
    /// client learns that a new version (or its lints) has been checked.
    fresh: std::collections::HashSet<Url>,
    generation: u64,
}

type Handled = Result<serde_json::Value, (ErrorCode, String)>;

fn params<P: DeserializeOwned>(v: serde_json::Value) -> Result<P, (ErrorCode, String)> {
    serde_json::from_value(v).map_err(|e| (ErrorCode::InvalidParams, format!("invalid parameters: {e}")))
}

fn json<T: Serialize>(v: T) -> Handled {
    serde_json::to_value(v).map_err(|e| (ErrorCode::InternalError, e.to_string()))
}

impl Server {
    fn run(&mut self, conn: &Connection) -> Result<(), String> {
        loop {
            let due = self.docs.values().filter(|d| !d.linting).filter_map(|d| d.lint_due).min();
            let timer = match due {
                Some(t) => crossbeam_channel::at(t),
                None => crossbeam_channel::never(),
            };
            select! {
                recv(conn.receiver) -> msg => {
                    let Ok(msg) = msg else { return Ok(()) };
                    match msg {
                        Message::Request(r) => {
                            if conn.handle_shutdown(&r).map_err(|e| format!("protocol error: {e}"))? {
                                return Ok(());
                            }
                            let id = r.id.clone();
                            // A bug in one feature answers that request with an error; the
                            // session goes on.
                            if catch_unwind(AssertUnwindSafe(|| self.request(conn, r))).is_err() {
                                let msg = "internal error in `revelio lsp` (please report it)".to_string();
                                Self::send(conn, Message::Response(Response::new_err(id, ErrorCode::InternalError as i32, msg)));
                            }
                        }
                        Message::Notification(n) => {
                            if n.method == notif::Exit::METHOD {
                                return Ok(());
                            }
                            let _ = catch_unwind(AssertUnwindSafe(|| self.notification(conn, n)));
                        }
                        Message::Response(_) => {}
                    }
                }
                recv(self.lint_rx) -> done => {
                    if let Ok(done) = done {
                        self.lint_done(conn, done);
                    }
                }
                recv(timer) -> _ => {}
            }
            self.start_due_lints();
        }
    }

    fn send(conn: &Connection, msg: Message) {
        // A client that went away ends the loop through its closed channel, not here.
        let _ = conn.sender.send(msg);
    }

    fn request(&mut self, conn: &Connection, r: Request) {
        let id: RequestId = r.id.clone();
        let result = match r.method.as_str() {
            req::HoverRequest::METHOD => params(r.params).and_then(|p| self.hover(p)),
            req::GotoDefinition::METHOD => params(r.params).and_then(|p| self.definition(p)),
            req::References::METHOD => params(r.params).and_then(|p| self.references(p)),
            req::Completion::METHOD => params(r.params).and_then(|p| self.completion(p)),
            req::CodeActionRequest::METHOD => params(r.params).and_then(|p| self.code_actions(p)),
            req::DocumentSymbolRequest::METHOD => params(r.params).and_then(|p| self.document_symbols(p)),
            req::Formatting::METHOD => params(r.params).and_then(|p| self.formatting(p)),
            req::SemanticTokensFullRequest::METHOD => params(r.params).and_then(|p| self.semantic_tokens(p)),
            _ => Err((ErrorCode::MethodNotFound, format!("unsupported request `{}`", r.method))),
        };
        let response = match result {
            Ok(v) => Response { id, result: Some(v), error: None },
            Err((code, message)) => Response::new_err(id, code as i32, message),
        };
        Self::send(conn, Message::Response(response));
    }

    fn notification(&mut self, conn: &Connection, n: Notification) {
        match n.method.as_str() {
            notif::DidOpenTextDocument::METHOD => {
                let Ok(p) = params::<lsp_types::DidOpenTextDocumentParams>(n.params) else { return };
                let d = p.text_document;
                self.set_text(d.uri.clone(), d.text, d.version);
                self.changed(conn, &d.uri);
            }
            notif::DidChangeTextDocument::METHOD => {
                let Ok(p) = params::<lsp_types::DidChangeTextDocumentParams>(n.params) else { return };
                // Full synchronisation: the last change holds the whole text.
                let Some(change) = p.content_changes.into_iter().last() else { return };
                let uri = p.text_document.uri;
                self.set_text(uri.clone(), change.text, p.text_document.version);
                self.changed(conn, &uri);
            }
            notif::DidSaveTextDocument::METHOD => {
                let Ok(p) = params::<lsp_types::DidSaveTextDocumentParams>(n.params) else { return };
                let lintable = |d: &Doc| d.analysis.compiled.domain.as_ref().is_some_and(|dom| !dom.name.is_empty());
                if let Some(d) = self.docs.get_mut(&p.text_document.uri).filter(|d| lintable(d)) {
                    d.lint_due = Some(Instant::now());
                }
            }
            notif::DidCloseTextDocument::METHOD => {
                let Ok(p) = params::<lsp_types::DidCloseTextDocumentParams>(n.params) else { return };
                if let Some(closed) = self.docs.remove(&p.text_document.uri) {
                    // Its users now read the file from disk again.
                    self.recheck_users(&closed.name, &p.text_document.uri);
                }
                self.publish(conn);
            }
            _ => {}
        }
    }

    fn set_text(&mut self, uri: Url, text: String, version: i32) {
        let name = name_of(&uri);
        let open = self.open_texts();
        self.generation += 1;
        let analysis = Analysis::new(&name, &text, &open_with(open, &name, &text));
        let doc = Doc {
            lines: LineIndex::new(&text),
            name,
            text,
            version,
            analysis,
            generation: self.generation,
            lints: Vec::new(),
            lint_due: None,
            linting: self.docs.get(&uri).is_some_and(|d| d.linting),
        };
        self.docs.insert(uri.clone(), doc);
        self.fresh.insert(uri.clone());
        self.schedule_lints(&uri);
    }

    /// After `uri` changed: recheck the open documents that load it, then publish.
    fn changed(&mut self, conn: &Connection, uri: &Url) {
        if let Some(name) = self.docs.get(uri).map(|d| d.name.clone()) {
            self.recheck_users(&name, uri);
        }
        self.publish(conn);
    }

    fn recheck_users(&mut self, name: &str, except: &Url) {
        let users: Vec<Url> = self
            .docs
            .iter()
            .filter(|(u, d)| *u != except && d.analysis.file_names().skip(1).any(|f| f == name))
            .map(|(u, _)| u.clone())
            .collect();
        let open = self.open_texts();
        for u in users {
            self.generation += 1;
            let generation = self.generation;
            if let Some(d) = self.docs.get_mut(&u) {
                d.analysis = Analysis::new(&d.name, &d.text, &open);
                d.generation = generation;
                d.lints.clear();
            }
            self.fresh.insert(u.clone());
            self.schedule_lints(&u);
        }
    }

    fn open_texts(&self) -> HashMap<String, String> {
        self.docs.values().map(|d| (d.name.clone(), d.text.clone())).collect()
    }

    fn schedule_lints(&mut self, uri: &Url) {
        let delay = self.lint_delay;
        if let Some(d) = self.docs.get_mut(uri) {
            let lintable = d.analysis.compiled.domain.as_ref().is_some_and(|dom| !dom.name.is_empty());
            d.lint_due = lintable.then(|| Instant::now() + delay);
        }
    }

    fn start_due_lints(&mut self) {
        let now = Instant::now();
        for (uri, d) in &mut self.docs {
            if d.linting || d.lint_due.is_none_or(|t| t > now) {
                continue;
            }
            d.lint_due = None;
            let Some(domain) = d.analysis.compiled.domain.clone() else { continue };
            d.linting = true;
            let (tx, uri, generation) = (self.lint_tx.clone(), uri.clone(), d.generation);
            std::thread::spawn(move || {
                // A failed lint pass still reports back, so the document is not left waiting.
                let diagnostics = catch_unwind(|| crate::lint::lint_domain(&domain)).unwrap_or_default();
                let _ = tx.send(LintDone { uri, generation, diagnostics });
            });
        }
    }

    fn lint_done(&mut self, conn: &Connection, done: LintDone) {
        let Some(d) = self.docs.get_mut(&done.uri) else { return };
        d.linting = false;
        if d.generation == done.generation {
            d.lints = done.diagnostics;
            self.fresh.insert(done.uri);
            self.publish(conn);
        }
    }

    /// Publish the diagnostics of every open document (and of the closed user files they
    /// load, which have no analysis of their own), sending only what changed.
    fn publish(&mut self, conn: &Connection) {
        let mut want: HashMap<Url, (Option<i32>, Vec<lsp_types::Diagnostic>)> = HashMap::new();
        for (uri, d) in &self.docs {
            want.entry(uri.clone()).or_insert((Some(d.version), Vec::new())).0 = Some(d.version);
            let a = &d.analysis;
            let lines: Vec<LineIndex> = a.compiled.files.iter().map(|f| LineIndex::new(&f.text)).collect();
            for diag in a.compiled.diagnostics.iter().chain(&d.lints) {
                if super::diagnostics::allowed(a, diag) {
                    continue;
                }
                let file = diag.span.map_or(0, |s| s.file);
                let target = if file == 0 {
                    uri.clone()
                } else {
                    let name = &a.compiled.files[file as usize].name;
                    let open = self.docs.values().any(|o| &o.name == name);
                    match self.files.uri(name) {
                        Some(u) if !open && !name.starts_with("std/") => u,
                        _ => continue,
                    }
                };
                let converted = super::diagnostics::convert(a, diag, &lines, &self.files, self.enc);
                let list = &mut want.entry(target).or_insert((None, Vec::new())).1;
                if !list.contains(&converted) {
                    list.push(converted);
                }
            }
        }
        let gone: Vec<Url> = self.published.keys().filter(|u| !want.contains_key(*u)).cloned().collect();
        for u in gone {
            want.insert(u, (None, Vec::new()));
        }
        for (uri, (version, diagnostics)) in want {
            let fresh = self.fresh.remove(&uri);
            if !fresh && self.published.get(&uri).map_or(diagnostics.is_empty(), |p| *p == diagnostics) {
                continue;
            }
            let p = PublishDiagnosticsParams { uri: uri.clone(), diagnostics: diagnostics.clone(), version };
            let n = Notification::new(notif::PublishDiagnostics::METHOD.to_string(), p);
            Self::send(conn, Message::Notification(n));
            if diagnostics.is_empty() {
                self.published.remove(&uri);
            } else {
                self.published.insert(uri, diagnostics);
            }
        }
        self.fresh.clear();
    }

    // ------------------------------------------------------------------ requests

    fn doc(&self, uri: &Url) -> Result<&Doc, (ErrorCode, String)> {
        self.docs.get(uri).ok_or((ErrorCode::InvalidParams, format!("`{uri}` is not open")))
    }

    fn offset(&self, d: &Doc, pos: Position) -> u32 {
        d.lines.offset(&d.text, pos, self.enc)
    }

    fn location(&self, a: &Analysis, span: crate::ir::Span) -> Option<Location> {
        let f = a.compiled.files.get(span.file as usize)?;
        let uri = self.files.uri(&f.name)?;
        let range = LineIndex::new(&f.text).range(&f.text, span.start, span.end, self.enc);
        Some(Location { uri, range })
    }

    fn hover(&self, p: lsp_types::HoverParams) -> Handled {
        let tp = p.text_document_position_params;
        let d = self.doc(&tp.text_document.uri)?;
        let Some((span, id)) = d.analysis.index.at(0, self.offset(d, tp.position)) else { return json(None::<Hover>) };
        json(Some(Hover {
            contents: HoverContents::Markup(MarkupContent {
                kind: MarkupKind::Markdown,
                value: super::hover::markdown(&d.analysis.index, id),
            }),
            range: Some(d.lines.range(&d.text, span.start, span.end, self.enc)),
        }))
    }

    fn definition(&self, p: lsp_types::GotoDefinitionParams) -> Handled {
        let tp = p.text_document_position_params;
        let d = self.doc(&tp.text_document.uri)?;
        let found = d.analysis.index.at(0, self.offset(d, tp.position));
        json(found.and_then(|(_, id)| self.location(&d.analysis, d.analysis.index.symbols[id].decl)))
    }

    /// Every occurrence of the symbol at the position, across all open documents' analyses
    /// (a stdlib kind is used by every domain that is open).
    fn references(&self, p: lsp_types::ReferenceParams) -> Handled {
        let tp = p.text_document_position;
        let d = self.doc(&tp.text_document.uri)?;
        let Some((_, id)) = d.analysis.index.at(0, self.offset(d, tp.position)) else {
            return json(Vec::<Location>::new());
        };
        let sym = &d.analysis.index.symbols[id];
        let key = (d.analysis.compiled.files[sym.decl.file as usize].name.clone(), sym.decl.start, sym.sort);
        let mut out: Vec<Location> = Vec::new();
        for other in self.docs.values() {
            let ix = &other.analysis.index;
            let same = ix.symbols.iter().position(|s| {
                other.analysis.compiled.files.get(s.decl.file as usize).is_some_and(|f| f.name == key.0)
                    && s.decl.start == key.1
                    && s.sort == key.2
            });
            let Some(same) = same else { continue };
            for (k, span) in ix.occurrences_of(same).into_iter().enumerate() {
                if k == 0 && !p.context.include_declaration {
                    continue;
                }
                if let Some(loc) = self.location(&other.analysis, span).filter(|l| !out.contains(l)) {
                    out.push(loc);
                }
            }
        }
        json(out)
    }

    fn completion(&self, p: lsp_types::CompletionParams) -> Handled {
        let tp = p.text_document_position;
        let d = self.doc(&tp.text_document.uri)?;
        let items = super::complete::complete(&d.analysis, &d.text, self.offset(d, tp.position));
        json(lsp_types::CompletionResponse::Array(items))
    }

    /// This document's diagnostics as shown, each with its LSP form.
    fn shown<'d>(&self, d: &'d Doc) -> Vec<(&'d Diagnostic, lsp_types::Diagnostic)> {
        let a = &d.analysis;
        let lines: Vec<LineIndex> = a.compiled.files.iter().map(|f| LineIndex::new(&f.text)).collect();
        a.compiled
            .diagnostics
            .iter()
            .chain(&d.lints)
            .filter(|x| x.span.is_some_and(|s| s.file == 0) && !super::diagnostics::allowed(a, x))
            .map(|x| (x, super::diagnostics::convert(a, x, &lines, &self.files, self.enc)))
            .collect()
    }

    fn code_actions(&self, p: lsp_types::CodeActionParams) -> Handled {
        let d = self.doc(&p.text_document.uri)?;
        let (from, to) = (self.offset(d, p.range.start), self.offset(d, p.range.end));
        let shown = self.shown(d);
        json(super::actions::actions(&d.analysis, &p.text_document.uri, &d.lines, self.enc, &shown, from, to))
    }

    fn document_symbols(&self, p: lsp_types::DocumentSymbolParams) -> Handled {
        let d = self.doc(&p.text_document.uri)?;
        json(lsp_types::DocumentSymbolResponse::Nested(super::symbols::outline(&d.analysis, &d.lines, self.enc)))
    }

    /// The whole document in the canonical layout; no edit when it has syntax errors (they are
    /// already shown as diagnostics) or is formatted.
    fn formatting(&self, p: lsp_types::DocumentFormattingParams) -> Handled {
        let d = self.doc(&p.text_document.uri)?;
        let edits = match crate::fmt::format(&d.text) {
            Ok(new_text) if new_text != d.text => {
                let range = lsp_types::Range { start: Position::new(0, 0), end: d.lines.end(&d.text, self.enc) };
                vec![TextEdit { range, new_text }]
            }
            _ => Vec::new(),
        };
        json(edits)
    }

    fn semantic_tokens(&self, p: lsp_types::SemanticTokensParams) -> Handled {
        let d = self.doc(&p.text_document.uri)?;
        let data = super::tokens::tokens(&d.analysis, &d.lines, self.enc);
        json(SemanticTokensResult::Tokens(SemanticTokens { result_id: None, data }))
    }
}

/// The open texts with `name` set to `text` (the document being analysed).
fn open_with(mut open: HashMap<String, String>, name: &str, text: &str) -> HashMap<String, String> {
    open.insert(name.to_string(), text.to_string());
    open
}
