#!/usr/bin/env node
// Run the Khronos glTF validator on one .glb/.gltf file and print its JSON report on stdout.
// Usage: node tools/validate_gltf.js FILE
// Exit status: 0 when the validator ran (whatever it found), 2 when it could not run.
'use strict';

const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function main(argv) {
  if (argv.length !== 1) {
    throw new Error('usage: validate_gltf.js FILE');
  }
  const file = path.resolve(argv[0]);
  const folder = path.dirname(file);
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
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
  process.stdout.write(JSON.stringify(report));
}

main(process.argv.slice(2)).catch((err) => {
  process.stderr.write(`validate_gltf.js: ${err && err.message ? err.message : err}\n`);
  process.exit(2);
});
