//! The VS Code extension packages without a question asked: `npm install` of its one
//! dependency (vscode-languageclient) and `npx @vscode/vsce package`, in a copy of
//! `editors/vscode/`. Needs `node`/`npx` and the npm registry; without `npx` the test says so
//! and passes, or fails where `REVELIO_REQUIRE_PEERS` is set (`.ci/run` installs node and sets
//! it).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap();
        if name == "node_modules" || p.extension().is_some_and(|x| x == "vsix") {
            continue;
        }
        if p.is_dir() {
            copy_dir(&p, &to.join(name));
        } else {
            std::fs::copy(&p, to.join(name)).unwrap();
        }
    }
}

fn run(dir: &Path, program: &str, args: &[&str]) {
    let out = Command::new(program)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{program}`: {e}"));
    assert!(
        out.status.success(),
        "`{program} {}` failed:\n{}\n{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_vscode_extension_packages_non_interactively() {
    if Command::new("npx").arg("--version").stdin(Stdio::null()).output().is_err() {
        common::peer_missing("the VS Code packaging test", "`npx` (node) is not installed (`.ci/run` installs it)");
        return;
    }
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("editors/vscode");
    let dir = tempfile::tempdir().unwrap();
    let ext = dir.path().join("vscode");
    copy_dir(&src, &ext);
    run(&ext, "npm", &["install", "--no-audit", "--no-fund", "--no-package-lock", "--omit=dev"]);
    run(&ext, "npx", &["--yes", "@vscode/vsce@3", "package", "--out", "revelio.vsix"]);
    let vsix = std::fs::read(ext.join("revelio.vsix")).unwrap();
    // A VSIX is a zip: the manifest, the client library and the grammar are inside.
    let names = String::from_utf8_lossy(&vsix);
    for inside in [
        "extension/package.json",
        "extension/extension.js",
        "extension/LICENSE",
        "extension/syntaxes/revelio.tmLanguage.json",
        "extension/node_modules/vscode-languageclient/package.json",
    ] {
        assert!(names.contains(inside), "`{inside}` is not in the package");
    }
}

#[test]
fn the_extension_is_a_client_of_revelio_lsp() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("editors/vscode");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("package.json")).unwrap()).unwrap();
    assert!(manifest["dependencies"]["vscode-languageclient"].is_string());
    assert!(manifest["repository"]["url"].is_string() && dir.join("LICENSE").is_file(), "vsce asks without them");
    let js = std::fs::read_to_string(dir.join("extension.js")).unwrap();
    assert!(js.contains("vscode-languageclient/node") && js.contains("\"lsp\""), "{js}");
}
