#!/usr/bin/env node
// Validates .glb / .gltf files with the Khronos glTF validator (npm package gltf-validator), a
// .gltf with the files its URIs name beside it:
// prints each error and warning as "file: SEVERITY CODE pointer: message", then one line per
// file "file: N errors, N warnings, N infos, N hints" and, with --json, the whole report.
// Exit code: 0 when no file has an error, 1 otherwise, 2 on bad usage or an unreadable file.
//
//   npm ci --prefix tools/gltf
//   node tools/gltf/validate.js boards.glb
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const SEVERITY = ['ERROR', 'WARNING', 'INFO', 'HINT'];

async function validateFile(file, json) {
  let bytes;
  try {
    bytes = fs.readFileSync(file);
  } catch (e) {
    console.error(`${file}: cannot read (${e.code || e.message})`);
    return 2;
  }
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 1000,
    // A .gltf's buffer and images: plain file names beside it (percent-encoded URIs).
    externalResourceFunction: (uri) => {
      const name = decodeURIComponent(uri);
      if (name.includes('/') || name === '..' || name === '.')
        return Promise.reject(new Error(`${uri}: not a file beside ${file}`));
      return fs.promises.readFile(path.join(path.dirname(file), name)).then((b) => new Uint8Array(b));
    },
  });
  const issues = report.issues;
  for (const m of issues.messages) {
    if (m.severity > 1) continue;  // infos and hints only in the counts
    console.log(`${file}: ${SEVERITY[m.severity]} ${m.code} ${m.pointer || ''}: ${m.message}`);
  }
  if (json) console.log(JSON.stringify(report, null, 1));
  console.log(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
              `${issues.numInfos} infos, ${issues.numHints} hints`);
  return issues.numErrors > 0 ? 1 : 0;
}

async function main() {
  const args = process.argv.slice(2);
  const json = args.includes('--json');
  const files = args.filter((a) => a !== '--json');
  if (files.length === 0) {
    console.error('usage: validate.js [--json] FILE.glb...');
    return 2;
  }
  let worst = 0;
  for (const f of files) worst = Math.max(worst, await validateFile(f, json));
  return worst;
}

main().then((code) => process.exit(code), (e) => {
  console.error(`validate.js: ${e}`);
  process.exit(2);
});
