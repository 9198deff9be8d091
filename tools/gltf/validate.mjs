// Usage: node validate.mjs PATH/material.gltf
// Prints the validator's summary; exits 1 when it reports any error (warnings are printed).
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate.mjs material.gltf');
  process.exit(2);
}
const data = await readFile(file);
const dir = path.dirname(file);
const report = await validator.validateBytes(new Uint8Array(data), {
  uri: path.basename(file),
  externalResourceFunction: async (uri) => new Uint8Array(await readFile(path.join(dir, decodeURIComponent(uri)))),
});
const issues = report.issues;
for (const m of issues.messages) console.log(`${['error', 'warning', 'info', 'hint'][m.severity]} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
console.log(`gltf-validator ${report.validatorVersion}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos, ${issues.numHints} hints`);
process.exit(issues.numErrors > 0 ? 1 : 0);
