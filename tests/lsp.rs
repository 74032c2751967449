//! `revelio lsp` over standard input/output, as an editor drives it: initialize, open a broken
//! file (diagnostics with codes and UTF-16 ranges on a line with non-ASCII text), fix it
//! (diagnostics cleared), hover, go to a definition in the stdlib, complete after `.`, apply a
//! did-you-mean fix, format, and shut down; then modules rechecking their users, lattice lints
//! with their `allow` quick fix, and a real client: Neovim's built-in LSP client (skipped without
//! `nvim`, or failed where `REVELIO_REQUIRE_PEERS` is set, as `.ci/run` does).

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

/// A minimal LSP client over a child process's pipes.
struct Client {
    child: Child,
    stdin: ChildStdin,
    inbox: Receiver<Value>,
    next_id: i64,
    /// Notifications received while waiting for something else.
    notifications: Vec<Value>,
}

impl Client {
    fn start(cache: &Path, init_options: Value) -> Client {
        let mut child = Command::new(env!("CARGO_BIN_EXE_revelio"))
            .arg("lsp")
            .env("XDG_CACHE_HOME", cache)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let (tx, inbox) = channel();
        std::thread::spawn(move || {
            loop {
                let mut len = 0usize;
                loop {
                    let mut line = String::new();
                    if out.read_line(&mut line).unwrap_or(0) == 0 {
                        return;
                    }
                    let line = line.trim_end();
                    if line.is_empty() {
                        break;
                    }
                    if let Some(v) = line.strip_prefix("Content-Length: ") {
                        len = v.parse().unwrap();
                    }
                }
                let mut body = vec![0; len];
                if out.read_exact(&mut body).is_err() {
                    return;
                }
                if tx.send(serde_json::from_slice(&body).unwrap()).is_err() {
                    return;
                }
            }
        });
        let mut c = Client { child, stdin, inbox, next_id: 0, notifications: Vec::new() };
        // No `positionEncodings` offered: the server must count UTF-16 code units.
        let init = c.request("initialize", json!({ "capabilities": {}, "initializationOptions": init_options }));
        assert_eq!(init["capabilities"]["positionEncoding"], "utf-16", "{init}");
        c.notify("initialized", json!({}));
        c
    }

    fn send(&mut self, msg: Value) {
        let body = msg.to_string();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
        self.stdin.flush().unwrap();
    }

    fn notify(&mut self, method: &str, params: Value) {
        self.send(json!({ "jsonrpc": "2.0", "method": method, "params": params }));
    }

    fn recv(&mut self) -> Value {
        self.inbox.recv_timeout(Duration::from_secs(60)).expect("the server answers within a minute")
    }

    fn request(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        self.send(json!({ "jsonrpc": "2.0", "id": id, "method": method, "params": params }));
        loop {
            let m = self.recv();
            if m["id"] == id {
                assert!(m.get("error").is_none(), "{method} failed: {m}");
                return m["result"].clone();
            }
            self.notifications.push(m);
        }
    }

    /// The next `publishDiagnostics` for `uri` that satisfies `want`.
    fn diagnostics(&mut self, uri: &str, want: impl Fn(&Value) -> bool) -> Value {
        let matches = |m: &Value| {
            m["method"] == "textDocument/publishDiagnostics" && m["params"]["uri"] == uri && want(&m["params"])
        };
        if let Some(i) = self.notifications.iter().position(matches) {
            return self.notifications.remove(i)["params"].clone();
        }
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            let m = self.recv();
            if matches(&m) {
                return m["params"].clone();
            }
            self.notifications.push(m);
        }
        panic!("no matching diagnostics for {uri}; got {:?}", self.notifications);
    }

    fn open(&mut self, uri: &str, text: &str) {
        let doc = json!({ "uri": uri, "languageId": "revelio", "version": 1, "text": text });
        self.notify("textDocument/didOpen", json!({ "textDocument": doc }));
    }

    fn change(&mut self, uri: &str, version: i64, text: &str) {
        let params =
            json!({ "textDocument": { "uri": uri, "version": version }, "contentChanges": [{ "text": text }] });
        self.notify("textDocument/didChange", params);
    }

    fn shutdown(mut self) {
        self.request("shutdown", json!(null));
        self.notify("exit", json!(null));
        let status = self.child.wait().unwrap();
        assert!(status.success(), "the server exits cleanly: {status}");
    }
}

fn uri(p: &Path) -> String {
    format!("file://{}", p.display())
}

fn at(line: u32, character: u32) -> Value {
    json!({ "line": line, "character": character })
}

/// The LSP position (UTF-16) of the first `needle` in `text`.
fn pos(text: &str, needle: &str) -> (u32, u32) {
    let i = text.find(needle).unwrap_or_else(|| panic!("`{needle}` not in the text"));
    let line = text[..i].matches('\n').count() as u32;
    let col = text[..i].rsplit('\n').next().unwrap().encode_utf16().count() as u32;
    (line, col)
}

const BROKEN: &str = "domain walk\nuse std::driving\n\nconcept walker {\n  description \"Fußgänger 🚶 vorn\"  add w: Cyclst in lane ahead_of ego\n  probe \"A cyclist.\" not \"No cyclist.\"\n}\n\nquestion q {\n  text \"Go?\"\n  option go \"Go\"\n  option stop \"Stop\"\n}\n\nrules priority {\n  rule near {\n    when exists e: Cyclist where e.distance <= 4m\n    expect q.stop\n  }\n  rule otherwise { expect q.go }\n}\n";

#[test]
fn an_editor_session_over_stdio() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("walk.rev");
    let u = uri(&path);
    let mut c = Client::start(&dir.path().join("cache"), json!({ "lintDelayMs": 60_000 }));

    // A broken file: an unknown kind on a line with non-ASCII text before it.
    c.open(&u, BROKEN);
    let d = c.diagnostics(&u, |p| p["diagnostics"].as_array().is_some_and(|a| !a.is_empty()));
    let diags = d["diagnostics"].as_array().unwrap();
    assert_eq!(diags.len(), 1, "{d}");
    assert_eq!(diags[0]["code"], "R0020");
    assert!(diags[0]["message"].as_str().unwrap().contains("unknown kind `Cyclst`"), "{d}");
    let (line, col) = pos(BROKEN, "Cyclst");
    assert_eq!(diags[0]["range"]["start"], at(line, col), "UTF-16 columns: `🚶` counts two, `ß` one");
    assert_eq!(diags[0]["range"]["end"], at(line, col + 6));
    let chars = BROKEN.lines().nth(line as usize).unwrap().split("Cyclst").next().unwrap().chars().count() as u32;
    assert_ne!(chars, col, "the line must tell UTF-16 from characters");

    // The did-you-mean fix, as the client would ask for it.
    let actions = c.request(
        "textDocument/codeAction",
        json!({ "textDocument": { "uri": u }, "range": diags[0]["range"], "context": { "diagnostics": [diags[0]] } }),
    );
    let fix = actions
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["title"] == "Replace `Cyclst` with `Cyclist`")
        .expect("a did-you-mean fix");
    let edit = &fix["edit"]["changes"][&u][0];
    assert_eq!((edit["newText"].as_str(), &edit["range"]), (Some("Cyclist"), &diags[0]["range"]));

    // The fixed text: diagnostics are cleared.
    let fixed = BROKEN.replace("Cyclst", "Cyclist");
    c.change(&u, 2, &fixed);
    c.diagnostics(&u, |p| p["version"] == 2 && p["diagnostics"] == json!([]));

    // Hover on a stdlib kind: its attributes, inherited ones included, with units and bounds.
    let (line, col) = pos(&fixed, "Cyclist in lane");
    let hover = c.request("textDocument/hover", json!({ "textDocument": { "uri": u }, "position": at(line, col + 2) }));
    let text = hover["contents"]["value"].as_str().unwrap();
    assert!(text.contains("kind Cyclist: Placed, Agent"), "{text}");
    assert!(text.contains("distance: length in 0m..120m = 6m..12m  // from Placed"), "{text}");
    // Hover on a rule's expectation and on an attribute.
    let (line, col) = pos(&fixed, "distance <=");
    let hover = c.request("textDocument/hover", json!({ "textDocument": { "uri": u }, "position": at(line, col) }));
    assert!(hover["contents"]["value"].as_str().unwrap().contains("Distance ahead of ego"), "{hover}");

    // Go to definition into the stdlib, which the server shows as a real (read-only) file.
    let def =
        c.request("textDocument/definition", json!({ "textDocument": { "uri": u }, "position": at(line, col - 2) }));
    assert_eq!(def["uri"].as_str(), Some(u.as_str()), "`e` is declared in the rule: {def}");
    let (line, col) = pos(&fixed, "Cyclist where");
    let def = c.request("textDocument/definition", json!({ "textDocument": { "uri": u }, "position": at(line, col) }));
    let target = def["uri"].as_str().unwrap();
    assert!(target.ends_with("/stdlib/driving.rev") && target.contains("/cache/revelio/std-"), "{def}");
    let std_text = std::fs::read_to_string(target.strip_prefix("file://").unwrap()).unwrap();
    assert_eq!(std_text, revelio::check::STDLIB.iter().find(|(n, _)| *n == "driving").unwrap().1);
    let (l, ch) = pos(&std_text, "Cyclist: Placed");
    assert_eq!(def["range"]["start"], at(l, ch));

    // References of the question across the file.
    let (line, col) = pos(&fixed, "question q");
    let refs = c.request(
        "textDocument/references",
        json!({ "textDocument": { "uri": u }, "position": at(line, col + 9), "context": { "includeDeclaration": true } }),
    );
    assert_eq!(refs.as_array().unwrap().len(), 3, "the declaration and two `expect`s: {refs}");

    // Completion after `.`: the world's attributes, and an `exists` variable's attributes.
    let typing = fixed.replace("  probe \"A cyclist.\"", "  set world.\n  probe \"A cyclist.\"");
    c.change(&u, 3, &typing);
    let (line, col) = pos(&typing, "world.\n");
    let items =
        c.request("textDocument/completion", json!({ "textDocument": { "uri": u }, "position": at(line, col + 6) }));
    let labels: Vec<&str> = items.as_array().unwrap().iter().map(|i| i["label"].as_str().unwrap()).collect();
    assert_eq!(labels, ["town", "weather", "intersection"]);
    let (line, col) = pos(&typing, "e.distance");
    let items =
        c.request("textDocument/completion", json!({ "textDocument": { "uri": u }, "position": at(line, col + 2) }));
    assert!(items.as_array().unwrap().iter().any(|i| i["label"] == "distance"), "{items}");

    // Formatting: one edit that rewrites the document in the canonical layout.
    let messy = fixed.replace("  rule otherwise { expect q.go }", "rule otherwise{expect q.go}");
    c.change(&u, 4, &messy);
    let edits = c.request(
        "textDocument/formatting",
        json!({ "textDocument": { "uri": u }, "options": { "tabSize": 2, "insertSpaces": true } }),
    );
    let new_text = edits[0]["newText"].as_str().unwrap();
    assert_eq!(new_text, revelio::fmt::format(&messy).unwrap());
    assert!(new_text.contains("  rule otherwise {\n    expect q.go\n  }"), "{new_text}");

    // Outline and semantic tokens answer too.
    let symbols = c.request("textDocument/documentSymbol", json!({ "textDocument": { "uri": u } }));
    let names: Vec<&str> = symbols.as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["walker", "q", "near", "otherwise"]);
    let tokens = c.request("textDocument/semanticTokens/full", json!({ "textDocument": { "uri": u } }));
    assert!(tokens["data"].as_array().unwrap().len() > 100, "{tokens}");
    c.shutdown();
}

#[test]
fn editing_a_module_rechecks_its_users_and_lints_can_be_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let lib = dir.path().join("lib.rev");
    let main = dir.path().join("main.rev");
    let lib_text = "/// Shiny things.\ntag Shiny\n";
    std::fs::write(&lib, lib_text).unwrap();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let shadowed = std::fs::read_to_string(root.join("tests/corpus/lints/shadowed_rule.rev")).unwrap();
    let main_text = format!("use \"lib.rev\"\n{}", shadowed.replace("kind Thing {", "kind Thing: Shiny {"));
    let mut c = Client::start(&dir.path().join("cache"), json!({ "lintDelayMs": 0 }));
    let (lu, mu) = (uri(&lib), uri(&main));
    c.open(&lu, lib_text);
    c.open(&mu, &main_text);
    // The lattice lints arrive after the front end's (empty) diagnostics.
    let codes = |p: &Value| -> Vec<String> {
        p["diagnostics"].as_array().unwrap().iter().map(|d| d["code"].as_str().unwrap().to_string()).collect()
    };
    let d = c.diagnostics(&mu, |p| codes(p).contains(&"R0101".to_string()));
    let r0101 = d["diagnostics"].as_array().unwrap().iter().find(|x| x["code"] == "R0101").unwrap().clone();
    assert!(r0101["relatedInformation"].as_array().is_some_and(|r| !r.is_empty()), "related spans: {r0101}");

    // The `allow` fix: an `allow` with a `///` line for the reason, above the rules block.
    let actions = c.request(
        "textDocument/codeAction",
        json!({ "textDocument": { "uri": mu }, "range": r0101["range"], "context": { "diagnostics": [r0101] } }),
    );
    let allow = actions
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["title"].as_str().unwrap().starts_with("Allow R0101"))
        .expect("an allow fix");
    let edit = &allow["edit"]["changes"][&mu][0];
    let insert = edit["newText"].as_str().unwrap();
    assert!(insert.starts_with("/// ") && insert.contains("\nallow R0101\n"), "{insert}");
    let (line, _) = pos(&main_text, "rules priority");
    assert_eq!(edit["range"]["start"]["line"], line, "above the rules block");

    // With the `allow` (and a reason) the lint is hidden, as `revelio check` hides it.
    let allowed = main_text
        .replace("rules priority", "/// The shadowed rule is the point of this test.\nallow R0101\n\nrules priority");
    c.change(&mu, 2, &allowed);
    let d = c.diagnostics(&mu, |p| p["version"] == 2 && codes(p).contains(&"R0104".to_string()));
    assert!(!codes(&d).contains(&"R0101".to_string()), "{d}");

    // Editing the used module rechecks the open file that uses it.
    c.change(&lu, 2, "tag Dull\n");
    let d = c.diagnostics(&mu, |p| codes(p).contains(&"R0020".to_string()));
    assert!(d["diagnostics"][0]["message"].as_str().unwrap().contains("`Shiny`"), "{d}");
    c.change(&lu, 3, lib_text);
    c.diagnostics(&mu, |p| !codes(p).contains(&"R0020".to_string()));
    c.shutdown();
}

/// Neovim, headless, with its built-in LSP client started on `revelio lsp`: the diagnostics it
/// received for a broken file are written out by Neovim itself and checked here.
#[test]
fn neovim_receives_the_diagnostics() {
    if Command::new("nvim").arg("--version").output().is_err() {
        common::peer_missing("the Neovim test", "`nvim` is not installed (`.ci/run` installs it)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("broken.rev");
    std::fs::write(&file, "domain broken\nuse std::driving\n\nconcept c {\n  add w: Cyclst in lane\n}\n").unwrap();
    let out = dir.path().join("diagnostics.json");
    let script = dir.path().join("client.lua");
    std::fs::write(
        &script,
        format!(
            r#"
local out = {out:?}
vim.api.nvim_create_autocmd('DiagnosticChanged', {{
  callback = function(args)
    local ds = vim.diagnostic.get(args.buf)
    if #ds == 0 then return end
    local list = {{}}
    for _, d in ipairs(ds) do
      local code = d.code or (d.user_data and d.user_data.lsp and d.user_data.lsp.code)
      table.insert(list, {{ code = code, lnum = d.lnum, col = d.col, message = d.message, source = d.source }})
    end
    local f = io.open(out, 'w')
    f:write(vim.json.encode(list))
    f:close()
    vim.cmd('qall!')
  end,
}})
-- `start_client` + `buf_attach_client` work from Neovim 0.7 (Debian 12) to today.
local client = vim.lsp.start_client({{ name = 'revelio', cmd = {{ {bin:?}, 'lsp' }}, root_dir = {root:?} }})
vim.defer_fn(function() vim.cmd('cquit 3') end, 60000)
vim.cmd('edit ' .. {file:?})
vim.lsp.buf_attach_client(0, client)
"#,
            out = out.display().to_string(),
            bin = env!("CARGO_BIN_EXE_revelio"),
            root = dir.path().display().to_string(),
            file = file.display().to_string(),
        ),
    )
    .unwrap();
    let status = Command::new("nvim")
        .args(["--headless", "--clean", "-u"])
        .arg(&script)
        .env("XDG_CACHE_HOME", dir.path().join("cache"))
        .env("XDG_STATE_HOME", dir.path().join("state"))
        .stdin(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "Neovim timed out or failed: {status}");
    let got: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let d =
        got.as_array().unwrap().iter().find(|d| d["code"] == "R0020").unwrap_or_else(|| panic!("no R0020 in {got}"));
    assert_eq!((d["lnum"].as_u64(), d["col"].as_u64()), (Some(4), Some(9)), "line 5, column 10: {got}");
    assert_eq!(d["source"], "revelio");
    assert!(d["message"].as_str().unwrap().contains("unknown kind `Cyclst`"), "{got}");
}
