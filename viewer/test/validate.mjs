// Validates GLB/glTF files with Khronos' glTF-Validator.
// Usage: node viewer/test/validate.mjs FILE.glb... [--strict]
// Exits 1 when any file has an error or a warning (with --strict: also an info), 2 on bad
// usage; prints every issue with its JSON pointer.
import { readFile } from 'node:fs/promises';
import { basename } from 'node:path';
import validator from 'gltf-validator';

const args = process.argv.slice(2);
const strict = args.includes('--strict');
const files = args.filter((a) => a !== '--strict');
if (files.length === 0) {
  console.error('usage: node viewer/test/validate.mjs FILE.glb... [--strict]');
  process.exit(2);
}

const SEVERITY = ['error', 'warning', 'info', 'hint'];
let failed = 0;
for (const file of files) {
  let bytes;
  try {
    bytes = new Uint8Array(await readFile(file));
  } catch (err) {
    console.error(`${file}: cannot read: ${err.message}`);
    failed += 1;
    continue;
  }
  let report;
  try {
    report = await validator.validateBytes(bytes, { uri: basename(file), maxIssues: 0 });
  } catch (err) {
    console.error(`${file}: not glTF: ${err}`);
    failed += 1;
    continue;
  }
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  const bad = numErrors + numWarnings + (strict ? numInfos : 0);
  console.log(
    `${bad ? 'FAIL' : 'ok  '} ${file}: ${numErrors} errors, ${numWarnings} warnings, ` +
      `${numInfos} infos, ${numHints} hints`,
  );
  for (const m of messages) {
    console.log(`    ${SEVERITY[m.severity] ?? m.severity} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
  }
  if (bad) failed += 1;
}
console.log(`${files.length - failed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
