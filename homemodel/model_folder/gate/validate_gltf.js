#!/usr/bin/env node
// Run the Khronos glTF validator on .glb/.gltf files and print its JSON reports.
// Usage: node validate_gltf.js FILE   one report on stdout
//        node validate_gltf.js --lines
//            a request per line on stdin, {"file": PATH}, and a reply per line on stdout,
//            {"report": ...} or {"error": "..."}, until stdin closes. The gate keeps one such
//            process: starting node and loading the validator cost 250 ms, a model 3-10 ms.
// `require` finds gltf-validator through NODE_PATH, which the gate sets to the node_modules
// folder it found (homemodel/core/node_packages.py).
// Exit status: 0 when the validator ran (whatever it found), 2 when it could not run.
'use strict';

const fs = require('fs');
const path = require('path');
const readline = require('readline');
const validator = require('gltf-validator');

function validateFile(name) {
  const file = path.resolve(name);
  const folder = path.dirname(file);
  const bytes = new Uint8Array(fs.readFileSync(file));
  return validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0,
    // External buffers and images may only come from the file's own folder, so a hostile
    // model cannot make the validator read elsewhere.
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
      try {
        const target = fs.realpathSync(path.resolve(folder, decodeURIComponent(uri)));
        const rel = path.relative(fs.realpathSync(folder), target);
        if (rel === '..' || rel.startsWith('..' + path.sep) || path.isAbsolute(rel)) {
          throw new Error(`${uri} lies outside the file's folder`);
        }
        resolve(new Uint8Array(fs.readFileSync(target)));
      } catch (err) {
        reject(err);
      }
    }),
  });
}

function message(err) {
  return err && err.message ? err.message : String(err);
}

async function serveLines() {
  const lines = readline.createInterface({ input: process.stdin, crlfDelay: Infinity });
  for await (const line of lines) {  // one request at a time, in order
    let reply;
    try {
      reply = { report: await validateFile(JSON.parse(line).file) };
    } catch (err) {
      reply = { error: message(err) };
    }
    process.stdout.write(JSON.stringify(reply) + '\n');
  }
}

async function main(argv) {
  if (argv.length === 1 && argv[0] === '--lines') {
    return serveLines();
  }
  if (argv.length !== 1) {
    throw new Error('usage: validate_gltf.js FILE | --lines');
  }
  process.stdout.write(JSON.stringify(await validateFile(argv[0])));
}

main(process.argv.slice(2)).catch((err) => {
  process.stderr.write(`validate_gltf.js: ${message(err)}\n`);
  process.exit(2);
});
