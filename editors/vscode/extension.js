// Runs `revelio check --format json FILE` on open/save and shows its diagnostics.
// The JSON format (one object per line) is documented in docs/diagnostics.md.
const vscode = require("vscode");
const { execFile } = require("child_process");

function activate(context) {
  const collection = vscode.languages.createDiagnosticCollection("revelio");
  context.subscriptions.push(collection);

  const check = (doc) => {
    if (doc.languageId !== "revelio" || doc.uri.scheme !== "file") return;
    const bin = vscode.workspace.getConfiguration("revelio").get("path") || "revelio";
    execFile(bin, ["check", "--format", "json", doc.uri.fsPath], (err, stdout) => {
      if (err && err.code !== 1) {
        collection.set(doc.uri, []);
        vscode.window.setStatusBarMessage(`revelio check failed: ${err.message}`, 5000);
        return;
      }
      const diags = [];
      for (const line of stdout.split("\n")) {
        if (!line.trim()) continue;
        let d;
        try { d = JSON.parse(line); } catch { continue; }
        if (d.file && vscode.Uri.file(d.file).fsPath !== doc.uri.fsPath && !doc.uri.fsPath.endsWith(d.file)) continue;
        // JSON lines/columns are 1-based; VS Code positions are 0-based.
        const range = new vscode.Range(
          Math.max(0, (d.line || 1) - 1), Math.max(0, (d.column || 1) - 1),
          Math.max(0, (d.end_line || d.line || 1) - 1), Math.max(0, (d.end_column || d.column || 1) - 1));
        const sev = d.severity === "error" ? vscode.DiagnosticSeverity.Error : vscode.DiagnosticSeverity.Warning;
        const diag = new vscode.Diagnostic(range, d.help ? `${d.message}\nhelp: ${d.help}` : d.message, sev);
        diag.code = d.code;
        diag.source = "revelio";
        diags.push(diag);
      }
      collection.set(doc.uri, diags);
    });
  };

  context.subscriptions.push(vscode.workspace.onDidOpenTextDocument(check));
  context.subscriptions.push(vscode.workspace.onDidSaveTextDocument(check));
  vscode.workspace.textDocuments.forEach(check);
}

function deactivate() {}

module.exports = { activate, deactivate };
