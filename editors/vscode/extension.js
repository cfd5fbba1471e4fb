// Starts `aida-kb lsp` for .kb files and connects VS Code to it over stdio.
"use strict";
const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const config = vscode.workspace.getConfiguration("aidaKb");
  const [command, ...args] = config.get("server.command", ["aida-kb", "lsp"]);
  const serverOptions = { command, args, transport: TransportKind.stdio };
  const clientOptions = {
    documentSelector: [{ language: "aida-kb" }],
    initializationOptions: { importPaths: config.get("importPaths", []) },
  };
  client = new LanguageClient("aida-kb", "aida-kb language server", serverOptions, clientOptions);
  context.subscriptions.push(client);
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
