#!/usr/bin/env node
// Checks Kubernetes manifests against the Kubernetes API's OpenAPI schemas, as compiled into the
// npm package kubernetes-models (its validators come from the API's published OpenAPI document):
// each YAML document's apiVersion and kind pick the schema. Prints one line per problem,
// "file: doc N (Kind name): /json/pointer message", then "file: N documents valid" or
// "file: N errors". Exit code: 0 all valid, 1 a document breaks its schema, 2 bad usage, an
// unreadable file, bad YAML or a kind the package does not know.
//
//   npm ci --prefix tools/k8s
//   node tools/k8s/validate.mjs deploy/k8s/sawyer-batch-job.yaml
//
// The schemas check types, enums, formats and required fields; like the API's OpenAPI document
// they allow fields they do not name (the API server rejects those only with strict field
// validation, `kubectl apply --validate=strict`).
import fs from 'fs';
import YAML from 'yaml';

// "batch/v1" -> "kubernetes-models/batch/v1", core "v1" -> "kubernetes-models/v1".
async function modelFor(apiVersion, kind) {
  if (typeof apiVersion !== 'string' || !/^[a-z0-9.-]+(\/[a-z0-9]+)?$/.test(apiVersion))
    throw new Error(`apiVersion ${JSON.stringify(apiVersion)} is not a Kubernetes API version`);
  let mod;
  try {
    mod = await import(`kubernetes-models/${apiVersion}`);
  } catch (e) {
    throw new Error(`apiVersion ${apiVersion} is not one kubernetes-models knows`);
  }
  if (typeof kind !== 'string' || typeof mod[kind] !== 'function')
    throw new Error(`kind ${JSON.stringify(kind)} is not in ${apiVersion}`);
  return mod[kind];
}

async function validateFile(file) {
  let text;
  try {
    text = fs.readFileSync(file, 'utf8');
  } catch (e) {
    console.error(`${file}: cannot read (${e.code || e.message})`);
    return 2;
  }
  const docs = YAML.parseAllDocuments(text);
  let errors = 0, count = 0;
  for (const [i, doc] of docs.entries()) {
    if (doc.errors.length > 0) {
      console.error(`${file}: doc ${i + 1}: not YAML: ${doc.errors[0].message.split('\n')[0]}`);
      return 2;
    }
    const obj = doc.toJS();
    if (obj === null || obj === undefined) continue;  // an empty document (a trailing ---)
    count++;
    const where = `${file}: doc ${i + 1} (${obj.kind} ${obj.metadata?.name ?? '?'})`;
    let Model;
    try {
      Model = await modelFor(obj.apiVersion, obj.kind);
    } catch (e) {
      console.error(`${where}: ${e.message}`);
      return 2;
    }
    try {
      new Model(obj).validate();
    } catch (e) {
      if (!Array.isArray(e.errors)) throw e;
      for (const err of e.errors) {
        const extra = err.params?.missingProperty ? ` (${err.params.missingProperty})`
                    : err.params?.allowedValues ? ` (${err.params.allowedValues.join(', ')})` : '';
        console.log(`${where}: ${err.instancePath || '/'} ${err.message}${extra}`);
        errors++;
      }
    }
  }
  console.log(errors === 0 ? `${file}: ${count} documents valid` : `${file}: ${errors} errors`);
  return errors === 0 ? 0 : 1;
}

async function main() {
  const files = process.argv.slice(2);
  if (files.length === 0) {
    console.error('usage: validate.mjs FILE.yaml...');
    return 2;
  }
  let worst = 0;
  for (const f of files) worst = Math.max(worst, await validateFile(f));
  return worst;
}

main().then((code) => process.exit(code), (e) => {
  console.error(`validate.mjs: ${e}`);
  process.exit(2);
});
