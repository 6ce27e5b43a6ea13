// A minimal VS Code client for `shadec lsp`: starts the server on
// stdio for `.shd` files and passes the `shadec.target` setting. Not built in
// CI; see docs/editors.md.
const vscode = require('vscode');
const { LanguageClient } = require('vscode-languageclient/node');

let client;

function activate(context) {
  const config = vscode.workspace.getConfiguration('shadec');
  const command = config.get('path', 'shadec');
  const serverOptions = { command, args: ['lsp'] };
  const clientOptions = {
    documentSelector: [{ scheme: 'file', language: 'shadec' }],
    initializationOptions: { shadec: { target: config.get('target', 'wgsl') } },
    // Sends `workspace/didChangeConfiguration` with the `shadec` section.
    synchronize: { configurationSection: 'shadec' },
  };
  client = new LanguageClient('shadec', 'shadec', serverOptions, clientOptions);
  context.subscriptions.push(client);
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
