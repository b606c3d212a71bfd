// bunny_to_ply.js — converts the npm package `bunny` (index.js exports
// `positions`: [[x,y,z],...] and `cells`: [[i,j,k],...]) to an ASCII PLY.
// Usage: node bunny_to_ply.js PACKAGE_DIR OUT.ply
'use strict';
const fs = require('fs');
const path = require('path');

if (process.argv.length !== 4) {
  console.error('usage: node bunny_to_ply.js PACKAGE_DIR OUT.ply');
  process.exit(2);
}
const bunny = require(path.resolve(process.argv[2]));
const pos = bunny.positions;
const cells = bunny.cells;
if (!Array.isArray(pos) || !Array.isArray(cells) || pos.length === 0 || cells.length === 0) {
  console.error('bunny_to_ply.js: package has no positions/cells arrays');
  process.exit(1);
}
const lines = [
  'ply',
  'format ascii 1.0',
  'comment Stanford bunny, from npm package bunny@1.0.1 (Y-up)',
  'element vertex ' + pos.length,
  'property float x',
  'property float y',
  'property float z',
  'element face ' + cells.length,
  'property list uchar int vertex_indices',
  'end_header',
];
for (const p of pos) lines.push(p[0] + ' ' + p[1] + ' ' + p[2]);
for (const c of cells) {
  for (const i of c) {
    if (!Number.isInteger(i) || i < 0 || i >= pos.length) {
      console.error('bunny_to_ply.js: bad vertex index ' + i);
      process.exit(1);
    }
  }
  lines.push(c.length + ' ' + c.join(' '));
}
// Write to a temporary name and rename, so a failure leaves no partial file.
const out = process.argv[3];
const tmp = out + '.tmp-' + process.pid;
fs.writeFileSync(tmp, lines.join('\n') + '\n');
fs.renameSync(tmp, out);
console.log('wrote ' + out + ': ' + pos.length + ' vertices, ' + cells.length + ' triangles');
