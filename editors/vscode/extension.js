// A client of `revelio lsp`: diagnostics as you type, hover, go to definition, completion,
// quick fixes, formatting and semantic tokens all come from the language server. The TextMate
// grammar (syntaxes/) still colours the file before the server answers.
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const config = vscode.workspace.getConfiguration("revelio");
  const command = config.get("path") || "revelio";
  const server = { command, args: ["lsp"] };
  client = new LanguageClient(
    "revelio",
    "Revelio",
    { run: server, debug: server },
    {
      documentSelector: [{ language: "revelio" }],
      initializationOptions: { lintDelayMs: config.get("lintDelayMs") },
    },
  );
  client.start().catch((e) => {
    vscode.window.showErrorMessage(
      `Could not start \`${command} lsp\`: ${e.message}. Install revelio (cargo install --path .) or set revelio.path.`,
    );
  });
  context.subscriptions.push({ dispose: () => client && client.stop() });
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
