#!/usr/bin/env node
// Runs the Khronos glTF validator (npm `gltf-validator`, pinned in package.json) on every
// file named on the command line, prints one line per file, and exits 1 if any file has an
// error (or could not be read at all), so CI can use it as the judge of our glTF output.
//
// Usage: node .ci/gltf_validate.mjs FILE.glb [FILE.gltf ...]
// Install first: cd .ci && npm install --no-audit --no-fund
// Set GLTF_VALIDATE_VERBOSE=1 to print every error and warning, not just the first codes.

import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { validateBytes, version } from 'gltf-validator';

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node .ci/gltf_validate.mjs FILE.glb|FILE.gltf ...');
  process.exit(2);
}
const verbose = process.env.GLTF_VALIDATE_VERBOSE === '1';

/** Distinct codes in first-seen order, with how often each occurs. */
function codeSummary(messages, limit) {
  const counts = new Map();
  for (const m of messages) counts.set(m.code, (counts.get(m.code) ?? 0) + 1);
  const parts = [...counts].slice(0, limit).map(([code, n]) => (n > 1 ? `${code}×${n}` : code));
  if (counts.size > limit) parts.push('…');
  return parts.join(', ');
}

let failed = false;
for (const file of files) {
  let bytes;
  try {
    bytes = new Uint8Array(await readFile(file));
  } catch (e) {
    console.log(`${file}: cannot read: ${e.message}`);
    failed = true;
    continue;
  }
  let report;
  try {
    report = await validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 0, // 0 = no limit, so the counts are the real ones
      // .gltf files may point at .bin buffers and images next to them.
      externalResourceFunction: (uri) =>
        readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then(
          (data) => new Uint8Array(data),
        ),
    });
  } catch (e) {
    console.log(`${file}: validator could not parse it: ${e}`);
    failed = true;
    continue;
  }
  const issues = report.issues;
  const errors = issues.messages.filter((m) => m.severity === 0);
  const warnings = issues.messages.filter((m) => m.severity === 1);
  let line = `${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos, ${issues.numHints} hints`;
  if (errors.length > 0) line += ` | errors: ${codeSummary(errors, 4)}`;
  if (warnings.length > 0) line += ` | warnings: ${codeSummary(warnings, 4)}`;
  console.log(line);
  if (verbose) {
    for (const m of [...errors, ...warnings]) {
      console.log(`  ${m.severity === 0 ? 'E' : 'W'} ${m.code} ${m.pointer ?? ''} ${m.message}`);
    }
  }
  if (issues.numErrors > 0) failed = true;
}
if (verbose) console.log(`gltf-validator ${version()}`);
process.exit(failed ? 1 : 0);
